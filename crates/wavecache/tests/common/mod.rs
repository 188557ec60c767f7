//! Shared by the integration tests.

/// A scene from scene.toml text (written to a temporary folder, loaded, and the folder removed).
pub fn scene_from_toml(text: &str) -> glimpse_scene::Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

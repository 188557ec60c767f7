//! Shared by the integration tests.

/// A scene from scene.toml text (written to a temporary folder, loaded, and the folder removed).
pub fn scene_from_toml(text: &str) -> glimpse_scene::Scene {
    scene_from_files(text, &[])
}

/// [`scene_from_toml`] with other files beside scene.toml (name, contents), e.g. an OBJ it loads.
pub fn scene_from_files(toml: &str, files: &[(&str, &str)]) -> glimpse_scene::Scene {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

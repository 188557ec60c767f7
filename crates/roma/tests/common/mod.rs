//! Scenes the ROMA tests share.

/// A ball of radius 1 floating 10 cm over a 400 m ground, seen from 5 m away, a sun over it:
/// `focus=auto` builds the grid around the ball and leaves the ground to the exact test.
pub fn ball_over_ground() -> glimpse_scene::Scene {
    let toml = "[camera]\nposition = [0.0, 2.0, 5.0]\ntarget = [0.0, 0.6, 0.0]\nfov_y_degrees = 40.0\n\
        [[quad]]\nsize = [400.0, 400.0]\n\
        [[sphere]]\nradius = 1.0\nsegments = 32\ntranslate = [0.0, 1.1, 0.0]\n\
        [[light]]\nkind = \"directional\"\ndirection = [0.3, -0.8, 0.2]\nintensity = 2.0\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    glimpse_scene::load(path.to_str().unwrap()).unwrap()
}

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

/// Prepares `t` and renders one frame of `g`.
#[allow(dead_code)] // not every test file renders
pub fn render(
    t: &mut dyn glimpse_render::Technique,
    ctx: &glimpse_render::FrameContext,
    g: &glimpse_trace::GBuffer,
) -> glimpse_core::Image {
    t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    t.render(ctx, g, &mut img).expect("render");
    img
}

/// Small precomputation settings for tests: a coarse BRDF grid, few samples and points, no disk
/// cache, no progress bar.
#[allow(dead_code)] // not every test file bakes
pub fn small_params() -> glimpse_wavecache::WavecacheParams {
    glimpse_wavecache::WavecacheParams {
        brdf_grid_u1: 16,
        brdf_grid_u2: 64,
        texel_samples: 4,
        irradiance_samples: 128,
        diffuse_points: 800,
        glossy_points: 600,
        path_floor: 0,
        disk_cache: false,
        progress: false,
        ..glimpse_wavecache::WavecacheParams::default()
    }
}

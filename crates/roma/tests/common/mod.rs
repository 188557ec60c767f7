//! Scenes and runs the ROMA tests share.

/// A ball of radius 1 floating 10 cm over a 400 m ground, seen from 5 m away, a sun over it:
/// `focus=auto` builds the grid around the ball and leaves the ground to the exact test.
#[allow(dead_code)] // not every test file uses it
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

/// `ao-roma` (seed `seed`) accumulated over `frames` frames of `spp` samples (`accumulate=frames`, so the
/// image is their running mean) with `param` set, and the last frame's stats.
#[allow(dead_code)] // not every test file accumulates
pub fn accumulated_ao_roma(
    ctx: &mut glimpse_render::FrameContext,
    spp: u32,
    seed: u64,
    frames: u32,
    param: &str,
) -> (glimpse_core::Image, glimpse_render::Stats) {
    use glimpse_render::Technique;
    let g = ctx.gbuffer();
    let accumulate = format!("accumulate={frames}");
    let params = glimpse_render::Params::parse(&[accumulate.as_str(), param]).unwrap();
    let mut t = glimpse_roma::technique::AoRoma::new(&glimpse_render::Settings { spp, seed }, &params).unwrap();
    params.finish("ao-roma").unwrap();
    let (mut img, mut stats) = (ctx.image(), glimpse_render::Stats::default());
    for k in 0..frames {
        ctx.frame_index = k;
        stats = t.prepare(ctx).unwrap();
        t.render(ctx, &g, &mut img).unwrap();
    }
    (img, stats)
}

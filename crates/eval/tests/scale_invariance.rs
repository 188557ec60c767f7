//! The same scene in centimetres instead of metres (`Scene::rescale(100)`, `--scale 100`) gives
//! every technique the same picture: no default hides an absolute length. Light-cut lengths were
//! such a default (the pVPL radius and σ_max in scene units: relative RMSE 0.41 between the two
//! renders of `glossy` before, 0 after). `cargo run --release -p glimpse-eval --example
//! scale_invariance` prints the full table, also for smaller scales, where the exact tracer's
//! ray offset floor (10⁻⁴ scene units, `glimpse_core::ray::offset_origin`) starts to show.

use glimpse_core::Image;
use glimpse_render::{FrameContext, Params, Settings};

fn render(id: &str, scene: &glimpse_scene::Scene) -> Option<Image> {
    let registry = glimpse_eval::registry();
    let mut t = registry.create(id, scene, &Settings { spp: 2, seed: 1 }, &Params::default()).ok()?;
    let ctx = FrameContext::new(scene, 0.0, 32, 32);
    let g = ctx.gbuffer();
    t.prepare(&ctx).ok()?;
    let mut image = ctx.image();
    t.render(&ctx, &g, &mut image).ok()?;
    Some(image)
}

fn mean(img: &Image) -> f64 {
    img.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / img.pixels.len() as f64
}

#[test]
fn a_scene_in_centimetres_renders_as_in_metres() {
    let mut scene = glimpse_scene::load("glossy").unwrap();
    // A point light too, for the shadow techniques (lights-*): above the middle of the scene.
    let b = scene.bounds();
    let top = b.center() + glimpse_core::Vec3::Y * (0.4 * b.extent().y);
    scene.lights.push(glimpse_scene::Light::point(top, glimpse_core::Vec3::splat(2.0 * b.extent().length_squared())));
    let mut centimetres = scene.clone();
    centimetres.rescale(100.0).unwrap();
    let mut checked = Vec::new();
    // The wavelet cache's precompute is too slow for the suite (the example covers it: 0.024).
    for info in glimpse_eval::registry().all().iter().filter(|i| i.id != "wavecache") {
        let Some(metres) = render(info.id, &scene) else { continue };
        let cm = render(info.id, &centimetres).unwrap_or_else(|| panic!("{} renders in metres but not in centimetres", info.id));
        let m0 = mean(&metres).max(1e-12);
        let mse = metres.pixels.iter().zip(&cm.pixels).map(|(a, b)| ((*a - *b).length_squared() / 3.0) as f64).sum::<f64>()
            / metres.pixels.len() as f64;
        let (relative_rmse, ratio) = (mse.sqrt() / m0, mean(&cm) / m0);
        println!("{:<16} relative RMSE {relative_rmse:.4}, mean ratio {ratio:.4}", info.id);
        assert!(relative_rmse < 0.02 && (ratio - 1.0).abs() < 0.005, "{}: the scene in centimetres renders differently", info.id);
        checked.push(info.id);
    }
    assert!(checked.len() >= 19, "only {checked:?} ran on glossy");
}

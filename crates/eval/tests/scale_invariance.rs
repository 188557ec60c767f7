//! The same scene in centimetres instead of metres (`Scene::rescale(100)`, `--scale 100`), or a
//! thousand times smaller (millimetres), gives every technique the same picture: no default
//! hides an absolute length. Two were found this way:
//! - the light cuts' lengths (the pVPL radius and σ_max in scene units: relative RMSE 0.41
//!   between the centimetre and metre renders of `glossy` before, 0 after);
//! - the exact tracer's ray offset, which had a floor of 10⁻⁴ scene units: at scale 0.001 the
//!   references moved by relative RMSE 0.05–0.13 (`env-exact` 0.0515 against its seed-to-seed
//!   0.0148, `pt` 0.117), 0.0000 now that the offset is relative to each point's error scale
//!   (`glimpse_core::ray::offset_origin`).
//!
//! `cargo run --release -p glimpse-eval --example scale_invariance -- SCENE SIZE SCALE…` prints
//! the full table, the wavelet cache included.

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
fn a_scene_in_centimetres_or_millimetres_renders_as_in_metres() {
    let mut scene = glimpse_scene::load("glossy").unwrap();
    // A point light too, for the shadow techniques (lights-*): above the middle of the scene.
    let b = scene.bounds();
    let top = b.center() + glimpse_core::Vec3::Y * (0.4 * b.extent().y);
    scene.lights.push(glimpse_scene::Light::point(top, glimpse_core::Vec3::splat(2.0 * b.extent().length_squared())));
    let scaled = [100.0, 0.001].map(|s| {
        let mut copy = scene.clone();
        copy.rescale(s).unwrap();
        (s, copy)
    });
    let mut checked = Vec::new();
    // The wavelet cache's precompute is too slow for the suite (the example covers it: 0.022 at
    // scale 100, 0.017 at 0.001, against 0.077 between two seeds).
    for info in glimpse_eval::registry().all().iter().filter(|i| i.id != "wavecache") {
        let Some(metres) = render(info.id, &scene) else { continue };
        for (s, other) in &scaled {
            let img = render(info.id, other).unwrap_or_else(|| panic!("{} renders at scale 1 but not at {s}", info.id));
            let m0 = mean(&metres).max(1e-12);
            let mse = metres.pixels.iter().zip(&img.pixels).map(|(a, b)| ((*a - *b).length_squared() / 3.0) as f64).sum::<f64>()
                / metres.pixels.len() as f64;
            let (relative_rmse, ratio) = (mse.sqrt() / m0, mean(&img) / m0);
            println!("{:<16} scale {s:<6} relative RMSE {relative_rmse:.4}, mean ratio {ratio:.4}", info.id);
            assert!(relative_rmse < 0.02 && (ratio - 1.0).abs() < 0.005, "{}: the scene at scale {s} renders differently", info.id);
        }
        checked.push(info.id);
    }
    assert!(checked.len() >= 19, "only {checked:?} ran on glossy");
}

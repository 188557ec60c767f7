//! The radiance maps' light samples (`texel_light_samples`): shadow rays towards the area lights
//! and the environment, splatted into the texel of their direction and weighed against the
//! texels' own rays by the balance heuristic. The maps must keep their expectation (the estimator
//! stays unbiased) and lose variance where the light is small and bright.

mod common;

use glimpse_core::{Rng, Vec3};
use glimpse_render::FrameContext;
use glimpse_wavecache::bake::{Integrator, MapSettings};
use glimpse_wavecache::halfcube::{HalfCube, map_frame};
use glimpse_wavecache::points::SurfaceSample;

/// Σ texel × ΔΩ (the map's ∫ L dω, luminance) and the texels' luminances.
fn integral(map: &[[f64; 3]], res: u32) -> (f64, Vec<f64>) {
    let h = HalfCube::new(res);
    let lum: Vec<f64> = map.iter().map(|t| 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2]).collect();
    let total = (0..h.texels()).map(|t| lum[t] * h.solid_angle(t as u32 % res, t as u32 / res)).sum();
    (total, lum)
}

#[test]
fn light_samples_keep_the_maps_expectation_and_cut_their_noise() {
    // A floor point under a small bright sphere, with the sky of the `glossy` scene behind: both
    // light samplers are at work.
    let toml = "[camera]\nposition = [0.0, 0.5, 1.5]\ntarget = [0.0, 0.0, 0.0]\n\
        [[quad]]\nsize = [3.0, 3.0]\nmaterial = { base_color = [0.5, 0.5, 0.5] }\n\
        [[box]]\nsize = [0.4, 0.4, 0.4]\ntranslate = [-0.5, 0.2, -0.3]\nmaterial = { base_color = [0.7, 0.3, 0.2] }\n\
        [[sphere]]\nradius = 0.04\nsegments = 12\ntranslate = [0.3, 0.5, 0.1]\nmaterial = { base_color = [0.0, 0.0, 0.0], emission = [400.0, 400.0, 400.0] }\n";
    let mut scene = common::scene_from_toml(toml);
    scene.environment = glimpse_scene::load("glossy").unwrap().environment;
    assert!(scene.environment.is_some(), "the glossy scene has a sky");
    let ctx = FrameContext::new(&scene, 0.0, 8, 8);
    let integ = Integrator::new(&ctx.frame, &ctx.tracer, 3, glimpse_render::bsdf::BrdfModel::Pbr);
    let point = SurfaceSample { position: Vec3::new(0.0, 0.0, 0.0), error_scale: 1e-4, normal: Vec3::Y, shading_normal: Vec3::Y };
    let frame = map_frame(Vec3::Y);
    let res = 8;
    let map = |texel: u32, light: u32, seed: u64| {
        integ
            .radiance_map(
                &point,
                &frame,
                &MapSettings { res, samples: texel, light_samples: light, split_env: false },
                &mut Rng::new(seed, 9),
            )
            .image
    };
    let (want, reference) = integral(&map(1024, 0, 1000), res);
    let runs = 12u64;
    let stats = |light: u32| {
        let (mut mean, mut err) = (0.0, 0.0);
        for seed in 0..runs {
            let (total, texels) = integral(&map(4, light, seed), res);
            mean += total / runs as f64;
            err += texels.iter().zip(&reference).map(|(a, b)| (a - b) * (a - b)).sum::<f64>() / runs as f64;
        }
        (mean, err)
    };
    let ((plain, plain_err), (lit, lit_err)) = (stats(0), stats(8));
    println!(
        "∫ L dω at the floor point: reference {want:.4}; 4 rays per texel {plain:.4} ({:+.1} %), + 8 light samples per texel {lit:.4} ({:+.1} %); texel squared error {plain_err:.3e} → {lit_err:.3e}",
        100.0 * (plain / want - 1.0),
        100.0 * (lit / want - 1.0)
    );
    assert!((lit / want - 1.0).abs() < 0.05, "light samples must keep the map's integral: {lit:.4} vs {want:.4}");
    // A count that is not a square (3 rays per texel: one stratum, two anywhere) keeps it too.
    let odd = (0..runs).map(|seed| integral(&map(3, 8, seed), res).0).sum::<f64>() / runs as f64;
    println!("3 rays + 8 light samples per texel: {odd:.4} ({:+.1} %)", 100.0 * (odd / want - 1.0));
    assert!((odd / want - 1.0).abs() < 0.05, "a non-square ray count keeps the map's integral: {odd:.4} vs {want:.4}");
    assert!(lit_err * 3.0 < plain_err, "light samples must cut the texels' error: {lit_err:.3e} vs {plain_err:.3e}");
}

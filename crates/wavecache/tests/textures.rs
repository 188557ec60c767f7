//! Textured glossy materials (issue #13 item 4): the wavelet cache applies each pixel's texel to
//! its material's shared glossy lobe, so a textured glossy surface keeps its texture. Measured
//! against `pt` on the built-in `glossy` scene with checker textures on the gold sphere and the
//! red box (its light is a sky and an area light: no punctual light, so those surfaces are shaded
//! by the cache alone, Eq. 20).

use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::Scene;
use glimpse_scene::procedural::{CheckerDef, TextureDef, bake};
use glimpse_trace::GBuffer;
use glimpse_wavecache::{Wavecache, WavecacheParams};

fn render(t: &mut dyn Technique, ctx: &FrameContext, g: &GBuffer) -> glimpse_core::Image {
    t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    t.render(ctx, g, &mut img).expect("render");
    img
}

fn mse(a: &glimpse_core::Image, b: &glimpse_core::Image) -> f64 {
    a.pixels.iter().zip(&b.pixels).map(|(x, y)| ((*x - *y) * (*x - *y)).element_sum() as f64 / 3.0).sum::<f64>() / a.pixels.len() as f64
}

/// The glossy scene with a dark/light checker on its gold sphere and red box.
fn textured_glossy() -> Scene {
    let mut s = glimpse_scene::load("glossy").unwrap();
    let checker =
        TextureDef { checker: Some(CheckerDef { cells: 6, colors: Some([[0.15; 3], [1.0; 3]]) }), noise: None, resolution: Some(128) };
    s.textures.push(bake(&checker).unwrap());
    let tex = s.textures.len() as u32 - 1;
    for m in s.materials.iter_mut().filter(|m| m.name == "gold" || m.name == "red plastic") {
        m.base_color_texture = Some(tex);
    }
    s
}

fn params() -> WavecacheParams {
    WavecacheParams {
        brdf_grid_u1: 16,
        brdf_grid_u2: 64,
        brdf_res: 32,
        map_scale: 4,
        texel_samples: 2,
        irradiance_samples: 128,
        diffuse_points: 600,
        glossy_points: 400,
        disk_cache: false,
        progress: false,
        ..WavecacheParams::default()
    }
}

#[test]
fn textured_glossy_surfaces_keep_their_texture() {
    let textured = textured_glossy();
    let plain = glimpse_scene::load("glossy").unwrap();
    assert!(
        textured.materials.iter().any(|m| m.name == "gold" && m.base_color_texture.is_some()),
        "the test scene has a textured gold material"
    );
    let ctx = FrameContext::new(&textured, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let mut pt = PathTracer::new(&Settings { spp: 256, seed: 77 }, &Params::default()).unwrap();
    let reference = render(&mut pt, &ctx, &g);

    let mut wc = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, params());
    let image = render(&mut wc, &ctx, &g);
    let e_textured = mse(&image, &reference);

    // What a texture-blind cache gives on the glossy surfaces: the untextured scene's cache
    // (identical geometry and lights) shaded at the same pixels.
    let plain_ctx = FrameContext::new(&plain, 0.0, 48, 36);
    let plain_g = plain_ctx.gbuffer();
    let mut wc_plain = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, params());
    let blind = render(&mut wc_plain, &plain_ctx, &plain_g);
    let e_blind = mse(&blind, &reference);
    let faults = image.pixels.iter().filter(|p| !p.is_finite()).count();
    println!(
        "textured glossy scene, 48×36: wavecache MSE {e_textured:.3e} vs pt 256 spp; texture-blind image {e_blind:.3e}; NaN/Inf {faults}"
    );
    assert_eq!(faults, 0);
    assert!(e_textured < 2e-3, "wavecache should stay close to pt on textured glossy surfaces: {e_textured:.3e}");
    assert!(e_textured * 2.0 < e_blind, "keeping the texture must halve the error at least: {e_textured:.3e} vs {e_blind:.3e}");
}

//! Textured glossy materials (issue #13 item 4): the wavelet cache applies each pixel's texel to
//! its material's shared glossy lobe, so a textured glossy surface keeps its texture. Measured
//! against `pt` on the built-in `glossy` scene with checker textures on the gold sphere and the
//! red box (its light is a sky and an area light: no punctual light, so those surfaces are shaded
//! by the cache alone, Eq. 20).

mod common;

use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::Scene;
use glimpse_scene::procedural::{CheckerDef, TextureDef, bake};
use glimpse_wavecache::{Wavecache, WavecacheParams};

use common::render;

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
        path_floor: 0,
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

/// A black texel of a glossy dielectric still reflects its white specular lobe (F0 = 0.04): the
/// cache reads a textured material's BRDF at the texel exactly (its black-base table,
/// `WaveCache::brdf_black`), where scaling the factor's lobe by the texel made those pixels black
/// (Spot's black patches on `textured-glossy`: 0.3 where `pt` has 3–5).
#[test]
fn black_texels_keep_their_specular_highlight() {
    // A glossy black/white checker floor mirroring a bright emissive panel, no punctual light:
    // the floor is shaded by Eq. 20 alone.
    let toml = "[camera]\nposition = [0.0, 0.6, 1.6]\ntarget = [0.0, 0.0, -0.2]\nfov_y_degrees = 40.0\n\
        [[quad]]\nsize = [3.0, 3.0]\nmaterial = { base_color = [1.0, 1.0, 1.0], roughness = 0.3, texture = { checker = { cells = 8, colors = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]] } } }\n\
        [[quad]]\nsize = [1.2, 0.5]\ntranslate = [0.0, 0.6, -1.0]\nrotate = { axis = [1.0, 0.0, 0.0], degrees = 70.0 }\nmaterial = { base_color = [0.0, 0.0, 0.0], emission = [20.0, 20.0, 20.0] }\n";
    let scene = common::scene_from_toml(toml);
    let ctx = FrameContext::new(&scene, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let floor = scene.materials.iter().position(|m| m.roughness == 0.3).unwrap() as u32;
    let black: Vec<usize> =
        (0..g.material.len()).filter(|&i| g.is_hit(i) && g.material[i] == floor && g.albedo[i].max_element() < 1e-3).collect();
    let mean = |img: &glimpse_core::Image| {
        black.iter().map(|&i| glimpse_core::luminance(img.pixels[i]) as f64).sum::<f64>() / black.len().max(1) as f64
    };
    let reference = render(&mut PathTracer::new(&Settings { spp: 512, seed: 3 }, &Params::default()).unwrap(), &ctx, &g);
    let p = WavecacheParams { glossy_points: 300, diffuse_points: 200, texel_samples: 4, ..params() };
    let mut wc = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p);
    let image = render(&mut wc, &ctx, &g);
    // The same cache without its black-base tables: the factor's lobe scaled by the texel.
    wc.cache.as_mut().unwrap().brdf_black.iter_mut().for_each(|t| *t = glimpse_wavecache::brdf::BrdfTable::default());
    let mut scaled = ctx.image();
    wc.render(&ctx, &g, &mut scaled).expect("render");
    let (want, got, old) = (mean(&reference), mean(&image), mean(&scaled));
    println!(
        "black texels of a glossy dielectric, {} px, mean luminance: pt {want:.4}; wavecache {got:.4} ({:+.1} %); lobe scaled by the texel {old:.4}",
        black.len(),
        100.0 * (got / want - 1.0)
    );
    assert!(black.len() > 100, "the floor shows its black cells");
    assert!(want > 0.05, "pt sees the panel's highlight on the black cells: {want:.4}");
    assert!((got / want - 1.0).abs() < 0.25, "the highlight on black texels: wavecache {got:.4} vs pt {want:.4}");
    assert!(old < 0.1 * want, "scaling the lobe by the texel loses it (what the test guards against): {old:.4}");
}

/// A metallic-roughness texture (a checker of polished metal, roughness 0.15, and rough
/// dielectric, 0.9): the cache's tables hold the material's mean BRDF, so the texels far from it
/// trace a sample of their own BRDF (`Runtime::off_mean`), as `pt` shades them. Drawn as the
/// mean instead, the metal cells lose the emissive panel's sharp reflection.
#[test]
fn metallic_roughness_texels_are_shaded_as_pt_shades_them() {
    let toml = "[camera]\nposition = [0.0, 0.6, 1.6]\ntarget = [0.0, 0.0, -0.2]\nfov_y_degrees = 40.0\n\
        [environment]\nconstant = [0.1, 0.1, 0.1]\n\
        [[quad]]\nsize = [3.0, 3.0]\nmaterial = { base_color = [0.9, 0.7, 0.5] }\n\
        [[quad]]\nsize = [1.2, 0.5]\ntranslate = [0.0, 0.6, -1.0]\nrotate = { axis = [1.0, 0.0, 0.0], degrees = 70.0 }\nmaterial = { base_color = [0.0, 0.0, 0.0], emission = [20.0, 20.0, 20.0] }\n";
    let mut scene = common::scene_from_toml(toml);
    let floor = scene.materials.iter().position(|m| m.base_color.x == 0.9).unwrap();
    // 64 × 64, 8 × 8 cells: G roughness, B metallic.
    let texel = |x: u32, y: u32| if (x / 8 + y / 8).is_multiple_of(2) { (1.0, 0.15) } else { (0.0, 0.9) };
    scene.textures.push(glimpse_core::Image::from_fn(64, 64, |x, y| {
        let (metallic, roughness) = texel(x, y);
        glimpse_core::Vec3::new(0.0, roughness, metallic)
    }));
    let map = glimpse_scene::MetallicRoughnessMap { texture: scene.textures.len() as u32 - 1, metallic: 1.0, roughness: 1.0 };
    let m = &mut scene.materials[floor];
    (m.metallic, m.roughness, m.metallic_roughness_map) = (0.5, 0.525, Some(map));
    let mut mean = scene.clone();
    mean.materials[floor].metallic_roughness_map = None;

    let ctx = FrameContext::new(&scene, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let on_floor: Vec<usize> = (0..g.material.len()).filter(|&i| g.is_hit(i) && g.material[i] == floor as u32).collect();
    let floor_mse = |a: &glimpse_core::Image, b: &glimpse_core::Image| {
        on_floor.iter().map(|&i| ((a.pixels[i] - b.pixels[i]) * (a.pixels[i] - b.pixels[i])).element_sum() as f64 / 3.0).sum::<f64>()
            / on_floor.len() as f64
    };
    let reference = render(&mut PathTracer::new(&Settings { spp: 512, seed: 3 }, &Params::default()).unwrap(), &ctx, &g);
    let p = WavecacheParams { glossy_points: 300, diffuse_points: 200, texel_samples: 4, ..params() };
    let image = render(&mut Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p.clone()), &ctx, &g);
    let mean_ctx = FrameContext::new(&mean, 0.0, 48, 36);
    let mean_g = mean_ctx.gbuffer();
    let as_mean = render(&mut Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p), &mean_ctx, &mean_g);
    let (e, e_mean) = (floor_mse(&image, &reference), floor_mse(&as_mean, &reference));
    let faults = image.pixels.iter().filter(|p| !p.is_finite()).count();
    println!(
        "metallic-roughness checker floor, {} px: MSE vs pt 512 spp: per texel {e:.3e}, the mean BRDF {e_mean:.3e}; NaN/Inf {faults}",
        on_floor.len()
    );
    assert!(on_floor.len() > 500, "the floor fills the view");
    assert_eq!(faults, 0);
    assert!(e * 3.0 < e_mean, "per-texel shading must cut the mean BRDF's error to a third at least: {e:.3e} vs {e_mean:.3e}");
}

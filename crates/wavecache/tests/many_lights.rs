//! Many punctual lights (`cache_punctual_above`, ours): the paper traces every punctual light at
//! every pixel (Eq. 15/16); above 32 lights their direct light on diffuse surfaces is cached with
//! the rest of the irradiance instead, so a cached diffuse pixel traces no shadow ray.

mod common;

use common::render;
use glimpse_core::luminance;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_wavecache::{CACHE_PUNCTUAL_ABOVE, Wavecache, WavecacheParams};

/// A diffuse floor and block under `n` point lights in a ring.
fn scene(n: usize) -> glimpse_scene::Scene {
    let mut toml = String::from(
        "[camera]\nposition = [0.0, 2.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y_degrees = 45.0\n\
         [[quad]]\nsize = [4.0, 4.0]\nmaterial = { base_color = [0.6, 0.6, 0.6] }\n\
         [[box]]\nsize = [0.6, 0.6, 0.6]\ntranslate = [0.0, 0.3, 0.0]\nmaterial = { base_color = [0.7, 0.4, 0.3] }\n",
    );
    for k in 0..n {
        let a = k as f32 / n as f32 * std::f32::consts::TAU;
        toml += &format!(
            "[[light]]\nkind = \"point\"\nposition = [{}, 1.5, {}]\nintensity = {}\n",
            1.5 * a.cos(),
            1.5 * a.sin(),
            8.0 / n as f32
        );
    }
    common::scene_from_toml(&toml)
}

#[test]
fn many_lights_are_cached_on_diffuse_surfaces() {
    let p = WavecacheParams::default();
    assert!(!p.caches_punctual(CACHE_PUNCTUAL_ABOVE as usize) && p.caches_punctual(CACHE_PUNCTUAL_ABOVE as usize + 1));
    assert!(!WavecacheParams::paper().caches_punctual(100_000), "profile=paper: every light traced");
    let read = WavecacheParams::read(&Params::parse(&["cache_punctual_above=4".to_owned()]).unwrap()).unwrap();
    assert!(read.caches_punctual(5));

    let lit = scene(40);
    let ctx = FrameContext::new(&lit, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let settings = Settings { spp: 1, seed: 1 };
    let shade = |above: u32| {
        let mut t = Wavecache::with_params(&settings, WavecacheParams { cache_punctual_above: above, ..common::small_params() });
        t.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        let stats = t.render(&ctx, &g, &mut img).unwrap();
        (img, stats.rays)
    };
    let (traced, traced_rays) = shade(u32::MAX);
    let (cached, cached_rays) = shade(CACHE_PUNCTUAL_ABOVE);
    let mean = |img: &glimpse_core::Image| img.pixels.iter().map(|&p| luminance(p) as f64).sum::<f64>() / img.pixels.len() as f64;
    let (a, b) = (mean(&traced), mean(&cached));
    println!("40 lights: every light traced {traced_rays} rays, mean {a:.4}; cached {cached_rays} rays, mean {b:.4}");
    assert!(cached_rays * 10 < traced_rays, "cached diffuse pixels trace no shadow rays: {cached_rays} vs {traced_rays}");
    assert!((a - b).abs() < 0.05 * a, "the cached light must match the traced light: {a} vs {b}");
    // Below the threshold nothing changes.
    let few = scene(4);
    let ctx = FrameContext::new(&few, 0.0, 24, 18);
    let g = ctx.gbuffer();
    let img = render(&mut Wavecache::with_params(&settings, common::small_params()), &ctx, &g);
    assert!(img.pixels.iter().all(|p| p.is_finite()));
}

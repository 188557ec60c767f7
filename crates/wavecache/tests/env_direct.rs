//! The environment's direct light at glossy pixels (`env_direct`, ours): where a map's bright
//! part is smaller than a radiance-map texel (a sun, a studio softbox), Eq. 20's texel product
//! aliases it; with `env_direct` the maps keep it out, store the environment's visibility per
//! texel, and the runtime integrates the pixel's own BRDF against the environment × that
//! visibility. Checked against `pt` on the same pixels: a glossy sphere and a glossy floor in
//! the sphere's shadow under a studio map whose softbox is smaller than a map texel.

mod common;

use glimpse_core::{Image, Vec3, luminance};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings};
use glimpse_scene::{Environment, Scene};
use glimpse_trace::GBuffer;
use glimpse_wavecache::{EnvDirect, Wavecache, WavecacheParams};

use common::render;

/// A studio: a dim grey surround and one softbox of 8 × 6 texels of a 512 × 256 map (about
/// 5.6° × 4.2°, under a texel of a 32² radiance map), high in front of the sphere, to the camera's right.
fn studio() -> Environment {
    let (w, h) = (512u32, 256u32);
    let centre = Environment::dir_to_uv(Vec3::new(0.35, 0.75, 0.55).normalize());
    let (cx, cy) = ((centre.x * w as f32) as i64, (centre.y * h as f32) as i64);
    let image = Image::from_fn(w, h, |x, y| {
        let (dx, dy) = (x as i64 - cx, y as i64 - cy);
        if (-4..4).contains(&dx) && (-3..3).contains(&dy) { Vec3::splat(150.0) } else { Vec3::splat(0.02) }
    });
    Environment::new(image, 1.0)
}

/// A glossy sphere on a glossy floor, its softbox shadow falling behind it.
fn studio_scene() -> Scene {
    let toml = "[camera]\nposition = [0.0, 0.5, 1.2]\ntarget = [0.0, 0.15, 0.0]\nfov_y_degrees = 35.0\n\
        [[quad]]\nsize = [3.0, 3.0]\nmaterial = { base_color = [0.5, 0.5, 0.5], roughness = 0.35 }\n\
        [[sphere]]\nradius = 0.2\ntranslate = [0.0, 0.2, 0.0]\nmaterial = { base_color = [0.8, 0.3, 0.2], roughness = 0.3 }\n";
    let mut scene = common::scene_from_toml(toml);
    scene.environment = Some(studio());
    scene
}

/// The area lights' brighter half's solid angle and `small_cached_sources`.
fn small_cached(scene: &Scene) -> (f32, bool) {
    let frame = scene.at(0.0);
    (glimpse_wavecache::emitters_half_power_solid_angle(&frame).unwrap(), glimpse_wavecache::small_cached_sources(&frame))
}

fn params() -> WavecacheParams {
    common::small_params()
}

#[test]
fn auto_splits_only_maps_that_cannot_resolve_the_environment() {
    let p = WavecacheParams::default();
    let softbox = studio();
    let even = Environment::constant(Vec3::ONE);
    assert!(p.split_env(Some(&softbox), 32, 0.3), "the softbox is under a texel of a 32² map, the lobe under two");
    assert!(!p.split_env(Some(&softbox), 16, 0.5), "a lobe of 2.5 texels barely aliases it");
    assert!(!p.split_env(Some(&even), 32, 0.3) && !p.split_env(None, 32, 0.3));
    assert!(!WavecacheParams::paper().split_env(Some(&softbox), 32, 0.3), "the paper's maps hold all the light");
    let on = WavecacheParams::read(&Params::parse(&["env_direct=on".to_owned()]).unwrap()).unwrap();
    assert!(on.env_direct == EnvDirect::On && on.split_env(Some(&even), 32, 0.9));
}

#[test]
fn disagreeing_points_are_traced_under_small_sources_by_default() {
    // `trace_disagree=auto`: the softbox's hard shadows are traced where the blended points
    // disagree; a constant sky's soft ones are not worth the traced pixels' time.
    assert!(glimpse_wavecache::small_env_source(Some(&studio())));
    assert!(!glimpse_wavecache::small_env_source(Some(&Environment::constant(Vec3::ONE))) && !glimpse_wavecache::small_env_source(None));
    // Area lights with no map: 2 cm emissive spheres in a 6 m room are small sources (`glints`,
    // 0.0034 sr), a Cornell box's ceiling light is not (0.38 sr); a small emitter under a map is
    // left to the map's rule.
    const LIGHT: &str = "translate = [0.0, 2.0, 0.0]\nmaterial = { base_color = [0.0, 0.0, 0.0], emission = [500.0, 500.0, 500.0] }\n";
    let room = |emitter: &str| {
        common::scene_from_toml(&format!(
            "[[quad]]\nsize = [6.0, 6.0]\nmaterial = {{ base_color = [0.5, 0.5, 0.5] }}\n\
             [[sphere]]\nradius = 0.5\ntranslate = [0.0, 0.5, 0.0]\nmaterial = {{ base_color = [0.5, 0.5, 0.5] }}\n{emitter}{LIGHT}"
        ))
    };
    let sphere = "[[sphere]]\nradius = 0.02\n";
    let (solid_angle, small) = small_cached(&room(sphere));
    assert!(solid_angle < 0.01 && small, "a 2 cm sphere: {solid_angle} sr");
    let (solid_angle, small) = small_cached(&room("[[quad]]\nsize = [2.0, 2.0]\n"));
    assert!(solid_angle > 0.01 && !small, "a 2 m panel: {solid_angle} sr");
    let mut under_sky = room(sphere);
    under_sky.environment = Some(Environment::constant(Vec3::ONE));
    assert!(!small_cached(&under_sky).1);
    let read = |args: &[&str]| WavecacheParams::read(&Params::parse(args).unwrap()).unwrap();
    let auto = read(&[]);
    assert!(auto.disagree_auto);
    let fixed = read(&["trace_disagree=4"]);
    assert!(!fixed.disagree_auto && fixed.trace_disagree == 4.0);
    let paper = read(&["profile=paper"]);
    assert!(!paper.disagree_auto && paper.trace_disagree.is_infinite());
}

#[test]
fn a_small_softbox_on_glossy_surfaces_matches_pt() {
    let scene = studio_scene();
    let ctx = FrameContext::new(&scene, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let sphere = scene.materials.iter().position(|m| m.roughness == 0.3).unwrap() as u32;
    let glossy: Vec<usize> = (0..g.material.len()).filter(|&i| g.is_hit(i) && g.material[i] == sphere).collect();
    let reference = render(&mut PathTracer::new(&Settings { spp: 4096, seed: 5 }, &Params::default()).unwrap(), &ctx, &g);
    let settings = Settings { spp: 16, seed: 1 };
    let split = render(&mut Wavecache::with_params(&settings, params()), &ctx, &g);
    let whole = render(&mut Wavecache::with_params(&settings, WavecacheParams { env_direct: EnvDirect::Off, ..params() }), &ctx, &g);
    let mse = |img: &Image| {
        glossy.iter().map(|&i| ((luminance(img.pixels[i]) - luminance(reference.pixels[i])) as f64).powi(2)).sum::<f64>()
            / glossy.len() as f64
    };
    // 3 × 3 means are not needed here: the sphere is smooth at 16 spp.
    let over_twice =
        |img: &Image| glossy.iter().filter(|&&i| luminance(img.pixels[i]) > 2.0 * luminance(reference.pixels[i]).max(0.05)).count();
    let (e_split, e_whole) = (mse(&split), mse(&whole));
    println!(
        "{} px: MSE against pt (4096 spp) {e_split:.3e} with env_direct, {e_whole:.3e} with the paper's maps; over 2× pt {} and {}",
        glossy.len(),
        over_twice(&split),
        over_twice(&whole)
    );
    assert!(glossy.len() > 200);
    assert!(e_split < 0.5 * e_whole, "env_direct must remove the aliased softbox: {e_split:.3e} vs {e_whole:.3e}");
    // At 1 spp a pixel read from the cache still takes `env_direct_pixel_samples` (256), not
    // `env_direct_samples` × 1 (8): the cache's pixels should not get noisier with fewer spp.
    let one = Settings { spp: 1, seed: 1 };
    let floored = mse(&render(&mut Wavecache::with_params(&one, params()), &ctx, &g));
    let per_spp = mse(&render(&mut Wavecache::with_params(&one, WavecacheParams { env_direct_pixel_samples: 0, ..params() }), &ctx, &g));
    println!("at 1 spp: MSE {floored:.3e} with 256 environment samples per pixel, {per_spp:.3e} with 8");
    assert!(floored < 0.7 * per_spp, "the pixel floor must cut the samples' noise: {floored:.3e} vs {per_spp:.3e}");
    // The visibility maps keep the softbox's shadow: the floor behind the sphere stays dark.
    let floor = scene.materials.iter().position(|m| m.roughness == 0.35).unwrap() as u32;
    let shadow: Vec<usize> = (0..g.material.len())
        .filter(|&i| g.is_hit(i) && g.material[i] == floor && luminance(reference.pixels[i]) < 0.3 * floor_median(&g, &reference, floor))
        .collect();
    let mean = |img: &Image, px: &[usize]| px.iter().map(|&i| luminance(img.pixels[i]) as f64).sum::<f64>() / px.len().max(1) as f64;
    println!(
        "the sphere's shadow on the floor, {} px: pt {:.4}, env_direct {:.4}, the paper's maps {:.4}",
        shadow.len(),
        mean(&reference, &shadow),
        mean(&split, &shadow),
        mean(&whole, &shadow)
    );
    assert!(shadow.len() > 20, "the scene must show the sphere's shadow");
    assert!(mean(&split, &shadow) < 1.5 * mean(&reference, &shadow) + 0.02, "the shadow must stay dark");
}

fn floor_median(g: &GBuffer, img: &Image, floor: u32) -> f32 {
    let mut v: Vec<f32> =
        (0..g.material.len()).filter(|&i| g.is_hit(i) && g.material[i] == floor).map(|i| luminance(img.pixels[i])).collect();
    v.sort_by(f32::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

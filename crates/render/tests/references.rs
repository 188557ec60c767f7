//! Properties every reference technique must have: determinism under a seed, finite
//! non-negative pixels on every built-in scene, and clear errors for bad parameters.

use glimpse_core::{Image, Vec3, is_finite3};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, ParamError, Params, Registry, RenderError, Settings, Technique};
use glimpse_scene::{Environment, Light, Scene};

fn registry() -> Registry {
    Registry::new(glimpse_render::techniques())
}

fn render(scene: &Scene, id: &str, settings: Settings, set: &[&str], size: u32) -> Image {
    let params = Params::parse(set).unwrap();
    let mut t = registry().create(id, scene, &settings, &params).unwrap_or_else(|e| panic!("{id}: {e}"));
    let ctx = FrameContext::new(scene, 0.0, size, size);
    let g = ctx.gbuffer();
    t.prepare(&ctx).unwrap();
    let mut img = ctx.image();
    t.render(&ctx, &g, &mut img).unwrap();
    if REFERENCES.contains(&id) {
        assert_eq!(ctx.progress.done(), (size * size) as u64, "{id}: one progress tick per pixel");
    }
    img
}

/// The Cornell box with every kind of light: its area light, a point light, a spot, a
/// directional light and an environment (seen through the open front).
fn lit_cornell() -> Scene {
    let mut s = glimpse_scene::load("cornell").unwrap();
    s.lights.push(Light::point(Vec3::new(0.15, 0.4, 0.2), Vec3::splat(0.05)));
    s.lights.push(Light::spot(Vec3::new(0.4, 0.5, 0.3), Vec3::new(0.0, -1.0, 0.1), Vec3::splat(0.2), 0.2, 0.5));
    s.lights.push(Light::directional(Vec3::new(0.1, -0.2, 1.0), Vec3::splat(0.5)));
    s.environment = Some(Environment::procedural_sky(32, Vec3::new(0.2, 0.3, -1.0), 20.0));
    s
}

/// The exact references (other techniques in the registry are approximations).
const REFERENCES: &[&str] = &["ao-exact", "soft-exact", "lights-exact", "env-exact", "gi-exact", "pt"];
/// The references whose image depends on the seed (lights-exact has no randomness).
const STOCHASTIC: &[&str] = &["ao-exact", "soft-exact", "env-exact", "gi-exact", "pt"];

#[test]
fn same_seed_same_image_different_seed_different_image() {
    let scene = lit_cornell();
    for info in glimpse_render::techniques() {
        let id = info.id;
        let set: &[&str] = if id == "env-exact" { &["rays=8"] } else { &[] };
        let a = render(&scene, id, Settings { spp: 2, seed: 1 }, set, 16);
        let b = render(&scene, id, Settings { spp: 2, seed: 1 }, set, 16);
        let c = render(&scene, id, Settings { spp: 2, seed: 2 }, set, 16);
        let differing = a.pixels.iter().zip(&c.pixels).filter(|(x, y)| x != y).count();
        println!("{id}: seed 1 twice identical: {}; seed 2 differs in {differing} of {} pixels", a == b, a.len());
        assert_eq!(a, b, "{id} is not deterministic");
        if STOCHASTIC.contains(&id) {
            assert!(differing > 0, "{id} ignores the seed");
        }
        if REFERENCES.contains(&id) {
            assert!(a.mean().max_element() > 0.0, "{id} renders black");
        }
    }
}

#[test]
fn references_refuse_scenes_without_their_lights() {
    let cornell = glimpse_scene::load("cornell").unwrap();
    for id in ["lights-exact", "env-exact"] {
        let e = registry().create(id, &cornell, &Settings::default(), &Params::default()).err().map(|e| e.to_string()).unwrap_or_default();
        println!("{id} on cornell: {e}");
        assert!(e.contains("has no"), "{id}: {e}");
    }
}

#[test]
fn every_reference_on_every_builtin_scene_is_finite_and_non_negative() {
    for name in glimpse_scene::builtin::NAMES {
        let scene = glimpse_scene::load(name).unwrap();
        for info in glimpse_render::techniques() {
            // A technique refuses a scene without its kind of light rather than render black.
            if let Err(RenderError::Unsupported { message, .. }) =
                registry().create(info.id, &scene, &Settings::default(), &Params::default())
            {
                println!("{name} / {}: not applicable: {message}", info.id);
                assert!(message.contains("has no"), "{message}");
                continue;
            }
            let img = render(&scene, info.id, Settings { spp: 2, seed: 3 }, &[], 16);
            let bad = img.pixels.iter().filter(|p| !is_finite3(**p) || p.min_element() < 0.0).count();
            println!("{name} / {}: mean {:.4}, {bad} bad pixels", info.id, img.mean());
            assert_eq!(bad, 0, "{name} / {}", info.id);
        }
        // And no path was dropped as NaN/inf.
        let mut pt = PathTracer::new(&Settings { spp: 4, seed: 3 }, &Params::default()).unwrap();
        let ctx = FrameContext::new(&scene, 0.0, 16, 16);
        let g = ctx.gbuffer();
        pt.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        pt.render(&ctx, &g, &mut img).unwrap();
        assert_eq!(pt.nonfinite_paths(), 0, "{name}: NaN or infinite paths");
    }
}

fn create_err(id: &str, settings: Settings, set: &[&str]) -> RenderError {
    let params = Params::parse(set).unwrap();
    match registry().create(id, &lit_cornell(), &settings, &params) {
        Ok(_) => panic!("{id} {set:?} should be rejected"),
        Err(e) => e,
    }
}

#[test]
fn bad_parameters_are_errors() {
    let ok = Settings::default();
    for info in glimpse_render::techniques() {
        let e = create_err(info.id, ok, &["no_such_key=1"]);
        assert!(matches!(&e, RenderError::Param(ParamError::Unknown { key, .. }) if key == "no_such_key"), "{}: {e}", info.id);
    }
    let cases: &[(&str, Settings, &[&str], &str)] = &[
        ("env-exact", ok, &["rays=0"], "rays"),
        ("env-exact", ok, &["rays=many"], "rays"),
        ("env-exact", ok, &["converged=true", "rays=1"], "rays"),
        ("env-exact", ok, &["converged=maybe"], "converged"),
        ("env-exact", ok, &["rotation=random"], "rotation"),
        ("pt", ok, &["max_depth=0"], "max_depth"),
        ("pt", ok, &["brdf=phong"], "brdf"),
        ("pt", Settings { spp: 0, seed: 0 }, &[], "spp"),
        ("soft-exact", Settings { spp: 0, seed: 0 }, &[], "spp"),
        ("soft-exact", ok, &["shadows=perhaps"], "shadows"),
        ("gi-exact", ok, &["include_direct=2"], "include_direct"),
        ("gi-exact", Settings { spp: 0, seed: 0 }, &[], "spp"),
        ("lights-exact", ok, &["lights=0"], "lights"),
        ("lights-exact", ok, &["lights=-1"], "lights"),
    ];
    for (id, settings, set, key) in cases {
        let e = create_err(id, *settings, set).to_string();
        println!("{id} {set:?} spp {}: {e}", settings.spp);
        assert!(e.contains(key), "{id}: {e}");
    }
}

#[test]
fn lights_parameter_counts_from_the_start() {
    // lights=1 on a scene with a point light and a second light: only the first one shines.
    let scene = lit_cornell();
    let all = render(&scene, "lights-exact", Settings::default(), &[], 16);
    let first = render(&scene, "lights-exact", Settings::default(), &["lights=1"], 16);
    let many = render(&scene, "lights-exact", Settings::default(), &["lights=1000"], 16);
    assert_eq!(all, many, "N beyond the count means all");
    assert!(first.mean().max_element() < all.mean().max_element());
}

#[test]
fn emission_and_background_conventions() {
    // Pixels on the light show its emission plus reflected light; misses show the environment
    // (every reference but AO, whose misses are open sky = 1).
    let scene = lit_cornell();
    let ctx = FrameContext::new(&scene, 0.0, 24, 24);
    let g = ctx.gbuffer();
    let misses = (0..g.len()).filter(|&i| !g.is_hit(i)).count();
    let emitters = (0..g.len()).filter(|&i| g.emission[i].max_element() > 0.0).count();
    println!("{misses} background pixels, {emitters} emitter pixels");
    assert!(emitters > 0);
    for info in glimpse_render::techniques().iter().filter(|i| REFERENCES.contains(&i.id) && i.id != "ao-exact") {
        let img = render(&scene, info.id, Settings { spp: 1, seed: 0 }, &[], 24);
        for i in 0..img.len() {
            if !g.is_hit(i) {
                let env = scene.environment.as_ref().unwrap().radiance(g.view_dir[i]);
                assert_eq!(img.pixels[i], env, "{}: background", info.id);
            } else if g.emission[i].max_element() > 0.0 {
                assert!((img.pixels[i] - g.emission[i]).min_element() >= -1e-6, "{}: emission", info.id);
            }
        }
    }
}

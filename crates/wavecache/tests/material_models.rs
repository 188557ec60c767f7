//! Materials other than glTF's metallic-roughness (the paper's only model), as the loaders make
//! them from Mitsuba scenes and scene.toml's `model`: smooth glass (`dielectric`), conductors with
//! their complex IOR (a mirror and a rough one) and Lambertian `diffuse`. Each is shaded as `pt`
//! shades it: glass and the mirror by traced chains, the rough conductor from its own BRDF
//! tables, the Lambertian surface with Lambert's albedos. Checked against `pt` on each object's
//! pixels. (Before session 23 the cache read every material as glTF's: the glass sphere was a
//! white diffuse ball and the mirror reflected 4 %, since a conductor's `metallic` is 0.)

mod common;

use glimpse_core::{Image, Vec3, luminance};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings};
use glimpse_scene::{Environment, Scene};
use glimpse_wavecache::{Class, Wavecache, WavecacheParams};

use common::render;

/// Four spheres of the four models on a grey floor before a wall, under a sky and a warm panel.
fn scene() -> Scene {
    let toml = "[camera]\nposition = [0.0, 0.9, 3.0]\ntarget = [0.0, 0.35, 0.0]\nfov_y_degrees = 40.0\n\
        [[quad]]\nsize = [6.0, 6.0]\nmaterial = { base_color = [0.5, 0.5, 0.5], roughness = 0.9 }\n\
        [[quad]]\nsize = [6.0, 3.0]\nrotate = { axis = [1.0, 0.0, 0.0], degrees = 90.0 }\ntranslate = [0.0, 1.5, -1.0]\n\
        material = { base_color = [0.2, 0.4, 0.7], texture = { checker = { cells = 6, colors = [[0.3,0.3,0.3],[0.9,0.9,0.9]] } } }\n\
        [[quad]]\nsize = [1.0, 1.0]\nrotate = { axis = [1.0, 0.0, 0.0], degrees = 180.0 }\ntranslate = [0.8, 2.0, 0.8]\n\
        material = { base_color = [0.0, 0.0, 0.0], emission = [12.0, 10.0, 8.0] }\n\
        [[sphere]]\nradius = 0.3\ntranslate = [-1.05, 0.3, 0.0]\nmaterial = { model = \"dielectric\", ior = 1.5 }\n\
        [[sphere]]\nradius = 0.3\ntranslate = [-0.35, 0.3, 0.0]\nmaterial = { model = \"conductor\", base_color = [1.0, 1.0, 1.0] }\n\
        [[sphere]]\nradius = 0.3\ntranslate = [0.35, 0.3, 0.0]\n\
        material = { model = \"conductor\", roughness = 0.35, eta = [0.2, 0.92, 1.1], k = [3.9, 2.45, 2.14] }\n\
        [[sphere]]\nradius = 0.3\ntranslate = [1.05, 0.3, 0.0]\nmaterial = { model = \"diffuse\", base_color = [0.7, 0.5, 0.3] }\n";
    let mut scene = common::scene_from_toml(toml);
    scene.environment = Some(Environment::constant(Vec3::new(0.5, 0.6, 0.8)));
    scene
}

fn params() -> WavecacheParams {
    WavecacheParams { glossy_points: 400, ..common::small_params() }
}

#[test]
fn the_models_are_classified_by_how_they_reflect() {
    let scene = scene();
    let p = WavecacheParams::default();
    let classes: Vec<Class> = scene.materials.iter().filter(|m| !m.is_emissive()).map(|m| p.classify(m)).collect();
    // Floor, wall (glTF, diffuse-rough), glass, mirror, rough copper, Lambertian.
    assert_eq!(classes, [Class::Diffuse, Class::Diffuse, Class::Mirror, Class::Mirror, Class::Glossy, Class::Diffuse]);
}

#[test]
fn each_model_matches_pt_on_its_own_pixels() {
    let scene = scene();
    let ctx = FrameContext::new(&scene, 0.0, 96, 48);
    let g = ctx.gbuffer();
    let reference = render(&mut PathTracer::new(&Settings { spp: 1024, seed: 5 }, &Params::default()).unwrap(), &ctx, &g);
    let cached = render(&mut Wavecache::with_params(&Settings { spp: 64, seed: 1 }, params()), &ctx, &g);
    let mean = |img: &Image, px: &[usize]| px.iter().map(|&i| luminance(img.pixels[i]) as f64).sum::<f64>() / px.len().max(1) as f64;
    let spheres = &scene.materials.iter().enumerate().filter(|(_, m)| !m.is_emissive()).map(|(i, _)| i as u32).collect::<Vec<_>>()[2..];
    let models =
        [("glass", spheres[0], 0.1), ("mirror", spheres[1], 0.1), ("rough copper", spheres[2], 0.1), ("Lambertian", spheres[3], 0.05)];
    for (name, material, bound) in models {
        let px: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i) && g.material[i] == material).collect();
        let (r, c) = (mean(&reference, &px), mean(&cached, &px));
        let rel = (c - r).abs() / r;
        println!("{name}: {} px, mean luminance pt {r:.4}, wavecache {c:.4} (relative difference {rel:.3})", px.len());
        assert!(px.len() > 100, "{name} must cover pixels");
        assert!(rel < bound, "{name}: wavecache {c:.4} against pt {r:.4}");
    }
}

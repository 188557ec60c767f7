//! What a diffuse pixel reads from the irradiance points.
//!
//! Buried points (`enclosed_share`). Real meshes interpenetrate and
//! rest on each other: Suzanne's eyeballs sit half inside her head, a block stands on a floor
//! that runs on under it. A point placed where no light reaches (an eyeball's hidden half, the
//! floor inside the block) caches the dark inside, and the query hands it to the visible pixels
//! nearby: black patches around `studio-objects`' eyes where `pt` is lit.
//!
//!
//! Blending (`blend`): the paper reads the one best point, which makes the image a mosaic of the
//! points' cells; the mean of the nearest few (a kernel of 2 r_max) is nearer the irradiance.
//!
//! Here: a closed box sunk into a floor under a uniform sky; the floor's points inside the box,
//! and the floor's irradiance falling towards the box's foot.

use glimpse_core::{Image, Mat4, Vec3, luminance};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::builtin::box_mesh;
use glimpse_scene::{Camera, Environment, Material, Mesh, Scene};
use glimpse_wavecache::bake::Integrator;
use glimpse_wavecache::half::f16_to_f32;
use glimpse_wavecache::points::SurfaceSample;
use glimpse_wavecache::technique::{Runtime, ShadePoint};
use glimpse_wavecache::{Wavecache, WavecacheParams};

fn scene() -> Scene {
    let mut s = Scene { name: "buried".into(), ..Default::default() };
    let grey = s.add_material(Material::diffuse("grey", Vec3::splat(0.7)));
    let floor = Mesh {
        name: "floor".into(),
        positions: vec![Vec3::new(-1.5, 0.0, 1.5), Vec3::new(1.5, 0.0, 1.5), Vec3::new(1.5, 0.0, -1.5), Vec3::new(-1.5, 0.0, -1.5)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material: grey,
        ..Default::default()
    };
    s.add_mesh(floor, Mat4::IDENTITY);
    // Sunk 5 cm into the floor: the floor under it is inside the box.
    s.add_mesh(box_mesh("block", grey, Vec3::splat(0.4)), Mat4::from_translation(Vec3::new(0.0, 0.35, 0.0)));
    s.environment = Some(Environment::new(Image::filled(32, 16, Vec3::ONE), 1.0));
    s.camera = Some(Camera::look_at(Vec3::new(0.9, 1.6, 2.0), Vec3::new(0.0, 0.2, 0.0), Vec3::Y, 45.0));
    s
}

fn params(enclosed_share: f32) -> WavecacheParams {
    WavecacheParams {
        irradiance_samples: 64,
        diffuse_points: 400,
        path_floor: 0,
        enclosed_share,
        disk_cache: false,
        progress: false,
        ..Default::default()
    }
}

#[test]
fn buried_points_are_dropped_and_leave_no_black_patches() {
    let scene = scene();
    let ctx = FrameContext::new(&scene, 0.0, 48, 40);
    let g = ctx.gbuffer();
    let mut pt = PathTracer::new(&Settings { spp: 64, seed: 3 }, &Params::default()).unwrap();
    pt.prepare(&ctx).unwrap();
    let mut reference = ctx.image();
    pt.render(&ctx, &g, &mut reference).unwrap();

    let run = |share: f32| {
        let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, params(share));
        let stats = t.prepare(&ctx).unwrap();
        let mut img = ctx.image();
        t.render(&ctx, &g, &mut img).unwrap();
        let c = t.cache.as_ref().unwrap();
        let dark_points = c.irradiance.iter().filter(|e| e.iter().all(|v| f16_to_f32(*v) < 1e-3)).count();
        let enclosed = stats.metrics.iter().find(|(k, _)| k == "enclosed_points").map_or(-1.0, |m| m.1);
        // Lit pixels under 10 % and under half of pt's.
        let lit: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i) && luminance(reference.pixels[i]) > 0.05).collect();
        let under = |k: f32| lit.iter().filter(|&&i| luminance(img.pixels[i]) < k * luminance(reference.pixels[i])).count();
        let black = (under(0.1), under(0.5));
        (enclosed, dark_points, c.irradiance.len(), black)
    };
    let (off_enclosed, off_dark, off_points, off_black) = run(1.0);
    let (on_enclosed, on_dark, on_points, on_black) = run(0.5);
    println!("enclosed_share=1 (off): {off_points} points, {off_dark} dark, lit pixels under 10 %, 50 % of pt: {off_black:?}");
    println!("enclosed_share=0.5: {on_points} points ({on_enclosed} buried dropped), {on_dark} dark, under 10 %, 50 %: {on_black:?}");
    assert_eq!(off_enclosed, 0.0, "off drops nothing");
    assert!(off_dark > 0, "the eye's hidden half holds points with no light");
    assert!(off_black.1 > 0, "and visible pixels next to the box read them");
    assert!(on_enclosed > 0.0 && on_enclosed as usize <= 2 * off_dark, "only buried points go");
    assert_eq!(on_dark, 0, "no dark point is left");
    assert_eq!(on_black, (0, 0), "no dark patch");
}

/// On the built-in scenes only points under something are buried: the floor under the blocks
/// and the red box, the ceiling above the light panel (its back faces the ceiling). Walls,
/// blocks, spheres and lights keep every point (sparsification off, so every point gone is a
/// buried one).
#[test]
fn only_points_under_something_are_buried() {
    for name in ["cornell-lit", "glossy"] {
        let scene = glimpse_scene::load(name).unwrap();
        let ctx = FrameContext::new(&scene, 0.0, 16, 16);
        let p = WavecacheParams { brdf_res: 16, brdf_grid_u1: 8, brdf_grid_u2: 32, texel_samples: 1, sparsify: 0.0, ..params(0.5) };
        let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p);
        let stats = t.prepare(&ctx).unwrap();
        let enclosed = stats.metrics.iter().find(|(k, _)| k == "enclosed_points").map_or(0.0, |m| m.1);
        println!("{name}: {enclosed} buried points");
        let mut floor_dropped = 0;
        for (i, mc) in t.cache.as_ref().unwrap().meshes.iter().enumerate() {
            let mesh = &scene.meshes[scene.instances[i].mesh as usize];
            let dropped = mc.points_before - mc.point_count;
            println!("  {}: {} of {} kept", mesh.name, mc.point_count, mc.points_before);
            if mesh.name == "floor" || mesh.name == "ceiling" {
                assert!(dropped * 4 <= mc.points_before, "{name} {}: {dropped} dropped", mesh.name);
                floor_dropped += (mesh.name == "floor") as u32 * dropped;
            } else {
                assert_eq!(dropped, 0, "{name} {}", mesh.name);
            }
        }
        assert!(floor_dropped > 0, "{name}: the floor under the blocks is buried");
    }
}

/// Blending the nearest points' irradiance is nearer the exact irradiance (the cache's own
/// estimator at 2,048 paths) than the best point's alone, over the floor's pixels.
#[test]
fn blending_points_is_nearer_the_irradiance() {
    let scene = scene();
    let ctx = FrameContext::new(&scene, 0.0, 40, 32);
    let g = ctx.gbuffer();
    let floor: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i) && g.instance[i] == 0).collect();
    let p = params(0.5);
    let integ = Integrator::new(&ctx.frame, &ctx.tracer, p.max_depth, glimpse_render::bsdf::BrdfModel::Pbr);
    let exact: Vec<Vec3> = floor
        .iter()
        .map(|&i| {
            let s = ShadePoint::at_pixel(&g, i);
            let sample =
                SurfaceSample { position: s.position, error_scale: s.error_scale, normal: s.normal, shading_normal: s.shading_normal };
            let mut rng = glimpse_core::Rng::new(9, i as u64);
            (0..2048).map(|_| integ.irradiance(&sample, &mut rng).0).sum::<Vec3>() / 2048.0
        })
        .collect();
    let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p.clone());
    t.prepare(&ctx).unwrap();
    let cache = t.cache.as_ref().unwrap();
    let error = |blend: u32| {
        let p = WavecacheParams { blend, ..p.clone() };
        let rt = Runtime::new(cache, &p, &ctx.frame, &ctx.tracer);
        let sum: f64 = floor
            .iter()
            .zip(&exact)
            .map(|(&i, e)| {
                let reading = rt.point_for(&ShadePoint::at_pixel(&g, i), -g.view_dir[i]);
                let got = reading.blended().map(|(p, w)| cache.irradiance_at(p.payload).unwrap_or(Vec3::ZERO) * w).sum::<Vec3>();
                ((got - *e).length_squared() / 3.0) as f64
            })
            .sum();
        sum / floor.len() as f64
    };
    let (one, four) = (error(1), error(4));
    println!("floor irradiance MSE over {} pixels: best point {one:.3e}, 4 blended {four:.3e}", floor.len());
    assert!(four < 0.8 * one, "blending is nearer the irradiance");
}

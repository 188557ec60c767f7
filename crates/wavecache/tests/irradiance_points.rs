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

/// A point's reach (`CachePoint::reach`, the harmonic mean of its probe rays' hit distances)
/// is short at the block's foot, where half its rays meet the block, and long out on the open
/// floor, where most escape to the sky; without probe rays (`enclosed_share=1`) it is unknown.
#[test]
fn points_know_their_reach() {
    let scene = scene();
    let ctx = FrameContext::new(&scene, 0.0, 16, 16);
    let reaches = |share: f32| {
        let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, params(share));
        t.prepare(&ctx).unwrap();
        let c = t.cache.as_ref().unwrap();
        let floor = c.meshes[0];
        let pts = &c.points[floor.first_point as usize..(floor.first_point + floor.point_count) as usize];
        // Distance from the block's footprint (half-size 0.4: |x|, |z| ≤ 0.4) along the floor.
        let gap = |p: &[f32; 3]| (p[0].abs() - 0.4).max(p[2].abs() - 0.4);
        let median = |mut v: Vec<f32>| {
            v.sort_by(f32::total_cmp);
            v[v.len() / 2]
        };
        let near: Vec<f32> = pts.iter().filter(|p| (0.0..0.1).contains(&gap(&p.position))).map(|p| p.reach).collect();
        let far: Vec<f32> = pts.iter().filter(|p| gap(&p.position) > 0.8).map(|p| p.reach).collect();
        assert!(pts.iter().all(|p| p.reach.is_finite() && p.reach > 0.0));
        (near.len(), median(near), far.len(), median(far))
    };
    let (n_near, near, n_far, far) = reaches(0.5);
    println!("reach at the block's foot {near:.3} m (median of {n_near}), out on the floor {far:.3e} m (of {n_far})");
    assert!(near < 0.5 && near * 10.0 < far, "near {near}, far {far}");
    let (_, unknown, _, _) = reaches(1.0);
    assert_eq!(unknown, glimpse_wavecache::bake::NO_REACH, "no probe, no reach");
}

/// `validity`: where lonely pixels are traced (`trace_disagree` applies), a pixel whose points
/// inside the kernel all lie beyond Ward's error (distance / reach + √(1 − n·n) ≥ `validity`)
/// is traced, on a diffuse floor and on a glossy one. The floor's points given a reach of 1 mm:
/// every floor pixel with points in its kernel is traced; of unbounded reach, or with
/// `validity=inf`: as before.
#[test]
fn points_beyond_their_reach_make_a_pixel_traced() {
    for roughness in [1.0, 0.3] {
        let mut scene = scene();
        scene.materials[0].roughness = roughness;
        let ctx = FrameContext::new(&scene, 0.0, 48, 40);
        let g = ctx.gbuffer();
        let p = WavecacheParams {
            trace_disagree: 3.0,
            disagree_auto: false,
            brdf_res: 16,
            brdf_grid_u1: 8,
            brdf_grid_u2: 32,
            texel_samples: 1,
            glossy_points: 400,
            ..params(0.5)
        };
        let mut t = Wavecache::with_params(&Settings { spp: 1, seed: 5 }, p.clone());
        t.prepare(&ctx).unwrap();
        let floor: Vec<usize> = (0..g.len()).filter(|&i| g.is_hit(i) && g.instance[i] == 0).collect();
        let class = t.cache.as_ref().unwrap().meshes[0].class;
        let traced = |reach: Option<f32>, validity: f32| {
            let mut cache = t.cache.clone().unwrap();
            let m = cache.meshes[0];
            if let Some(r) = reach {
                cache.points[m.first_point as usize..(m.first_point + m.point_count) as usize].iter_mut().for_each(|p| p.reach = r);
            }
            let p = WavecacheParams { validity, ..p.clone() };
            let rt = Runtime::new(&cache, &p, &ctx.frame, &ctx.tracer);
            floor.iter().filter(|&&i| rt.point_for(&ShadePoint::at_pixel(&g, i), -g.view_dir[i]).far).count()
        };
        let measured = traced(None, 0.3);
        let (short, unbounded, off) =
            (traced(Some(1e-3), 0.3), traced(Some(glimpse_wavecache::bake::NO_REACH), 0.3), traced(Some(1e-3), f32::INFINITY));
        println!(
            "roughness {roughness} (class {class}): floor pixels traced of {}: reach as measured {measured}, 1 mm {short}, unbounded {unbounded}, validity=inf {off}",
            floor.len()
        );
        assert_eq!(class, if roughness == 1.0 { 0 } else { 1 }, "a diffuse floor, then a glossy one");
        assert!(short > floor.len() * 9 / 10, "points 1 mm long hold nowhere: {short}");
        assert!(unbounded <= measured && measured < short);
        assert_eq!(off, unbounded, "validity=inf reads the points whatever their reach");
    }
}

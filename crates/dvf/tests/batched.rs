//! The batched runtime (issue #14) against the per-ray loop it replaces: the same image bit for
//! bit, and its parts (directions, octahedral pixels, sin/cos) against the scalar functions.
//! Each test prints what it compared before asserting zero differences.

use glimpse_core::sampling::uniform_sphere;
use glimpse_core::{Image, Rng, Vec3};
use glimpse_dvf::grid::octahedral_pixel;
use glimpse_dvf::raybatch::{self, Block, Former};
use glimpse_dvf::rays::RaySet;
use glimpse_dvf::technique::{EnvDvf, RuntimePath};
use glimpse_render::direct::{self, Shading};
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_trace::GBuffer;

/// The render loop of `EnvDvf::render`, with the runtime's loop chosen.
fn shade(t: &EnvDvf, ctx: &FrameContext, g: &GBuffer, path: RuntimePath) -> (Image, u64) {
    let rt = t.runtime(ctx).expect("prepared, with an environment");
    let mut img = ctx.image();
    let rays = direct::shade_pixels(ctx, g, t.settings.seed, &mut img, |i, rng| {
        let Some(s) = Shading::from_gbuffer(g, i) else { return (Vec3::ZERO, 0) };
        let set = RaySet::new(s.shading_normal, t.params.rays, rng.next_2d(), t.params.rotate_about_normal);
        let (e, rays) = rt.irradiance_by(&s, &set, path);
        (s.albedo * e, rays)
    })
    .unwrap();
    (img, rays)
}

fn differing_pixels(a: &Image, b: &Image) -> usize {
    a.pixels.iter().zip(&b.pixels).filter(|(p, q)| p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits)).count()
}

#[test]
fn batched_image_equals_per_ray_image_bit_for_bit() {
    let configs: &[&str] = &[
        "",
        "unknown=trace",
        "unshadowed=rays",
        "unshadowed=sh unknown=trace",
        "rotation=normal",
        "rotation=normal unshadowed=rays unknown=trace",
        "rays=100",
        "rays=37 octahedral=16 unknown=trace",
        "rays=200 octahedral=32",
        "rays=256 octahedral=5",
        "rays=300",
        "bright=on bright_sr=1",
        "bright=on octahedral=5 unshadowed=rays",
        "bright=on rays=37 octahedral=16 bright_sr=0.05",
        "bright=off",
    ];
    let (mut images, mut pixels, mut rays_total) = (0usize, 0usize, 0u64);
    let mut formers = vec![Former::Scalar];
    if raybatch::simd_supported() {
        formers.push(Former::Simd);
    }
    println!("AVX2 former supported: {}, enabled after self-check: {}", raybatch::simd_supported(), raybatch::simd_enabled());
    for scene_name in ["sky", "cornell-lit"] {
        let scene = glimpse_scene::load(scene_name).unwrap();
        if scene.environment.is_none() {
            println!("{scene_name}: no environment, skipped");
            continue;
        }
        let ctx = FrameContext::new(&scene, 0.0, 48, 36);
        let g = ctx.gbuffer();
        for (ci, cfg) in configs.iter().enumerate() {
            for force in [None, Some(0u8), Some(1u8)] {
                let mut pairs = vec!["points=3000".to_owned(), "grid=8".to_owned()];
                pairs.extend(cfg.split_whitespace().map(str::to_owned));
                let mut t = EnvDvf::new(&Settings { spp: 1, seed: 5 + ci as u64 }, &Params::parse(&pairs).unwrap()).unwrap();
                t.force_label = force;
                t.prepare(&ctx).unwrap();
                let (old, old_rays) = shade(&t, &ctx, &g, RuntimePath::PerRay);
                for &former in &formers {
                    let (new, new_rays) = shade(&t, &ctx, &g, RuntimePath::Batched(former));
                    let diff = differing_pixels(&old, &new);
                    println!(
                        "{scene_name} [{cfg}] label {force:?} {former:?}: {} pixels, {diff} differ; rays {old_rays} vs {new_rays}",
                        old.pixels.len()
                    );
                    assert_eq!(diff, 0, "{scene_name} [{cfg}] {force:?} {former:?}");
                    assert_eq!(old_rays, new_rays);
                    images += 1;
                    pixels += old.pixels.len();
                    rays_total += new_rays;
                }
                // And the technique's own render (the default path).
                let mut img = ctx.image();
                t.render(&ctx, &g, &mut img).unwrap();
                assert_eq!(differing_pixels(&old, &img), 0, "render(): {scene_name} [{cfg}] {force:?}");
            }
        }
    }
    println!("{images} batched images, {pixels} pixels compared ({rays_total} rays traced): 0 differences");
    assert!(images > 0);
}

#[test]
fn block_directions_equal_ray_set_directions() {
    let mut rng = Rng::new(99, 3);
    let (mut compared, mut diffs, mut used_diffs, mut pixel_diffs) = (0u64, 0u64, 0u64, 0u64);
    let mut formers = vec![Former::Scalar];
    if raybatch::simd_supported() {
        formers.push(Former::Simd);
    }
    let mut b = Box::<Block>::default();
    for i in 0..3000u32 {
        let normal = match i % 50 {
            0 => Vec3::Z,
            1 => -Vec3::Z,
            2 => Vec3::X,
            3 => Vec3::new(0.0, -1.0, 0.0),
            _ => uniform_sphere(rng.next_2d()),
        };
        let count = [128, 1, 7, 8, 9, 64, 100, 255, 256][i as usize % 9];
        let shift = if i % 17 == 0 { glimpse_core::Vec2::new(0.5, 0.0) } else { rng.next_2d() };
        let set = RaySet::new(normal, count, shift, i % 5 == 4);
        let geometric = (normal + uniform_sphere(rng.next_2d()) * 0.5).normalize_or(normal);
        let r = [8, 1, 3, 16, 32][i as usize % 5];
        for &former in &formers {
            raybatch::form(&set, geometric, normal, r, former, &mut b);
            for k in 0..count as usize {
                let d = set.direction(k as u32);
                let got = b.direction(k);
                diffs += (d.to_array().map(f32::to_bits) != got.to_array().map(f32::to_bits)) as u64;
                pixel_diffs += (octahedral_pixel(d, r) != b.pixel[k]) as u64;
                let s = Shading { position: Vec3::ZERO, error_scale: 0.0, normal: geometric, shading_normal: normal, albedo: Vec3::ONE };
                let used = s.cos(d) > 0.0;
                used_diffs += (used != (b.used[k / 64] >> (k % 64) & 1 == 1)) as u64;
                compared += 1;
            }
            for k in count as usize..raybatch::MAX_RAYS {
                used_diffs += b.used[k / 64] >> (k % 64) & 1;
            }
        }
    }
    println!(
        "{compared} directions compared (formers {formers:?}): {diffs} differ, {pixel_diffs} pixels differ, {used_diffs} horizon bits differ"
    );
    assert_eq!((diffs, pixel_diffs, used_diffs), (0, 0, 0));
}

#[test]
fn simd_octahedral_pixels_equal_scalar() {
    let mut rng = Rng::new(7, 11);
    let mut dirs: Vec<Vec3> = Vec::new();
    // Axes, ±0 components and the octants' diagonals.
    let vals = [0.0f32, -0.0, 1.0, -1.0, 0.5, -0.5, std::f32::consts::FRAC_1_SQRT_2, -std::f32::consts::FRAC_1_SQRT_2];
    for &x in &vals {
        for &y in &vals {
            for &z in &vals {
                let v = Vec3::new(x, y, z);
                if v.length_squared() > 0.0 {
                    dirs.push(v / v.length());
                    dirs.push(v);
                }
            }
        }
    }
    for _ in 0..200_000 {
        let d = uniform_sphere(rng.next_2d());
        dirs.push(d);
        // On the octahedron's edges: one component zeroed (either sign).
        let i = (rng.next_f32() * 3.0) as usize % 3;
        let mut a = d.to_array();
        a[i] = if rng.next_f32() < 0.5 { 0.0 } else { -0.0 };
        dirs.push(Vec3::from_array(a));
    }
    let (mut compared, mut diffs) = (0u64, 0u64);
    for r in [1u32, 2, 3, 8, 16, 32] {
        for chunk in dirs.chunks(8) {
            let mut x = [0.0f32; 8];
            let mut y = [0.0f32; 8];
            let mut z = [1.0f32; 8];
            for (i, d) in chunk.iter().enumerate() {
                (x[i], y[i], z[i]) = (d.x, d.y, d.z);
            }
            let got = raybatch::octahedral_pixels8(x, y, z, r);
            for i in 0..chunk.len() {
                diffs += (got[i] != octahedral_pixel(Vec3::new(x[i], y[i], z[i]), r)) as u64;
                compared += 1;
            }
        }
    }
    println!("{compared} octahedral pixels compared (AVX2: {}): {diffs} differ", raybatch::simd_supported());
    assert_eq!(diffs, 0);
}

#[test]
fn sincos_replica_equals_platform_sin_cos() {
    if !raybatch::simd_supported() {
        println!("no AVX2 + FMA: the replica is not used, nothing to compare");
        return;
    }
    let mut rng = Rng::new(3, 5);
    let lo = -std::f32::consts::FRAC_PI_4;
    let mut thetas: Vec<f32> = (0..1_000_000).map(|_| lo + std::f32::consts::PI * rng.next_f32()).collect();
    // Band edges: glibc's tiny (2^-12) and small (0.75) thresholds, multiples of π/4, ±0.
    for c in
        [0.0f32, 2f32.powi(-12), 0.75, std::f32::consts::FRAC_PI_4, std::f32::consts::FRAC_PI_2, 2.0, 3.0 * std::f32::consts::FRAC_PI_4]
    {
        for d in 0..200u32 {
            for v in [c, -c] {
                thetas.push(f32::from_bits(v.to_bits().wrapping_add(d)));
                thetas.push(f32::from_bits(v.to_bits().wrapping_sub(d)));
            }
        }
    }
    thetas.retain(|t| t.is_finite() && t.abs() < 3.0);
    let (mut compared, mut diffs) = (0u64, 0u64);
    for chunk in thetas.chunks(8) {
        let mut t = [0.0f32; 8];
        t[..chunk.len()].copy_from_slice(chunk);
        let (s, c) = raybatch::sincos_lanes(t).expect("in range");
        for i in 0..chunk.len() {
            let (rs, rc) = std::hint::black_box(t[i]).sin_cos();
            diffs += (s[i].to_bits() != rs.to_bits() || c[i].to_bits() != rc.to_bits()) as u64;
            compared += 1;
        }
    }
    println!("{compared} angles compared: {diffs} differ");
    assert_eq!(diffs, 0);
}

#[test]
fn radiance_replica_equals_environment_radiance() {
    let mut rng = Rng::new(17, 1);
    let mut maps = vec![("sky", glimpse_scene::load("sky").unwrap().environment.unwrap())];
    maps.push(("constant", glimpse_scene::Environment::constant(Vec3::new(0.3, 0.5, 0.7))));
    let mut tiny = Image::new(7, 3);
    for (i, p) in tiny.pixels.iter_mut().enumerate() {
        *p = Vec3::new(i as f32, (i * i) as f32 * 0.1, 1.0 / (i + 1) as f32);
    }
    maps.push(("7x3", glimpse_scene::Environment::new(tiny, 1.7)));
    let (mut compared, mut diffs) = (0u64, 0u64);
    for (name, env) in &maps {
        let mut dirs: Vec<Vec3> =
            vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(-0.0, 0.0, -1.0), Vec3::new(0.0, -0.0, 1.0)];
        dirs.extend((0..200_000).map(|_| uniform_sphere(rng.next_2d())));
        // The seam u = 0 / 1 (d.x = ±0, d.z > 0) and the poles.
        dirs.extend((0..2000).map(|i| Vec3::new(if i % 2 == 0 { 0.0 } else { -0.0 }, (i as f32 / 1000.0) - 1.0, 1.0).normalize()));
        dirs.extend((0..2000).map(|i| Vec3::new(1e-7 * (i as f32 - 1000.0), 1.0, -1e-7).normalize()));
        for d in dirs {
            let (a, b) = (env.radiance(d), glimpse_dvf::raybatch::radiance(env, d));
            diffs += (a.to_array().map(f32::to_bits) != b.to_array().map(f32::to_bits)) as u64;
            compared += 1;
        }
        println!("{name}: compared");
    }
    println!("{compared} radiance lookups compared: {diffs} differ");
    assert_eq!(diffs, 0);
}

/// The build's batched `trace_sample` sets the same mask bits as the per-ray loop it replaced,
/// for samples on every surface of `sky` and `cornell-lit`, both hemispheres, several ray counts.
#[test]
fn batched_build_samples_equal_per_ray_samples() {
    use glimpse_dvf::field::{PointSample, RaySetKey, SampleSettings, trace_sample, trace_sample_per_ray};
    use glimpse_dvf::points::PointSampling;
    let (mut samples, mut differ, mut rays) = (0, 0, 0u64);
    for scene_name in ["sky", "cornell-lit"] {
        let scene = glimpse_scene::load(scene_name).unwrap();
        let ctx = FrameContext::new(&scene, 0.0, 8, 8);
        let triangles = ctx.frame.world_triangles();
        let mut rng = Rng::new(17, 3);
        for n_rays in [128u32, 100, 37] {
            let s = SampleSettings { sampling: PointSampling::Hash, rays: n_rays, rotate_about_normal: false, seed: 1, frame_index: 0 };
            for _ in 0..300 {
                let t = triangles[(rng.next_f32() * triangles.len() as f32) as usize % triangles.len()];
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Y);
                let normal = if rng.next_f32() < 0.5 { n } else { -n };
                let (position, error_scale) = glimpse_dvf::points::point_and_error_scale(t, glimpse_core::Vec2::new(u, v));
                let p = PointSample { position, error_scale, normal, rays: RaySetKey { shift: rng.next_2d() } };
                let (mut v1, mut o1, mut v2, mut o2) = ([0u64; 1], [0u64; 1], [0u64; 1], [0u64; 1]);
                let a = trace_sample(&ctx.tracer, &p, &s, 8, &mut v1, &mut o1);
                let b = trace_sample_per_ray(&ctx.tracer, &p, &s, 8, &mut v2, &mut o2);
                samples += 1;
                rays += b;
                differ += ((a, v1, o1) != (b, v2, o2)) as usize;
            }
        }
    }
    println!("build samples: {samples} compared ({rays} rays), {differ} differ");
    assert_eq!(differ, 0);
}

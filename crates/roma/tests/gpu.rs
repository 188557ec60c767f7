//! ROMA on the GPU against the CPU build (docs/gpu.md, "ROMA"): the exact division and square
//! root the kernels use, the BOM and every rotated map bit for bit, the snapped queries for
//! random rays and AO rays, and one frame of `ao-roma`. Skipped, with the reason printed, when
//! there is no GPU adapter (CI runs it on Mesa's lavapipe).
#![cfg(feature = "gpu")]

use glimpse_core::{Image, Ray, Rng, Vec3};
use glimpse_gpu::compute::{Kernel, read_back, storage_buffer, storage_buffer_zeroed, workgroups};
use glimpse_gpu::{GpuContext, GpuTimer};
use glimpse_render::Progress;
use glimpse_roma::gpu::{self, GpuQuery, GpuRoma};
use glimpse_roma::{Roma, RomaParams, with_maps};
use glimpse_trace::{ExactTracer, GBuffer};

mod common;

/// The GPU context, or `None` after printing why the test is skipped.
fn context(test: &str) -> Option<GpuContext> {
    GpuContext::for_test(test)
}

/// The CPU build and the GPU build of one frame (jitter on, as the techniques build it).
fn builds(ctx: &GpuContext, gpu: &mut GpuRoma, scene: &glimpse_scene::Scene, params: &RomaParams, seed: u64, frame: u32) -> Roma {
    let f = scene.at(0.0);
    let cpu = Roma::build(&f, params, seed, frame);
    gpu.build(ctx, &f.world_triangles(), f.bounds, params, seed, frame, &mut GpuTimer::new(ctx, 2)).unwrap();
    cpu
}

fn u128_words(roma: &Roma) -> (Vec<u128>, Vec<u128>) {
    match roma {
        Roma::R128(m) => (m.bom.words.clone(), m.maps.clone()),
        _ => panic!("the GPU build is at resolution 128"),
    }
}

/// `div_exact` and `sqrt_exact` equal the CPU's `/` and `sqrt` bit for bit, on random operands
/// over the whole exponent range and on the special cases.
#[test]
fn exact_division_and_square_root() {
    let Some(ctx) = context("exact arithmetic") else { return };
    let source = format!(
        "{}
@group(0) @binding(0) var<storage, read> input: array<vec2<f32>>;
@group(0) @binding(1) var<storage, read_write> output: array<vec2<u32>>;
fn no_fold() -> u32 {{ return 0u; }}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    if id.x >= arrayLength(&input) {{ return; }}
    let v = input[id.x];
    // |v.x| by its bits: a float `abs` flushes a subnormal to zero on NVIDIA before sqrt_exact
    // sees it (an H200 then differed on 182 of the operands; with this, on none).
    output[id.x] = vec2<u32>(bitcast<u32>(div_exact(v.x, v.y)), bitcast<u32>(sqrt_exact(bitcast<f32>(bitcast<u32>(v.x) & 0x7fffffffu))));
}}",
        gpu::wgsl_library()
    );
    let kernel = Kernel::new(&ctx, "exact arithmetic", &source, "main").unwrap();
    let mut rng = Rng::new(5, 0);
    let mut any = || f32::from_bits(rng.next_u32());
    let mut input: Vec<[f32; 2]> = (0..40_000).map(|_| [any(), any()]).collect();
    // Operands of the magnitudes the kernels divide (cells, unit vectors), and special values.
    let mut rng = Rng::new(6, 0);
    input.extend((0..40_000).map(|_| [(rng.next_f32() - 0.5) * 300.0, (rng.next_f32() - 0.5) * 2.0]));
    let special = [0.0, -0.0, 1.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE, 1e-40, -3e-39, f32::MAX, 3.0, 0.1];
    input.extend(special.iter().flat_map(|&a| special.iter().map(move |&b| [a, b])));
    let inp = storage_buffer(&ctx, "input", &input).unwrap();
    let out = storage_buffer_zeroed(&ctx, "output", 8 * input.len() as u64).unwrap();
    let bind = kernel.bind(&ctx, &[(0, &inp), (1, &out)]);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    kernel.dispatch(&mut encoder, &bind, workgroups(input.len(), 64), None);
    ctx.queue.submit([encoder.finish()]);
    let got: Vec<[u32; 2]> = read_back(&ctx, &out, input.len()).unwrap();
    let same = |g: u32, c: f32| g == c.to_bits() || (c.is_nan() && f32::from_bits(g).is_nan());
    let div_differ = input.iter().zip(&got).filter(|([a, b], g)| !same(g[0], a / b)).count();
    let sqrt_differ = input.iter().zip(&got).filter(|([a, _], g)| !same(g[1], a.abs().sqrt())).count();
    println!("{} operand pairs: div_exact differs from the CPU on {div_differ}, sqrt_exact on {sqrt_differ}", input.len());
    for ([a, b], g) in input.iter().zip(&got).filter(|([a, b], g)| !same(g[0], a / b) || !same(g[1], a.abs().sqrt())).take(8) {
        println!(
            "  {a:e} / {b:e}: GPU {:e}, CPU {:e}; sqrt(|a|): GPU {:e}, CPU {:e}",
            f32::from_bits(g[0]),
            a / b,
            f32::from_bits(g[1]),
            a.abs().sqrt()
        );
    }
    assert_eq!((div_differ, sqrt_differ), (0, 0));
}

/// The BOM and every ray-aligned map read back equal the CPU's words, for two scenes at n = 4
/// (the AO default) and one at n = 8.
#[test]
fn bom_and_maps_equal_the_cpu_bit_for_bit() {
    let Some(ctx) = context("BOM and maps") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    for (name, n, frame) in [("cornell", 4, 0), ("glossy", 4, 0), ("cornell", 8, 3)] {
        let scene = glimpse_scene::load(name).unwrap();
        let params = RomaParams { n, ..RomaParams::default() };
        let cpu = builds(&ctx, &mut gpu, &scene, &params, 11, frame);
        let (cpu_bom, cpu_maps) = u128_words(&cpu);
        let gpu_bom = gpu.bom_words(&ctx).unwrap();
        let gpu_maps = gpu.map_words(&ctx).unwrap();
        let bom_differ = cpu_bom.iter().zip(&gpu_bom).filter(|(a, b)| a != b).count();
        let maps_differ = cpu_maps.iter().zip(&gpu_maps).filter(|(a, b)| a != b).count();
        let bits = |w: &[u128]| w.iter().map(|w| w.count_ones() as u64).sum::<u64>();
        println!(
            "{name:8} n={n} frame {frame}: BOM {} of {} words differ ({} cells set, GPU {}); maps {} of {} words differ ({} bits set, GPU {})",
            bom_differ,
            cpu_bom.len(),
            bits(&cpu_bom),
            bits(&gpu_bom),
            maps_differ,
            cpu_maps.len(),
            bits(&cpu_maps),
            bits(&gpu_maps)
        );
        assert_eq!((gpu_bom.len(), gpu_maps.len()), (cpu_bom.len(), cpu_maps.len()));
        assert!(bits(&cpu_bom) > 0);
        assert_eq!((bom_differ, maps_differ), (0, 0), "{name} n={n}");
    }
}

/// `n` rays with origins in the box `[lo, hi]` and uniform directions, a third infinite.
fn random_rays(lo: Vec3, hi: Vec3, n: usize, seed: u64) -> Vec<(Ray, f32)> {
    let mut rng = Rng::new(seed, 0);
    let diagonal = (hi - lo).length();
    (0..n)
        .map(|i| {
            let o = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let d = glimpse_core::sampling::uniform_sphere(rng.next_2d());
            let t_max = if i % 3 == 0 { f32::INFINITY } else { diagonal * rng.next_f32() };
            (Ray::new(o, d), t_max)
        })
        .collect()
}

/// The share of agreeing answers, printed; at most 1 in 10⁴ may differ (a ray within float
/// distance of a cell or stratum boundary; with the exact arithmetic none are expected).
fn check_agreement(what: &str, differ: usize, n: usize) {
    println!("{what}: {:.4} % agree ({differ} of {n} differ)", 100.0 - 100.0 * differ as f64 / n as f64);
    assert!(differ * 10_000 <= n, "{what}: {differ} of {n} differ");
}

/// Snapped any-hit (from the origin, and as `occluded_ray`) and closest hit agree with the CPU
/// for random rays through the scene and for AO rays from a GBuffer.
#[test]
fn snapped_queries_agree_with_the_cpu() {
    let Some(ctx) = context("snapped queries") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    for (name, n) in [("cornell", 4), ("glossy", 8)] {
        let scene = glimpse_scene::load(name).unwrap();
        let params = RomaParams { n, ..RomaParams::default() };
        let cpu = builds(&ctx, &mut gpu, &scene, &params, 3, 0);
        let frame = scene.at(0.0);
        let b = frame.bounds;
        let mut rays = random_rays(b.min, b.max, 20_000, 9);
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(4.0 / 3.0), 64, 48);
        let offset = cpu.cell_size_world() * params.origin_offset_cells;
        let (ao, _) = gpu::ao_queries(&g, 4, f32::INFINITY, offset, 3, 0);
        let queries: Vec<GpuQuery> = rays.iter().map(|(r, t)| GpuQuery::new(r.origin, r.dir, *t)).chain(ao.iter().copied()).collect();
        let as_cpu = |q: &GpuQuery| (Vec3::from(q.origin), Vec3::from(q.dir), q.t_max);

        let any = gpu.any_hit_snapped(&ctx, &queries).unwrap();
        let differ = queries
            .iter()
            .zip(&any)
            .filter(|(q, g)| {
                let (o, d, t) = as_cpu(q);
                let (k, sign) = cpu.select(d);
                cpu.any_hit_snapped(k, sign, o, t) != **g
            })
            .count();
        let hits = any.iter().filter(|&&h| h).count();
        check_agreement(&format!("{name} n={n} any-hit ({} random + {} AO rays, {hits} hit)", rays.len(), ao.len()), differ, queries.len());

        let closest = gpu.closest_hit_snapped(&ctx, &queries).unwrap();
        let differ = queries
            .iter()
            .zip(&closest)
            .filter(|(q, g)| {
                let (o, d, t) = as_cpu(q);
                let (k, sign) = cpu.select(d);
                cpu.closest_hit_snapped(k, sign, o, t) != **g
            })
            .count();
        check_agreement(&format!("{name} n={n} closest hit (same distance, bit for bit)"), differ, queries.len());

        rays.extend(ao.iter().map(|q| (Ray::new(Vec3::from(q.origin), Vec3::from(q.dir)), 0.5 * b.extent().length())));
        let occluded = gpu.occluded(&ctx, &rays).unwrap();
        let differ = rays.iter().zip(&occluded).filter(|((r, t), g)| with_maps!(&cpu, m => m.occluded_ray(r, *t)) != **g).count();
        check_agreement(&format!("{name} n={n} occluded_ray (offset origin, finite and infinite t_max)"), differ, rays.len());
        ctx.check().unwrap();
    }
}

/// Un-snapped DDA any-hit (`soft-roma`'s default query) agrees with the CPU's
/// `any_hit_unsnapped`: random segments through and beyond the scene box (short and long, so the
/// step limit both ends and cuts walks), and `soft-roma`'s light segments from a GBuffer, at
/// three step limits.
#[test]
fn dda_queries_agree_with_the_cpu() {
    let Some(ctx) = context("dda queries") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    for (name, n) in [("cornell-lit", 8), ("glossy", 4)] {
        let scene = glimpse_scene::load(name).unwrap();
        let params = RomaParams { n, ..RomaParams::default() };
        let cpu = builds(&ctx, &mut gpu, &scene, &params, 5, 1);
        let frame = scene.at(0.0);
        let b = frame.bounds;
        let (lo, hi) = (b.min - b.extent() * 0.1, b.max + b.extent() * 0.1);
        let mut rng = Rng::new(21, 0);
        let mut point = || lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut segments: Vec<(Vec3, Vec3)> = (0..20_000)
            .map(|i| {
                let (p, q) = (point(), point());
                // Every other segment short: a few cells, finished within the step limit.
                if i % 2 == 0 { (p, p + (q - p) * 0.05) } else { (p, q) }
            })
            .collect();
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(4.0 / 3.0), 64, 48);
        let offset = cpu.cell_size_world() * params.origin_offset_cells;
        let mut light = 0;
        if frame.emissive_distribution.is_some() {
            for i in 0..g.len() {
                let Some(s) = glimpse_render::direct::Shading::from_gbuffer(&g, i) else { continue };
                let mut rng = Rng::for_pixel(5, i as u64, 1);
                for _ in 0..4 {
                    if let Some((_, from, to)) =
                        glimpse_render::direct::area_light_segment(&frame, &s, rng.next_f32(), rng.next_2d(), offset)
                    {
                        segments.push((from, to));
                        light += 1;
                    }
                }
            }
        }
        let queries: Vec<GpuQuery> = segments.iter().map(|&(a, b)| GpuQuery::segment(a, b)).collect();
        for steps in [1, 8, 64] {
            let got = gpu.any_hit_unsnapped(&ctx, &queries, steps).unwrap();
            let want: Vec<bool> = segments.iter().map(|&(a, b)| cpu.any_hit_unsnapped(a, b, steps)).collect();
            let differ = got.iter().zip(&want).filter(|(g, c)| g != c).count();
            let hits = want.iter().filter(|&&h| h).count();
            let what = format!("{name} n={n} dda_steps={steps} ({} random + {light} light segments, {hits} hit)", segments.len() - light);
            println!("{what}: {differ} of {} differ", segments.len());
            // The kernel is the CPU's arithmetic, operation for operation: equal on every segment.
            assert_eq!(differ, 0, "{what}");
            assert!(hits > 0 && hits < segments.len(), "{what}: a constant answer proves nothing");
        }
        ctx.check().unwrap();
    }
}

/// One frame of `ao-roma` on the GPU equals the CPU technique's single frame (same GBuffer, same
/// per-pixel directions), pixel for pixel; counted as the paper counts, and weighted
/// (`snap_weight=cos`).
#[test]
fn ao_roma_frame_equals_the_cpu() {
    let Some(ctx) = context("ao-roma") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    for (name, radius, frame_index, weight) in
        [("cornell", f32::INFINITY, 0, false), ("glossy", 0.5, 2, false), ("cornell", f32::INFINITY, 1, true)]
    {
        let scene = glimpse_scene::load(name).unwrap();
        let params = RomaParams::default();
        let (spp, seed) = (4, 7);
        let cpu = builds(&ctx, &mut gpu, &scene, &params, seed, frame_index);
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(4.0 / 3.0), 48, 36);
        let mut cpu_image = Image::new(g.width, g.height);
        glimpse_roma::technique::ambient_occlusion(&cpu, &g, spp, radius, weight, seed, frame_index, &Progress::default(), &mut cpu_image);
        let gpu_image = gpu::ambient_occlusion(&ctx, &mut gpu, &g, spp, radius, weight, seed, frame_index).unwrap();
        let differ = cpu_image.pixels.iter().zip(&gpu_image.pixels).filter(|(a, b)| a != b).count();
        let mse = cpu_image.pixels.iter().zip(&gpu_image.pixels).map(|(a, b)| ((a.x - b.x) as f64).powi(2)).sum::<f64>()
            / cpu_image.pixels.len() as f64;
        let mean = gpu_image.pixels.iter().map(|p| p.x as f64).sum::<f64>() / gpu_image.pixels.len() as f64;
        println!(
            "{name:8} radius {radius} frame {frame_index} weighted {weight}: {} pixels × {spp} rays, mean AO {mean:.4}, {differ} pixels differ, RMSE {:.2e}",
            g.len(),
            mse.sqrt()
        );
        assert!(mse.sqrt() <= 1e-3, "{name}: RMSE {}", mse.sqrt());
        assert!(differ * 1000 <= g.len(), "{name}: {differ} pixels differ");
    }
}

/// `focus=auto` on the GPU (`GpuRoma::build_frame`): the grid around the ball, the 400 m ground
/// traced by the exact GPU tracer after each query. Every query form and one `ao-roma` frame
/// agree with the CPU's focused build, and the ground answers a share of them.
#[test]
fn a_focused_frame_agrees_with_the_cpu() {
    let Some(ctx) = context("focused frame") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    let scene = common::ball_over_ground();
    let frame = scene.at(0.0);
    let params = RomaParams { focus: true, ..RomaParams::default() };
    let (seed, frame_index) = (4, 1);
    let cpu = Roma::build(&frame, &params, seed, frame_index);
    gpu.build_frame(&ctx, &frame, &params, seed, frame_index, &mut GpuTimer::new(&ctx, 3)).unwrap();
    assert!(cpu.focus_share().is_some() && gpu.focus_share == cpu.focus_share(), "{:?} {:?}", cpu.focus_share(), gpu.focus_share);
    let mut rays = random_rays(Vec3::new(-8.0, -0.5, -8.0), Vec3::new(8.0, 3.0, 8.0), 20_000, 11);
    let tracer = ExactTracer::build(&frame);
    let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(4.0 / 3.0), 48, 36);
    let offset = cpu.cell_size_world() * params.origin_offset_cells;
    let (ao, _) = gpu::ao_queries(&g, 4, f32::INFINITY, offset, seed, frame_index);
    let queries: Vec<GpuQuery> = rays.iter().map(|(r, t)| GpuQuery::new(r.origin, r.dir, *t)).chain(ao.iter().copied()).collect();
    let snapped = |q: &GpuQuery| {
        let (k, sign) = cpu.select(q.dir.into());
        (k, sign, Vec3::from(q.origin), q.t_max)
    };
    let by_ground = queries
        .iter()
        .filter(|q| {
            let (k, sign, o, t) = snapped(q);
            with_maps!(&cpu, m => m.exact.any_hit(o, cpu.candidates().dirs[k] * sign, t))
        })
        .count();
    println!("focused: {} exact triangles, {by_ground} of {} queries meet the ground", with_maps!(&cpu, m => m.exact.len()), queries.len());
    assert!(by_ground * 10 > queries.len(), "the exact pass must be exercised");

    let any = gpu.any_hit_snapped(&ctx, &queries).unwrap();
    let differ = queries.iter().zip(&any).filter(|(q, g)| {
        let (k, sign, o, t) = snapped(q);
        cpu.any_hit_snapped(k, sign, o, t) != **g
    });
    check_agreement("focused any-hit", differ.count(), queries.len());
    let closest = gpu.closest_hit_snapped(&ctx, &queries).unwrap();
    let differ = queries.iter().zip(&closest).filter(|(q, g)| {
        let (k, sign, o, t) = snapped(q);
        cpu.closest_hit_snapped(k, sign, o, t) != **g
    });
    check_agreement("focused closest hit (bit for bit)", differ.count(), queries.len());
    rays.extend(ao.iter().map(|q| (Ray::new(Vec3::from(q.origin), Vec3::from(q.dir)), 6.0)));
    let occluded = gpu.occluded(&ctx, &rays).unwrap();
    let differ = rays.iter().zip(&occluded).filter(|((r, t), g)| with_maps!(&cpu, m => m.occluded_ray(r, *t)) != **g);
    check_agreement("focused occluded_ray", differ.count(), rays.len());
    let segments: Vec<GpuQuery> = rays.iter().map(|(r, _)| GpuQuery::segment(r.origin, r.origin + r.dir * 3.0)).collect();
    let dda = gpu.any_hit_unsnapped(&ctx, &segments, 8).unwrap();
    let differ = segments.iter().zip(&dda).filter(|(q, g)| cpu.any_hit_unsnapped(q.origin.into(), q.dir.into(), 8) != **g);
    check_agreement("focused dda", differ.count(), segments.len());

    let mut cpu_image = Image::new(g.width, g.height);
    glimpse_roma::technique::ambient_occlusion(&cpu, &g, 4, f32::INFINITY, false, seed, frame_index, &Progress::default(), &mut cpu_image);
    let gpu_image = gpu::ambient_occlusion(&ctx, &mut gpu, &g, 4, f32::INFINITY, false, seed, frame_index).unwrap();
    let differ = cpu_image.pixels.iter().zip(&gpu_image.pixels).filter(|(a, b)| a != b).count();
    println!("focused ao-roma frame: {differ} of {} pixels differ", g.len());
    assert_eq!(differ, 0);
    ctx.check().unwrap();
}

/// Bad input is an error, not a panic.
#[test]
fn unsupported_settings_are_errors() {
    let Some(ctx) = context("errors") else { return };
    let mut gpu = GpuRoma::new(&ctx).unwrap();
    assert!(gpu.occluded(&ctx, &[(Ray::new(Vec3::ZERO, Vec3::Y), 1.0)]).is_err(), "query before build");
    let scene = glimpse_scene::load("cornell").unwrap();
    let f = scene.at(0.0);
    let tris = f.world_triangles();
    let mut timer = GpuTimer::new(&ctx, 2);
    let e = gpu.build(&ctx, &tris, f.bounds, &RomaParams { resolution: 64, ..Default::default() }, 0, 0, &mut timer).unwrap_err();
    println!("resolution 64: {e}");
    let e = gpu.build(&ctx, &tris, f.bounds, &RomaParams { n: 0, ..Default::default() }, 0, 0, &mut timer).unwrap_err();
    println!("n = 0: {e}");
    // No triangles: an empty BOM and empty maps, and every ray misses.
    gpu.build(&ctx, &[], f.bounds, &RomaParams::default(), 0, 0, &mut timer).unwrap();
    assert!(gpu.bom_words(&ctx).unwrap().iter().all(|&w| w == 0));
    assert!(!gpu.occluded(&ctx, &[(Ray::new(Vec3::ZERO, Vec3::Y), f32::INFINITY)]).unwrap()[0]);
    ctx.check().unwrap();
}

//! The DVF on the GPU against the CPU build (docs/gpu.md, "DVF"): every pass's output (areas,
//! normals, prefix sums, sample counts and ids, the samples themselves, then the masks and labels)
//! bit for bit for the same parameters, seed and frame; env-dvf's image within a stated bound; a
//! second frame in the same buffers; errors instead of panics. Skipped, with the reason printed,
//! when there is no GPU adapter (CI runs it on Mesa's lavapipe).
#![cfg(feature = "gpu")]

use glimpse_dvf::areas::{WorldMesh, areas_and_normals};
use glimpse_dvf::field::{PointSample, SampleSettings, point_sample};
use glimpse_dvf::gpu::{DvfBench, DvfGpuError, GpuDvf, GpuEnvDvf, bench};
use glimpse_dvf::grid::Grid;
use glimpse_dvf::points::{PointSampling, Rounding, Task, first_sample_id, sample_count};
use glimpse_dvf::scan::exclusive_scan;
use glimpse_dvf::technique::EnvDvf;
use glimpse_dvf::{AutoBudget, Dvf, DvfParams, Sides};
use glimpse_gpu::{GpuContext, GpuTimer, timer::format_times};
use glimpse_render::{FrameContext, Params, Settings, Stats, Technique};
use glimpse_scene::Scene;
use std::sync::Arc;

fn courtyard() -> Scene {
    glimpse_scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/courtyard.toml")).expect("test scene loads")
}

/// Small settings: the paper's, with few samples and rays (2 shared cores in CI).
fn small(points: u32, rays: u32, workgroup: u32) -> DvfParams {
    DvfParams { points, rays, grid: 8, workgroup, ..DvfParams::paper() }
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn differ<T: PartialEq>(a: &[T], b: &[T]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x != y).count() + a.len().abs_diff(b.len())
}

/// The CPU's passes for one frame, pass by pass as `Dvf::build` runs them.
struct CpuPasses {
    areas: Vec<f32>,
    normals: Vec<glimpse_core::Vec3>,
    prefix: Vec<f32>,
    total: f32,
    counts: Vec<(u32, u64)>,
    samples: Vec<(PointSample, usize)>,
    dvf: Dvf,
}

fn cpu_passes(ctx: &FrameContext, back: &[u32], p: &DvfParams, seed: u64, frame_index: u32) -> CpuPasses {
    let mesh = WorldMesh::gather(&ctx.frame, back);
    let (areas, normals) = areas_and_normals(&mesh);
    let (prefix, total) = exclusive_scan(&areas, p.workgroup as usize);
    let counts: Vec<(u32, u64)> = (0..areas.len())
        .map(|k| {
            (
                sample_count(p.points, areas[k], [prefix[k], prefix.get(k + 1).copied().unwrap_or(total)], total, p.rounding),
                first_sample_id(p.points, prefix[k], total, k),
            )
        })
        .collect();
    let settings = SampleSettings { sampling: p.sampling, rays: p.rays, rotate_about_normal: p.rotate_about_normal, seed, frame_index };
    let grid = Grid::from_bounds(ctx.frame.bounds, p.grid);
    let mut samples = Vec::new();
    for (k, &(count, first)) in counts.iter().enumerate() {
        let task = Task { triangle: k as u32, first: 0, count, of: count };
        for i in 0..count {
            let s = point_sample(&mesh, normals[k], first, &task, i, &settings);
            samples.push((s, grid.cell_of(s.position)));
        }
    }
    let dvf = Dvf::build(&ctx.frame, back, &ctx.tracer, p, seed, frame_index, None, &mut Stats::default());
    CpuPasses { areas, normals, prefix, total, counts, samples, dvf }
}

/// Builds on the GPU and compares every pass with the CPU's; returns (mask words, cells) compared.
fn compare_build(
    ctx: &GpuContext,
    gpu: &mut GpuDvf,
    what: &str,
    frame: &FrameContext,
    p: &DvfParams,
    seed: u64,
    frame_index: u32,
) -> (usize, usize) {
    // `sides=seen` variants stand in instance 0 for the camera's probe.
    let back = p.back_instances(frame.frame.scene.instances.len(), || vec![0]);
    let cpu = cpu_passes(frame, &back, p, seed, frame_index);
    let mut timer = GpuTimer::new(ctx, 64);
    gpu.build(ctx, &frame.frame, &back, p, seed, frame_index, &mut timer).unwrap();
    ctx.wait().unwrap();
    let times = timer.finish(ctx).unwrap();
    let (areas, prefix, total) = gpu.areas(ctx).unwrap();
    let normals = gpu.normals(ctx).unwrap();
    let counts = gpu.counts(ctx).unwrap();
    let samples = gpu.samples(ctx).unwrap();
    let (visible, occluded) = gpu.masks(ctx).unwrap();
    let labels = gpu.labels(ctx).unwrap();
    let (cpu_visible, cpu_occluded) = cpu.dvf.masks.snapshot();

    let normal_bits = |n: &[glimpse_core::Vec3]| n.iter().flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    let sample_key = |pos: glimpse_core::Vec3, shift: glimpse_core::Vec2, cell: u32| {
        (pos.to_array().map(f32::to_bits), shift.to_array().map(f32::to_bits), cell)
    };
    let cpu_samples: Vec<_> = cpu.samples.iter().map(|(s, c)| sample_key(s.position, s.rays.shift, *c as u32)).collect();
    let gpu_samples: Vec<_> = samples.iter().map(|s| sample_key(s.position, s.shift, s.cell)).collect();
    let d = [
        ("areas", differ(&bits(&cpu.areas), &bits(&areas))),
        ("normals", differ(&normal_bits(&cpu.normals), &normal_bits(&normals))),
        ("prefix sums", differ(&bits(&cpu.prefix), &bits(&prefix)) + (cpu.total.to_bits() != total.to_bits()) as usize),
        ("counts and ids", differ(&cpu.counts, &counts)),
        ("samples", differ(&cpu_samples, &gpu_samples)),
        ("visible words", differ(&cpu_visible, &visible)),
        ("occluded words", differ(&cpu_occluded, &occluded)),
        ("labels", differ(&cpu.dvf.labels, &labels)),
    ];
    let set = |w: &[u64]| w.iter().map(|w| w.count_ones() as u64).sum::<u64>();
    println!(
        "{what}: {} triangles, {} samples, {} cells; visible bits {} (GPU {}), occluded bits {} (GPU {}), {} cells occluded; differ: {}",
        areas.len(),
        samples.len(),
        labels.len(),
        set(&cpu_visible),
        set(&visible),
        set(&cpu_occluded),
        set(&occluded),
        cpu.dvf.occluded_cells(),
        d.iter().map(|(n, c)| format!("{n} {c}")).collect::<Vec<_>>().join(", ")
    );
    if let Some(note) = ctx.software_note() {
        println!("  kernel times ({note}): {}", format_times(&times));
    }
    assert_eq!(samples.len() as u64, cpu.dvf.samples, "{what}: sample total");
    assert!(set(&cpu_visible) > 0 && set(&cpu_occluded) > 0, "{what}: both maps have bits");
    for (name, count) in d {
        assert_eq!(count, 0, "{what}: {name} differ");
    }
    (visible.len() + occluded.len(), labels.len())
}

/// Every pass equals the CPU's bit for bit, over the sampling, rounding, rotation, sides and
/// scan-depth variants, on the courtyard test scene and the Cornell box; then a second frame
/// reuses every buffer. (One test, so lavapipe compiles the kernels once.)
#[test]
fn passes_equal_the_cpu_bit_for_bit() {
    let Some(ctx) = GpuContext::for_test("DVF passes") else { return };
    let mut gpu = GpuDvf::new(&ctx).unwrap();
    let courtyard = courtyard();
    let cornell = glimpse_scene::load("cornell").unwrap();
    let (yard, box_) = (FrameContext::new(&courtyard, 0.0, 16, 16), FrameContext::new(&cornell, 0.0, 16, 16));
    let variants: Vec<(&str, &FrameContext, DvfParams)> = vec![
        ("courtyard hash ceil wg2 (deep scan)", &yard, small(3000, 16, 2)),
        ("courtyard hash ceil wg64", &yard, small(3000, 16, 64)),
        (
            "courtyard hammersley round sides=both",
            &yard,
            DvfParams { sampling: PointSampling::Hammersley, rounding: Rounding::Round, sides: Sides::Both, ..small(2000, 16, 64) },
        ),
        (
            "courtyard rotation=normal octahedral=16",
            &yard,
            DvfParams { rotate_about_normal: true, octahedral: 16, ..small(2000, 12, 1024) },
        ),
        ("cornell hash ceil wg1024 sides=both", &box_, DvfParams { sides: Sides::Both, ..small(3000, 16, 1024) }),
        (
            "cornell cumulative, back sides on instance 0 only",
            &box_,
            DvfParams { rounding: Rounding::Cumulative, sides: Sides::Seen, ..small(3000, 16, 64) },
        ),
        (
            "cornell hammersley build_rays=24",
            &box_,
            DvfParams { sampling: PointSampling::Hammersley, build_rays: 24, ..small(2000, 8, 16) },
        ),
    ];
    let (mut words, mut cells) = (0, 0);
    for (i, (what, frame, p)) in variants.iter().enumerate() {
        let (w, c) = compare_build(&ctx, &mut gpu, what, frame, p, 7 + i as u64, i as u32);
        words += w;
        cells += c;
    }
    println!("masks and labels equal: {words} mask words and {cells} labels over {} builds", variants.len());

    // A second frame (new frame index, same sizes) in the same buffers, still the CPU's.
    let p = small(2500, 16, 64);
    compare_build(&ctx, &mut gpu, "frame 0", &yard, &p, 3, 0);
    let (after_first, bytes) = (gpu.reallocations(), gpu.memory_bytes());
    compare_build(&ctx, &mut gpu, "frame 1", &yard, &p, 3, 1);
    println!("reallocations after frame 0: {after_first}, after frame 1: {}; {} bytes on the GPU", gpu.reallocations(), gpu.memory_bytes());
    assert_eq!(gpu.reallocations(), after_first, "the second frame reallocated a buffer");
    assert_eq!(gpu.memory_bytes(), bytes);
    ctx.check().unwrap();
}

/// One frame of env-dvf on the GPU against the CPU technique: same field (masks and labels bit
/// for bit), and an image within 2e-3 of the CPU's per channel and RMSE ≤ 2e-4 (only the
/// environment lookup's atan2/acos and the SH evaluation are WGSL built-ins, not the CPU's libm;
/// lavapipe measured max 7.4e-4, RMSE 7.9e-5 on pixels of mean 0.47).
#[test]
fn env_dvf_frame_agrees_with_the_cpu() {
    let Some(ctx) = GpuContext::for_test("env-dvf") else { return };
    let ctx = Arc::new(ctx);
    let scene = courtyard();
    let mut gpu: Option<GpuEnvDvf> = None;
    for (keys, frame_index) in [
        (&["rays=16", "points=2500", "grid=8", "unknown=trace"][..], 0),
        (&["rays=12", "points=2000", "grid=6", "unshadowed=rays", "sides=front", "unknown=skip", "footprint=cell"][..], 2),
        (&["rays=16", "points=300", "grid=8", "unknown=skip", "bright=on", "bright_sr=1", "footprint=cell"][..], 1),
    ] {
        let mut frame = FrameContext::new(&scene, 0.0, 40, 30);
        frame.frame_index = frame_index;
        let g = frame.gbuffer();
        let params = Params::parse(keys).unwrap();
        let settings = Settings { spp: 1, seed: 5 };
        let mut cpu = EnvDvf::new(&settings, &params).unwrap();
        // One GpuEnvDvf, re-keyed, so lavapipe compiles its kernels once.
        let gpu = match &mut gpu {
            Some(g) => {
                g.set_params(&params).unwrap();
                g
            }
            None => gpu.insert(GpuEnvDvf::new(ctx.clone(), &settings, &params).unwrap()),
        };
        let mut cpu_image = frame.image();
        cpu.prepare(&frame).unwrap();
        cpu.render(&frame, &g, &mut cpu_image).unwrap();
        let mut gpu_image = frame.image();
        gpu.prepare(&frame).unwrap();
        gpu.render(&frame, &g, &mut gpu_image).unwrap();

        let dvf = cpu.dvf.as_ref().unwrap();
        let (cv, co) = dvf.masks.snapshot();
        let (gv, go) = gpu.dvf.masks(&ctx).unwrap();
        let gl = gpu.dvf.labels(&ctx).unwrap();
        let (mask_differ, label_differ) = (differ(&cv, &gv) + differ(&co, &go), differ(&dvf.labels, &gl));
        let diffs: Vec<f32> = cpu_image.pixels.iter().zip(&gpu_image.pixels).map(|(a, b)| (*a - *b).abs().max_element()).collect();
        let worst = diffs.iter().copied().fold(0.0f32, f32::max);
        let rmse = (diffs.iter().map(|d| (*d as f64).powi(2)).sum::<f64>() / diffs.len() as f64).sqrt();
        let mean = cpu_image.pixels.iter().map(|p| p.max_element() as f64).sum::<f64>() / diffs.len() as f64;
        println!(
            "env-dvf {keys:?} frame {frame_index}: {}x{}, mean CPU value {mean:.4}; masks differ {mask_differ}, labels differ {label_differ}; image max |diff| {worst:.2e}, RMSE {rmse:.2e}",
            g.width, g.height
        );
        if let Some(note) = ctx.software_note() {
            println!("  kernel times ({note}): {}", format_times(gpu.last_times()));
        }
        assert_eq!((mask_differ, label_differ), (0, 0));
        assert!(mean > 0.01, "the image is lit");
        // `bright` and the default `footprint=around` change the image (so the GPU's agreement
        // covers them): the CPU without them differs.
        let without =
            if keys.contains(&"bright=on") { Some("bright=off") } else { (!keys.contains(&"footprint=cell")).then_some("footprint=cell") };
        if let Some(off) = without {
            let mut off_keys: Vec<&str> = keys.iter().copied().filter(|k| *k != "bright=on").collect();
            off_keys.push(off);
            let mut cpu_off = EnvDvf::new(&settings, &Params::parse(&off_keys).unwrap()).unwrap();
            let mut off_image = frame.image();
            cpu_off.prepare(&frame).unwrap();
            cpu_off.render(&frame, &g, &mut off_image).unwrap();
            let changed = cpu_image.pixels.iter().zip(&off_image.pixels).filter(|(a, b)| a != b).count();
            println!("  {off} on the CPU: {changed} pixels differ");
            assert!(changed > 0);
        }
        assert!(worst <= 2e-3 && rmse <= 2e-4, "max |diff| {worst}, RMSE {rmse}");
    }
}

/// Unsupported settings and early reads are errors, not panics.
#[test]
fn bad_settings_are_errors() {
    let Some(ctx) = GpuContext::for_test("DVF errors") else { return };
    let mut gpu = GpuDvf::new(&ctx).unwrap();
    assert!(matches!(gpu.masks(&ctx), Err(DvfGpuError::NotBuilt)));
    let scene = glimpse_scene::load("cornell").unwrap();
    let frame = scene.at(0.0);
    let mut timer = GpuTimer::new(&ctx, 64);
    let cases = [
        ("octahedral=64", DvfParams { octahedral: 64, ..small(100, 4, 64) }),
        ("workgroup=65536", small(100, 4, 65536)),
        ("points=auto", DvfParams { auto: AutoBudget { points: true, ..Default::default() }, ..small(100, 4, 64) }),
        ("points=2^32-1", small(u32::MAX - 1, 4, 64)),
    ];
    for (what, p) in cases {
        let e = gpu.build(&ctx, &frame, &[], &p, 0, 0, &mut timer).unwrap_err();
        println!("{what}: {e}");
    }
    ctx.check().unwrap();
}

/// `gpu::bench`, the `env-dvf` row of `glimpse bench gpu`: a frame of each technique at the same
/// N_r, the field's budget, kernel times when the adapter has timestamps, and the speed-up line;
/// a scene without an environment is a skip with its reason, not an error.
#[test]
fn bench_times_env_dvf_against_env_exact() {
    let Some(ctx) = GpuContext::for_test("DVF bench") else { return };
    let ctx = Arc::new(ctx);
    let keys = DvfParams::default().read(&Params::parse(&["rays=8", "points=500", "grid=6"]).unwrap()).unwrap();
    let skipped = bench(&ctx, &glimpse_scene::load("cornell").unwrap(), (8, 6), 1, keys).unwrap();
    println!("{}", skipped.lines().join("\n"));
    assert!(matches!(&skipped, DvfBench::Skipped(why) if why.contains("no environment map")));

    let measured = bench(&ctx, &glimpse_scene::load("cornell-lit").unwrap(), (16, 12), 1, keys).unwrap();
    let lines = measured.lines();
    println!("{}", lines.join("\n"));
    let DvfBench::Measured(row) = measured else { panic!("cornell-lit has an environment: {lines:?}") };
    assert_eq!((row.width, row.height, row.rays, row.points, row.grid), (16, 12, 8, 500, 6));
    assert!(row.exact_rays > 0 && row.exact_rays <= 16 * 12 * 8, "env-exact traced {} rays", row.exact_rays);
    assert!(row.dvf.wall_ms > 0.0 && row.exact.wall_ms > 0.0);
    if ctx.has_timestamps() {
        let named = |n: &str| row.dvf.kernels.iter().any(|k| k.name == n);
        assert!(named("areas") && named("field") && named("labels") && named("shade"), "{:?}", row.dvf.kernels);
        assert!(row.exact.kernel_ms.is_some_and(|ms| ms > 0.0));
    }
    assert!(lines.len() == 3 && lines[2].starts_with("env-dvf speed-up") && lines[2].contains("x; issue #18"), "{lines:?}");
}

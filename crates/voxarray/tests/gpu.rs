//! The GPU query (`glimpse_voxarray::gpu`, `query.wgsl`) against the CPU's batched query: the
//! uploaded data read back bit for bit, and the decisions of random, adversarial and
//! `lights-voxarray` shadow segments, plain and compressed, at 32, 64 and 128 bits per row, with
//! arrays split over several bindings. Every disagreement must sit on a cell boundary. Then the
//! moving scenes' structures (Alg. 5's instances, Alg. 6's rebuilt array) over two frames: their
//! decisions and the `--device gpu` technique's images against the CPU's. Skipped (with a printed
//! reason) when there is no GPU adapter; CI runs it on Mesa's lavapipe.
#![cfg(feature = "gpu")]

mod common;
use common::{cornell_dynamic_lit, dome_on_ground, scene};
use glimpse_core::{Rng, Vec3};
use glimpse_gpu::GpuContext;
use glimpse_gpu::compute::read_back;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_trace::{ExactTracer, GBuffer};
use glimpse_voxarray::directions::row_direction;
use glimpse_voxarray::gpu::structure::GpuStructure;
use glimpse_voxarray::gpu::technique::GpuLightsVoxArray;
use glimpse_voxarray::gpu::{GpuVoxArray, GpuVoxArrayError, cpu_answers, on_cell_boundary, shadow_samples, shadow_segments};
use glimpse_voxarray::technique::{LightsVoxArray, Structure};
use glimpse_voxarray::{CompressParams, Rows, VoxArray, VoxArrayParams};
use std::sync::Arc;

/// The GPU context, or `None` after printing why the test is skipped.
fn context(test: &str) -> Option<GpuContext> {
    GpuContext::for_test(test)
}

/// Random segments in and around the grid's cube (some starting on the floor, some long).
fn random_segments(seed: u64, n: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng::new(seed, 1);
    let mut p = |s: f32| (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0) * s;
    (0..n)
        .map(|k| {
            let mut a = p(1.2);
            if k % 3 == 0 {
                a.y = -1.0;
            }
            let b = if k % 5 == 0 { a + p(4.0) } else { a + p(0.8) };
            (a, b)
        })
        .collect()
}

/// Segments made to be hard: along a voxelization's rows with ends and midpoints on or a hair
/// off cell boundaries, directions on the boundary between two direction bins, axis-aligned,
/// zero-length and tiny, and outside the grid.
fn adversarial_segments(array: &VoxArray, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng::new(seed, 2);
    let (grid, n, res) = match array {
        VoxArray::R32(a) => (a.grid, a.dirs.clone(), 32),
        VoxArray::R64(a) => (a.grid, a.dirs.clone(), 64),
        VoxArray::R128(a) => (a.grid, a.dirs.clone(), 128),
    };
    let half = res as f32 * 0.5;
    let mut out = Vec::new();
    let offsets = [0.0f32, 0.5, 1e-4, -1e-4, 1e-6, -1e-6, 0.999_99];
    // Along rows of random voxelizations, in cell coordinates mapped back to the world.
    for _ in 0..3000 {
        let (i, j) = (rng.below(n.n), rng.below(n.n));
        let r = n.rotation(i, j).transpose();
        let world = |q: Vec3| r * ((q - Vec3::splat(half)) / grid.scale) + grid.center;
        let cell = |rng: &mut Rng| rng.below(res) as f32;
        let o = |rng: &mut Rng| offsets[rng.below(offsets.len() as u32) as usize];
        let (x, y) = (cell(&mut rng) + o(&mut rng), cell(&mut rng) + o(&mut rng));
        let (z0, z1) = (cell(&mut rng) + o(&mut rng) - 1.0, cell(&mut rng) + o(&mut rng) + 1.0);
        out.push((world(Vec3::new(x, y, z0)), world(Vec3::new(x, y, z1))));
        // Slightly tilted: the ends in neighbouring rows, the midpoint on a boundary.
        out.push((world(Vec3::new(x - 0.5, y + 0.5, z0)), world(Vec3::new(x + 0.5, y - 0.5, z1))));
    }
    // Directions on the boundary between two bins (θ or φ at a half step).
    let step = std::f32::consts::PI / n.n as f32;
    for k in 0..2000 {
        let (ti, pj) = (rng.below(2 * n.n) as f32, rng.below(2 * n.n) as f32);
        let (theta, phi) = if k % 2 == 0 { ((ti + 0.5) * step, pj * step) } else { (ti * step, (pj + 0.5) * step) };
        let d = row_direction(theta, phi);
        let a = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0) * 0.9;
        out.push((a, a + d * (0.1 + rng.next_f32())));
    }
    // Axis-aligned, zero-length, tiny, far outside.
    for _ in 0..1000 {
        let a = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0) * 0.95;
        for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            out.push((a, a + d * rng.next_f32()));
        }
        out.push((a, a));
        out.push((a, a + Vec3::new(1e-7, -2e-7, 3e-7)));
        out.push((a + Vec3::splat(50.0), a + Vec3::new(60.0, -40.0, 55.0)));
    }
    out
}

struct Agreement {
    total: usize,
    differ: usize,
    off_boundary: usize,
}

/// GPU and CPU answers for `segments`; prints the agreement.
fn compare(ctx: &GpuContext, gpu: &mut GpuVoxArray, array: &VoxArray, segments: &[(Vec3, Vec3)], what: &str) -> Agreement {
    let g = gpu.occluded_segments(ctx, segments).unwrap();
    let c = cpu_answers(array, segments);
    let mut a = Agreement { total: segments.len(), differ: 0, off_boundary: 0 };
    for ((g, c), &(s, e)) in g.iter().zip(&c).zip(segments) {
        if g != c {
            a.differ += 1;
            if !on_cell_boundary(array, s, e, 1e-3) {
                a.off_boundary += 1;
                if a.off_boundary <= 5 {
                    println!("  differs off a cell boundary: {s:?} → {e:?} (gpu {g}, cpu {c})");
                }
            }
        }
    }
    let occluded = c.iter().filter(|&&o| o).count();
    println!(
        "{what}: {} segments ({occluded} occluded on the CPU), agreement {:.4} % ({} differ, {} off a cell boundary)",
        a.total,
        100.0 - 100.0 * a.differ as f64 / a.total.max(1) as f64,
        a.differ,
        a.off_boundary
    );
    a
}

fn assert_agrees(a: &Agreement) {
    assert!(a.differ as f64 <= 1e-4 * a.total as f64, "agreement below 99.99 %: {} of {} differ", a.differ, a.total);
    assert_eq!(a.off_boundary, 0, "disagreements off a cell boundary");
}

fn compressed() -> Option<CompressParams> {
    Some(CompressParams { dictionary_rows: 4096, steps: 4, seed: 3 })
}

#[test]
fn uploaded_data_reads_back_bit_for_bit() {
    let Some(ctx) = context("upload") else { return };
    let tris = scene(1, 60);
    for (resolution, compress) in [(32, None), (64, compressed()), (128, compressed()), (128, None)] {
        let p = VoxArrayParams { resolution, directions: 8, compress, ..VoxArrayParams::default() };
        let array = VoxArray::from_triangles(&tris, &p);
        let gpu = GpuVoxArray::new(&ctx, &array).unwrap();
        let (rows, indices) = gpu.data_buffers();
        let words = |buffers: &[glimpse_gpu::wgpu::Buffer]| -> Vec<u32> {
            buffers.iter().flat_map(|b| read_back::<u32>(&ctx, b, (b.size() / 4) as usize).unwrap()).collect()
        };
        let (cpu_rows, cpu_indices): (Vec<u32>, Vec<u32>) = match &array {
            VoxArray::R32(a) => split(&a.rows),
            VoxArray::R64(a) => split(&a.rows),
            VoxArray::R128(a) => split(&a.rows),
        };
        let cos_sin: Vec<f32> = read_back(&ctx, gpu.cos_sin_buffer(), 2 * 8).unwrap();
        let cpu_cos_sin: Vec<f32> = match &array {
            VoxArray::R32(a) => a.dirs.cos_sin.iter().flat_map(|&(c, s)| [c, s]).collect(),
            VoxArray::R64(a) => a.dirs.cos_sin.iter().flat_map(|&(c, s)| [c, s]).collect(),
            VoxArray::R128(a) => a.dirs.cos_sin.iter().flat_map(|&(c, s)| [c, s]).collect(),
        };
        println!(
            "{resolution}³ {}: {} row words, {} index words read back",
            if compress.is_some() { "compressed" } else { "plain" },
            cpu_rows.len(),
            cpu_indices.len()
        );
        assert_eq!(words(rows), cpu_rows, "rows / dictionary");
        if compress.is_some() {
            assert_eq!(words(indices), cpu_indices, "packed indices");
        }
        assert!(cos_sin.iter().zip(&cpu_cos_sin).all(|(a, b)| a.to_bits() == b.to_bits()), "cos/sin table");
    }
}

/// The CPU's rows (or dictionary) and packed index words as u32 words.
fn split<R: glimpse_voxarray::Row + bytemuck::Pod>(rows: &Rows<R>) -> (Vec<u32>, Vec<u32>) {
    match rows {
        Rows::Plain(v) => (bytemuck::cast_slice(v).to_vec(), Vec::new()),
        Rows::Compressed(c) => (bytemuck::cast_slice(&c.dictionary).to_vec(), bytemuck::cast_slice(&c.indices).to_vec()),
    }
}

#[test]
fn random_and_adversarial_segments_agree_with_the_cpu() {
    let Some(ctx) = context("segments") else { return };
    let tris = scene(2, 300);
    let random = random_segments(7, 60_000);
    for (resolution, compress) in [(32, None), (64, compressed()), (64, None), (128, compressed())] {
        let p = VoxArrayParams { resolution, directions: 16, compress, ..VoxArrayParams::default() };
        let array = VoxArray::from_triangles(&tris, &p);
        let mut gpu = GpuVoxArray::new(&ctx, &array).unwrap();
        let label = format!("{resolution}³ {} (f64 division: {})", if compress.is_some() { "compressed" } else { "plain" }, gpu.exact_f64);
        assert_agrees(&compare(&ctx, &mut gpu, &array, &random, &format!("{label}, random")));
        // The bench's busy warm-up between two queries leaves the next one's answers alone.
        gpu.keep_busy(&ctx, &random, 3).unwrap();
        gpu.keep_busy(&ctx, &[], 3).unwrap();
        let adversarial = adversarial_segments(&array, resolution as u64);
        assert_agrees(&compare(&ctx, &mut gpu, &array, &adversarial, &format!("{label}, adversarial")));
    }
}

#[test]
fn plain_wgsl_division_is_measured() {
    // Without the f64 correction (devices without SHADER_F64): printed, and held to the same
    // boundary rule.
    let Some(ctx) = context("plain division") else { return };
    let tris = scene(2, 300);
    let p = VoxArrayParams { resolution: 64, directions: 16, compress: compressed(), ..VoxArrayParams::default() };
    let array = VoxArray::from_triangles(&tris, &p);
    let mut gpu = GpuVoxArray::with_f64(&ctx, &array, false).unwrap();
    let mut segments = random_segments(9, 30_000);
    segments.extend(adversarial_segments(&array, 64));
    let a = compare(&ctx, &mut gpu, &array, &segments, "64³ compressed, WGSL division and sqrt");
    assert!(a.differ as f64 <= 1e-3 * a.total as f64, "{} of {} differ", a.differ, a.total);
}

#[test]
fn lights_voxarray_shadow_segments_agree_with_the_cpu() {
    let Some(ctx) = context("shadow segments") else { return };
    for (name, lights, size, resolution) in [("cornell-lit", usize::MAX, 48, 64), ("many-lights", 64, 32, 64), ("many-lights", 16, 24, 128)]
    {
        let scene = glimpse_scene::load(name).unwrap();
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let gbuffer = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), size, size);
        let p = VoxArrayParams { resolution, directions: 16, ..VoxArrayParams::default() };
        let array = VoxArray::build(&frame, &p);
        let segments = shadow_segments(&array, &frame, &gbuffer, lights);
        let mut gpu = GpuVoxArray::new(&ctx, &array).unwrap();
        let label = format!("{name} {size}x{size}, {resolution}³ × 16² compressed, {} lights", frame.lights.len().min(lights));
        assert_agrees(&compare(&ctx, &mut gpu, &array, &segments, &label));
    }
}

#[test]
fn arrays_larger_than_one_binding_are_split() {
    let Some(_) = context("split") else { return };
    // 64 KiB bindings: the plain 64³ × 16² array (8 MiB) and the compressed one's indices take
    // several chunks each.
    let ctx = GpuContext::with_limits(|l| l.max_storage_buffer_binding_size = 64 << 10).unwrap();
    let tris = scene(3, 100);
    let segments = random_segments(11, 20_000);
    for compress in [None, compressed()] {
        let p = VoxArrayParams { resolution: 64, directions: 4, compress, ..VoxArrayParams::default() };
        let array = VoxArray::from_triangles(&tris, &p);
        let mut gpu = GpuVoxArray::new(&ctx, &array).unwrap();
        let (rows, indices) = gpu.data_buffers();
        let label = format!(
            "64³ × 4² {} in {} row + {} index chunks",
            if compress.is_some() { "compressed" } else { "plain" },
            rows.len(),
            indices.len()
        );
        assert!(rows.len() + indices.len() > 2, "{label}: not split");
        assert_agrees(&compare(&ctx, &mut gpu, &array, &segments, &label));
    }
    // Too few storage bindings for the chunks: an error, not a panic.
    let ctx = GpuContext::with_limits(|l| {
        l.max_storage_buffer_binding_size = 16 << 10;
        l.max_storage_buffers_per_shader_stage = 6;
    })
    .unwrap();
    let p = VoxArrayParams { resolution: 64, directions: 4, compress: None, ..VoxArrayParams::default() };
    let e = GpuVoxArray::new(&ctx, &VoxArray::from_triangles(&tris, &p)).err().expect("fits 6 bindings of 16 KiB?");
    println!("under 16 KiB bindings and 6 storage buffers: {e}");
    assert!(matches!(e, GpuVoxArrayError::TooManyBindings { .. }), "{e}");
    ctx.check().unwrap();
}

/// The moving scenes on the GPU, two frames each: cornell-dynamic with 8 point lights (rigid
/// instances, Alg. 5) and deforming (its sun; Alg. 6 rebuilt every frame). Per frame, the GPU
/// structure's decisions on the shadow segments of a 48×48 GBuffer against the CPU structure's
/// `occluded_from_surface`, and the GPU technique's image against the CPU technique's: both must
/// be equal (the same decisions, then the same arithmetic).
#[test]
fn moving_scenes_decide_and_render_as_the_cpu() {
    let Some(ctx) = context("moving scenes") else { return };
    let ctx = Arc::new(ctx);
    let params = || {
        let set = ["resolution=32", "directions=8", "type_resolution=32", "dictionary=4096", "disk_cache=false", "epsilon=false"];
        Params::parse(&set).unwrap()
    };
    for (scene, kind) in
        [(cornell_dynamic_lit(8), "rigid instances (Alg. 5)"), (glimpse_scene::load("deforming").unwrap(), "deforming (Alg. 6)")]
    {
        let mut cpu = LightsVoxArray::new(&scene, &Settings::default(), &params()).unwrap();
        let mut gpu = GpuLightsVoxArray::new(ctx.clone(), &scene, &Settings::default(), &params()).unwrap();
        let mut structure: Option<GpuStructure> = None;
        for time in [0.25, 0.75] {
            let frame = FrameContext::new(&scene, time, 48, 48);
            let gbuffer = frame.gbuffer();
            cpu.prepare(&frame).unwrap();
            let cpu_structure = cpu.structure.as_ref().unwrap();
            assert_eq!(matches!(cpu_structure, Structure::Instanced(_)), kind.starts_with("rigid"), "{}: {kind}?", scene.name);
            match &mut structure {
                Some(g) => g.sync(&ctx, cpu_structure).unwrap(),
                None => structure = Some(GpuStructure::new(&ctx, cpu_structure).unwrap()),
            }
            // Decisions on the same segments.
            let samples = shadow_samples(&frame.frame, &gbuffer, usize::MAX);
            let segments: Vec<(Vec3, Vec3)> = samples.iter().map(|(ps, n)| cpu_structure.surface_segment(ps, *n)).collect();
            let on_gpu = structure.as_mut().unwrap().occluded_segments(&ctx, &segments).unwrap();
            let on_cpu: Vec<bool> = samples.iter().map(|(ps, n)| cpu_structure.occluded_from_surface(ps, *n)).collect();
            let differ = on_gpu.iter().zip(&on_cpu).filter(|(g, c)| g != c).count();
            let occluded = on_cpu.iter().filter(|&&o| o).count();
            // Alg. 5: the decisions only a moving instance's type array makes (the test is void
            // without them).
            let by_instances = match cpu_structure {
                Structure::Instanced(i) => Some(
                    segments
                        .iter()
                        .zip(&on_cpu)
                        .filter(|&(&(s, e), &o)| o && !i.static_part.as_ref().is_some_and(|a| a.occluded_segment(s, e)))
                        .count(),
                ),
                _ => None,
            };
            // Images of the same frame.
            let (mut cpu_image, mut gpu_image) = (frame.image(), frame.image());
            cpu.render(&frame, &gbuffer, &mut cpu_image).unwrap();
            gpu.prepare(&frame).unwrap();
            gpu.render(&frame, &gbuffer, &mut gpu_image).unwrap();
            let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
            let pixels_differ = gpu_image.pixels.iter().zip(&cpu_image.pixels).filter(|(a, b)| bits(a) != bits(b)).count();
            let lit = cpu_image.pixels.iter().filter(|p| p.max_element() > 0.0).count();
            println!(
                "{} t={time}, {kind}: {} segments ({occluded} occluded on the CPU{}), agreement {:.4} % ({differ} differ); image {} pixels ({lit} lit), {pixels_differ} differ",
                scene.name,
                segments.len(),
                by_instances.map_or(String::new(), |n| format!(", {n} by a moving instance only")),
                100.0 - 100.0 * differ as f64 / segments.len().max(1) as f64,
                cpu_image.pixels.len()
            );
            assert!(occluded > 0 && occluded < segments.len(), "no shadow or no light: the test proves nothing");
            assert!(by_instances.is_none_or(|n| n > 0), "no segment is blocked by a moving instance alone");
            assert_eq!(differ, 0, "decisions differ");
            assert!(lit > cpu_image.pixels.len() / 4, "{lit} lit pixels");
            assert_eq!(pixels_differ, 0, "images differ");
        }
    }
    ctx.check().unwrap();
}

/// `focus=auto` on the GPU: the CPU builds the array around the dome (the 2 km ground left out)
/// and cuts each segment to its sphere; the kernel answers the cut segments. Decisions and the
/// `--device gpu` image equal the CPU's.
#[test]
fn a_focused_array_decides_and_renders_as_the_cpu() {
    let Some(ctx) = context("focused array") else { return };
    let ctx = Arc::new(ctx);
    let scene = dome_on_ground();
    let params = || Params::parse(&["resolution=64", "directions=16", "disk_cache=false", "epsilon=false"]).unwrap();
    let mut cpu = LightsVoxArray::new(&scene, &Settings::default(), &params()).unwrap();
    let mut gpu = GpuLightsVoxArray::new(ctx.clone(), &scene, &Settings::default(), &params()).unwrap();
    let frame = FrameContext::new(&scene, 0.0, 48, 36);
    let gbuffer = frame.gbuffer();
    cpu.prepare(&frame).unwrap();
    assert!(cpu.focus_box.is_some(), "the dome's box is the focus");
    let (mut cpu_image, mut gpu_image) = (frame.image(), frame.image());
    cpu.render(&frame, &gbuffer, &mut cpu_image).unwrap();
    gpu.prepare(&frame).unwrap();
    gpu.render(&frame, &gbuffer, &mut gpu_image).unwrap();
    let cpu_structure = cpu.structure.as_ref().unwrap();
    let samples = shadow_samples(&frame.frame, &gbuffer, usize::MAX);
    let segments: Vec<(Vec3, Vec3)> = samples.iter().map(|(ps, n)| cpu_structure.surface_segment(ps, *n)).collect();
    let on_gpu = GpuStructure::new(&ctx, cpu_structure).unwrap().occluded_segments(&ctx, &segments).unwrap();
    let on_cpu: Vec<bool> = samples.iter().map(|(ps, n)| cpu_structure.occluded_from_surface(ps, *n)).collect();
    let differ = on_gpu.iter().zip(&on_cpu).filter(|(g, c)| g != c).count();
    let occluded = on_cpu.iter().filter(|&&o| o).count();
    let bits = |v: &glimpse_core::Vec3| v.to_array().map(f32::to_bits);
    let pixels_differ = gpu_image.pixels.iter().zip(&cpu_image.pixels).filter(|(a, b)| bits(a) != bits(b)).count();
    println!("focused dome: {} segments ({occluded} occluded), {differ} differ; image {pixels_differ} pixels differ", segments.len());
    assert!(occluded > 0 && occluded < segments.len(), "no shadow or no light: the test proves nothing");
    assert_eq!(differ, 0, "decisions differ");
    assert_eq!(pixels_differ, 0, "images differ");
    ctx.check().unwrap();
}

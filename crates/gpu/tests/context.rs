//! The context, the helper API and the scene upload: error paths return errors (never panic),
//! timings come back per kernel, and a scene update rewrites its buffers in place.
#![cfg(feature = "gpu")]

mod common;

use common::{context, percent, random_rays};
use glimpse_gpu::compute::{Kernel, read_back, storage_buffer, storage_buffer_zeroed, workgroups};
use glimpse_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, GpuTracer};
use glimpse_trace::ExactTracer;

#[test]
fn a_scene_too_large_for_the_binding_limit_is_an_error() {
    if context("limits").is_none() {
        return;
    }
    let small = GpuContext::with_limits(|l| l.max_storage_buffer_binding_size = 16 << 10).unwrap();
    let scene = glimpse_scene::load("many-lights").unwrap();
    let e = GpuScene::new(&small, &scene.at(0.0), &mut GpuTimer::new(&small, 1)).err().expect("many-lights fits in 16 KiB?");
    println!("many-lights under a 16 KiB binding limit: {e}");
    assert!(matches!(e, GpuError::BindingTooLarge { limit: 16384, .. }), "{e}");
    let e = storage_buffer_zeroed(&small, "big", 1 << 20).unwrap_err();
    assert!(matches!(e, GpuError::BindingTooLarge { .. }), "{e}");
    small.check().unwrap();
}

/// The GPU traversal has no alpha test: a scene with a glTF MASK material is refused with the
/// material's name, never traced as if opaque (the CPU references cut it out).
#[test]
fn an_alpha_masked_scene_is_refused() {
    let Some(ctx) = context("alpha mask") else { return };
    let mut scene = glimpse_scene::load("cornell").unwrap();
    let mask = glimpse_scene::AlphaMask { texture: None, factor: 0.3, cutoff: 0.5 };
    scene.materials[0].alpha_mask = Some(mask);
    let e = GpuScene::new(&ctx, &scene.at(0.0), &mut GpuTimer::new(&ctx, 1)).err().expect("a masked scene was uploaded");
    println!("{e}");
    assert!(matches!(&e, GpuError::AlphaMask(name) if *name == scene.materials[0].name), "{e}");
}

#[test]
fn a_wgsl_error_is_returned_with_the_compilers_message() {
    let Some(ctx) = context("shader error") else { return };
    let e = Kernel::new(&ctx, "broken", "@compute @workgroup_size(1) fn main() { let x: u32 = 1.5; }", "main").err().unwrap();
    println!("{e}");
    assert!(matches!(e, GpuError::Shader { .. }), "{e}");
    let e = Kernel::new(&ctx, "no entry", "@compute @workgroup_size(1) fn main() {}", "other").err().unwrap();
    assert!(matches!(e, GpuError::Shader { .. }), "{e}");
    ctx.check().unwrap();
}

#[test]
fn the_helper_api_runs_a_kernel_and_times_it() {
    let Some(ctx) = context("helpers") else { return };
    let input: Vec<u32> = (0..1000).collect();
    let source = "@group(0) @binding(0) var<storage, read> a: array<u32>;
        @group(0) @binding(1) var<storage, read_write> b: array<u32>;
        @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
            if (id.x < arrayLength(&a)) { b[id.x] = 2u * a[id.x] + 1u; }
        }";
    let kernel = Kernel::new(&ctx, "double", source, "main").unwrap();
    let a = storage_buffer(&ctx, "a", &input).unwrap();
    let b = storage_buffer_zeroed(&ctx, "b", 4 * input.len() as u64).unwrap();
    let bind = kernel.bind(&ctx, &[(0, &a), (1, &b)]);
    let mut timer = GpuTimer::new(&ctx, 2);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    kernel.dispatch(&mut encoder, &bind, workgroups(input.len(), 64), timer.pass("double"));
    ctx.queue.submit([encoder.finish()]);
    let out: Vec<u32> = read_back(&ctx, &b, input.len()).unwrap();
    assert!(out.iter().enumerate().all(|(i, &v)| v == 2 * i as u32 + 1));
    let times = timer.finish(&ctx).unwrap();
    println!("times {times:?}; software: {:?}", ctx.software_note());
    assert_eq!(times.len(), ctx.has_timestamps() as usize);
    assert!(read_back::<u32>(&ctx, &b, 10_000).is_err(), "reading past the end is an error");
}

/// A moving scene: `update` reuses the buffers, and the flattened GPU scene still agrees with
/// the CPU's two-level tracer (which transforms rays instead of triangles) except within
/// rounding of an edge.
#[test]
fn update_rewrites_the_scene_in_place() {
    let Some(ctx) = context("update") else { return };
    let scene = glimpse_scene::load("cornell-dynamic").unwrap();
    let mut timer = GpuTimer::new(&ctx, 4);
    let mut gscene = GpuScene::new(&ctx, &scene.at(0.0), &mut timer).unwrap();
    let mut gpu = GpuTracer::new(&ctx).unwrap();
    for time in [1.0, 2.5] {
        let frame = scene.at(time);
        gscene.update(&ctx, &frame, &mut timer).unwrap();
        assert_eq!(gscene.generation, 0, "same sizes: no reallocation");
        let cpu = ExactTracer::build(&frame);
        let b = cpu.bounds();
        let rays = random_rays(b.min, b.max, 10_000, time as u64);
        let gpu_hits = gpu.occluded(&ctx, &gscene, &rays).unwrap();
        let differ = rays.iter().zip(&gpu_hits).filter(|((r, t), g)| cpu.occluded(r, *t) != **g).count();
        println!("cornell-dynamic at t = {time}: any-hit agrees on {:.3} % of {} rays", 100.0 - percent(differ, rays.len()), rays.len());
        assert!(percent(differ, rays.len()) <= 0.1);
    }
    let times = timer.finish(&ctx).unwrap();
    println!("upload times: {times:?}");
}

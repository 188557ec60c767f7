//! `glimpse bench gpu SCENE`: the exact tracer on the GPU (glimpse-gpu, wgpu + WGSL) beside the
//! CPU `ExactTracer` on the same AO rays from the same GBuffer: the adapter, per-kernel GPU times
//! from timestamp queries (upload, any-hit, closest-hit), rays/s, and how many answers agree;
//! then a `roma` row: ROMA's GPU build and snapped query on the same rays (glimpse-roma `gpu`),
//! a `voxarray` row (glimpse-voxarray `gpu`), and an `env-dvf` row: one GPU frame of env-dvf, the
//! rebuild included, against one of the GPU env-exact at `--size` (glimpse-dvf `gpu::bench`).
//! Built only with `--features gpu`; without it the command explains how to get it.

use anyhow::Result;
use clap::Args;

#[derive(Args)]
// Without the feature the arguments are parsed (so `--help` shows them) but never read.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))]
pub struct GpuArgs {
    pub scene: String,
    /// GBuffer size the AO rays start from, and the frame size of the env-dvf row.
    #[arg(long, default_value = "256x256", value_parser = crate::args::parse_size)]
    pub size: (u32, u32),
    /// AO rays traced (drawn from every GBuffer pixel that sees geometry).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// AO ray length (default: infinite).
    #[arg(long, default_value_t = f32::INFINITY)]
    pub radius: f32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// env-dvf parameter for the env-dvf row, key=value (repeatable; env-exact gets the same
    /// `rays`), e.g. `--set bright=off` to time the frame without it.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

#[cfg(not(feature = "gpu"))]
pub fn run(_: GpuArgs) -> Result<()> {
    anyhow::bail!("this glimpse was built without the GPU backend; rebuild with `cargo build --release -p glimpse --features gpu`")
}

#[cfg(feature = "gpu")]
pub fn run(a: GpuArgs) -> Result<()> {
    use anyhow::Context;
    use glimpse_gpu::timer::format_times;
    use glimpse_gpu::{GpuContext, GpuScene, GpuTimer, GpuTracer};
    use glimpse_trace::{ExactTracer, GBuffer, rays};
    use rayon::prelude::*;
    use std::time::Instant;

    if a.rays == 0 || a.rays > 100_000_000 {
        anyhow::bail!("--rays {}: must be between 1 and 100000000", a.rays);
    }
    if a.radius.is_nan() || a.radius <= 0.0 {
        anyhow::bail!("--radius {}: must be positive", a.radius);
    }
    crate::args::check_scene(&a.scene)?;
    let scene = glimpse_scene::load(&a.scene).with_context(|| format!("loading {}", a.scene))?;
    let frame = scene.at(0.0);
    let ctx = std::sync::Arc::new(GpuContext::new()?);
    println!("adapter: {}", ctx.describe());
    if let Some(note) = ctx.software_note() {
        println!("note: {note}");
    }
    if !ctx.has_timestamps() {
        println!("note: the adapter has no timestamp queries: GPU kernel times are not available");
    }

    let cpu = ExactTracer::build(&frame);
    let (w, h) = a.size;
    let gbuffer = GBuffer::new(&frame, &cpu, &scene.camera_or_default(w as f32 / h as f32), w, h);
    let seen = (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)).count();
    if seen == 0 {
        anyhow::bail!("the camera sees no geometry in {}: no AO rays to trace", a.scene);
    }
    let per_pixel = a.rays.div_ceil(seen) as u32;
    let all = rays::ao_rays_from(&gbuffer, per_pixel, a.radius, a.seed);
    // Every k-th ray, spread over the whole image: truncating would keep the image's first rows
    // only (at 1920x1080, 1M rays were its upper half).
    let step = all.len() as f64 / a.rays.min(all.len()) as f64;
    let rays: Vec<_> = (0..a.rays.min(all.len())).map(|i| all[(i as f64 * step) as usize]).collect();
    println!("{}: {} triangles; {} AO rays from a {w}x{h} GBuffer ({per_pixel} per pixel)", a.scene, cpu.triangle_count(), rays.len());

    let mut timer = GpuTimer::new(&ctx, 1);
    let gscene = GpuScene::new(&ctx, &frame, &mut timer)?;
    ctx.wait()?;
    let upload = timer.finish(&ctx)?;
    let mut gpu = GpuTracer::new(&ctx)?;
    // Untimed passes over the whole batch first: pipelines, buffers and the GPU's clocks warm up
    // outside the measurement.
    glimpse_gpu::timer::warm_up(|| gpu.occluded(&ctx, &gscene, &rays).map(drop))?;
    glimpse_gpu::timer::warm_up(|| gpu.closest_hit(&ctx, &gscene, &rays).map(drop))?;
    let t = Instant::now();
    let gpu_occluded = gpu.occluded(&ctx, &gscene, &rays)?;
    let gpu_any_wall = t.elapsed().as_secs_f64();
    let any_times = std::mem::take(&mut gpu.last_times);
    let t = Instant::now();
    let gpu_hits = gpu.closest_hit(&ctx, &gscene, &rays)?;
    let gpu_closest_wall = t.elapsed().as_secs_f64();
    let closest_times = std::mem::take(&mut gpu.last_times);

    let t = Instant::now();
    let cpu_occluded: Vec<bool> = rays.par_iter().map(|(r, t_max)| cpu.occluded(r, *t_max)).collect();
    let cpu_any_wall = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let cpu_hits: Vec<_> = rays.par_iter().map(|(r, t_max)| cpu.closest_hit(r, *t_max)).collect();
    let cpu_closest_wall = t.elapsed().as_secs_f64();

    let n = rays.len() as f64;
    let kernel_ms = |times: &[glimpse_gpu::KernelTime]| times.iter().map(|k| k.ms).sum::<f64>();
    let rate = |seconds: f64| if seconds > 0.0 { format!("{:.2} Mrays/s", n / seconds * 1e-6) } else { "-".into() };
    println!("GPU kernel times (timestamps): {}", format_times(&[upload, any_times.clone(), closest_times.clone()].concat()));
    let any_kernel = kernel_ms(&any_times);
    let closest_kernel = kernel_ms(&closest_times);
    println!("{:<12} {:>22} {:>22} {:>22}", "", "GPU kernel", "GPU wall (with copies)", "CPU exact (wall)");
    for (name, kernel, gpu_wall, cpu_wall) in
        [("any-hit", any_kernel, gpu_any_wall, cpu_any_wall), ("closest-hit", closest_kernel, gpu_closest_wall, cpu_closest_wall)]
    {
        let kernel = if kernel > 0.0 { rate(kernel * 1e-3) } else { "-".into() };
        println!("{name:<12} {kernel:>22} {:>22} {:>22}", rate(gpu_wall), rate(cpu_wall));
    }
    println!("CPU threads: {}", rayon::current_num_threads());
    let any_differ = gpu_occluded.iter().zip(&cpu_occluded).filter(|(g, c)| g != c).count();
    // A closest hit differs when it is another distance or a miss; a hit on another triangle at
    // the same distance (a ray through a shared edge or vertex) is counted apart: either answer
    // is exact, and which one a tie goes to depends on the driver's float contraction.
    let (mut closest_differ, mut closest_ties) = (0usize, 0usize);
    for (g, c) in gpu_hits.iter().zip(&cpu_hits) {
        match (g, c) {
            (Some(g), Some(c)) if (g.t - c.t).abs() > 1e-5 * c.t.abs() => closest_differ += 1,
            (Some(g), Some(c)) if (g.instance, g.triangle) != (c.instance, c.triangle) => closest_ties += 1,
            (Some(_), None) | (None, Some(_)) => closest_differ += 1,
            _ => {}
        }
    }
    println!(
        "agreement with the CPU: any-hit {:.4} % ({any_differ} differ), closest-hit {:.4} % ({closest_differ} differ; \
         {closest_ties} more hit another triangle at the same distance)",
        100.0 - 100.0 * any_differ as f64 / n,
        100.0 - 100.0 * closest_differ as f64 / n
    );
    // ROMA on the GPU (glimpse-roma's `gpu` feature): build and snapped any-hit on the same rays.
    for line in glimpse_roma::gpu::bench(&ctx, &frame, &rays, a.seed)?.lines((any_kernel > 0.0).then_some(any_kernel)) {
        println!("{line}");
    }
    // The voxel array's query on the GPU, on the same rays (glimpse-voxarray's `gpu` module).
    glimpse_voxarray::gpu::print_bench_row(&ctx, &frame, &rays, any_kernel)?;
    // env-dvf (its defaults, N_r = 128, unless --set) against env-exact, one frame each at --size.
    let dvf = glimpse_dvf::DvfParams::default().read(&glimpse_render::Params::parse(&a.set)?)?;
    for line in glimpse_dvf::gpu::bench(&ctx, &scene, a.size, a.seed, dvf)?.lines() {
        println!("{line}");
    }
    if let Some(note) = ctx.software_note() {
        println!("note: {note}");
    }
    Ok(())
}

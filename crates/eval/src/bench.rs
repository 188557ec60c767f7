//! `glimpse bench rays`: one ray set from the GBuffer (AO rays, shadow rays to the lights, or
//! diffuse bounce rays) sent through every registered [`Visibility`] backend. Reports build
//! time, throughput and the fraction of rays on which each backend gives the exact tracer's
//! answer; the exact tracer is always the first row, measured in the same run.
//!
//! With the `gpu` feature, the GPU backends ([`GPU_BACKENDS`]: the exact tracer, ROMA and the
//! voxel array on the GPU) add rows when named: the same rays, their `trace ms` the wall time of
//! the GPU calls (ray upload, kernels, read-back), their kernel time from timestamp queries
//! beside it, and the adapter (with the software-adapter note) under the table.

use anyhow::{Result, bail};
use glimpse_core::Ray;
use glimpse_render::Stopwatch;
use glimpse_scene::SceneFrame;
use glimpse_trace::{ExactTracer, GBuffer, Visibility, rays};
use rayon::prelude::*;
use serde::Serialize;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    Ao,
    Shadow,
    Gi,
}

impl RayKind {
    pub fn parse(s: &str) -> Result<Self> {
        Ok(match s {
            "ao" => RayKind::Ao,
            "shadow" => RayKind::Shadow,
            "gi" => RayKind::Gi,
            _ => bail!("--kind {s}: expected ao, shadow or gi"),
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Ao => "ao",
            RayKind::Shadow => "shadow",
            RayKind::Gi => "gi",
        }
    }
}

/// A visibility structure that can be built for a frame and benchmarked.
pub struct Backend {
    pub name: &'static str,
    pub build: fn(&SceneFrame) -> Result<Box<dyn Visibility>>,
}

/// Every backend, the exact tracer first.
pub fn backends() -> Vec<Backend> {
    vec![
        Backend { name: "exact", build: |frame| Ok(Box::new(ExactTracer::build(frame))) },
        // ROMA at the paper's defaults (128², 4²), snapped any-hit; frame 0, seed 0.
        Backend { name: "roma", build: |frame| Ok(Box::new(glimpse_roma::Roma::build(frame, &glimpse_roma::RomaParams::default(), 0, 0))) },
        // The distance field from the same BOM (128³, 3 mips, ≤ 64 sphere-tracing steps).
        Backend {
            name: "df",
            build: |frame| Ok(Box::new(glimpse_baselines::DfScene::build(frame, &glimpse_baselines::DfParams::default(), 0, 0))),
        },
        // The 2D array of voxelizations at the paper's defaults (128³, 90×90), uncompressed and
        // with Alg. 2 (1M-row dictionary, 4 steps); bias 1 cell at both ends, no normal offset.
        Backend {
            name: "voxarray",
            build: |frame| Ok(Box::new(glimpse_voxarray::VoxArray::build(frame, &glimpse_voxarray::VoxArrayParams::uncompressed()))),
        },
        Backend {
            name: "voxarray-vq",
            build: |frame| Ok(Box::new(glimpse_voxarray::VoxArray::build(frame, &glimpse_voxarray::VoxArrayParams::default()))),
        },
    ]
}

/// Backends that run on the GPU (built with the `gpu` feature), run only when named.
pub const GPU_BACKENDS: &[&str] = &["gpu-exact", "gpu-roma", "gpu-voxarray"];

/// The error for a GPU backend named in a build without the `gpu` feature.
pub fn gpu_backend_unavailable(name: &str) -> anyhow::Error {
    anyhow::anyhow!(
        "backend {name}: this glimpse was built without the GPU backend; rebuild with `cargo build --release -p glimpse --features gpu`"
    )
}

#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub scene_spec: String,
    pub kind: RayKind,
    pub rays: usize,
    /// GBuffer resolution the rays start from.
    pub width: u32,
    pub height: u32,
    /// AO ray length (∞ = to the scene's end, as ROMA's AO).
    pub radius: f32,
    pub seed: u64,
    /// Backends to run besides `exact` (empty: all).
    pub only: Vec<String>,
    /// Command-line scene overrides (`--env`, `--sun`, `--light`, `--camera`, …).
    pub overrides: glimpse_scene::SceneOverrides,
}

#[derive(Clone, Debug, Serialize)]
pub struct BackendResult {
    pub name: String,
    pub build_ms: f64,
    pub trace_ms: f64,
    pub mrays_per_s: f64,
    /// Fraction of rays with the exact tracer's answer.
    pub agreement: f64,
    /// Throughput relative to the exact tracer in this run.
    pub speedup_vs_exact: f64,
    /// GPU rows: the kernels' time from timestamp queries (`None` on the CPU or without them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_ms: Option<f64>,
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchResults {
    pub scene: String,
    pub kind: String,
    pub rays: usize,
    pub threads: usize,
    pub occluded_fraction: f64,
    pub backends: Vec<BackendResult>,
    /// The GPU adapter, when a GPU backend ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_adapter: Option<String>,
    /// Said of a software adapter (lavapipe): its timings are not GPU timings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_note: Option<String>,
}

/// Generates the benchmark's rays from the GBuffer of `frame`.
pub fn generate_rays(frame: &SceneFrame, gbuffer: &GBuffer, kind: RayKind, count: usize, radius: f32, seed: u64) -> Vec<(Ray, f32)> {
    let hits = (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)).count().max(1);
    let per_pixel = count.div_ceil(hits).max(1) as u32;
    let mut rays = match kind {
        RayKind::Ao => rays::ao_rays_from(gbuffer, per_pixel, radius, seed),
        RayKind::Shadow => rays::shadow_rays_from(frame, gbuffer, per_pixel, seed),
        RayKind::Gi => rays::bounce_rays_from(gbuffer, per_pixel, seed),
    };
    rays.truncate(count);
    rays
}

/// Rays handed to a backend at once, in parallel chunks: every backend gets the same batches
/// (the exact tracer answers them one by one; ROMA vectorizes across them).
pub const BATCH_RAYS: usize = 64;

/// Answers `rays` through `vis` in batches of [`BATCH_RAYS`] over all threads.
pub fn answer_batches(vis: &dyn Visibility, rays: &[(Ray, f32)], out: &mut [bool]) {
    rays.par_chunks(BATCH_RAYS).zip(out.par_chunks_mut(BATCH_RAYS)).for_each(|(r, o)| vis.occluded_batch(r, o));
}

pub fn run_bench(cfg: &BenchConfig) -> Result<BenchResults> {
    let gpu_named: Vec<&str> = GPU_BACKENDS.iter().copied().filter(|g| cfg.only.iter().any(|o| o == g)).collect();
    #[cfg(not(feature = "gpu"))]
    if let Some(name) = gpu_named.first() {
        return Err(gpu_backend_unavailable(name));
    }
    let mut scene = glimpse_scene::load(&cfg.scene_spec)?;
    cfg.overrides.apply(&mut scene).map_err(anyhow::Error::msg)?;
    let frame = scene.at(0.0);
    let exact = crate::progress::with_spinner("building the scene's tracer", || ExactTracer::build(&frame));
    let camera = scene.camera_or_default(cfg.width as f32 / cfg.height as f32);
    let gbuffer = GBuffer::new(&frame, &exact, &camera, cfg.width, cfg.height);
    let rays = generate_rays(&frame, &gbuffer, cfg.kind, cfg.rays, cfg.radius, cfg.seed);
    if rays.is_empty() {
        bail!(
            "{}: no {} rays: the camera sees no geometry{}",
            cfg.scene_spec,
            cfg.kind.name(),
            if cfg.kind == RayKind::Shadow { " or the scene has no lights" } else { "" }
        );
    }
    let mut results: Vec<BackendResult> = Vec::new();
    let mut truth: Vec<bool> = Vec::new();
    for backend in backends() {
        if backend.name != "exact" && !cfg.only.is_empty() && !cfg.only.iter().any(|o| o == backend.name) {
            continue;
        }
        let sw = Stopwatch::start();
        let vis = crate::progress::with_spinner(&format!("building {}", backend.name), || (backend.build)(&frame))?;
        let build_ms = sw.ms();
        // Warm up caches and threads on a slice, then time the whole set.
        let mut answers = vec![false; rays.len()];
        let warm = rays.len().min(10_000);
        answer_batches(vis.as_ref(), &rays[..warm], &mut answers[..warm]);
        let sw = Stopwatch::start();
        crate::progress::with_spinner(&format!("tracing {} rays through {}", rays.len(), backend.name), || {
            answer_batches(vis.as_ref(), &rays, &mut answers)
        });
        let trace_ms = sw.ms();
        if truth.is_empty() {
            truth = answers.clone();
        }
        let agree = answers.iter().zip(&truth).filter(|(a, b)| a == b).count() as f64 / rays.len() as f64;
        let mrays_per_s = rays.len() as f64 / (trace_ms * 1e3);
        let speedup_vs_exact = results.first().map_or(1.0, |e| mrays_per_s / e.mrays_per_s);
        results.push(BackendResult {
            name: backend.name.to_owned(),
            build_ms,
            trace_ms,
            mrays_per_s,
            agreement: agree,
            speedup_vs_exact,
            kernel_ms: None,
        });
    }
    #[cfg_attr(not(feature = "gpu"), allow(unused_mut))]
    let (mut gpu_adapter, mut gpu_note): (Option<String>, Option<String>) = (None, None);
    #[cfg(feature = "gpu")]
    if !gpu_named.is_empty() {
        let ctx = glimpse_gpu::GpuContext::new().map_err(|e| anyhow::anyhow!("backend {}: {e}", gpu_named[0]))?;
        gpu_adapter = Some(ctx.describe());
        gpu_note = ctx.software_note().map(str::to_owned);
        for name in gpu_named {
            let run = crate::progress::with_spinner(&format!("{name}: building and tracing {} rays", rays.len()), || {
                gpu_rows::run(name, &ctx, &frame, &rays)
            })?;
            let agree = run.answers.iter().zip(&truth).filter(|(a, b)| a == b).count() as f64 / rays.len() as f64;
            let mrays_per_s = rays.len() as f64 / (run.trace_ms * 1e3);
            let speedup_vs_exact = results.first().map_or(1.0, |e| mrays_per_s / e.mrays_per_s);
            results.push(BackendResult {
                name: name.to_owned(),
                build_ms: run.build_ms,
                trace_ms: run.trace_ms,
                mrays_per_s,
                agreement: agree,
                speedup_vs_exact,
                kernel_ms: run.kernel_ms,
            });
        }
    }
    let occluded_fraction = truth.iter().filter(|&&o| o).count() as f64 / truth.len() as f64;
    Ok(BenchResults {
        scene: cfg.scene_spec.clone(),
        kind: cfg.kind.name().to_owned(),
        rays: rays.len(),
        threads: rayon::current_num_threads(),
        occluded_fraction,
        backends: results,
        gpu_adapter,
        gpu_note,
    })
}

pub fn format_table(r: &BenchResults) -> String {
    let mut s = format!(
        "bench rays: {}, {} {} rays, {} threads, {:.1}% occluded\n{:<12} {:>10} {:>10} {:>10} {:>10} {:>10}\n",
        r.scene,
        r.rays,
        r.kind,
        r.threads,
        r.occluded_fraction * 100.0,
        "backend",
        "build ms",
        "trace ms",
        "Mrays/s",
        "vs exact",
        "agreement"
    );
    for b in &r.backends {
        s += &format!(
            "{:<12} {:>10.1} {:>10.1} {:>10.2} {:>9.2}x {:>9.4}%\n",
            b.name,
            b.build_ms,
            b.trace_ms,
            b.mrays_per_s,
            b.speedup_vs_exact,
            b.agreement * 100.0
        );
    }
    s += "Mrays/s: million visibility queries (any-hit tests of one ray segment) per second, every thread\n\
          answering batches of the same rays; build ms (the backend's structure) is not in it. vs exact:\n\
          throughput over the exact BVH tracer's in this run. agreement: answers equal to the exact tracer's.\n";
    let gpu_rows: Vec<&BackendResult> = r.backends.iter().filter(|b| GPU_BACKENDS.contains(&b.name.as_str())).collect();
    if !gpu_rows.is_empty() {
        s += "gpu-* rows: trace ms is the wall time of the GPU calls (ray upload, kernels, read-back); kernel time\n\
              from timestamp queries:";
        for b in gpu_rows {
            s += &match b.kernel_ms {
                Some(ms) if ms > 0.0 => format!(" {} {ms:.2} ms ({:.2} Mrays/s);", b.name, r.rays as f64 / (ms * 1e3)),
                _ => format!(" {} - (no timestamp queries);", b.name),
            };
        }
        s += "\n";
    }
    if let Some(adapter) = &r.gpu_adapter {
        s += &format!("GPU adapter: {adapter}\n");
    }
    if let Some(note) = &r.gpu_note {
        s += &format!("note: {note}\n");
    }
    s
}

/// The GPU backends' rows: build (upload), one untimed warm-up batch, then all rays timed.
#[cfg(feature = "gpu")]
mod gpu_rows {
    use anyhow::Result;
    use glimpse_core::Ray;
    use glimpse_gpu::{GpuContext, GpuScene, GpuTimer, GpuTracer, KernelTime};
    use glimpse_render::Stopwatch;
    use glimpse_scene::SceneFrame;

    pub struct GpuRun {
        pub answers: Vec<bool>,
        /// Wall time of the build and upload.
        pub build_ms: f64,
        /// Wall time of the timed batch (uploads, kernels, read-backs).
        pub trace_ms: f64,
        pub kernel_ms: Option<f64>,
    }

    fn kernel_ms(times: &[KernelTime]) -> Option<f64> {
        (!times.is_empty()).then(|| times.iter().map(|k| k.ms).sum())
    }

    /// Runs backend `name` on `rays`: `gpu-exact` the exact tracer (`GpuTracer::occluded`),
    /// `gpu-roma` ROMA at the `roma` row's settings (paper defaults, frame 0, seed 0; the
    /// `Visibility` answer, `occluded_ray`), `gpu-voxarray` the `voxarray-vq` row's array
    /// (128³ × 90², compressed; built on the CPU, uploaded) on the rays' segments.
    pub fn run(name: &str, ctx: &GpuContext, frame: &SceneFrame, rays: &[(Ray, f32)]) -> Result<GpuRun> {
        let warm = &rays[..rays.len().min(10_000)];
        let sw = Stopwatch::start();
        let run = match name {
            "gpu-exact" => {
                let scene = GpuScene::new(ctx, frame, &mut GpuTimer::new(ctx, 1))?;
                let mut tracer = GpuTracer::new(ctx)?;
                ctx.wait()?;
                let build_ms = sw.ms();
                tracer.occluded(ctx, &scene, warm)?;
                let sw = Stopwatch::start();
                let answers = tracer.occluded(ctx, &scene, rays)?;
                GpuRun { answers, build_ms, trace_ms: sw.ms(), kernel_ms: kernel_ms(&tracer.last_times) }
            }
            "gpu-roma" => {
                let mut roma = glimpse_roma::gpu::GpuRoma::new(ctx)?;
                let params = glimpse_roma::RomaParams::default();
                roma.build(ctx, &frame.occluding_triangles(), frame.bounds, &params, 0, 0, &mut GpuTimer::new(ctx, 2))?;
                let build_ms = sw.ms();
                roma.occluded(ctx, warm)?;
                let sw = Stopwatch::start();
                let answers = roma.occluded(ctx, rays)?;
                GpuRun { answers, build_ms, trace_ms: sw.ms(), kernel_ms: kernel_ms(&roma.last_times) }
            }
            "gpu-voxarray" => {
                use glimpse_voxarray::gpu::{GpuVoxArray, ray_segments};
                let array = glimpse_voxarray::VoxArray::build(frame, &glimpse_voxarray::VoxArrayParams::default());
                let mut gpu = GpuVoxArray::new(ctx, &array)?;
                ctx.wait()?;
                let build_ms = sw.ms();
                gpu.occluded_segments(ctx, &ray_segments(&array, warm))?;
                let sw = Stopwatch::start();
                let answers = gpu.occluded_segments(ctx, &ray_segments(&array, rays))?;
                GpuRun { answers, build_ms, trace_ms: sw.ms(), kernel_ms: kernel_ms(&gpu.last_times) }
            }
            other => anyhow::bail!("unknown GPU backend '{other}' (known: {})", super::GPU_BACKENDS.join(", ")),
        };
        Ok(run)
    }
}

//! The `env-dvf` row of `glimpse bench gpu`: issue #18's DVF target, "a DVF frame including the
//! rebuild ≥ 4× `env-exact`" (on a real GPU at 1280×720, N_r = 128), measured on one device.
//!
//! One frame of [`GpuEnvDvf`] (the field rebuilt, then the masked shading) beside one frame of
//! glimpse-gpu's `env-exact` (the CPU technique's rays traced on the GPU), both through their
//! `Technique` calls as `--device gpu` runs them: same scene time, GBuffer, size, seed and N_r, one
//! primary sample per pixel. Each runs one untimed frame first (pipelines, buffers, the
//! environment's SH), then one timed frame: the sum of its kernel times (timestamps) and its wall
//! time (uploads, read-backs and env-exact's CPU shading included). DVF's kernel sum includes its
//! scene upload (it rebuilds every frame); env-exact's has only its traversal kernels.

use super::{DvfGpuError, GpuEnvDvf};
use crate::{DvfParams, Unshadowed};
use glimpse_core::Image;
use glimpse_gpu::references::GpuEnvExact;
use glimpse_gpu::timer::format_times;
use glimpse_gpu::{GpuContext, KernelTime};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use std::sync::Arc;
use std::time::Instant;

/// What [`bench()`] found: a row, or why there is none.
#[derive(Clone, Debug)]
pub enum DvfBench {
    /// The scene or the device cannot run env-dvf: the reason.
    Skipped(String),
    Measured(BenchRow),
}

/// One timed frame of one technique.
#[derive(Clone, Debug)]
pub struct FrameTimes {
    /// The sum of the frame's kernel times (`None` without timestamp queries).
    pub kernel_ms: Option<f64>,
    pub wall_ms: f64,
    /// Per kernel, summed over its dispatches (empty without timestamp queries).
    pub kernels: Vec<KernelTime>,
}

#[derive(Clone, Debug)]
pub struct BenchRow {
    pub width: u32,
    pub height: u32,
    /// N_r: both techniques' rays per pixel (and the field's per sample, unless `build_rays`).
    pub rays: u32,
    /// The field's budget as chosen for this frame size.
    pub points: u32,
    pub grid: u32,
    /// The map-dependent choices as the timed frame made them (`bright`, `unshadowed`).
    pub bright: bool,
    pub unshadowed: Unshadowed,
    pub dvf: FrameTimes,
    pub exact: FrameTimes,
    /// Rays env-exact traced in its timed frame.
    pub exact_rays: u64,
}

/// Times one frame of `env-dvf` (with `params`) and one of `env-exact` (with the same N_r) on
/// `ctx` at `width × height`, frame 0 of `scene`. Skipped, not failed, when the scene has no
/// environment or the device no 64-bit floats.
pub fn bench(
    ctx: &Arc<GpuContext>,
    scene: &Scene,
    (width, height): (u32, u32),
    seed: u64,
    params: DvfParams,
) -> Result<DvfBench, RenderError> {
    if scene.environment.is_none() {
        return Ok(DvfBench::Skipped("the scene has no environment map, which env-dvf and env-exact light with (try sky)".into()));
    }
    let settings = Settings { spp: 1, seed };
    let mut dvf = match GpuEnvDvf::with_params(ctx.clone(), &settings, params) {
        Err(e @ DvfGpuError::NoF64(_)) => return Ok(DvfBench::Skipped(e.to_string())),
        built => built?,
    };
    let mut exact = GpuEnvExact::new(ctx.clone(), scene, &settings, &Params::parse(&[format!("rays={}", params.rays)])?)?;
    let frame = FrameContext::new(scene, 0.0, width, height);
    let gbuffer = frame.gbuffer();
    let (dvf_times, _) = time_frame(&mut dvf, &frame, &gbuffer, GpuEnvDvf::last_times)?;
    let (exact_times, exact_stats) = time_frame(&mut exact, &frame, &gbuffer, GpuEnvExact::last_times)?;
    let field = &dvf.dvf.built()?.params;
    Ok(DvfBench::Measured(BenchRow {
        width,
        height,
        rays: exact.rays(),
        points: field.points,
        grid: field.grid,
        bright: dvf.params.bright,
        unshadowed: dvf.params.unshadowed,
        dvf: dvf_times,
        exact: exact_times,
        exact_rays: exact_stats.rays,
    }))
}

/// One untimed frame (pipelines, buffers, the environment's SH), then one timed: its wall time,
/// the kernel times `kernels` reports for it and the render's stats.
fn time_frame<T: Technique>(
    technique: &mut T,
    frame: &FrameContext,
    gbuffer: &GBuffer,
    kernels: fn(&T) -> &[KernelTime],
) -> Result<(FrameTimes, Stats), RenderError> {
    let mut image = Image::new(gbuffer.width, gbuffer.height);
    technique.prepare(frame)?;
    technique.render(frame, gbuffer, &mut image)?;
    let start = Instant::now();
    technique.prepare(frame)?;
    let stats = technique.render(frame, gbuffer, &mut image)?;
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let kernels = kernels(technique).to_vec();
    let kernel_ms = (!kernels.is_empty()).then(|| kernels.iter().map(|k| k.ms).sum());
    Ok((FrameTimes { kernel_ms, wall_ms, kernels }, stats))
}

impl DvfBench {
    /// The row as printed lines (one line saying why, when skipped).
    pub fn lines(&self) -> Vec<String> {
        match self {
            DvfBench::Skipped(why) => vec![format!("env-dvf: skipped: {why}")],
            DvfBench::Measured(row) => row.lines(),
        }
    }
}

impl BenchRow {
    /// env-dvf's kernels, both frames' totals, and env-exact ÷ env-dvf for kernels and wall.
    pub fn lines(&self) -> Vec<String> {
        let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3} ms"));
        let speed_up = |exact: Option<f64>, dvf: Option<f64>| match (exact, dvf) {
            (Some(e), Some(d)) if d > 0.0 => format!("{:.2}x", e / d),
            _ => "-".into(),
        };
        let kernels = if self.dvf.kernels.is_empty() { "-".into() } else { format_times(&self.dvf.kernels) };
        let setting = format!("{}x{}, N_r={}, 1 spp", self.width, self.height, self.rays);
        vec![
            format!(
                "env-dvf ({setting}, points={}, grid={}, bright={}, unshadowed={}) GPU kernels: {kernels}",
                self.points,
                self.grid,
                if self.bright { "on" } else { "off" },
                match self.unshadowed {
                    Unshadowed::Sh => "sh",
                    Unshadowed::Rays => "rays",
                }
            ),
            format!(
                "env-dvf frame (rebuild + shading): kernels {}, wall {:.3} ms; env-exact frame ({} rays): kernels {}, wall {:.3} ms",
                ms(self.dvf.kernel_ms),
                self.dvf.wall_ms,
                self.exact_rays,
                ms(self.exact.kernel_ms),
                self.exact.wall_ms
            ),
            format!(
                "env-dvf speed-up (env-exact ÷ env-dvf, one frame): kernels {}, wall {}; issue #18's target on a GPU: >= 4x at 1280x720, N_r=128",
                speed_up(self.exact.kernel_ms, self.dvf.kernel_ms),
                speed_up(Some(self.exact.wall_ms), Some(self.dvf.wall_ms))
            ),
        ]
    }
}

//! `ao-roma` on the GPU as a [`Technique`] (`--device gpu`): each frame's ROMA built by the
//! `voxelize` and `generate` kernels ([`GpuRoma::build`], bit for bit the CPU's build), the CPU
//! technique's rays ([`super::ao_queries`]: same `Rng::for_pixel` streams and origin offset)
//! answered by the snapped query kernel, then the same temporal accumulation as the CPU
//! `ao-roma` ([`crate::Accumulator`]). Parameters are read exactly as the CPU technique reads
//! them; only what the kernels support is accepted (resolution 128, `voxelization=sampled`,
//! n ≤ 32), anything else is an error naming the parameter.

use super::{GPU_RESOLUTION, GpuRoma};
use crate::{Accumulator, DEFAULT_ACCUMULATE, RomaParams, Voxelization};
use glimpse_core::Image;
use glimpse_gpu::{GpuContext, GpuTimer};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use std::sync::Arc;

fn gpu_error(e: impl std::fmt::Display) -> RenderError {
    RenderError::Unsupported { technique: "ao-roma".into(), message: format!("on the GPU: {e}") }
}

/// `ao-roma` with its build and queries on the GPU.
pub struct GpuAoRoma {
    gpu: Arc<GpuContext>,
    roma: Option<GpuRoma>,
    params: RomaParams,
    settings: Settings,
    /// AO ray length (default ∞, as the CPU technique's).
    pub radius: f32,
    accumulator: Accumulator,
}

impl GpuAoRoma {
    pub fn new(gpu: Arc<GpuContext>, _scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::direct::require_spp(settings)?;
        // The CPU `AoRoma::new`'s reads, in its order.
        let p = RomaParams::default().read(params, false)?;
        let window = params.u32("accumulate", DEFAULT_ACCUMULATE, 1, 1 << 20)?;
        let radius = params.f32("radius", f32::INFINITY, 0.0, f32::INFINITY)?;
        let unsupported = |key: &str, value: String, why: &str| {
            Err(RenderError::Unsupported { technique: "ao-roma".into(), message: format!("{key}={value} on the GPU: {why}") })
        };
        if p.resolution != GPU_RESOLUTION {
            return unsupported("resolution", p.resolution.to_string(), "the GPU kernels support resolution=128 only");
        }
        if p.voxelization != Voxelization::PAPER {
            return unsupported("voxelization", format!("{:?}", p.voxelization), "the GPU kernels support voxelization=sampled only");
        }
        if p.n == 0 || p.n > 32 {
            return unsupported("n", p.n.to_string(), "the GPU kernels support n from 1 to 32");
        }
        Ok(Self { gpu, roma: None, params: p, settings: *settings, radius, accumulator: Accumulator::new(window) })
    }
}

impl Technique for GpuAoRoma {
    fn id(&self) -> &'static str {
        "ao-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let p = &self.params;
        glimpse_core::memory_budget::check(format!("ROMA: {}² occupancy maps of {}³ bits", p.n, p.resolution), p.estimated_bytes())?;
        let mut stats = Stats::default();
        let gpu = &self.gpu;
        if self.roma.is_none() {
            self.roma = Some(stats.time("gpu kernels", || GpuRoma::new(gpu)).map_err(gpu_error)?);
        }
        let roma = self.roma.as_mut().ok_or_else(|| gpu_error("the kernels were not compiled"))?;
        let triangles = stats.time("gather", || ctx.frame.world_triangles());
        let mut timer = GpuTimer::new(gpu, 2);
        let (seed, frame_index) = (self.settings.seed, ctx.frame_index);
        stats.time("gpu build", || roma.build(gpu, &triangles, ctx.frame.bounds, p, seed, frame_index, &mut timer)).map_err(gpu_error)?;
        let f = roma.frame().map_err(gpu_error)?;
        stats.memory_bytes = (f.bom.size() + f.maps.size()) as usize;
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let Some(roma) = self.roma.as_mut() else {
            return Err(RenderError::Unsupported { technique: "ao-roma".into(), message: "render called before prepare".into() });
        };
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported { technique: "ao-roma".into(), message: "image and GBuffer sizes differ".into() });
        }
        let f = roma.frame().map_err(gpu_error)?;
        let mut stats = Stats { memory_bytes: (f.bom.size() + f.maps.size()) as usize, ..Default::default() };
        let (spp, seed, radius, gpu) = (self.settings.spp, self.settings.seed, self.radius, &self.gpu);
        let image =
            stats.time("trace", || super::ambient_occlusion(gpu, roma, gbuffer, spp, radius, seed, ctx.frame_index)).map_err(gpu_error)?;
        out.pixels.copy_from_slice(&image.pixels);
        ctx.progress.add(out.pixels.len() as u64);
        stats.rays = (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)).count() as u64 * spp as u64;
        stats.time("accumulate", || self.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

//! `lights-voxarray` on the GPU as a [`Technique`] (`--device gpu`): the array is built (or
//! loaded from the disk cache) on the CPU exactly as the CPU technique does — by the CPU
//! technique's own `prepare` — and uploaded once ([`GpuVoxArray::new`]); each render forms every
//! pixel × light shadow segment on the CPU as the technique does (same facing test, same
//! [`crate::Array::surface_segment`]), answers them with the Alg. 3 kernel in batches, and sums
//! each pixel's unblocked lights in the scene's order, so the image equals the CPU's wherever the
//! decisions do (all of them in the lavapipe parity tests, docs/gpu.md).
//!
//! Static scenes only: Alg. 5 (rigid instances) and Alg. 6 (deforming meshes) stay on the CPU,
//! and a moving scene is an error rather than a silently stale array. `epsilon` (ε_v, ε_s, untimed)
//! is measured with the CPU array the GPU holds a copy of.

use super::GpuVoxArray;
use crate::technique::{LightsVoxArray, Structure, is_static};
use glimpse_core::{Image, Vec3};
use glimpse_gpu::{GpuContext, KernelTime};
use glimpse_render::direct::{self, Shading};
use glimpse_render::{FrameContext, Need, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::Arc;

/// Shadow segments per GPU batch the pixel blocks aim at.
const SEGMENTS_PER_BATCH: usize = 1 << 21;

fn gpu_error(e: impl std::fmt::Display) -> RenderError {
    RenderError::Unsupported { technique: "lights-voxarray".into(), message: format!("on the GPU: {e}") }
}

/// `lights-voxarray` with its queries on the GPU.
pub struct GpuLightsVoxArray {
    gpu: Arc<GpuContext>,
    /// The CPU technique: parameters, and the array its `prepare` builds or loads.
    cpu: LightsVoxArray,
    array: Option<GpuVoxArray>,
    /// Kernel times of the last render (empty without timestamp queries).
    pub last_times: Vec<KernelTime>,
}

impl GpuLightsVoxArray {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "lights-voxarray", Need::PunctualLights)?;
        let cpu = LightsVoxArray::new(scene, settings, params)?;
        if !is_static(scene) {
            return Err(RenderError::Unsupported {
                technique: "lights-voxarray".into(),
                message: format!("on the GPU: static scenes only ('{}' moves; Alg. 5 and 6 run on the CPU: drop --device gpu)", scene.name),
            });
        }
        Ok(Self { gpu, cpu, array: None, last_times: Vec::new() })
    }
}

impl Technique for GpuLightsVoxArray {
    fn id(&self) -> &'static str {
        "lights-voxarray"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        if self.array.is_some() {
            return Ok(Stats { memory_bytes: self.cpu.structure.as_ref().map_or(0, Structure::memory_bytes), ..Default::default() });
        }
        let mut stats = self.cpu.prepare(ctx)?;
        let Some(Structure::Static(array)) = &self.cpu.structure else {
            return Err(gpu_error("the array of a static scene was not built"));
        };
        let gpu = &self.gpu;
        self.array = Some(stats.time("gpu upload", || GpuVoxArray::new(gpu, array)).map_err(gpu_error)?);
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let (Some(gpu_array), Some(Structure::Static(array))) = (self.array.as_mut(), &self.cpu.structure) else {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "render before prepare".into() });
        };
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "image and GBuffer sizes differ".into() });
        }
        let mut stats = Stats { memory_bytes: array.memory_bytes(), ..Default::default() };
        let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.cpu.lights as usize)];
        let block = (SEGMENTS_PER_BATCH / lights.len().max(1)).max(1);
        let gpu = &self.gpu;
        let mut times = Vec::new();
        let shade = || -> Result<u64, RenderError> {
            let mut decisions = 0u64;
            for (b, pixels) in out.pixels.chunks_mut(block).enumerate() {
                let first = b * block;
                // Per pixel, the lights that can reach it (irradiance × cosine) and their
                // segments, in the scene's order: the CPU technique's samples.
                let samples: Vec<Vec<(Vec3, (Vec3, Vec3))>> = (first..first + pixels.len())
                    .into_par_iter()
                    .map(|i| {
                        let Some(s) = Shading::from_gbuffer(gbuffer, i) else { return Vec::new() };
                        lights
                            .iter()
                            .filter_map(|light| {
                                let ps = direct::punctual(light, s.position, s.normal);
                                let cos = s.cos(ps.wi);
                                (cos > 0.0 && ps.irradiance.max_element() > 0.0)
                                    .then(|| (ps.irradiance * cos, array.surface_segment(&ps, s.normal)))
                            })
                            .collect()
                    })
                    .collect();
                let segments: Vec<(Vec3, Vec3)> = samples.iter().flatten().map(|(_, seg)| *seg).collect();
                let occluded =
                    if segments.is_empty() { Vec::new() } else { gpu_array.occluded_segments(gpu, &segments).map_err(gpu_error)? };
                times.append(&mut gpu_array.last_times);
                decisions += segments.len() as u64;
                let mut offset = 0;
                for (k, (px, pixel_samples)) in pixels.iter_mut().zip(&samples).enumerate() {
                    let i = first + k;
                    *px = match Shading::from_gbuffer(gbuffer, i) {
                        Some(s) => {
                            let mut e = Vec3::ZERO;
                            for ((irradiance, _), &o) in pixel_samples.iter().zip(&occluded[offset..]) {
                                if !o {
                                    e += *irradiance;
                                }
                            }
                            gbuffer.emission[i] + s.albedo / PI * e
                        }
                        None => direct::background(&ctx.frame, gbuffer.view_dir[i]),
                    };
                    offset += pixel_samples.len();
                }
            }
            ctx.progress.add(out.pixels.len() as u64);
            Ok(decisions)
        };
        stats.rays = stats.time("shade", shade)?;
        self.last_times = times;
        if self.cpu.epsilon {
            // The CPU array's decisions, which the GPU's equal (docs/gpu.md, parity).
            let e = crate::epsilon::epsilon(&ctx.frame, gbuffer, &ctx.tracer, lights.len(), |_, ps, s| {
                array.occluded_from_surface(ps, s.normal)
            });
            stats.metrics = e.to_metrics();
        }
        Ok(stats)
    }
}

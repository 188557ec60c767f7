//! `lights-voxarray` on the GPU as a [`Technique`] (`--device gpu`), for every scene the CPU
//! technique handles. Its structure is the CPU technique's, made by the CPU technique's own
//! `prepare`, and mirrored on the GPU by [`GpuStructure`]:
//! - static scene (Alg. 1 + 2): the array built (or loaded from the disk cache) once and
//!   uploaded once;
//! - rigid moving instances (Alg. 5): the static array and the type arrays uploaded once; each
//!   frame the CPU updates the world-to-local transforms, and every segment is answered against
//!   the static array, then, moved into each instance's frame on the CPU, against its type's;
//! - deforming meshes (Alg. 6): the array is rebuilt **on the CPU** every frame (`dynamic::rebuild`;
//!   the paper's Alg. 6 rasterizes on the GPU, a port left out) and re-uploaded; the upload is
//!   counted in `prepare` ("gpu upload").
//!
//! Each render forms every pixel × light shadow segment on the CPU as the technique does (same
//! facing test, same [`Structure::surface_segment`]), answers them on the GPU in batches, and sums
//! each pixel's unblocked lights in the scene's order, so the image equals the CPU's wherever the
//! decisions do (all of them in the lavapipe parity tests, docs/gpu.md). `epsilon` (ε_v, ε_s,
//! untimed) is measured with the CPU structure the GPU holds a copy of.

use super::lit_samples;
use super::structure::GpuStructure;
use crate::technique::{LightsVoxArray, Structure};
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

/// A light that reaches a pixel: irradiance × cosine, the array's segment, and the sample whose
/// exact ray `refine` traces.
type LitSample = (Vec3, (Vec3, Vec3), direct::PunctualSample);

fn gpu_error(e: impl std::fmt::Display) -> RenderError {
    RenderError::Unsupported { technique: "lights-voxarray".into(), message: format!("on the GPU: {e}") }
}

/// `lights-voxarray` with its queries on the GPU.
pub struct GpuLightsVoxArray {
    gpu: Arc<GpuContext>,
    /// The CPU technique: parameters, and the structure its `prepare` builds, loads or moves.
    cpu: LightsVoxArray,
    /// The CPU structure's arrays on the GPU, synced after each `prepare`.
    structure: Option<GpuStructure>,
    /// Kernel times of the last render (empty without timestamp queries).
    pub last_times: Vec<KernelTime>,
}

impl GpuLightsVoxArray {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "lights-voxarray", Need::PunctualLights)?;
        // `focus=auto` as on the CPU: the CPU builds the focused array and cuts every segment to
        // its sphere (`surface_segment`), the kernel answers the cut segments.
        let cpu = LightsVoxArray::new(scene, settings, params)?;
        Ok(Self { gpu, cpu, structure: None, last_times: Vec::new() })
    }
}

impl Technique for GpuLightsVoxArray {
    fn id(&self) -> &'static str {
        "lights-voxarray"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        // The CPU's work: a static array once, Alg. 5's transforms, Alg. 6's rebuild.
        let mut stats = self.cpu.prepare(ctx)?;
        let Some(cpu) = &self.cpu.structure else { return Err(gpu_error("the CPU technique built no structure")) };
        let gpu = &self.gpu;
        match &mut self.structure {
            None => self.structure = Some(stats.time("gpu upload", || GpuStructure::new(gpu, cpu)).map_err(gpu_error)?),
            // Alg. 6: this frame's rebuilt array goes up.
            Some(g) if matches!(cpu, Structure::Deforming(_)) => stats.time("gpu upload", || g.sync(gpu, cpu)).map_err(gpu_error)?,
            // Alg. 5: the new transforms (no upload); a static array stays.
            Some(g) => g.sync(gpu, cpu).map_err(gpu_error)?,
        }
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let (Some(gpu_structure), Some(structure)) = (self.structure.as_mut(), &self.cpu.structure) else {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "render before prepare".into() });
        };
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "image and GBuffer sizes differ".into() });
        }
        let mut stats = Stats { memory_bytes: structure.memory_bytes(), ..Default::default() };
        let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.cpu.lights as usize)];
        let block = (SEGMENTS_PER_BATCH / lights.len().max(1)).max(1);
        let gpu = &self.gpu;
        let refine = self.cpu.refine_for(structure, &ctx.tracer);
        let mut times = Vec::new();
        let shade = || -> Result<u64, RenderError> {
            let mut decisions = 0u64;
            for (b, pixels) in out.pixels.chunks_mut(block).enumerate() {
                let first = b * block;
                // Per pixel, the lights that can reach it (irradiance × cosine) and their
                // segments, in the scene's order: the CPU technique's samples.
                let samples: Vec<Vec<LitSample>> = (first..first + pixels.len())
                    .into_par_iter()
                    .map(|i| {
                        let Some(s) = Shading::from_gbuffer(gbuffer, i) else { return Vec::new() };
                        lit_samples(s, lights)
                            .map(|(ps, cos)| (ps.irradiance * cos, structure.surface_segment(&ps, s.normal), ps))
                            .collect()
                    })
                    .collect();
                let segments: Vec<(Vec3, Vec3)> = samples.iter().flatten().map(|(_, seg, _)| *seg).collect();
                let mut occluded =
                    if segments.is_empty() { Vec::new() } else { gpu_structure.occluded_segments(gpu, &segments).map_err(gpu_error)? };
                if let Some(r) = refine {
                    // `refine`: the GPU's answers checked by the CPU's exact tracer (the CPU
                    // technique's rule; no exact GPU tracer is wired in here).
                    let flat: Vec<&direct::PunctualSample> = samples.iter().flatten().map(|(_, _, ps)| ps).collect();
                    occluded.par_iter_mut().zip(flat).for_each(|(o, ps)| *o = r.occluded(*o, ps));
                }
                times.append(&mut gpu_structure.take_times());
                decisions += segments.len() as u64;
                let mut offset = 0;
                for (k, (px, pixel_samples)) in pixels.iter_mut().zip(&samples).enumerate() {
                    let i = first + k;
                    *px = match Shading::from_gbuffer(gbuffer, i) {
                        Some(s) => {
                            let mut e = Vec3::ZERO;
                            for ((irradiance, _, _), &o) in pixel_samples.iter().zip(&occluded[offset..]) {
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
            // The CPU structure's decisions, which the GPU's equal (docs/gpu.md, parity).
            let e = crate::epsilon::epsilon(&ctx.frame, gbuffer, &ctx.tracer, lights.len(), |_, ps, s| {
                let o = structure.occluded_from_surface(ps, s.normal);
                refine.map_or(o, |r| r.occluded(o, ps))
            });
            stats.metrics = e.to_metrics();
        }
        Ok(stats)
    }
}

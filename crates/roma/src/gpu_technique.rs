//! The ROMA techniques on the GPU as [`Technique`]s (`--device gpu`): `ao-roma`, `soft-roma` and
//! `gi-roma`. Each frame's ROMA is built by the `voxelize` and `generate` kernels
//! ([`GpuRoma::build`], bit for bit the CPU's build); the CPU technique's samples (same
//! `Rng::for_pixel` streams, same origins) are gathered on the CPU, their ROMA queries answered by
//! the kernels in one batch, and the shading and temporal accumulation ([`crate::Accumulator`])
//! are the CPU technique's, operation for operation, so the images are the CPU's.
//! Parameters are read exactly as the CPU techniques read them; only what the kernels support is
//! accepted (resolution 128, `voxelization=sampled`, n ≤ 32), anything else is an error naming
//! the parameter.

use super::{GPU_RESOLUTION, GpuQuery, GpuRoma};
use crate::{Accumulator, DEFAULT_ACCUMULATE, RomaParams, Voxelization};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Rng, Vec3};
use glimpse_gpu::{GpuContext, GpuTimer};
use glimpse_render::direct::{self, Shading};
use glimpse_render::rsm::Rsm;
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::Arc;

fn gpu_error(id: &str, e: impl std::fmt::Display) -> RenderError {
    RenderError::Unsupported { technique: id.into(), message: format!("on the GPU: {e}") }
}

/// What the three techniques share: the kernels and this frame's build, the parameters, the
/// history (as the CPU's `RomaState`).
struct GpuRomaState {
    id: &'static str,
    gpu: Arc<GpuContext>,
    roma: Option<GpuRoma>,
    params: RomaParams,
    settings: Settings,
    accumulator: Accumulator,
}

impl GpuRomaState {
    /// The CPU `RomaState::new`'s reads, in its order, then the GPU's limits.
    fn new(
        id: &'static str,
        gpu: Arc<GpuContext>,
        settings: &Settings,
        params: &Params,
        defaults: RomaParams,
        with_dda: bool,
    ) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        let p = defaults.read(params, with_dda)?;
        let window = params.u32("accumulate", DEFAULT_ACCUMULATE, 1, 1 << 20)?;
        let unsupported = |key: &str, value: String, why: &str| {
            Err(RenderError::Unsupported { technique: id.into(), message: format!("{key}={value} on the GPU: {why}") })
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
        Ok(Self { id, gpu, roma: None, params: p, settings: *settings, accumulator: Accumulator::new(window) })
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        // n=auto as the CPU technique chooses it (RomaState::prepare).
        self.params.resolve_n(&ctx.frame, &ctx.tracer, &ctx.camera, self.settings.seed);
        let (p, id) = (&self.params, self.id);
        glimpse_core::memory_budget::check(format!("ROMA: {}² occupancy maps of {}³ bits", p.n, p.resolution), p.estimated_bytes())?;
        let mut stats = Stats::default();
        let gpu = &self.gpu;
        if self.roma.is_none() {
            self.roma = Some(stats.time("gpu kernels", || GpuRoma::new(gpu)).map_err(|e| gpu_error(id, e))?);
        }
        let roma = self.roma.as_mut().ok_or_else(|| gpu_error(id, "the kernels were not compiled"))?;
        // The upload of a focused frame's exact planes is a third timed pass.
        let mut timer = GpuTimer::new(gpu, 3);
        let (seed, frame_index) = (self.settings.seed, ctx.frame_index);
        stats.time("gpu build", || roma.build_frame(gpu, &ctx.frame, p, seed, frame_index, &mut timer)).map_err(|e| gpu_error(id, e))?;
        if let Some(share) = roma.focus_share {
            stats.metrics.push(("focus_share".to_owned(), share as f64));
        }
        stats.memory_bytes = self.memory_bytes()?;
        Ok(stats)
    }

    /// The kernels after `prepare`, and the image and GBuffer sizes checked.
    fn roma(&mut self, gbuffer: &GBuffer, out: &Image) -> Result<&mut GpuRoma, RenderError> {
        let id = self.id;
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported { technique: id.into(), message: "image and GBuffer sizes differ".into() });
        }
        self.roma.as_mut().ok_or_else(|| RenderError::Unsupported { technique: id.into(), message: "render called before prepare".into() })
    }

    fn memory_bytes(&self) -> Result<usize, RenderError> {
        let roma = self.roma.as_ref().ok_or_else(|| gpu_error(self.id, "not built"))?;
        Ok(roma.memory_bytes().map_err(|e| gpu_error(self.id, e))? as usize)
    }
}

/// Per GBuffer pixel that sees geometry, `f(pixel, shading, rng)` with the pixel's
/// `Rng::for_pixel` stream as [`direct::shade_pixels`] hands it; `None` for the others.
fn per_pixel<T: Send>(gbuffer: &GBuffer, seed: u64, frame_index: u32, f: impl Fn(usize, &Shading, &mut Rng) -> T + Sync) -> Vec<Option<T>> {
    (0..gbuffer.len())
        .into_par_iter()
        .map(|i| {
            let s = Shading::from_gbuffer(gbuffer, i)?;
            let mut rng = Rng::for_pixel(seed, i as u64, frame_index as u64);
            Some(f(i, &s, &mut rng))
        })
        .collect()
}

/// The index of each pixel's first query in the concatenation of `counts` (prefix sums).
fn offsets(counts: impl Iterator<Item = usize>) -> Vec<usize> {
    counts
        .scan(0, |next, n| {
            let first = *next;
            *next += n;
            Some(first)
        })
        .collect()
}

/// `ao-roma` with its build and queries on the GPU.
pub struct GpuAoRoma {
    state: GpuRomaState,
    /// AO ray length (default ∞, as the CPU technique's).
    pub radius: f32,
    /// `snap_weight=cos`, as the CPU technique's.
    pub cosine_weight: bool,
}

impl GpuAoRoma {
    pub fn new(gpu: Arc<GpuContext>, _scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        // The CPU `AoRoma::new`'s reads, in its order.
        let state = GpuRomaState::new("ao-roma", gpu, settings, params, RomaParams::with_auto_n(), false)?;
        let radius = params.f32("radius", f32::INFINITY, 0.0, f32::INFINITY)?;
        let cosine_weight = params.choice("snap_weight", "none", &["none", "cos"])? == "cos";
        Ok(Self { state, radius, cosine_weight })
    }
}

impl Technique for GpuAoRoma {
    fn id(&self) -> &'static str {
        "ao-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: self.state.memory_bytes()?, ..Default::default() };
        let (spp, seed, radius, gpu) = (self.state.settings.spp, self.state.settings.seed, self.radius, self.state.gpu.clone());
        let weight = self.cosine_weight;
        let roma = self.state.roma(gbuffer, out)?;
        let image = stats
            .time("trace", || super::ambient_occlusion(&gpu, roma, gbuffer, spp, radius, weight, seed, ctx.frame_index))
            .map_err(|e| gpu_error("ao-roma", e))?;
        out.pixels.copy_from_slice(&image.pixels);
        ctx.progress.add(out.pixels.len() as u64);
        stats.rays = (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)).count() as u64 * spp as u64;
        stats.time("accumulate", || {
            self.state.accumulator.blend(ctx.frame_index, out);
            crate::weighting::clamp_open_fraction(out);
        });
        Ok(stats)
    }
}

/// `soft-roma` with its build and shadow queries on the GPU: the un-snapped DDA (`dda` kernel)
/// or, with `snap=true`, the snapped any-hit.
pub struct GpuSoftRoma {
    state: GpuRomaState,
    /// Trace the shadow rays snapped instead of by DDA (as the CPU technique's `snap`).
    pub snap: bool,
}

impl GpuSoftRoma {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "soft-roma", glimpse_render::Need::AreaLights)?;
        // The CPU `SoftRoma::new`'s reads, in its order.
        let defaults = RomaParams { n: 8, ..RomaParams::default() };
        let state = GpuRomaState::new("soft-roma", gpu, settings, params, defaults, true)?;
        Ok(Self { state, snap: params.bool("snap", false)? })
    }
}

/// One area-light sample of a `soft-roma` pixel: its contribution when unblocked, and its shadow
/// query (`None`: a zero-length segment, never blocked, as `shadow_blocked` answers).
type SoftSample = (Vec3, Option<GpuQuery>);

impl Technique for GpuSoftRoma {
    fn id(&self) -> &'static str {
        "soft-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: self.state.memory_bytes()?, ..Default::default() };
        let (spp, seed, snap, steps) = (self.state.settings.spp, self.state.settings.seed, self.snap, self.state.params.dda_steps);
        let origin_offset_cells = self.state.params.origin_offset_cells;
        let gpu = self.state.gpu.clone();
        let roma = self.state.roma(gbuffer, out)?;
        let offset = roma.frame().map_err(|e| gpu_error("soft-roma", e))?.grid.cell_size_world * origin_offset_cells;
        let frame = &ctx.frame;
        // The CPU technique's samples, in its order (`SoftRoma::render`).
        let pixels: Vec<Option<Vec<SoftSample>>> = stats.time("samples", || {
            per_pixel(gbuffer, seed, ctx.frame_index, |_, s, rng| {
                (0..spp)
                    .filter_map(|_| {
                        let (ls, from, to) = direct::area_light_segment(frame, s, rng.next_f32(), rng.next_2d(), offset)?;
                        let contribution = ls.radiance * (s.cos(ls.wi) / ls.pdf);
                        let d = to - from;
                        let len = d.length();
                        let query = (len > 0.0).then(|| if snap { GpuQuery::new(from, d / len, len) } else { GpuQuery::segment(from, to) });
                        Some((contribution, query))
                    })
                    .collect()
            })
        });
        let queries: Vec<GpuQuery> = pixels.iter().flatten().flatten().filter_map(|(_, q)| *q).collect();
        let blocked = stats
            .time("trace", || if snap { roma.any_hit_snapped(&gpu, &queries) } else { roma.any_hit_unsnapped(&gpu, &queries, steps) })
            .map_err(|e| gpu_error("soft-roma", e))?;
        let first = offsets(pixels.iter().map(|p| p.iter().flatten().filter(|(_, q)| q.is_some()).count()));
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, seed, out, |i, _| {
                let (Some(samples), Some(s)) = (&pixels[i], Shading::from_gbuffer(gbuffer, i)) else {
                    return (Vec3::ZERO, 0);
                };
                let (mut e, mut next) = (Vec3::ZERO, first[i]);
                for (contribution, query) in samples {
                    let is_blocked = query.is_some() && {
                        next += 1;
                        blocked[next - 1]
                    };
                    if !is_blocked {
                        e += *contribution;
                    }
                }
                (s.albedo / PI * e / spp as f32, samples.len() as u64)
            })
        })?;
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

/// `gi-roma` with its build and bounce queries (snapped closest hit) on the GPU; the RSMs, the
/// direct light (exact shadow rays) and the shading on the CPU, as the CPU technique's.
pub struct GpuGiRoma {
    state: GpuRomaState,
    pub include_direct: bool,
    pub rsm: crate::technique::RsmSettings,
    rsms: Vec<Rsm>,
}

impl GpuGiRoma {
    pub fn new(gpu: Arc<GpuContext>, scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        glimpse_render::require(scene, "gi-roma", glimpse_render::Need::AnyLight)?;
        // The CPU `GiRoma::new`'s checks and reads, in its order.
        let rsm = crate::technique::RsmSettings::read(scene, params)?;
        let state = GpuRomaState::new("gi-roma", gpu, settings, params, RomaParams::with_auto_n(), false)?;
        Ok(Self { state, include_direct: params.bool("include_direct", true)?, rsm, rsms: Vec::new() })
    }
}

/// A `gi-roma` pixel before the bounces are answered: the bounce origin, the direct irradiance
/// and rays (the CPU's sums), and per traced bounce the stratum and sign it was snapped to.
struct GiPixel {
    origin: Vec3,
    direct_e: Vec3,
    rays: u64,
    bounces: Vec<(GpuQuery, usize, f32)>,
}

impl Technique for GpuGiRoma {
    fn id(&self) -> &'static str {
        "gi-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        // The CPU `GiRoma::prepare`: the same RSMs from the same random numbers.
        let mut stats = self.state.prepare(ctx)?;
        self.rsms = crate::technique::build_rsms(ctx, self.state.settings.seed, self.state.params.jitter, &self.rsm, &mut stats)?;
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut stats = Stats { memory_bytes: self.state.memory_bytes()?, ..Default::default() };
        let (spp, seed, include_direct) = (self.state.settings.spp, self.state.settings.seed, self.include_direct);
        let origin_offset_cells = self.state.params.origin_offset_cells;
        let gpu = self.state.gpu.clone();
        let roma = self.state.roma(gbuffer, out)?;
        let f = roma.frame().map_err(|e| gpu_error("gi-roma", e))?;
        let (cell, candidates) = (f.grid.cell_size_world, f.candidates.clone());
        let offset = cell * origin_offset_cells;
        let bias = self.rsm.bias_cells * cell;
        let (frame, rsms) = (&ctx.frame, &self.rsms);
        let env = frame.scene.environment.as_ref();
        // The CPU technique's direct light and bounce directions, in its order (`GiRoma::render`).
        let pixels: Vec<Option<GiPixel>> = stats.time("samples", || {
            per_pixel(gbuffer, seed, ctx.frame_index, |_, s, rng| {
                let basis = Frame::from_z(s.shading_normal);
                let origin = s.position + s.normal * offset;
                let mut p = GiPixel { origin, direct_e: Vec3::ZERO, rays: 0, bounces: Vec::new() };
                if include_direct {
                    let (e, r) = direct::punctual_irradiance(&frame.lights, &ctx.tracer, s);
                    p.direct_e += e * spp as f32;
                    p.rays += r;
                }
                for _ in 0..spp {
                    if include_direct {
                        let (a, ra) = direct::area_irradiance(frame, &ctx.tracer, s, rng);
                        let (e, re) = direct::env_irradiance(env, &ctx.tracer, s, rng);
                        p.direct_e += a + e;
                        p.rays += ra + re;
                    }
                    let d = basis.to_world(cosine_hemisphere(rng.next_2d()));
                    if s.cos(d) <= 0.0 {
                        continue;
                    }
                    p.rays += 1;
                    let (k, sign) = candidates.select(d);
                    p.bounces.push((GpuQuery::new(origin, d, f32::INFINITY), k, sign));
                }
                p
            })
        });
        let queries: Vec<GpuQuery> = pixels.iter().flatten().flat_map(|p| p.bounces.iter().map(|b| b.0)).collect();
        let hits = stats.time("trace", || roma.closest_hit_snapped(&gpu, &queries)).map_err(|e| gpu_error("gi-roma", e))?;
        let first = offsets(pixels.iter().map(|p| p.as_ref().map_or(0, |p| p.bounces.len())));
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, seed, out, |i, _| {
                let (Some(p), Some(s)) = (&pixels[i], Shading::from_gbuffer(gbuffer, i)) else {
                    return (Vec3::ZERO, 0);
                };
                let mut indirect = Vec3::ZERO;
                for (n, &(_, k, sign)) in p.bounces.iter().enumerate() {
                    let Some(t) = hits[first[i] + n] else { continue };
                    let hit = p.origin + candidates.dirs[k] * (sign * t);
                    indirect += rsms.iter().map(|rsm| rsm.lit_radiance(hit, s.position, bias)).sum::<Vec3>();
                }
                (s.albedo * (p.direct_e / PI + indirect) / spp as f32, p.rays)
            })
        })?;
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

//! The shading that uses ROMA (paper §5): `ao-roma` (Eq. 1, snapped any-hit, infinite `t_max`),
//! `gi-roma` (Eq. 2, snapped closest-hit, the hit lit from reflective shadow maps) and
//! `soft-roma` (Eq. 3, un-snapped any-hit with a finite `t_max`), each accumulated over frames
//! ([`crate::accumulate`]).
//!
//! Shared choices (the paper's where it has one):
//! - ROMA is rebuilt in `prepare` every frame: BOM jitter and candidates are drawn from
//!   (`seed`, `frame_index`), so `glimpse play` re-draws them and the accumulation converges.
//! - Per pixel, `spp` samples (the paper: 1 per frame) against the one frame's ROMA; each pixel's
//!   random numbers come from `Rng::for_pixel(seed, pixel, frame_index)`, as the references do,
//!   so at equal seeds ROMA sees the same sample directions as the exact technique.
//! - Ray origins move 1.5 cells along the **geometric** normal (paper §6 "along the surface
//!   normal"; the geometric one is what the voxels follow); sample directions follow the shading
//!   normal, as in the references.
//! - AO / GI: a cosine-weighted direction picks its stratum's candidate ("snap", §4.2); the
//!   estimator then treats the snapped ray as the sampled one (as the paper does). A snapped
//!   direction can fall below the surface near the horizon; it is traced as it is. `ao-roma`'s
//!   `snap_weight=cos` (ours, off by default) weights the samples against the bias this has
//!   ([`crate::weighting`]).
//! - Soft shadows: a light sample exactly as `soft-exact` draws it; the segment runs from the
//!   offset origin to the light point moved 1.5 cells off the emitter along the emitter's normal
//!   (so the emitter's cells — and the ceiling it hangs under — do not block it; pulling it back
//!   along the segment instead left grazing segments inside the ceiling's cells: 27.6% wrong
//!   decisions against 6.0% in the Cornell box), traced un-snapped through the OM of its stratum
//!   with ≤ `dda_steps` texel fetches (`snap=true` traces it snapped instead, for comparison).
//! - GI: direct light is computed as `gi-exact` does (exact shadow rays: the paper's renderer
//!   has its own direct lighting; ROMA only traces the bounce). The bounce's hit point is
//!   projected into one RSM per light ([`glimpse_render::rsm`], 512² as in the paper) and lit
//!   when it is no farther from the light than the RSM's surface plus one ROMA cell and the
//!   texel's own depth range (the "perturb the points to avoid shadow acne" of §6, with §7's
//!   "voxel-sized bias"; [`RsmSettings::bias_cells`]) and the shading point is on the lit side. The
//!   environment map is injected as a few directional lights per frame, each with its own RSM
//!   ([`RsmSettings::env_lights`], ours: the paper's RSMs are for spot and point lights, and a
//!   surface lit by the map alone would reflect nothing).

use crate::weighting::{self, SnappedSample};
use crate::{Accumulator, DEFAULT_ACCUMULATE, Roma, RomaParams};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Image, Rng, Vec2, Vec3};
use glimpse_render::direct::{self, Shading};
use glimpse_render::focus::FocusCache;
use glimpse_render::rsm::{Rsm, environment_lights, rsm_lights};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use rayon::prelude::*;
use std::f32::consts::PI;

/// ROMA state shared by the three techniques: parameters, this frame's build, the history.
struct RomaState {
    params: RomaParams,
    settings: Settings,
    roma: Option<Roma>,
    focus: FocusCache,
    accumulator: Accumulator,
}

impl RomaState {
    fn new(settings: &Settings, params: &Params, defaults: RomaParams, with_dda: bool) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        let params_read = defaults.read(params, with_dda)?;
        let window = params.u32("accumulate", DEFAULT_ACCUMULATE, 1, 1 << 20)?;
        let focus = FocusCache::default();
        Ok(Self { params: params_read, settings: *settings, roma: None, focus, accumulator: Accumulator::new(window) })
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        // n=auto is chosen once, at the first frame (the history assumes one n).
        let escape = self.params.resolve_n(&ctx.frame, &ctx.tracer, &ctx.camera, self.settings.seed);
        let p = &self.params;
        let what = format!("ROMA: {}² occupancy maps of {}³ bits", p.n, p.resolution);
        glimpse_core::memory_budget::check(what, p.estimated_bytes())?;
        let roma = Roma::build_cached(&ctx.frame, &self.params, &mut self.focus, self.settings.seed, ctx.frame_index);
        let t = roma.timings();
        let mut stats = Stats { memory_bytes: roma.memory_bytes(), ..Default::default() };
        if p.focus {
            stats.stage("focus", t.focus_ms);
        }
        stats.stage("bom", t.voxelize_ms);
        stats.stage("generate", t.generate_ms);
        // The resolution is the paper's maximum (128-bit texels), not chosen from the scene: the
        // cell it gives this scene is what bounds the error (reported, as the voxel array's).
        stats.metrics.push(("cell_m".to_owned(), roma.cell_size_world() as f64));
        stats.metrics.push(("n".to_owned(), p.n as f64));
        if let Some(share) = roma.focus_share() {
            // The focus's share of the scene's diagonal: what it did to the cell.
            stats.metrics.push(("focus_share".to_owned(), share as f64));
        }
        if let Some(e) = escape {
            stats.metrics.push(("escape_fraction".to_owned(), e as f64));
        }
        self.roma = Some(roma);
        Ok(stats)
    }

    fn roma(&self, id: &str) -> Result<&Roma, RenderError> {
        self.roma.as_ref().ok_or_else(|| RenderError::Unsupported { technique: id.into(), message: "render called before prepare".into() })
    }
}

/// `ao-roma`.
pub struct AoRoma {
    state: RomaState,
    /// AO ray length (default ∞, as the paper's AO).
    pub radius: f32,
    /// `snap_weight=cos` (ours; default `none`, the paper's count): each snapped sample is
    /// weighted by [`crate::CandidateSet::cosine_weight`] ([`crate::weighting`]).
    pub cosine_weight: bool,
}

impl AoRoma {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "ao-roma",
            family: "ambient occlusion",
            reference: Some("ao-exact"),
            description: "ROMA ambient occlusion: snapped any-hit through n×n ray-aligned occupancy maps (resolution=128 n=auto (4 or 8) offset=1.5 accumulate=10 focus=auto: the grid around all but the supporting planes, tested exactly; snap_weight=none, cos: samples weighted against the snapping bias; profile=paper: n=4 focus=scene)",
            create: |_: &Scene, settings, params| Ok(Box::new(AoRoma::new(settings, params)?)),
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let state = RomaState::new(settings, params, RomaParams::with_auto_n(), false)?;
        let cosine_weight = params.choice("snap_weight", "none", &["none", "cos"])? == "cos";
        Ok(Self { state, radius: params.f32("radius", f32::INFINITY, 0.0, f32::INFINITY)?, cosine_weight })
    }
}

impl Technique for AoRoma {
    fn id(&self) -> &'static str {
        "ao-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let roma = self.state.roma("ao-roma")?;
        let mut stats = Stats { memory_bytes: roma.memory_bytes(), ..Default::default() };
        let (spp, seed, radius) = (self.state.settings.spp, self.state.settings.seed, self.radius);
        let weight = self.cosine_weight;
        stats.rays =
            stats.time("trace", || ambient_occlusion(roma, gbuffer, spp, radius, weight, seed, ctx.frame_index, &ctx.progress, out));
        stats.time("accumulate", || {
            self.state.accumulator.blend(ctx.frame_index, out);
            weighting::clamp_open_fraction(out);
        });
        Ok(stats)
    }
}

/// ROMA ambient occlusion of every GBuffer pixel (1 = open); returns the rays traced. With
/// `cosine_weight` (`snap_weight=cos`) the samples are combined by [`crate::weighting`].
#[allow(clippy::too_many_arguments)]
pub fn ambient_occlusion(
    roma: &Roma,
    gbuffer: &GBuffer,
    spp: u32,
    radius: f32,
    cosine_weight: bool,
    seed: u64,
    frame_index: u32,
    progress: &glimpse_render::Progress,
    out: &mut Image,
) -> u64 {
    let offset = roma.cell_size_world() * crate::with_maps!(roma, m => m.origin_offset_cells);
    let width = gbuffer.width as usize;
    let candidates = roma.candidates();
    // One row per task (the lone-sample rule reads a pixel's neighbour); the progress counter
    // is shared, so it is bumped once per row.
    out.pixels.par_chunks_mut(width).enumerate().for_each(|(row, pixels)| {
        let mut samples = vec![None; width * spp as usize];
        for (x, px_samples) in samples.chunks_mut(spp as usize).enumerate() {
            let i = row * width + x;
            if !gbuffer.is_hit(i) {
                continue;
            }
            let origin = gbuffer.position[i] + gbuffer.normal[i] * offset;
            let basis = Frame::from_z(gbuffer.shading_normal[i]);
            let mut rng = Rng::for_pixel(seed, i as u64, frame_index as u64);
            for sample in px_samples {
                let (k, sign) = roma.select(basis.to_world(cosine_hemisphere(rng.next_2d())));
                let open = !roma.any_hit_snapped(k, sign, origin, radius);
                let weight = if cosine_weight { candidates.cosine_weight(k, sign, basis.z) } else { 1.0 };
                *sample = Some(SnappedSample { open: open as u8 as f32, weight });
            }
        }
        weighting::open_fractions(&samples, spp as usize, pixels);
        progress.add(pixels.len() as u64);
    });
    gbuffer.instance.iter().filter(|&&i| i != glimpse_trace::gbuffer::NO_HIT).count() as u64 * spp as u64
}

/// `soft-roma`.
pub struct SoftRoma {
    state: RomaState,
    /// Trace the shadow rays snapped instead of by DDA (the paper's Fig. 8b comparison).
    pub snap: bool,
}

impl SoftRoma {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "soft-roma",
            family: "soft shadows",
            reference: Some("soft-exact"),
            description: "ROMA soft shadows: area-light samples as soft-exact, un-snapped DDA shadow rays (n=8 dda_steps=8 focus=auto; snap=true: snapped)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "soft-roma", glimpse_render::Need::AreaLights)?;
                Ok(Box::new(SoftRoma::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let defaults = RomaParams { n: 8, ..RomaParams::default() };
        let state = RomaState::new(settings, params, defaults, true)?;
        Ok(Self { state, snap: params.bool("snap", false)? })
    }
}

impl Technique for SoftRoma {
    fn id(&self) -> &'static str {
        "soft-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        self.state.prepare(ctx)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let roma = self.state.roma("soft-roma")?;
        let mut stats = Stats { memory_bytes: roma.memory_bytes(), ..Default::default() };
        let (spp, seed, snap, steps) = (self.state.settings.spp, self.state.settings.seed, self.snap, self.state.params.dda_steps);
        let offset = roma.cell_size_world() * self.state.params.origin_offset_cells;
        let frame = &ctx.frame;
        stats.rays = stats.time("trace", || {
            direct::shade_pixels(ctx, gbuffer, seed, out, |i, rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let (mut e, mut rays) = (Vec3::ZERO, 0u64);
                for _ in 0..spp {
                    let Some((ls, from, to)) = direct::area_light_segment(frame, &s, rng.next_f32(), rng.next_2d(), offset) else {
                        continue;
                    };
                    rays += 1;
                    if !shadow_blocked(roma, from, to, snap, steps) {
                        e += ls.radiance * (s.cos(ls.wi) / ls.pdf);
                    }
                }
                (s.albedo / PI * e / spp as f32, rays)
            })
        })?;
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

/// Is the segment `from → to` blocked in ROMA? Un-snapped DDA, or snapped along the candidate of
/// its stratum for the same length.
pub fn shadow_blocked(roma: &Roma, from: Vec3, to: Vec3, snap: bool, dda_steps: u32) -> bool {
    let d = to - from;
    let len = d.length();
    if len <= 0.0 {
        return false;
    }
    if snap {
        let (k, sign) = roma.select(d / len);
        roma.any_hit_snapped(k, sign, from, len)
    } else {
        roma.any_hit_unsnapped(from, to, dda_steps)
    }
}

/// Lights (punctual lights + emitting instances) `gi-roma` accepts: one 512² RSM each per frame.
pub const MAX_RSM_LIGHTS: usize = 16;

/// `gi-roma`'s reflective shadow maps: their resolution, and the environment's share (ours).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsmSettings {
    /// RSM texels per side for the scene's lights (paper §6: 512; `rsm`).
    pub resolution: u32,
    /// Directions of the environment map injected per frame, each a directional light with its
    /// own RSM ([`glimpse_render::rsm::environment_lights`]; `env_lights`, 0 with
    /// `profile=paper`, whose RSMs hold spot and point lights only). Without them a surface lit
    /// only by the map reflects nothing into the bounce, which `gi-exact` counts: on
    /// `studio-objects` the teapot's underside, lit by the white floor, was black.
    pub env_lights: u32,
    /// Their texels per side (`env_rsm`): two per ROMA cell of the default 128³ grid, which
    /// spans the same bounding sphere; the bounce's hit is known to a cell.
    pub env_resolution: u32,
    /// How much deeper than its texel's surface (in ROMA cells, plus the texel's own depth
    /// range: [`glimpse_render::rsm::Rsm::lit_radiance`]) a bounce hit may lie and still be lit
    /// (`rsm_bias`): the paper's "voxel-sized bias" (§7; §6 only says the points are
    /// perturbed), 1. Two cells (our first reading) let light through Sponza's 0.66 m: its
    /// bounce from the point lights came out 1.66× `gi-exact`'s (1.02× with one cell).
    pub bias_cells: f32,
}

impl RsmSettings {
    /// Reads `rsm`, `env_lights` and `env_rsm`, and refuses a scene with more than
    /// [`MAX_RSM_LIGHTS`] lights (one map each per frame; a many-light scene would need
    /// thousands of 512² maps).
    pub fn read(scene: &Scene, params: &Params) -> Result<Self, RenderError> {
        let emitting =
            scene.instances.iter().filter(|i| scene.materials[scene.meshes[i.mesh as usize].material as usize].is_emissive()).count();
        let maps = scene.lights.len() + emitting;
        if maps > MAX_RSM_LIGHTS {
            return Err(RenderError::Unsupported {
                technique: "gi-roma".into(),
                message: format!("{maps} lights would need {maps} reflective shadow maps per frame (at most {MAX_RSM_LIGHTS})"),
            });
        }
        let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
        Ok(Self {
            resolution: params.u32("rsm", 512, 8, 4096)?,
            env_lights: params.u32("env_lights", if paper { 0 } else { DEFAULT_ENV_LIGHTS }, 0, 64)?,
            env_resolution: params.u32("env_rsm", 256, 8, 4096)?,
            bias_cells: params.f32("rsm_bias", 1.0, 0.0, 16.0)?,
        })
    }
}

/// [`RsmSettings::env_lights`]' default.
pub const DEFAULT_ENV_LIGHTS: u32 = 4;

/// `gi-roma`.
pub struct GiRoma {
    state: RomaState,
    pub include_direct: bool,
    pub rsm: RsmSettings,
    rsms: Vec<Rsm>,
}

impl GiRoma {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "gi-roma",
            family: "global illumination",
            reference: Some("gi-exact"),
            description: "ROMA one-bounce diffuse GI: snapped closest-hit bounce, hit lit from 512² reflective shadow maps of the lights and of 4 environment directions per frame (include_direct=true adds exact direct light; focus=auto as ao-roma)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "gi-roma", glimpse_render::Need::AnyLight)?;
                Ok(Box::new(GiRoma::new(scene, settings, params)?))
            },
        }
    }

    pub fn new(scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let rsm = RsmSettings::read(scene, params)?;
        let state = RomaState::new(settings, params, RomaParams::with_auto_n(), false)?;
        Ok(Self { state, include_direct: params.bool("include_direct", true)?, rsm, rsms: Vec::new() })
    }
}

/// `gi-roma`'s reflective shadow maps for this frame (one per light that casts them, then one
/// per environment direction), checked against the memory budget first; the CPU technique and
/// its GPU port build the same maps from the same random numbers.
pub(crate) fn build_rsms(
    ctx: &FrameContext,
    seed: u64,
    jitter: bool,
    settings: &RsmSettings,
    stats: &mut Stats,
) -> Result<Vec<Rsm>, RenderError> {
    let (res, env_res) = (settings.resolution as u64, settings.env_resolution as u64);
    let maps = glimpse_render::rsm::rsm_light_count(&ctx.frame);
    let env_maps = if ctx.frame.scene.environment.is_some() { settings.env_lights as usize } else { 0 };
    let bytes = (maps as u64 * res * res + env_maps as u64 * env_res * env_res) * glimpse_render::rsm::BYTES_PER_TEXEL;
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    let what = if env_maps == 0 {
        format!("gi-roma: {maps} reflective shadow map{} of {res}² texels", plural(maps))
    } else {
        format!(
            "gi-roma: {} reflective shadow maps ({maps} of {res}² texels, {env_maps} of {env_res}² for the environment)",
            maps + env_maps
        )
    };
    glimpse_core::memory_budget::check(what, bytes)?;
    let rsms: Vec<Rsm> = stats.time("rsm", || {
        let mut rng = Rng::new(seed, 0x2500_0000 + ctx.frame_index as u64);
        let mut rsms: Vec<Rsm> = rsm_lights(&ctx.frame, &mut rng)
            .iter()
            .map(|light| {
                let j = if jitter { rng.next_2d() - Vec2::splat(0.5) } else { Vec2::ZERO };
                Rsm::build(&ctx.frame, &ctx.tracer, light, settings.resolution, j)
            })
            .collect();
        // The environment's directions from their own stream: the lights' maps stay as they were.
        let mut env_rng = Rng::new(seed, 0x2600_0000 + ctx.frame_index as u64);
        for light in environment_lights(&ctx.frame, settings.env_lights, &mut env_rng) {
            let j = if jitter { env_rng.next_2d() - Vec2::splat(0.5) } else { Vec2::ZERO };
            rsms.push(Rsm::build(&ctx.frame, &ctx.tracer, &light, settings.env_resolution, j));
        }
        rsms
    });
    stats.memory_bytes += rsms.iter().map(Rsm::memory_bytes).sum::<usize>();
    Ok(rsms)
}

impl Technique for GiRoma {
    fn id(&self) -> &'static str {
        "gi-roma"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = self.state.prepare(ctx)?;
        self.rsms = build_rsms(ctx, self.state.settings.seed, self.state.params.jitter, &self.rsm, &mut stats)?;
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let roma = self.state.roma("gi-roma")?;
        let mut stats = Stats { memory_bytes: roma.memory_bytes(), ..Default::default() };
        let (spp, seed, include_direct) = (self.state.settings.spp, self.state.settings.seed, self.include_direct);
        let cell = roma.cell_size_world();
        let offset = cell * self.state.params.origin_offset_cells;
        let bias = self.rsm.bias_cells * cell;
        let (frame, rsms) = (&ctx.frame, &self.rsms);
        let env = frame.scene.environment.as_ref();
        stats.rays = stats.time("trace", || {
            direct::shade_pixels(ctx, gbuffer, seed, out, |i, rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let basis = Frame::from_z(s.shading_normal);
                let origin = s.position + s.normal * offset;
                let (mut direct_e, mut indirect, mut rays) = (Vec3::ZERO, Vec3::ZERO, 0u64);
                if include_direct {
                    let (e, r) = direct::punctual_irradiance(&frame.lights, &ctx.tracer, &s);
                    direct_e += e * spp as f32;
                    rays += r;
                }
                for _ in 0..spp {
                    if include_direct {
                        let (a, ra) = direct::area_irradiance(frame, &ctx.tracer, &s, rng);
                        let (e, re) = direct::env_irradiance(env, &ctx.tracer, &s, rng);
                        direct_e += a + e;
                        rays += ra + re;
                    }
                    let d = basis.to_world(cosine_hemisphere(rng.next_2d()));
                    if s.cos(d) <= 0.0 {
                        continue;
                    }
                    rays += 1;
                    let (k, sign) = roma.select(d);
                    let Some(t) = roma.closest_hit_snapped(k, sign, origin, f32::INFINITY) else { continue };
                    let hit = origin + roma.candidates().dirs[k] * (sign * t);
                    indirect += rsms.iter().map(|rsm| rsm.lit_radiance(hit, s.position, bias)).sum::<Vec3>();
                }
                (s.albedo * (direct_e / PI + indirect) / spp as f32, rays)
            })
        })?;
        stats.time("accumulate", || self.state.accumulator.blend(ctx.frame_index, out));
        Ok(stats)
    }
}

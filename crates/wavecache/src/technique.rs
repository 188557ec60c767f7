//! `wavecache`: the runtime (paper Sec. 5, Eqs. 15–21; Sec. 6 "Runtime").
//!
//! `prepare` runs (or loads from the disk cache) the precomputation — the scene must be static.
//! Per pixel of the GBuffer (the paper's V-buffer):
//! - direct light of punctual lights by shadow rays with the full BRDF (Eq. 15/16);
//! - the cache points read: the paper's best point by its score, blended with the next best
//!   within 2 r_max (`blend`, `blend_glossy`, ours; [`Runtime::point_for`]);
//! - diffuse meshes: the points' irradiance × (base A_d(θ_o) + A_s(θ_o))/π (Eq. 19;
//!   A_d = 1, A_s = 0 for a Lambertian material, the directional albedos of the glTF material
//!   otherwise, so the cache shades the same BRDF as `pt`);
//! - glossy meshes: Σ bilinear weights × (BRDF tree of the grid node ⊗ the point's radiance tree)
//!   (Eq. 20; four products blended, equal to the product of the blended tree by linearity, the
//!   depth capped at `layers`); ω_o in the frame of the pixel's shading normal (paper), the map in
//!   the cache point's frame (both `Frame::from_z`, so nearby normals give nearby tangents);
//! - roughness < 0.1: a perfect mirror chain with Schlick F (h = n) up to `mirror_depth` (Eq. 18);
//!   a chain that reaches a surface of roughness ≥ 0.1 shades it with the cache and its punctual
//!   lights (spec §6.2's consistent choice), one that escapes sees the environment;
//! - clear coat (Eqs. 11, 12, 17, 21; `Material::clearcoat` = γ > 0): everything above × (1 − F_c)
//!   plus F_c × the radiance along the **clear-coat ray**, the mirror direction of ω_o about the
//!   shading normal (a smooth coat: h = n, [`clear_coat_fresnel`]), traced in a chain of at most
//!   `coat_depth` (paper: 3) whose next surfaces are shaded as here. `pt` shades the same coat
//!   (`glimpse_render::pt::ClearCoat`), so the two compare like for like.
//!
//! The pixel's own emission and misses (environment) are added by `shade_pixels`, as for `pt`.
//! Timings: `prepare` reports the precomputation stages ("brdf tables", "lighting cache") or
//! "cache load"; `render` reports "shade". `memory_bytes` = the cache's storage.

use crate::bake::CachePoint;
use crate::brdf;
use crate::brdf::BrdfTable;
use crate::cache::{ALBEDO_BINS, BrdfPlan, NO_VISIBILITY, WaveCache, cache_key};
use crate::env_direct::EnvSampler;
use crate::haar;
use crate::halfcube::{HalfCube, map_frame};
use crate::points::{self, QueryParams};
use crate::{Class, WavecacheParams, WoFrame};
use glimpse_core::{Image, Ray, Rng, Vec2, Vec3, luminance};
use glimpse_render::bsdf::{self, BrdfModel, Bsdf};
use glimpse_render::direct::{self, punctual};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::Scene;
use glimpse_trace::{GBuffer, SurfacePoint};
use std::f32::consts::PI;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Most cache points a lookup blends (the upper bound of `blend` and `blend_glossy`).
pub const MAX_BLEND: usize = 16;

/// What a shaded point reads from the cache ([`Runtime::point_for`]).
#[derive(Clone, Copy, Debug)]
pub struct Reading<'a> {
    /// The best point by the paper's score (`None` on a mirror or where none is found).
    pub point: Option<&'a CachePoint>,
    /// The points blended (`blend`) and their weights, summing to 1: the best point alone where
    /// no point lies within the kernel.
    blended: [(Option<&'a CachePoint>, f32); MAX_BLEND],
    /// The best point cannot stand for the shaded point's light (`trace_far`): too far, or
    /// outside the normal cutoff.
    pub far: bool,
    /// Where only the blended points' disagreement (`trace_disagree`) made the pixel traced:
    /// the brightest of their irradiances over their blend, by luminance (≥ 1). The pixel's
    /// light lies between its points' (a shadow's edge), so a traced sample above this many
    /// times the blend is bounded ([`DISAGREE_BOUND`]).
    pub disagree_ratio: Option<f32>,
}

/// A traced disagreeing pixel's sample is bounded at this factor over its brightest point's
/// light: a sample that finds a caustic (a diffuse pixel's ray reaching a glossy surface's
/// highlight of a softbox) made one pixel 70× `pt` on `scenes/extra/outdoor-sun` at 4 spp,
/// while at a shadow's edge a sample is at most about the unshadowed light.
pub const DISAGREE_BOUND: f32 = 2.0;

/// How far (in metallic or roughness) a metallic-roughness texel may be from its material's
/// mean, which the BRDF tables hold, and still be shaded from the cache: beyond it the pixel
/// traces a sample of its own BRDF ([`Runtime::texel_traced`]). Our choice, not tuned on a
/// scene (the paper has one BRDF per material): a metallic 0.1 off moves the reflectance by a
/// tenth of the gap between the base colour and 0.04; a texture that varies by less is read
/// from the cache as its mean.
pub const TEXEL_TRACE_TOLERANCE: f32 = 0.1;

/// The fewest samples a pixel traced for its metallic-roughness texel takes ([`Runtime::off_mean`]):
/// there the technique is a one-bounce path tracer over the cache, and at 4 spp its noise is
/// `pt`'s. Measured on `scenes/extra/metal-tiles` at 96 × 64 and 4 spp against `pt` at 4,096
/// spp: MSE 0.319 drawn as the mean (biased: the metal tiles look like stone), 0.759 at 4
/// samples, 0.250 at 16, 0.068 at 64 (shading 17, 63 and 240 ms; `pt` at 4 spp 0.816, at 64
/// spp 0.065).
pub const TEXEL_TRACE_SAMPLES: u32 = 16;

impl Default for Reading<'_> {
    fn default() -> Self {
        Self { point: None, blended: [(None, 0.0); MAX_BLEND], far: false, disagree_ratio: None }
    }
}

impl<'a> Reading<'a> {
    /// The blended points with their weights.
    pub fn blended(&self) -> impl Iterator<Item = (&'a CachePoint, f32)> + '_ {
        self.blended.iter().filter_map(|&(p, w)| p.map(|p| (p, w)))
    }
}

pub struct Wavecache {
    pub params: WavecacheParams,
    pub settings: Settings,
    pub cache: Option<WaveCache>,
    /// `env_direct`'s sampler of the environment, built with the cache ([`env_sampler_for`]).
    env_sampler: Option<Arc<EnvSampler>>,
    /// Where the last `prepare` got its cache: "built", "disk" or "memory".
    pub source: &'static str,
}

/// Filament's clear-coat Fresnel (Eq. 12): [0.04 + 0.96 (1 − ω_o·h)^5] γ.
pub fn clear_coat_fresnel(cos_oh: f32, gamma: f32) -> f32 {
    (0.04 + 0.96 * (1.0 - cos_oh).clamp(0.0, 1.0).powi(5)) * gamma
}

impl Wavecache {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "wavecache",
            family: "global illumination",
            reference: Some("pt"),
            description: "Haar-wavelet radiance caching (Xing et al. 2024): half-cube maps, GGX BRDF trees ⊗ cached radiance, irradiance points, octrees; static scenes; precompute cached on disk (cache=false to skip)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "wavecache", glimpse_render::Need::AnyLight)?;
                if scene.is_animated() {
                    return Err(RenderError::Unsupported {
                        technique: "wavecache".into(),
                        message: format!("the scene '{}' is animated; the radiance cache needs static geometry and lighting", scene.name),
                    });
                }
                Ok(Box::new(Wavecache::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        Ok(Self::with_params(settings, WavecacheParams::read(params)?))
    }

    pub fn with_params(settings: &Settings, params: WavecacheParams) -> Self {
        Self { params, settings: *settings, cache: None, env_sampler: None, source: "none" }
    }

    fn ensure_cache(&mut self, ctx: &FrameContext, stats: &mut Stats) -> Result<(), RenderError> {
        let mut params = self.params.clone();
        params.back_sides = stats.time("back sides", || ctx.instances_seen_from_behind(128));
        stats.metrics.push(("two_sided_instances".to_owned(), params.back_sides.len() as f64));
        let key = stats.time("cache key", || cache_key(&ctx.frame, &params, self.settings.seed));
        if self.cache.as_ref().is_some_and(|c| c.key == key) {
            self.source = "memory";
            return Ok(());
        }
        let path = if self.params.disk_cache { WaveCache::path_for(key) } else { None };
        if let Some(path) = &path {
            let sw = glimpse_render::Stopwatch::start();
            if let Some(c) = WaveCache::load_or_discard(path, key) {
                stats.stage("cache load", sw.ms());
                self.cache = Some(c);
                self.source = "disk";
                return Ok(());
            }
        }
        // The ray budget, turned into paths at this scene's measured path length.
        let mut p = params;
        if p.ray_budget > 0 {
            let rays_per_path = stats
                .time("path-length pilot", || crate::cache::mean_rays_per_path(&ctx.frame, &ctx.tracer, &self.params, self.settings.seed));
            stats.metrics.push(("rays_per_path".to_owned(), rays_per_path));
            p.path_budget = p.effective_path_budget(rays_per_path);
        }
        let estimate = WaveCache::estimated_bytes(&ctx.frame, &p);
        glimpse_core::memory_budget::check("wavecache: the cache points and tree headers", estimate)?;
        let units = WaveCache::work_units(&ctx.frame, &p);
        let bar = if self.params.progress {
            let b = indicatif::ProgressBar::new(units);
            b.set_style(
                indicatif::ProgressStyle::with_template("wavecache precompute {bar:40} {pos}/{len} [{elapsed_precise} < {eta_precise}]")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        } else {
            indicatif::ProgressBar::hidden()
        };
        let tick = |n: u64| bar.inc(n);
        let c = WaveCache::build(&ctx.frame, &ctx.tracer, &p, self.settings.seed, key, &tick);
        bar.finish_and_clear();
        let c = c?;
        stats.stage("brdf tables", c.build_info.first().copied().unwrap_or(0.0));
        // What the memory holds: the distinct BRDF tables and their bytes beside the lighting's.
        let plan = BrdfPlan::new(&ctx.frame, &p);
        let tables = plan.table_count(&ctx.frame, &p);
        stats.metrics.push(("brdf_tables".to_owned(), tables as f64));
        let snap = plan.max_snap(&ctx.frame);
        if snap > 0.0 {
            // A parameter the scene made us choose: said once, with how to undo it.
            stats.metrics.push(("brdf_roughness_snap".to_owned(), snap as f64));
            let max = BrdfPlan::max_tables(&p);
            let fit = if tables <= max { "to fit" } else { "and still over (its metallic values and models vary)" };
            let limit = if max < p.brdf_max_tables as u64 {
                format!(
                    "the {max} tables of {:.0} MB at most that fit {:.1} GB",
                    BrdfPlan::max_table_bytes(&p) as f64 / 1e6,
                    crate::BRDF_TABLES_MAX_BYTES as f64 / 1e9
                )
            } else {
                format!("brdf_max_tables={max}")
            };
            eprintln!(
                "wavecache: glossy roughnesses snapped by up to {snap:.4}: {tables} BRDF tables, {fit} {limit} (brdf_max_tables=0 lifts it)"
            );
        }
        stats.metrics.push(("brdf_mib".to_owned(), c.brdf_bytes() as f64 / (1u64 << 20) as f64));
        stats.metrics.push(("lighting_mib".to_owned(), c.lighting_bytes() as f64 / (1u64 << 20) as f64));
        stats.stage("lighting cache", c.build_info.get(1).copied().unwrap_or(0.0));
        stats.rays = c.build_info.get(2).copied().unwrap_or(0.0) as u64;
        if let Some(&n) = c.build_info.get(5) {
            stats.metrics.push(("enclosed_points".to_owned(), n));
        }
        if let (Some(&paths), Some(&scale)) = (c.build_info.get(3), c.build_info.get(4)) {
            stats.metrics.push(("precompute_paths".to_owned(), paths));
            stats.metrics.push(("point_budget_scale".to_owned(), scale));
            if scale > 1.0 {
                eprintln!(
                    "wavecache: cache points scaled to {scale:.2}× of diffuse_points/glossy_points ({:.1}M paths) toward path_floor={} (path_floor=0 lifts it)",
                    paths / 1e6,
                    self.params.path_floor,
                );
            }
            if scale < 1.0 {
                // A parameter the scene made us choose: said once, with how to undo it.
                eprintln!(
                    "wavecache: cache points scaled to {scale:.2}× of diffuse_points/glossy_points to fit {:.0}M paths (budget={} paths, ray_budget={} rays at {:.1} rays per path; budget=0 ray_budget=0 lift it)",
                    p.path_budget as f64 / 1e6,
                    self.params.path_budget,
                    self.params.ray_budget,
                    stats.metrics.iter().find(|m| m.0 == "rays_per_path").map_or(1.0, |m| m.1),
                );
            }
        }
        if let Some(path) = &path {
            // A failed write only costs the next run a recomputation.
            if let Err(e) = c.save(path) {
                eprintln!("warning: {e}");
            }
        }
        self.cache = Some(c);
        self.source = "built";
        Ok(())
    }
}

/// What the runtime needs.
pub struct Runtime<'a> {
    pub cache: &'a WaveCache,
    pub params: &'a WavecacheParams,
    pub frame: &'a glimpse_scene::SceneFrame<'a>,
    pub vis: &'a glimpse_trace::ExactTracer,
    pub classes: Vec<Class>,
    /// Per material: a glossy lobe too narrow for its radiance map, shaded by tracing a sample
    /// of its BSDF instead of Eq. 20 ([`lobe_finer_than_map`]).
    pub traced: Vec<bool>,
    /// Emissive triangles by hit, for the MIS weight of emission a traced sample finds.
    pub emitters: direct::EmitterIndex,
    /// cos of the query's normal cutoff (`normal_cutoff_deg`).
    normal_cutoff: f32,
    /// Environment samples (`env_direct`) at a pixel read from the cache: the render loop sets
    /// [`pixel_env_samples`], since it shades such a pixel once; a traced sample's hit takes
    /// `env_direct_samples`.
    pub pixel_env_samples: u32,
    /// The environment's sampler for `env_direct` (where some map has a visibility map).
    env_sampler: Option<Arc<EnvSampler>>,
    /// `trace_disagree` as it applies to this scene (`auto` chosen from the environment).
    pub trace_disagree: f32,
    /// The diffuse points' irradiance includes the punctual lights
    /// ([`WavecacheParams::cache_punctual_above`]): cached diffuse pixels trace none.
    pub punctual_cached: bool,
}

/// `env_direct` samples at a pixel read from the cache, which is shaded once whatever the spp:
/// `env_direct_samples` per pixel sample, at least `env_direct_pixel_samples`.
pub fn pixel_env_samples(params: &WavecacheParams, spp: u32) -> u32 {
    params.env_direct_samples.saturating_mul(spp.max(1)).max(params.env_direct_pixel_samples)
}

/// `env_direct`'s sampler of the frame's environment, where some map of `cache` has a
/// visibility map ([`EnvSampler`]).
pub fn env_sampler_for(cache: &WaveCache, frame: &glimpse_scene::SceneFrame) -> Option<Arc<EnvSampler>> {
    frame.scene.environment.as_ref().filter(|_| !cache.env_visibility.is_empty()).map(|e| Arc::new(EnvSampler::new(e)))
}

/// Whether a GGX lobe of `roughness` is narrower than a texel of a radiance half-cube map of
/// resolution `map_res` (Table 2 ÷ `map_scale`): reflected directions spread over about 2α
/// (α = roughness²) around the mirror direction, a texel spans about π / `map_res`.
///
/// Why (issue #13, a deviation): such a lobe cannot be represented by the map. Eq. 20 then
/// spreads a small bright emitter's texel over the whole lobe's peak, and a near-mirror sphere
/// (roughness 0.12, 32² maps at `map_scale` 4) showed glints up to 40× `pt` (own MSE 1.0e3 on the
/// `glints` suite scene). Those materials are shaded as `pt` shades one bounce (light sampling
/// and one BSDF sample per pixel sample, MIS), the hit shaded from the cache (`traced_sample`).
/// The paper's Table 2 starts its 128² maps at roughness 0.1; at `map_scale` 1 the rule keeps
/// roughness above 0.111 on the cache. Materials below the mirror threshold with a non-zero roughness
/// are traced the same way (their GGX lobe, as `pt` has it, instead of Eq. 18's perfect mirror).
pub fn lobe_finer_than_map(roughness: f32, map_res: u32, texels: f32) -> bool {
    2.0 * roughness * roughness < texels * std::f32::consts::PI / map_res as f32
}

/// The base colour a BRDF table is read at: base / b per channel, b the colour it was
/// tabulated with ([`WaveCache::brdf_base`]: a material's own factor, or white). A textured
/// pixel's base is texel × factor; with a white table the ratio is the base itself. A zero b
/// channel stays as tabulated.
///
/// Why the black table beside it (issue #13): scaling the whole lobe by the texel also darkened
/// a textured dielectric's white specular highlight on Spot's black patches, 0.3 where `pt` has
/// 3–5 (`textured-glossy`: 8 pixels black where lit).
fn texel_ratio(base: Vec3, factor: Vec3) -> Vec3 {
    let r = |b: f32, f: f32| if f > 1e-6 { b / f } else { 1.0 };
    Vec3::new(r(base.x, factor.x), r(base.y, factor.y), r(base.z, factor.z))
}

/// A surface to shade.
#[derive(Clone, Copy, Debug)]
pub struct ShadePoint {
    pub position: Vec3,
    /// The ray offset's scale ([`SurfacePoint::error_scale`]).
    pub error_scale: f32,
    pub normal: Vec3,
    pub shading_normal: Vec3,
    pub base: Vec3,
    pub material: u32,
    /// Texture coordinates (a metallic-roughness texture's texels: [`Runtime::texel_traced`]).
    pub uv: Vec2,
    pub instance: u32,
    /// Whether the triangle's winding faces `wo` (glass needs the side to know which way it
    /// refracts; the GBuffer does not keep it, so a glass pixel is traced again).
    pub front_face: bool,
}

impl ShadePoint {
    /// The surface a traced ray hit.
    pub fn at_hit(frame: &glimpse_scene::SceneFrame, sp: &SurfacePoint) -> Self {
        Self {
            position: sp.position,
            error_scale: sp.error_scale,
            normal: sp.normal,
            shading_normal: sp.shading_normal,
            base: sp.base_color(frame),
            material: sp.material,
            uv: sp.uv,
            instance: sp.instance,
            front_face: sp.front_face,
        }
    }

    /// The normal shading and the cache lookup use when seen from `wo`: the shading normal where
    /// it faces `wo`, else the geometric one.
    pub fn facing_normal(&self, wo: Vec3) -> Vec3 {
        if self.shading_normal.dot(wo) > 0.0 { self.shading_normal } else { self.normal }
    }

    /// The surface a GBuffer pixel sees.
    pub fn at_pixel(g: &GBuffer, i: usize) -> Self {
        Self {
            position: g.position[i],
            error_scale: g.error_scale[i],
            normal: g.normal[i],
            shading_normal: g.shading_normal[i],
            base: g.albedo[i],
            material: g.material[i],
            uv: g.uv[i],
            instance: g.instance[i],
            front_face: true,
        }
    }
}

impl<'a> Runtime<'a> {
    pub fn new(
        cache: &'a WaveCache,
        params: &'a WavecacheParams,
        frame: &'a glimpse_scene::SceneFrame<'a>,
        vis: &'a glimpse_trace::ExactTracer,
    ) -> Self {
        Self::with_env_sampler(cache, params, frame, vis, env_sampler_for(cache, frame))
    }

    /// [`Runtime::new`] with `env_direct`'s sampler built already ([`env_sampler_for`]: the
    /// technique builds it once per cache, not per frame; a 1024 × 512 map's takes about 8 ms).
    pub fn with_env_sampler(
        cache: &'a WaveCache,
        params: &'a WavecacheParams,
        frame: &'a glimpse_scene::SceneFrame<'a>,
        vis: &'a glimpse_trace::ExactTracer,
        env_sampler: Option<Arc<EnvSampler>>,
    ) -> Self {
        let classes: Vec<Class> = frame.scene.materials.iter().map(|m| params.classify(m)).collect();
        // `sharp_env`: a map whose bright half fits in one texel of an N² map gets the Nyquist rule.
        let env = frame.scene.environment.as_ref().filter(|_| params.sharp_env);
        let env_half_power = env.map_or(f32::INFINITY, |e| e.half_power_solid_angle());
        let texels = |n: u32| {
            let unresolved = env_half_power < (std::f32::consts::PI / n as f32).powi(2);
            if unresolved { params.sharp_texels.max(2.0) } else { params.sharp_texels }
        };
        let traced = frame
            .scene
            .materials
            .iter()
            .zip(&classes)
            .map(|(m, c)| {
                let sharp_glossy = *c == Class::Glossy
                    && params.map_resolution(m.roughness).is_some_and(|n| lobe_finer_than_map(m.roughness, n, texels(n)));
                // Below the mirror threshold but not smooth: `pt`'s GGX lobe, not Eq. 18's mirror.
                let rough_mirror = *c == Class::Mirror && m.roughness > 0.0;
                params.trace_sharp && (sharp_glossy || rough_mirror)
            })
            .collect();
        let emitters = direct::EmitterIndex::new(frame);
        let normal_cutoff = params.normal_cutoff_deg.to_radians().cos();
        let pixel_env_samples = params.env_direct_samples;
        let small_source = crate::small_cached_sources(frame);
        let trace_disagree = match (params.disagree_auto, small_source) {
            (true, true) => crate::AUTO_DISAGREE,
            (true, false) => f32::INFINITY,
            (false, _) => params.trace_disagree,
        };
        let punctual_cached = params.caches_punctual(frame.lights.len());
        Self {
            cache,
            params,
            frame,
            vis,
            classes,
            traced,
            emitters,
            normal_cutoff,
            pixel_env_samples,
            env_sampler,
            trace_disagree,
            punctual_cached,
        }
    }

    /// The cache point chosen for the shaded point `s` (normal `ns` for the score), on the side
    /// of its geometric normal: a point of the other side caches the other hemisphere's light,
    /// so none is found there (a back face the camera did not see when the cache was made gets
    /// no cached light, rather than the front's).
    pub fn lookup(&self, s: &ShadePoint, ns: Vec3) -> Option<&'a CachePoint> {
        let mut best = [(0.0, 0)];
        let (pts, found) = self.lookup_best(s, ns, &mut best);
        (found > 0).then(|| &pts[best[0].1 as usize])
    }

    /// [`Self::lookup`] keeping the `best.len()` best (score, index) pairs, best first; returns
    /// the mesh's points (what the indices index) and how many were found.
    fn lookup_best(&self, s: &ShadePoint, ns: Vec3, best: &mut [(f32, u32)]) -> (&'a [CachePoint], usize) {
        let Some(mc) = self.cache.meshes.get(s.instance as usize).filter(|mc| mc.point_count > 0) else {
            return (&[], 0);
        };
        let nodes = &self.cache.octree[mc.first_node as usize..(mc.first_node + mc.node_count) as usize];
        let pts = &self.cache.points[mc.first_point as usize..(mc.first_point + mc.point_count) as usize];
        let r_max = mc.r_max.max(1e-12);
        let q = QueryParams {
            r_max,
            normal_weight: self.params.normal_weight,
            normal_cutoff: self.normal_cutoff,
            max_candidates: self.params.query_m,
            search_radius: self.params.search_radius * r_max,
        };
        (pts, points::query_points_best(nodes, pts, &q, s.position, ns, s.normal, best))
    }

    /// What `s` reads from the cache seen from `wo` ([`Reading`]): its best point, the nearest
    /// points blended (`blend`) and their weights, and whether the best point is too far to
    /// stand for `s`'s light: none found, or farther than `trace_far` × its mesh's r_max (then
    /// `shade` traces instead).
    pub fn point_for(&self, s: &ShadePoint, wo: Vec3) -> Reading<'a> {
        let blend = match self.classes.get(s.material as usize) {
            None | Some(Class::Mirror) => return Reading::default(),
            Some(Class::Diffuse) => self.params.blend,
            Some(Class::Glossy) => self.params.blend_glossy,
        };
        let ns = s.facing_normal(wo);
        let mut best = [(0.0, 0); MAX_BLEND];
        let k = (blend as usize).clamp(1, MAX_BLEND);
        let (pts, found) = self.lookup_best(s, ns, &mut best[..k]);
        let mut reading = Reading::default();
        let (Some(&(_, first)), Some(mc)) = (best[..found].first(), self.cache.meshes.get(s.instance as usize)) else {
            reading.far = self.params.trace_far.is_finite();
            return reading;
        };
        let point = &pts[first as usize];
        reading.point = Some(point);
        // Far, or turned away: the query takes a point outside the normal cutoff only when the
        // search radius holds none inside it, and such a point caches another orientation's
        // hemisphere (a pillar's side reading its top). `trace_far=inf` reads both.
        let turned = ns.dot(Vec3::from(point.shading_normal)) < self.normal_cutoff;
        let distant = (Vec3::from(point.position) - s.position).length() > self.params.trace_far * mc.r_max;
        reading.far = self.params.trace_far.is_finite() && (distant || turned);
        // A biweight kernel of radius `blend_radius` × r_max times the normals' agreement,
        // inside the normal cutoff.
        let radius = self.params.blend_radius * mc.r_max;
        let diffuse = self.classes.get(s.material as usize) == Some(&Class::Diffuse);
        let (mut total, mut valid) = (0.0, false);
        for (slot, &(_, i)) in reading.blended.iter_mut().zip(&best[..found]) {
            let p = &pts[i as usize];
            let distance = s.position.distance(Vec3::from(p.position));
            let (d, c) = (distance / radius, ns.dot(Vec3::from(p.shading_normal)));
            if d < 1.0 && c >= self.normal_cutoff {
                let w = (1.0 - d * d).powi(2) * c;
                *slot = (Some(p), w);
                total += w;
                // Ward's error: the point's light holds here (`validity`).
                valid = valid || distance / p.reach + (1.0 - c).max(0.0).sqrt() < self.params.validity;
            }
        }
        if total > 0.0 {
            reading.blended.iter_mut().for_each(|b| b.1 /= total);
        } else {
            reading.blended[0] = (Some(point), 1.0);
        }
        // No point inside the kernel (`trace_lonely`, diffuse): where shadows are hard, the one
        // point beyond it can hold another place's light, and nothing disagrees to show it.
        // Points inside it of which none is valid here by Ward's error (`validity`, diffuse and
        // glossy: a glossy point's map and environment visibility change as fast) are as lonely.
        let lonely = diffuse && total <= 0.0;
        let invalid = total > 0.0 && !valid && self.params.validity.is_finite();
        if (lonely || invalid) && self.params.trace_lonely && self.trace_disagree.is_finite() {
            reading.far = self.params.trace_far.is_finite();
        }
        // Diffuse points that disagree (`trace_disagree`): their mean is no answer here.
        if diffuse && blend > 1 && self.trace_disagree.is_finite() {
            let lum = |p: &CachePoint| glimpse_core::luminance(self.cache.irradiance_at(p.payload).unwrap_or(Vec3::ZERO));
            let (lo, hi) = reading.blended().map(|(p, _)| lum(p)).fold((f32::INFINITY, 0.0f32), |(lo, hi), l| (lo.min(l), hi.max(l)));
            if !reading.far && hi > self.trace_disagree * lo {
                let mean: f32 = reading.blended().map(|(p, w)| lum(p) * w).sum();
                reading.far = true;
                reading.disagree_ratio = Some(if mean > 0.0 { hi / mean } else { f32::INFINITY });
            }
        }
        reading
    }

    /// Eq. 20: the blended BRDF trees of `material` with base colour `base` (its texel) at
    /// `wo_local` ⊗ radiance tree `tree`. A table of another base b (white, for a textured material
    /// or one sharing its tables with other colours) is read at base / b per channel with its black table: black + ratio ×
    /// (b's − black's), exact (the BRDF is affine in the base colour); a material's own table
    /// (ratio 1) alone.
    pub fn glossy(&self, material: u32, base: Vec3, wo_local: Vec3, tree: u32) -> Vec3 {
        let m = material as usize;
        let (Some(table), Some(&b)) = (self.cache.brdf_tables.get(m), self.cache.brdf_base.get(m)) else {
            return Vec3::ZERO;
        };
        let ratio = texel_ratio(base, Vec3::from(b));
        let lit = self.product(table, wo_local, tree);
        match self.cache.brdf_black.get(m).filter(|t| t.res > 0 && (ratio - Vec3::ONE).abs().max_element() > 1e-4) {
            Some(black) => {
                let dark = self.product(black, wo_local, tree);
                (dark + (lit - dark) * ratio).max(Vec3::ZERO)
            }
            None => lit * ratio,
        }
    }

    /// Eq. 20 with the BRDF table `t`: its four trees around `wo_local`, bilinearly blended,
    /// ⊗ radiance tree `tree`.
    fn product(&self, t: &BrdfTable, wo_local: Vec3, tree: u32) -> Vec3 {
        let c = self.cache;
        let Some(rt) = c.radiance_trees.get(tree as usize) else {
            return Vec3::ZERO;
        };
        if t.res == 0 {
            return Vec3::ZERO;
        }
        let wo = Vec3::new(wo_local.x, wo_local.y, wo_local.z.max(1e-4)).normalize();
        let corners = brdf::bilinear(wo, t.n_u1, t.n_u2);
        let trees = corners.map(|(i, j, _)| c.brdf_trees[(t.first_tree + i * t.n_u2 + j) as usize]);
        // Depth = the lowest of the four (Sec. 6), capped by `layers`.
        let mut cap = trees.iter().map(|t| t.depth).min().unwrap_or(0);
        if self.params.layers > 0 {
            cap = cap.min(self.params.layers);
        }
        let mut sum = Vec3::ZERO;
        for (k, (_, _, w)) in corners.iter().enumerate() {
            if *w > 0.0 {
                sum += haar::product(&c.brdf_nodes, trees[k], &c.radiance_nodes, *rt, cap) * *w;
            }
        }
        sum.max(Vec3::ZERO)
    }

    /// Cached part (Eq. 19/20) at `s` seen from `wo`.
    pub fn cached(&self, s: &ShadePoint, wo: Vec3) -> Vec3 {
        self.cached_from(s, wo, &self.point_for(s, wo))
    }

    /// Eq. 19/20 at `s` seen from `wo`, from what [`Self::point_for`] read.
    fn cached_from(&self, s: &ShadePoint, wo: Vec3, reading: &Reading) -> Vec3 {
        let Some(class) = self.classes.get(s.material as usize) else {
            return Vec3::ZERO;
        };
        let ns = s.facing_normal(wo);
        match class {
            Class::Mirror => Vec3::ZERO,
            Class::Diffuse => {
                let e = reading.blended().map(|(p, w)| self.cache.irradiance_at(p.payload).unwrap_or(Vec3::ZERO) * w).sum::<Vec3>();
                let base = s.material as usize * ALBEDO_BINS as usize;
                let table = self.cache.albedo.get(base..base + ALBEDO_BINS as usize).unwrap_or(&[]);
                let [ad, as_] = brdf::albedo_lookup(table, ns.dot(wo));
                e * (s.base * ad + Vec3::splat(as_)) / PI
            }
            Class::Glossy => {
                // Per shaded point: ω_o in the pixel's frame, and its mirror direction about ns.
                let (wo_pixel, r) = (map_frame(ns).to_local(wo), bsdf::reflect(wo, ns));
                let radiance = |p: &CachePoint| {
                    let np = Vec3::from(p.shading_normal);
                    let wo_local = match self.params.wo_frame {
                        WoFrame::Pixel => wo_pixel,
                        WoFrame::Point => map_frame(np).to_local(wo),
                        WoFrame::Reflect => map_frame(np).to_local(bsdf::reflect(r, np)),
                    };
                    self.glossy(s.material, s.base, wo_local, p.payload)
                };
                reading.blended().map(|(p, w)| radiance(p) * w).sum::<Vec3>()
            }
        }
    }

    /// The environment's direct light at a glossy `s` whose cache points keep it out of their
    /// maps (`env_direct`): ∫ f cos L_env V dω with the pixel's own BSDF (its texel, its normal),
    /// the map's radiance, and V from the blended points' visibility maps, by `n` samples, half
    /// of the BSDF and half of the map, combined by the balance heuristic. No rays: V is the
    /// cached part. Zero where the points' maps hold that light (the paper's maps).
    fn env_direct(&self, s: &ShadePoint, wo: Vec3, reading: &Reading, n: u32, rng: &mut Rng) -> Vec3 {
        let (Some(env), Some(sampler), Some(first)) = (self.frame.scene.environment.as_ref(), self.env_sampler.as_ref(), reading.point)
        else {
            return Vec3::ZERO;
        };
        let c = self.cache;
        let with_map = |p: &CachePoint| c.env_visibility_first.get(p.payload as usize).is_some_and(|&f| f != NO_VISIBILITY);
        if self.classes.get(s.material as usize) != Some(&Class::Glossy) || !with_map(first) {
            return Vec3::ZERO;
        }
        let Some(b) = self.bsdf(s, wo) else {
            return Vec3::ZERO;
        };
        // Each blended point's frame, visibility map, resolution and weight.
        let mut maps = [(glimpse_core::Frame::from_z(Vec3::Z), &[][..], 0u32, 0.0f32); MAX_BLEND];
        let mut count = 0;
        for (p, w) in reading.blended().filter(|(p, _)| with_map(p)) {
            // In range: `WaveCache::validate` checked every map's N² bytes (N ≥ 4).
            let first = c.env_visibility_first[p.payload as usize] as usize;
            let res = 1u32 << c.radiance_trees[p.payload as usize].levels;
            let texels = c.env_visibility.get(first..first + res as usize * res as usize).unwrap_or(&[]);
            maps[count] = (map_frame(Vec3::from(p.shading_normal)), texels, res, w);
            count += 1;
        }
        let visibility = |d: Vec3| -> f32 {
            maps[..count]
                .iter()
                .map(|(frame, texels, res, w)| {
                    let local = frame.to_local(d);
                    if local.z <= 0.0 || texels.is_empty() {
                        return 0.0;
                    }
                    let (x, y) = HalfCube::new(*res).texel_of(local);
                    texels[y as usize * *res as usize + x as usize] as f32 / 255.0 * w
                })
                .sum()
        };
        crate::env_direct::estimate(&b, s.normal, env, sampler, visibility, n, rng)
    }

    /// The BRDF at `s` seen from `wo`: the material's own model at `s`'s texel (its
    /// metallic-roughness texture read per texel), as `pt` shades it.
    fn bsdf(&self, s: &ShadePoint, wo: Vec3) -> Option<Bsdf> {
        let m = &self.frame.scene.materials[s.material as usize];
        let (metallic, roughness) = self.frame.scene.metallic_roughness(s.material, s.uv);
        Bsdf::for_material(self.params.brdf, m.model, s.base, metallic, roughness, s.shading_normal, s.normal, wo)
    }

    /// Whether `s` is shaded by tracing a sample of its own BRDF: its material is traced
    /// ([`Self::traced`]), or [`Self::off_mean`].
    pub fn texel_traced(&self, s: &ShadePoint) -> bool {
        self.traced.get(s.material as usize).copied().unwrap_or(false) || self.off_mean(s)
    }

    /// Whether `s`'s metallic-roughness texel is more than [`TEXEL_TRACE_TOLERANCE`] from its
    /// material's mean. The cache's BRDF tables hold one BRDF per material, the texture's mean:
    /// a polished metal tile beside rough stone ones would be drawn as their mean
    /// (`scenes/extra/metal-tiles`), so such texels take the traced lobe, whose hit reads the
    /// cache.
    pub fn off_mean(&self, s: &ShadePoint) -> bool {
        let Some(m) = self.frame.scene.materials.get(s.material as usize).filter(|m| m.metallic_roughness_map.is_some()) else {
            return false;
        };
        let (metallic, roughness) = self.frame.scene.metallic_roughness(s.material, s.uv);
        (metallic - m.metallic).abs() > TEXEL_TRACE_TOLERANCE || (roughness - m.roughness).abs() > TEXEL_TRACE_TOLERANCE
    }

    /// Eq. 15/16: punctual lights with shadow rays and the full BRDF. Returns (radiance, rays).
    pub fn punctual(&self, s: &ShadePoint, wo: Vec3) -> (Vec3, u64) {
        let Some(b) = self.bsdf(s, wo) else {
            return (Vec3::ZERO, 0);
        };
        let (mut l, mut rays) = (Vec3::ZERO, 0);
        for light in &self.frame.lights {
            let ps = punctual(light, s.position, s.normal, s.error_scale);
            let cos = b.cos(ps.wi);
            if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
                continue;
            }
            let f = b.eval(ps.wi);
            if f.max_element() <= 0.0 {
                continue;
            }
            rays += 1;
            if !self.vis.occluded(&ps.shadow, ps.t_max) {
                l += f * ps.irradiance * cos;
            }
        }
        (l, rays)
    }

    /// Everything reflected at `s` towards `wo` (no emission of `s`); (radiance, rays).
    pub fn shade(&self, s: &ShadePoint, wo: Vec3, depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        self.shade_from(s, wo, depth, rng, None)
    }

    /// [`Self::shade`] with `s`'s [`Self::point_for`] already known (the render loop looks it up
    /// once per pixel to choose the sample count).
    fn shade_from(&self, s: &ShadePoint, wo: Vec3, depth: u32, rng: &mut Rng, known: Option<&Reading<'a>>) -> (Vec3, u64) {
        let class = self.classes.get(s.material as usize).copied().unwrap_or(Class::Diffuse);
        let traced = self.texel_traced(s);
        if let Some(ior) = self.glass_ior(s.material) {
            return self.glass(s, wo, ior, depth, rng);
        }
        if class == Class::Mirror && !traced {
            return self.mirror(s, wo, depth, rng);
        }
        let (mut d, mut rays, mut d_cached) = (Vec3::ZERO, 0, false);
        let indirect = if traced && depth + 1 < self.params.mirror_depth {
            let (l, r) = self.traced_sample(s, wo, depth, rng);
            rays += r;
            l
        } else if class == Class::Mirror {
            // The end of a traced chain on a mirror: its mirror reflection's emission only.
            let (l, r) = self.mirror(s, wo, depth, rng);
            rays += r;
            l
        } else {
            // A cache point too far holds another place's light: trace, as a sharp lobe. At the
            // pixel only: a traced sample's hit reads the cache whatever its distance (a chain
            // of far hits would become a path tracer).
            let looked_up;
            let reading = match known {
                Some(r) => r,
                None => {
                    looked_up = self.point_for(s, wo);
                    &looked_up
                }
            };
            if reading.far && depth == 0 && depth + 1 < self.params.mirror_depth {
                let (mut l, r) = self.traced_sample(s, wo, depth, rng);
                rays += r;
                if let Some(ratio) = reading.disagree_ratio {
                    // The brightest point's light from the blend's: the cached value × ratio.
                    let bound = DISAGREE_BOUND * ratio * luminance(self.cached_from(s, wo, reading));
                    let lum = luminance(l);
                    if lum > bound {
                        l *= bound / lum;
                    }
                }
                l
            } else {
                // Many punctual lights: a diffuse surface's irradiance holds their light too.
                d_cached = class == Class::Diffuse && self.punctual_cached;
                let n = if depth == 0 { self.pixel_env_samples } else { self.params.env_direct_samples };
                self.cached_from(s, wo, reading) + self.env_direct(s, wo, reading, n, rng)
            }
        };
        if !d_cached {
            let (l, r) = self.punctual(s, wo);
            d = l;
            rays += r;
        }
        let base = d + indirect;
        let gamma = self.frame.scene.materials[s.material as usize].clearcoat;
        if gamma <= 0.0 || self.params.brdf != BrdfModel::Pbr {
            return (base, rays);
        }
        // Eq. 21 and the clear-coat ray (Eqs. 11–12): the base (cache and punctual lights) seen
        // through the coat, (1 − F_c), plus F_c times the radiance along the mirror direction,
        // traced (h = n for the smooth coat, as `pt`'s `ClearCoat`).
        let ns = s.facing_normal(wo);
        let fc = clear_coat_fresnel(ns.dot(wo).clamp(0.0, 1.0), gamma);
        let (coat, coat_rays) = self.specular_ray(s, wo, ns, depth, self.params.coat_depth, rng);
        (base * (1.0 - fc) + coat * fc, rays + coat_rays)
    }

    /// Radiance arriving at `s` along the mirror direction of `wo` about `ns`: the environment on
    /// a miss, else the hit's emission plus its own shading while the chain is shorter than
    /// `max_depth` (emission only at the last link). (radiance, rays).
    fn specular_ray(&self, s: &ShadePoint, wo: Vec3, ns: Vec3, depth: u32, max_depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        let dir = bsdf::reflect(wo, ns).normalize();
        if dir.dot(s.normal) <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        self.radiance_along(s, dir, depth, max_depth, rng)
    }

    /// Radiance arriving at `s` from unit direction `dir` (either side of the surface): the
    /// environment on a miss, else the hit's emission plus its own shading while the chain is
    /// shorter than `max_depth`. (radiance, rays).
    fn radiance_along(&self, s: &ShadePoint, dir: Vec3, depth: u32, max_depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        let ray = Ray::spawn(s.position, s.normal, s.error_scale, dir);
        let Some(hit) = self.vis.closest_hit(&ray, f32::INFINITY) else {
            return (direct::background(self.frame, dir), 1);
        };
        let sp = SurfacePoint::from_hit(self.frame, &ray, &hit);
        let le = sp.emission(self.frame);
        if depth + 1 >= max_depth {
            return (le, 1);
        }
        let (l, rays) = self.shade(&ShadePoint::at_hit(self.frame, &sp), -dir, depth + 1, rng);
        (le + l, rays + 1)
    }

    /// A sharp glossy lobe's reflected radiance (everything but punctual lights), estimated as
    /// `pt` estimates one bounce: light sampling of the area lights and of the environment, and
    /// one BSDF sample whose hit adds its emission, each weighted by the power heuristic against
    /// the other strategy, plus the hit's own shading from the cache (up to `mirror_depth`).
    /// Without the light sampling a small bright emitter or a map's softbox found by the BSDF
    /// sample alone made fireflies hundreds of times the pixel (`textured-glossy`'s floor).
    fn traced_sample(&self, s: &ShadePoint, wo: Vec3, depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        let frame = self.frame;
        let Some(b) = self.bsdf(s, wo) else {
            return (Vec3::ZERO, 0);
        };
        let env = frame.scene.environment.as_ref();
        let (mut l, mut rays) = (Vec3::ZERO, 0u64);
        // Area lights (MIS).
        let (u_pick, u_area) = (rng.next_f32(), rng.next_2d());
        if let Some(ls) = direct::sample_area_light(frame, s.position, s.normal, s.error_scale, u_pick, u_area) {
            let (cos, f) = (b.cos(ls.wi), b.eval(ls.wi));
            if cos > 0.0 && f.max_element() > 0.0 {
                rays += 1;
                if !self.vis.occluded(&ls.shadow, ls.t_max) {
                    l += f * ls.radiance * (cos * direct::power_heuristic(ls.pdf, b.pdf(ls.wi)) / ls.pdf);
                }
            }
        }
        // The environment (MIS).
        let u_env = rng.next_2d();
        if let Some(env) = env {
            let es = env.sample_direction(u_env);
            let (d, pdf) = (es.dir, es.pdf);
            let (cos, f) = (b.cos(d), b.eval(d));
            if pdf > 0.0 && cos > 0.0 && f.max_element() > 0.0 {
                rays += 1;
                if !self.vis.occluded(&Ray::spawn(s.position, s.normal, s.error_scale, d), f32::INFINITY) {
                    l += f * env.sample_radiance(&es) * (cos * direct::power_heuristic(pdf, b.pdf(d)) / pdf);
                }
            }
        }
        // One BSDF sample: the emission it finds (MIS) and the hit's reflected light.
        let Some(bs) = b.sample(rng.next_f32(), rng.next_2d()) else {
            return (l, rays);
        };
        if bs.wi.dot(s.normal) <= 0.0 {
            return (l, rays);
        }
        let weight = bs.f * (bs.cos / bs.pdf);
        let ray = Ray::spawn(s.position, s.normal, s.error_scale, bs.wi);
        rays += 1;
        let Some(hit) = self.vis.closest_hit(&ray, f32::INFINITY) else {
            if let Some(env) = env {
                let (le, env_pdf) = env.radiance_and_pdf(bs.wi);
                l += weight * le * direct::power_heuristic(bs.pdf, env_pdf);
            }
            return (l, rays);
        };
        let sp = SurfacePoint::from_hit(frame, &ray, &hit);
        let le = sp.emission(frame);
        if le.max_element() > 0.0 {
            let cos_light = sp.normal.dot(-bs.wi).abs();
            let light_pdf = self.emitters.pdf(frame, hit.instance, hit.triangle, hit.t, cos_light);
            l += weight * le * direct::power_heuristic(bs.pdf, light_pdf);
        }
        if depth + 1 < self.params.mirror_depth {
            let next = ShadePoint::at_hit(frame, &sp);
            let (reflected, r) = self.shade(&next, -bs.wi, depth + 1, rng);
            l += weight * reflected;
            rays += r;
        }
        (l, rays)
    }

    /// Eq. 18: the perfect-mirror chain.
    fn mirror(&self, s: &ShadePoint, wo: Vec3, depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        let m = &self.frame.scene.materials[s.material as usize];
        let ns = s.facing_normal(wo);
        let cos = ns.dot(wo);
        if cos <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        let f = match m.model {
            // A conductor's reflectance: base × its exact Fresnel term, as `pt`'s lobe has it.
            glimpse_scene::MaterialModel::Conductor { eta, k } => s.base * bsdf::fresnel_conductor(cos, eta, k),
            _ => bsdf::schlick(Vec3::splat(0.04).lerp(s.base, self.frame.scene.metallic_roughness(s.material, s.uv).0), cos),
        };
        let (l, rays) = self.specular_ray(s, wo, ns, depth, self.params.mirror_depth, rng);
        (f * l, rays)
    }

    /// The index of refraction of smooth glass (`MaterialModel::Dielectric`) under the PBR
    /// integrator, `None` for any other material (the Lambert integrator shades glass as
    /// diffuse, as `pt` does).
    fn glass_ior(&self, material: u32) -> Option<f32> {
        match self.frame.scene.materials.get(material as usize).map(|m| m.model) {
            Some(glimpse_scene::MaterialModel::Dielectric { ior }) if self.params.brdf == BrdfModel::Pbr => Some(ior),
            _ => None,
        }
    }

    /// Smooth glass (not in the paper, whose materials are glTF's; traced as its mirrors are):
    /// one of its two delta lobes per sample, reflection with probability F and refraction
    /// otherwise, exactly as `pt` picks them (weights base and base/η²), followed up to
    /// `mirror_depth` links; the surface the chain reaches is shaded from the cache.
    fn glass(&self, s: &ShadePoint, wo: Vec3, ior: f32, depth: u32, rng: &mut Rng) -> (Vec3, u64) {
        if s.normal.dot(wo) <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        let (dir, weight) = bsdf::sample_smooth_glass(wo, s.normal, s.front_face, ior, s.base, rng.next_f32());
        let (l, rays) = self.radiance_along(s, dir, depth, self.params.mirror_depth, rng);
        (weight * l, rays)
    }
}

impl Technique for Wavecache {
    fn id(&self) -> &'static str {
        "wavecache"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        self.ensure_cache(ctx, &mut stats)?;
        if self.source != "memory" {
            self.env_sampler = self.cache.as_ref().and_then(|c| env_sampler_for(c, &ctx.frame));
        }
        stats.memory_bytes = self.cache.as_ref().map_or(0, |c| c.memory_bytes());
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        // `prepare` checked the cache against this frame's key (hashing the scene again here would
        // cost more than a cheap frame).
        let cache = self
            .cache
            .as_ref()
            .ok_or_else(|| RenderError::Unsupported { technique: "wavecache".into(), message: "render called before prepare".into() })?;
        if cache.meshes.len() != ctx.frame.scene.instances.len() || cache.brdf_tables.len() != ctx.frame.scene.materials.len() {
            return Err(RenderError::Unsupported {
                technique: "wavecache".into(),
                message: "the cache was prepared for another scene".into(),
            });
        }
        let mut stats = Stats { memory_bytes: cache.memory_bytes(), ..Default::default() };
        let mut rt = Runtime::with_env_sampler(cache, &self.params, &ctx.frame, &ctx.tracer, self.env_sampler.clone());
        rt.pixel_env_samples = pixel_env_samples(&self.params, self.settings.spp);
        let far_pixels = AtomicU64::new(0);
        stats.rays = stats.time("shade", || {
            let spp = self.settings.spp.max(1);
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng: &mut Rng| {
                let mut p = ShadePoint::at_pixel(gbuffer, i);
                let glass = rt.glass_ior(p.material).is_some();
                if glass {
                    // The GBuffer does not keep the side glass refracts from: trace the primary
                    // ray again, as `pt` does.
                    let primary = Ray::new(gbuffer.camera.position, gbuffer.view_dir[i]);
                    if let Some(hit) = ctx.tracer.closest_hit(&primary, f32::INFINITY) {
                        p = ShadePoint::at_hit(&ctx.frame, &SurfacePoint::from_hit(&ctx.frame, &primary, &hit));
                    }
                }
                // The cache is read deterministically; only a traced lobe (sharp, or beyond the
                // cache: `trace_far`, or glass) draws random numbers, so only it takes the
                // pixel's `spp` samples; a pixel traced for its cache points at least
                // `far_samples`, and a texel far from its material's mean BRDF at least
                // `TEXEL_TRACE_SAMPLES`.
                let off_mean = !glass && rt.off_mean(&p);
                let sharp = glass || off_mean || rt.traced.get(p.material as usize).copied().unwrap_or(false);
                let known = if sharp { None } else { Some(rt.point_for(&p, -gbuffer.view_dir[i])) };
                let far = known.as_ref().is_some_and(|k| k.far);
                if far {
                    far_pixels.fetch_add(1, Ordering::Relaxed);
                }
                let samples = match (sharp || far, off_mean) {
                    (true, true) => spp.max(TEXEL_TRACE_SAMPLES),
                    (true, false) if far => spp.max(self.params.far_samples),
                    (true, false) => spp,
                    (false, _) => 1,
                };
                let (mut sum, mut rays) = (Vec3::ZERO, 0);
                for _ in 0..samples {
                    let (l, r) = rt.shade_from(&p, -gbuffer.view_dir[i], 0, rng, known.as_ref());
                    (sum, rays) = (sum + l, rays + r);
                }
                (sum / samples as f32, rays)
            })
        })?;
        // The pixels traced because their cache point was too far (`trace_far`), of the image.
        let share = far_pixels.into_inner() as f64 / gbuffer.len().max(1) as f64;
        stats.metrics.push(("far_traced_pct".to_owned(), 100.0 * share));
        Ok(stats)
    }
}

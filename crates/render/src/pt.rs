//! `pt`: a unidirectional path tracer, the ground truth for full global illumination.
//!
//! The primary hit is the GBuffer's (one pixel-filter sample per pixel: every technique shades
//! the same GBuffer; several film samples are several passes). From there each of the `spp` paths bounces with the [`crate::bsdf`] BRDF
//! (glTF metallic-roughness: Lambert + GGX, VNDF sampling; `brdf=lambert` treats every material
//! as Lambertian with its base colour, to compare with the Lambertian references):
//! - area lights and the environment by next-event estimation *and* BRDF sampling, combined
//!   with the power heuristic (one light sample of each kind per vertex);
//! - punctual lights by next-event estimation only (they cannot be hit): every light at every
//!   vertex when the scene has at most [`ALL_PUNCTUAL`] of them, else one chosen uniformly;
//! - `max_depth` (default 8) counts scattering vertices: 1 = direct light only, 2 = direct plus
//!   one diffuse/glossy bounce (what `gi-exact` computes), light found by the BRDF sample of the
//!   last vertex included;
//! - a clear coat (`Material::clearcoat` = γ > 0, [`ClearCoat`]): a smooth dielectric layer with
//!   F_c = γ·Schlick(0.04, n·ωo) over the BRDF, which is weighted by 1 − F_c; its mirror lobe is a
//!   delta, sampled with probability F_c and given full weight when it finds a light;
//! - material models ([`MaterialModel`]): `pbr` as above, `diffuse` the Lambert lobe, `conductor`
//!   the GGX lobe alone with the exact conductor Fresnel term, `dielectric` smooth glass (delta
//!   reflection with probability F, else refraction with weight 1/η²; no light sampling there,
//!   light found through it counts in full);
//! - Russian roulette from the fourth vertex on, continuing with probability
//!   min(1, max(throughput)) and dividing by it; `max_depth=-1` is unbounded, paths ending by
//!   roulette alone (continuation probability at most 0.95 there, so every path ends).
//!
//! Nothing is clamped (the estimator is unbiased); a path whose contribution is NaN or infinite is
//! dropped and counted ([`PathTracer::nonfinite_paths`]) so tests can assert there are none.

use crate::bsdf::{self, BrdfModel, Bsdf};
use crate::direct::{self, EmitterIndex};
use crate::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_core::{Image, Ray, Rng, Vec3, is_finite3};
use glimpse_scene::{BumpShadowing, MaterialModel, NormalMapShadowing, Scene, SceneFrame};
use glimpse_trace::{ExactTracer, GBuffer, SurfacePoint};
use std::sync::atomic::{AtomicU64, Ordering};

/// With at most this many punctual lights, every one is sampled at every vertex.
pub const ALL_PUNCTUAL: usize = 8;
/// Russian roulette starts after this many vertices.
pub const RR_DEPTH: u32 = 3;
/// `max_depth = -1`: paths end only by Russian roulette.
pub const UNBOUNDED: u32 = u32::MAX;
/// The largest continuation probability of an unbounded path.
pub const UNBOUNDED_RR_MAX: f32 = 0.95;

pub struct PathTracer {
    pub max_depth: u32,
    pub brdf: BrdfModel,
    pub settings: Settings,
    emitters: EmitterIndex,
    nonfinite: u64,
}

/// The surface a path is at: its position, normals and material (base colour already textured).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathVertex {
    pub position: Vec3,
    /// The ray offset's scale ([`SurfacePoint::error_scale`]).
    pub error_scale: f32,
    pub normal: Vec3,
    pub shading_normal: Vec3,
    pub base: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    /// Clear-coat strength γ (0: none).
    pub clearcoat: f32,
    pub model: MaterialModel,
    /// The ray arrived on the triangle's front (winding) side: a dielectric is entered there.
    pub front_face: bool,
    /// [`SurfacePoint::bump_shadowing`].
    pub bump_shadowing: Option<BumpShadowing>,
}

impl PathVertex {
    pub fn of(frame: &SceneFrame, sp: &SurfacePoint) -> Self {
        let m = &frame.scene.materials[sp.material as usize];
        let (metallic, roughness) = frame.scene.metallic_roughness(sp.material, sp.uv);
        Self {
            position: sp.position,
            error_scale: sp.error_scale,
            normal: sp.normal,
            shading_normal: sp.shading_normal,
            base: sp.base_color(frame),
            metallic,
            roughness,
            clearcoat: m.clearcoat,
            model: m.model,
            front_face: sp.front_face,
            bump_shadowing: sp.bump_shadowing,
        }
    }
}

/// A vertex's clear coat (Filament's, as the wavelet-cache paper uses it, Eqs. 11–12): a smooth
/// dielectric layer over the base with F_c = γ · Schlick(0.04, n·ωo) (h = n for a smooth coat).
/// The base is seen through it with weight 1 − F_c; the coat reflects F_c into the mirror
/// direction, a delta lobe that only BRDF sampling finds (chosen with probability F_c).
/// Uncoated (γ = 0, or the Lambert model): F_c = 0, and every factor below is exactly 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClearCoat {
    pub fresnel: f32,
    /// 1 − F_c.
    pub through: f32,
    /// The coat's normal (the shading normal when ωo is above it, as the BRDF's).
    pub normal: Vec3,
}

impl ClearCoat {
    pub fn at(v: &PathVertex, model: BrdfModel, wo: Vec3) -> ClearCoat {
        let normal = if v.shading_normal.dot(wo) > 0.0 { v.shading_normal } else { v.normal };
        let fresnel = if model == BrdfModel::Pbr && v.clearcoat > 0.0 {
            v.clearcoat * crate::bsdf::schlick(Vec3::splat(0.04), normal.dot(wo).clamp(0.0, 1.0)).x
        } else {
            0.0
        };
        ClearCoat { fresnel, through: 1.0 - fresnel, normal }
    }

    /// Probability of sampling the base BRDF rather than the coat.
    pub fn base_probability(&self) -> f32 {
        1.0 - self.fresnel
    }

    /// The coat's mirror direction of `wo`.
    pub fn mirror(&self, wo: Vec3) -> Vec3 {
        (2.0 * self.normal.dot(wo) * self.normal - wo).normalize()
    }
}

/// How a path's first vertex is treated (the wavelet cache starts paths mid-way and traces the
/// punctual lights of its first vertex itself).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathStart {
    /// Depth of the first vertex (1 at a camera hit).
    pub depth: u32,
    /// BRDF model of the first vertex, if not the integrator's.
    pub model: Option<BrdfModel>,
    /// Sample the punctual lights at the first vertex.
    pub punctual: bool,
}

impl PathStart {
    /// A camera path: depth 1, the integrator's BRDF, every light.
    pub const CAMERA: PathStart = PathStart { depth: 1, model: None, punctual: true };
}

/// `pt`'s estimator from any vertex: what `pt` runs per pixel sample, and what the wavelet
/// cache's precomputation runs from its cache points, so both estimate the same integral.
pub struct PathIntegrator<'a> {
    pub frame: &'a SceneFrame<'a>,
    pub tracer: &'a ExactTracer,
    pub emitters: &'a EmitterIndex,
    pub max_depth: u32,
    pub model: BrdfModel,
}

impl PathIntegrator<'_> {
    /// Russian roulette after vertex `depth`: false ends the path. It continues with
    /// probability q = min(1, max(β)) and divides β by q; when the depth is unbounded, q is at
    /// most [`UNBOUNDED_RR_MAX`] so that a closed, perfectly white scene still terminates.
    fn roulette(&self, depth: u32, beta: &mut Vec3, rng: &mut Rng) -> bool {
        if depth < RR_DEPTH {
            return true;
        }
        let cap = if self.max_depth == UNBOUNDED { UNBOUNDED_RR_MAX } else { 1.0 };
        let q = beta.max_element().min(cap);
        if rng.next_f32() >= q {
            return false;
        }
        *beta /= q;
        true
    }

    /// Radiance leaving `v` towards `wo` (without `v`'s own emission) and the rays traced.
    pub fn path(&self, mut v: PathVertex, mut wo: Vec3, start: PathStart, rng: &mut Rng) -> (Vec3, u64) {
        let frame = self.frame;
        let env = frame.scene.environment.as_ref();
        let lights = &frame.lights;
        let (mut beta, mut l, mut rays) = (Vec3::ONE, Vec3::ZERO, 0u64);
        for depth in start.depth..=self.max_depth {
            let model = if depth == start.depth { start.model.unwrap_or(self.model) } else { self.model };
            if let (BrdfModel::Pbr, MaterialModel::Dielectric { ior }) = (model, v.model) {
                // Smooth glass: only its delta lobes, no light sampling.
                let (wi, weight) = bsdf::sample_smooth_glass(wo, v.normal, v.front_face, ior, v.base, rng.next_f32());
                beta *= weight;
                let ray = Ray::spawn(v.position, v.normal, v.error_scale, wi);
                rays += 1;
                let Some(hit) = self.tracer.closest_hit(&ray, f32::INFINITY) else {
                    if let Some(env) = env {
                        l += beta * env.radiance(wi);
                    }
                    break;
                };
                let sp = SurfacePoint::from_hit(frame, &ray, &hit);
                l += beta * sp.emission(frame);
                if depth == self.max_depth || !self.roulette(depth, &mut beta, rng) {
                    break;
                }
                wo = -wi;
                v = PathVertex::of(frame, &sp);
                continue;
            }
            let Some(bsdf) = Bsdf::for_material(model, v.model, v.base, v.metallic, v.roughness, v.shading_normal, v.normal, wo)
                .map(|b| b.with_bump_shadowing(v.bump_shadowing))
            else {
                break;
            };
            let coat = ClearCoat::at(&v, model, wo);
            // Next-event estimation: area lights (MIS).
            let (u_pick, u_area) = (rng.next_f32(), rng.next_2d());
            if let Some(ls) = direct::sample_area_light(frame, v.position, v.normal, v.error_scale, u_pick, u_area) {
                let cos = bsdf.cos(ls.wi);
                let f = bsdf.eval(ls.wi) * coat.through;
                if cos > 0.0 && f.max_element() > 0.0 {
                    rays += 1;
                    if !self.tracer.occluded(&ls.shadow, ls.t_max) {
                        let w = direct::power_heuristic(ls.pdf, coat.base_probability() * bsdf.pdf(ls.wi));
                        l += beta * f * ls.radiance * (cos * w / ls.pdf);
                    }
                }
            }
            // The environment (MIS).
            let u_env = rng.next_2d();
            if let Some(env) = env {
                let s = env.sample_direction(u_env);
                let (d, pdf) = (s.dir, s.pdf);
                let cos = bsdf.cos(d);
                if pdf > 0.0 && cos > 0.0 {
                    let f = bsdf.eval(d) * coat.through;
                    if f.max_element() > 0.0 {
                        rays += 1;
                        if !self.tracer.occluded(&Ray::spawn(v.position, v.normal, v.error_scale, d), f32::INFINITY) {
                            let w = direct::power_heuristic(pdf, coat.base_probability() * bsdf.pdf(d));
                            l += beta * f * env.sample_radiance(&s) * (cos * w / pdf);
                        }
                    }
                }
            }
            // Punctual lights (NEE only).
            let u_light = rng.next_f32();
            if depth != start.depth || start.punctual {
                let (chosen, scale) = if lights.len() <= ALL_PUNCTUAL {
                    (&lights[..], 1.0)
                } else {
                    let k = ((u_light * lights.len() as f32) as usize).min(lights.len() - 1);
                    (&lights[k..k + 1], lights.len() as f32)
                };
                for light in chosen {
                    let ps = direct::punctual(light, v.position, v.normal, v.error_scale);
                    let cos = bsdf.cos(ps.wi);
                    if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
                        continue;
                    }
                    let f = bsdf.eval(ps.wi) * coat.through;
                    if f.max_element() <= 0.0 {
                        continue;
                    }
                    rays += 1;
                    if !self.tracer.occluded(&ps.shadow, ps.t_max) {
                        l += beta * f * ps.irradiance * (cos * scale);
                    }
                }
            }
            // Continue the path: the coat's mirror lobe with probability F_c (only drawn on a
            // coated vertex, so uncoated scenes keep their random streams), else the BRDF.
            // `mis_pdf` is None for the delta lobe: light it finds gets full weight.
            let on_coat = coat.fresnel > 0.0 && rng.next_f32() < coat.fresnel;
            let (u_lobe, u_dir) = (rng.next_f32(), rng.next_2d());
            let (wi, mis_pdf) = if on_coat {
                // F_c / P(coat) = 1: the throughput is unchanged.
                let wi = coat.mirror(wo);
                if v.normal.dot(wi) <= 0.0 {
                    break;
                }
                (wi, None)
            } else {
                let Some(s) = bsdf.sample(u_lobe, u_dir) else {
                    break;
                };
                beta *= s.f * (s.cos / s.pdf) * (coat.through / coat.base_probability());
                (s.wi, Some(coat.base_probability() * s.pdf))
            };
            let ray = Ray::spawn(v.position, v.normal, v.error_scale, wi);
            rays += 1;
            let Some(hit) = self.tracer.closest_hit(&ray, f32::INFINITY) else {
                if let Some(env) = env {
                    let (le, env_pdf) = env.radiance_and_pdf(wi);
                    let w = mis_pdf.map_or(1.0, |p| direct::power_heuristic(p, env_pdf));
                    l += beta * le * w;
                }
                break;
            };
            let sp = SurfacePoint::from_hit(frame, &ray, &hit);
            let le = sp.emission(frame);
            if le.max_element() > 0.0 {
                let cos_light = sp.normal.dot(-wi).abs();
                let w = mis_pdf
                    .map_or(1.0, |p| direct::power_heuristic(p, self.emitters.pdf(frame, hit.instance, hit.triangle, hit.t, cos_light)));
                l += beta * le * w;
            }
            if depth == self.max_depth || !self.roulette(depth, &mut beta, rng) {
                break;
            }
            wo = -wi;
            v = PathVertex::of(frame, &sp);
        }
        (l, rays)
    }
}

impl PathTracer {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "pt",
            family: "global illumination",
            reference: None,
            description: "unidirectional path tracer (NEE + MIS, GGX metallic-roughness, max_depth=8, brdf=pbr|lambert)",
            create: |scene: &Scene, settings, params| {
                crate::require(scene, "pt", crate::Need::AnyLight)?;
                Ok(Box::new(PathTracer::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        direct::require_spp(settings)?;
        let max_depth = match params.i64("max_depth", 8, -1, 1024)? {
            -1 => UNBOUNDED,
            0 => {
                let message = "renders nothing: give 1..1024, or -1 for unbounded".into();
                return Err(crate::ParamError::Invalid { key: "max_depth".into(), value: "0".into(), message }.into());
            }
            d => d as u32,
        };
        let brdf = match params.choice("brdf", "pbr", &["pbr", "lambert"])?.as_str() {
            "lambert" => BrdfModel::Lambert,
            _ => BrdfModel::Pbr,
        };
        Ok(Self { max_depth, brdf, settings: *settings, emitters: EmitterIndex::default(), nonfinite: 0 })
    }

    /// Paths of the last `render` whose contribution was NaN or infinite (dropped).
    pub fn nonfinite_paths(&self) -> u64 {
        self.nonfinite
    }

    /// One path's radiance through pixel `i` (excluding the primary hit's emission) and the
    /// rays it traced.
    fn path(&self, ctx: &FrameContext, g: &GBuffer, i: usize, rng: &mut Rng) -> (Vec3, u64) {
        let m = &ctx.frame.scene.materials[g.material[i] as usize];
        let glass = matches!(m.model, MaterialModel::Dielectric { .. });
        let shadowed = m.normal_map.is_some_and(|n| n.shadowing == NormalMapShadowing::Microfacet);
        // The GBuffer does not keep the hit's side, which glass needs, nor the normal before its
        // normal map bent it, which a shadowed bend needs: trace the primary ray again.
        let primary = Ray::new(g.camera.position, g.view_dir[i]);
        let hit = if glass || shadowed { ctx.tracer.closest_hit(&primary, f32::INFINITY) } else { None };
        let v = if let Some(hit) = hit {
            PathVertex::of(&ctx.frame, &SurfacePoint::from_hit(&ctx.frame, &primary, &hit))
        } else {
            let (metallic, roughness) = ctx.frame.scene.metallic_roughness(g.material[i], g.uv[i]);
            PathVertex {
                position: g.position[i],
                error_scale: g.error_scale[i],
                normal: g.normal[i],
                shading_normal: g.shading_normal[i],
                base: g.albedo[i],
                metallic,
                roughness,
                clearcoat: m.clearcoat,
                model: m.model,
                front_face: true,
                bump_shadowing: None,
            }
        };
        let integrator = PathIntegrator {
            frame: &ctx.frame,
            tracer: &ctx.tracer,
            emitters: &self.emitters,
            max_depth: self.max_depth,
            model: self.brdf,
        };
        integrator.path(v, -g.view_dir[i], PathStart::CAMERA, rng)
    }
}

impl Technique for PathTracer {
    fn id(&self) -> &'static str {
        "pt"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        self.emitters = stats.time("emitter index", || EmitterIndex::new(&ctx.frame));
        stats.memory_bytes = self.emitters.memory_bytes();
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        if self.emitters.len() != ctx.frame.emissive.len() {
            // Not prepared for this frame: MIS needs the index of exactly these emitters.
            self.emitters = EmitterIndex::new(&ctx.frame);
        }
        let mut stats = Stats { memory_bytes: ctx.tracer.memory_bytes() + self.emitters.memory_bytes(), ..Default::default() };
        let nonfinite = AtomicU64::new(0);
        let spp = self.settings.spp;
        let this = &*self;
        stats.rays = stats.time("trace", || {
            direct::shade_pixels(ctx, gbuffer, this.settings.seed, out, |i, rng| {
                let (mut sum, mut rays) = (Vec3::ZERO, 0);
                for _ in 0..spp {
                    let (l, r) = this.path(ctx, gbuffer, i, rng);
                    rays += r;
                    if is_finite3(l) {
                        sum += l;
                    } else {
                        nonfinite.fetch_add(1, Ordering::Relaxed);
                    }
                }
                (sum / spp as f32, rays)
            })
        })?;
        self.nonfinite = nonfinite.into_inner();
        Ok(stats)
    }
}

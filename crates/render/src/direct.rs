//! Direct lighting with exact shadow rays, shared by every reference: the pixel loop and its
//! conventions, light sampling (area lights by power, punctual lights, the environment map by
//! importance), the emitter lookup for MIS, and the power heuristic.
//!
//! Conventions (the same for every reference, so they differ only in what they estimate):
//! - a pixel that sees no geometry shows the environment's radiance along its primary ray, or
//!   black without an environment;
//! - a pixel on an emitter adds its emission towards the camera (`gbuffer.emission`);
//! - each pixel draws its random numbers from `Rng::for_pixel(seed, pixel, frame_index)`;
//! - secondary rays leave the surface through [`Ray::spawn`] off the *geometric* normal, and a
//!   direction below the geometric surface carries no light (it would enter the object), while
//!   cosines are taken with the shading normal;
//! - area lights emit from their front face only (the winding's normal, as
//!   [`glimpse_trace::SurfacePoint::emission`]).

use crate::{FrameContext, ParamError, RenderError, Settings};
use glimpse_core::ray::offset_origin;
use glimpse_core::{Image, Ray, Rng, Vec2, Vec3};
use glimpse_scene::{Environment, SceneFrame, WorldLight};
use glimpse_trace::tracer::PACKET;
use glimpse_trace::{GBuffer, SurfacePoint, Visibility};
use rayon::prelude::*;
use std::collections::HashMap;

/// A surface point as the Lambertian references shade it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    pub position: Vec3,
    /// The magnitude `position`'s rounding error is relative to (the ray offset's scale,
    /// [`glimpse_core::ray::error_scale`]).
    pub error_scale: f32,
    /// Unit geometric normal, facing the viewer.
    pub normal: Vec3,
    /// Unit shading normal, in `normal`'s hemisphere.
    pub shading_normal: Vec3,
    /// Diffuse albedo ρ (the BRDF is ρ/π).
    pub albedo: Vec3,
}

impl Shading {
    /// The GBuffer's surface at pixel `i`, if it sees geometry.
    pub fn from_gbuffer(g: &GBuffer, i: usize) -> Option<Self> {
        g.is_hit(i).then(|| Self {
            position: g.position[i],
            error_scale: g.error_scale[i],
            normal: g.normal[i],
            shading_normal: g.shading_normal[i],
            albedo: g.albedo[i],
        })
    }

    /// A secondary hit.
    pub fn from_surface(frame: &SceneFrame, sp: &SurfacePoint) -> Self {
        Self {
            position: sp.position,
            error_scale: sp.error_scale,
            normal: sp.normal,
            shading_normal: sp.shading_normal,
            albedo: sp.base_color(frame),
        }
    }

    /// The cosine weighting light from `wi` (unit): with the shading normal, and zero where
    /// `wi` lies below the geometric surface.
    pub fn cos(&self, wi: Vec3) -> f32 {
        if self.normal.dot(wi) <= 0.0 { 0.0 } else { self.shading_normal.dot(wi).max(0.0) }
    }

    /// A ray leaving the surface along `dir`.
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray::spawn(self.position, self.normal, self.error_scale, dir)
    }
}

/// What a pixel that sees no geometry shows: the environment along `dir`, or black.
pub fn background(frame: &SceneFrame, dir: Vec3) -> Vec3 {
    frame.scene.environment.as_ref().map_or(Vec3::ZERO, |e| e.radiance(dir))
}

/// Rejects `spp = 0` (every estimator divides by it).
pub fn require_spp(settings: &Settings) -> Result<u32, RenderError> {
    if settings.spp == 0 {
        return Err(ParamError::Invalid { key: "spp".into(), value: "0".into(), message: "must be at least 1".into() }.into());
    }
    Ok(settings.spp)
}

/// The pixel loop every reference uses: in parallel over pixels, background for misses,
/// `shade(pixel, rng)` (returning reflected radiance and rays traced) plus the emission for
/// hits, one progress tick per pixel. Returns the rays traced.
pub fn shade_pixels<F>(ctx: &FrameContext, gbuffer: &GBuffer, seed: u64, out: &mut Image, shade: F) -> Result<u64, RenderError>
where
    F: Fn(usize, &mut Rng) -> (Vec3, u64) + Sync,
{
    if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
        return Err(RenderError::Unsupported {
            technique: "render".into(),
            message: format!("image is {}x{} but the GBuffer is {}x{}", out.width, out.height, gbuffer.width, gbuffer.height),
        });
    }
    let rays = out
        .pixels
        .par_iter_mut()
        .enumerate()
        .map(|(i, px)| {
            let rays = if gbuffer.is_hit(i) {
                let mut rng = Rng::for_pixel(seed, i as u64, ctx.frame_index as u64);
                let (l, rays) = shade(i, &mut rng);
                *px = gbuffer.emission[i] + l;
                rays
            } else {
                *px = background(&ctx.frame, gbuffer.view_dir[i]);
                0
            };
            ctx.progress.add(1);
            rays
        })
        .sum();
    Ok(rays)
}

/// Visibility with nothing in the way (the unshadowed variants).
pub struct Unoccluded;

impl Visibility for Unoccluded {
    fn occluded(&self, _ray: &Ray, _t_max: f32) -> bool {
        false
    }
}

/// One sampled point on an area light, seen from a receiver.
#[derive(Clone, Copy, Debug)]
pub struct AreaSample {
    /// Unit direction from the receiver to the light point.
    pub wi: Vec3,
    /// Emitted radiance towards the receiver.
    pub radiance: Vec3,
    /// Solid-angle density of choosing `wi` (triangle by power, then uniform by area).
    pub pdf: f32,
    /// The shadow segment: from the receiver (offset) to the light point (offset off the
    /// emitter towards the receiver, so the emitter itself never blocks its own light).
    pub shadow: Ray,
    pub t_max: f32,
}

/// Samples the area lights from the receiver `p` (geometric normal `n`, error scale `e`): an emissive triangle
/// with probability ∝ power (`frame.emissive_distribution`), a uniform point on it, the area
/// density turned into solid angle (pdf = P(tri) · d² / (area · cos θ_light)). `None` when the
/// scene has no area light, the point is behind its one-sided emitter, or it falls in the
/// emitter's alpha-mask cut-out (zero contribution: the emitter is not there, and the density
/// over the whole triangle stays unbiased). The radiance is the point's own (an emissive
/// texture's texel: `SceneFrame::emitted_at`); the triangle is picked by its mean.
pub fn sample_area_light(frame: &SceneFrame, p: Vec3, n: Vec3, e: f32, u_pick: f32, u: Vec2) -> Option<AreaSample> {
    let dist = frame.emissive_distribution.as_ref()?;
    let (idx, p_tri) = dist.sample_discrete(u_pick);
    let tri = &frame.emissive[idx];
    let (x, x_scale) = tri.sample(u);
    let to = x - p;
    let d2 = to.length_squared();
    if d2 <= 0.0 || p_tri <= 0.0 {
        return None;
    }
    let b = glimpse_core::sampling::uniform_triangle(u);
    let radiance = frame.emitted_at(tri, b.x, b.y)?;
    let wi = to / d2.sqrt();
    let cos_light = -tri.normal.dot(wi);
    if cos_light <= 0.0 {
        return None;
    }
    let (shadow, t_max) = segment(p, n, e, offset_origin(x, tri.normal, x_scale));
    Some(AreaSample { wi, radiance, pdf: p_tri * d2 / (tri.area * cos_light), shadow, t_max })
}

/// The shadow ray from the surface point `p` (normal `n`, error scale `e`) to the point `end`.
pub fn segment(p: Vec3, n: Vec3, e: f32, end: Vec3) -> (Ray, f32) {
    let origin = Ray::spawn(p, n, e, end - p).origin;
    let to = end - origin;
    let len = to.length();
    (Ray::new(origin, to / len.max(f32::MIN_POSITIVE)), len)
}

/// Finds the emissive-triangle index of a hit, for the light-sampling density of a direction
/// that a BSDF sample found (MIS).
#[derive(Clone, Debug, Default)]
pub struct EmitterIndex {
    index: HashMap<(u32, u32), u32>,
}

impl EmitterIndex {
    pub fn new(frame: &SceneFrame) -> Self {
        Self { index: frame.emissive.iter().enumerate().map(|(i, e)| ((e.instance, e.triangle), i as u32)).collect() }
    }

    pub fn memory_bytes(&self) -> usize {
        self.index.capacity() * 16
    }

    /// Emissive triangles indexed.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Solid-angle density with which [`sample_area_light`] picks the direction of a ray that hit
    /// `(instance, triangle)` at distance `t` with cosine `cos_light` at the emitter.
    pub fn pdf(&self, frame: &SceneFrame, instance: u32, triangle: u32, t: f32, cos_light: f32) -> f32 {
        let (Some(&i), Some(dist)) = (self.index.get(&(instance, triangle)), &frame.emissive_distribution) else {
            return 0.0;
        };
        let tri = &frame.emissive[i as usize];
        if cos_light <= 0.0 {
            return 0.0;
        }
        dist.discrete_pdf(i as usize) * t * t / (tri.area * cos_light)
    }
}

/// A punctual light seen from a receiver.
#[derive(Clone, Copy, Debug)]
pub struct PunctualSample {
    pub wi: Vec3,
    /// Irradiance on a surface facing the light (before the cosine); zero outside a spot's cone.
    pub irradiance: Vec3,
    pub shadow: Ray,
    pub t_max: f32,
}

/// Direction, irradiance and shadow segment of `light` at `p` (geometric normal `n`, error
/// scale `e`).
pub fn punctual(light: &WorldLight, p: Vec3, n: Vec3, e: f32) -> PunctualSample {
    let (wi, d, irradiance) = light.incident(p);
    let (shadow, t_max) = if d.is_finite() { segment(p, n, e, light.position) } else { (Ray::spawn(p, n, e, wi), f32::INFINITY) };
    PunctualSample { wi, irradiance, shadow, t_max }
}

/// Power heuristic (β = 2) weight of a sample with density `a` against another strategy's `b`
/// (both already multiplied by their sample counts).
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// One-sample estimate of the irradiance from the area lights at `s` (exact shadow ray through
/// `vis`); returns (irradiance, rays traced).
pub fn area_irradiance(frame: &SceneFrame, vis: &dyn Visibility, s: &Shading, rng: &mut Rng) -> (Vec3, u64) {
    let (u_pick, u) = (rng.next_f32(), rng.next_2d());
    let Some(ls) = sample_area_light(frame, s.position, s.normal, s.error_scale, u_pick, u) else {
        return (Vec3::ZERO, 0);
    };
    let cos = s.cos(ls.wi);
    if cos <= 0.0 {
        return (Vec3::ZERO, 0);
    }
    if vis.occluded(&ls.shadow, ls.t_max) { (Vec3::ZERO, 1) } else { (ls.radiance * (cos / ls.pdf), 1) }
}

/// Exact irradiance from the punctual lights `lights` at `s`; returns (irradiance, rays):
/// [`punctual_irradiance_with`] with `vis`, its shadow rays asked together ([`sum_unblocked`]).
pub fn punctual_irradiance(lights: &[WorldLight], vis: &dyn Visibility, s: &Shading) -> (Vec3, u64) {
    let items = lights.iter().filter_map(|light| {
        let ps = punctual(light, s.position, s.normal, s.error_scale);
        let cos = s.cos(ps.wi);
        (cos > 0.0 && ps.irradiance.max_element() > 0.0).then(|| (ps.irradiance * cos, ps.shadow, ps.t_max))
    });
    sum_unblocked(vis, items, |&e| e)
}

/// Σ `value(item)` over the items `(item, shadow ray, t_max)` whose segment `vis` finds
/// unblocked, summed in the items' order; returns (sum, segments asked). The segments go to
/// `vis` [`PACKET`] at a time ([`Visibility::occluded_batch`]: the exact tracer traces one
/// point's rays as packets), so the sum is the one a ray-at-a-time loop makes.
pub fn sum_unblocked<V: Visibility + ?Sized, T>(
    vis: &V,
    items: impl IntoIterator<Item = (T, Ray, f32)>,
    value: impl Fn(&T) -> Vec3,
) -> (Vec3, u64) {
    let (mut sum, mut asked) = (Vec3::ZERO, 0u64);
    let (mut held, mut segments) = (Vec::with_capacity(PACKET), Vec::with_capacity(PACKET));
    let mut blocked = [false; PACKET];
    let mut items = items.into_iter().peekable();
    while items.peek().is_some() {
        held.clear();
        segments.clear();
        for (item, ray, t_max) in items.by_ref().take(PACKET) {
            held.push(item);
            segments.push((ray, t_max));
        }
        vis.occluded_batch(&segments, &mut blocked[..segments.len()]);
        for (item, b) in held.iter().zip(&blocked) {
            if !b {
                sum += value(item);
            }
        }
        asked += segments.len() as u64;
    }
    (sum, asked)
}

/// Irradiance from the punctual lights `lights` at `s` with shadows decided by
/// `blocked(light index, sample)`, asked only for lights that can reach `s`; returns
/// (irradiance, shadow decisions made). Shadow maps and other approximate shadow tests plug in
/// here so that they differ from `lights-exact` only in that decision.
pub fn punctual_irradiance_with(lights: &[WorldLight], s: &Shading, blocked: impl Fn(usize, &PunctualSample) -> bool) -> (Vec3, u64) {
    let mut e = Vec3::ZERO;
    let mut decisions = 0;
    for (l, light) in lights.iter().enumerate() {
        let ps = punctual(light, s.position, s.normal, s.error_scale);
        let cos = s.cos(ps.wi);
        if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
            continue;
        }
        decisions += 1;
        if !blocked(l, &ps) {
            e += ps.irradiance * cos;
        }
    }
    (e, decisions)
}

/// One importance sample of the environment's irradiance at `s`; returns (irradiance, rays).
pub fn env_irradiance(env: Option<&Environment>, vis: &dyn Visibility, s: &Shading, rng: &mut Rng) -> (Vec3, u64) {
    let u = rng.next_2d();
    let Some(env) = env else {
        return (Vec3::ZERO, 0);
    };
    let es = env.sample_direction(u);
    let (d, pdf) = (es.dir, es.pdf);
    let cos = s.cos(d);
    if pdf <= 0.0 || cos <= 0.0 {
        return (Vec3::ZERO, 0);
    }
    if vis.occluded(&s.spawn(d), f32::INFINITY) { (Vec3::ZERO, 1) } else { (env.sample_radiance(&es) * (cos / pdf), 1) }
}

/// One area-light sample exactly as `soft-exact` draws it (`direct::sample_area_light` with the
/// same two random numbers), with the ends of the shadow segment moved off both surfaces by
/// `offset` (world) along their normals: the receiver's geometric normal and the emitter's. `None`
/// for a sample that carries no light (behind the emitter or below the receiver).
pub fn area_light_segment(frame: &SceneFrame, s: &Shading, u_pick: f32, u: Vec2, offset: f32) -> Option<(AreaSample, Vec3, Vec3)> {
    let ls = sample_area_light(frame, s.position, s.normal, s.error_scale, u_pick, u)?;
    if s.cos(ls.wi) <= 0.0 {
        return None;
    }
    // The emitter `sample_area_light` picked with `u_pick`, for its normal.
    let (tri, _) = frame.emissive_distribution.as_ref()?.sample_discrete(u_pick);
    let light_point = ls.shadow.at(ls.t_max) + frame.emissive[tri].normal * offset;
    Some((ls, s.position + s.normal * offset, light_point))
}

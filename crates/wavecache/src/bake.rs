//! Lighting precomputation (paper Sec. 4.3 and Sec. 6): per mesh, cache points by weighted
//! sample elimination; diffuse meshes store the irradiance (Eq. 14), glossy meshes the path-traced
//! incident-radiance half-cube map at the Table 2 resolution for their roughness, Haar-pruned
//! (β) in fp16; points that add little over their neighbours are removed (Sec. 6); one octree per
//! mesh.
//!
//! The path tracer that fills the maps is the ground truth's (`pt`) estimator (NEE to area lights,
//! the environment and punctual lights with MIS, the same BRDF, Russian roulette, the same depth
//! count: the cache point is vertex 1, so its incident paths have `max_depth − 1` vertices).
//! Choices where the paper is silent (spec §5.5–5.7):
//! - a radiance texel holds the mean incident radiance over the texel (stratified samples, uniform
//!   in the texel's face area, weighted by the cube Jacobian / ΔΩ) — the ΔΩ is on the BRDF side;
//!   directions below the geometric surface carry nothing (the ground truth's rule); the emission
//!   those samples find is combined with light samples splatted into the texels (ours,
//!   `texel_light_samples`; [`Integrator::radiance_map`]);
//! - irradiance: the same integral ∫ L cos dω is estimated with NEE + MIS at the point (a white
//!   Lambertian vertex, E = π L_o) instead of summing a traced map — same expectation, far less
//!   variance for the same rays; punctual lights are left out at the point itself (they are
//!   traced at runtime, Eq. 15–16), kept at later vertices (their indirect light is cached);
//! - sparsification (irradiance points only, the paper's "low-frequency" objects): a point whose mean relative energy difference to its neighbours (within
//!   2 r_max) is below the cloud's mean is removed with probability
//!   `sparsify × (1 − diff / mean)`, never next to a point already removed.
//! - buried points (ours, `enclosed_share`): a point whose probe rays mostly hit the back of a
//!   one-sided surface lies inside a closed mesh; it is not baked, and the caller drops it.

use crate::brdf;
use crate::haar::{self, HaarNode, TreeRef};
use crate::halfcube::HalfCube;
use crate::points::{self, OctNode, SurfaceSample, WorldMesh};
use crate::{Class, WavecacheParams};
use bytemuck::{Pod, Zeroable};
use glimpse_core::{Frame, Ray, Rng, Vec2, Vec3, is_finite3, luminance};
use glimpse_render::bsdf::BrdfModel;
use glimpse_render::direct::{EmitterIndex, sample_area_light};
use glimpse_render::pt::{PathIntegrator, PathStart, PathVertex};
use glimpse_scene::SceneFrame;
use glimpse_trace::{ExactTracer, SurfacePoint};
use rayon::prelude::*;
use std::f32::consts::PI;

/// A cache point: where it is, its normals, its energy (luminance of the irradiance or of the
/// map's mean radiance), its reach and its payload (index into the irradiance or radiance-tree
/// array).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CachePoint {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub shading_normal: [f32; 3],
    pub energy: f32,
    /// The harmonic mean of its probe rays' hit distances ([`Integrator::enclosed_share`];
    /// [`NO_REACH`] where none hit or no probe ran): how far its light stays valid (Ward's
    /// irradiance caching, R_i), read by `validity`.
    pub reach: f32,
    pub payload: u32,
}

/// [`CachePoint::reach`] where no probe ray hit anything (or none was cast).
pub const NO_REACH: f32 = f32::MAX;

/// Per instance: its class and where its octree and points are.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MeshCache {
    /// [`Class`] as u32.
    pub class: u32,
    pub material: u32,
    pub first_node: u32,
    pub node_count: u32,
    pub first_point: u32,
    pub point_count: u32,
    pub r_max: f32,
    /// Radiance-map resolution (glossy), 0 otherwise.
    pub map_res: u32,
    /// Points before sparsification.
    pub points_before: u32,
    pub _pad: u32,
}

/// The path tracer that fills the cache: `pt`'s own estimator ([`PathIntegrator`]), started at
/// the cache point or at the first hit of a map texel's ray.
pub struct Integrator<'a> {
    pub frame: &'a SceneFrame<'a>,
    pub tracer: &'a ExactTracer,
    pub emitters: EmitterIndex,
    pub max_depth: u32,
    pub model: BrdfModel,
    /// The irradiance includes the punctual lights' direct light
    /// ([`crate::WavecacheParams::cache_punctual_above`]); otherwise the runtime traces it.
    pub punctual_irradiance: bool,
}

impl<'a> Integrator<'a> {
    pub fn new(frame: &'a SceneFrame<'a>, tracer: &'a ExactTracer, max_depth: u32, model: BrdfModel) -> Self {
        Self { frame, tracer, emitters: EmitterIndex::new(frame), max_depth, model, punctual_irradiance: false }
    }

    fn pt(&self) -> PathIntegrator<'_> {
        PathIntegrator { frame: self.frame, tracer: self.tracer, emitters: &self.emitters, max_depth: self.max_depth, model: self.model }
    }

    /// What arrives along `ray`, split for multiple importance sampling against light samples:
    /// the first hit's emission (or the environment on a miss) with the densities the light
    /// samplers give its direction, and the light the hit reflects.
    pub fn arrival(&self, ray: &Ray, rng: &mut Rng) -> Arrival {
        let env = self.frame.scene.environment.as_ref();
        let Some(hit) = self.tracer.closest_hit(ray, f32::INFINITY) else {
            let (emitted, env_pdf) = env.map_or((Vec3::ZERO, 0.0), |e| e.radiance_and_pdf(ray.dir));
            return Arrival { emitted, env_pdf, escaped: true, rays: 1, ..Default::default() };
        };
        let sp = SurfacePoint::from_hit(self.frame, ray, &hit);
        let emitted = sp.emission(self.frame);
        let area_pdf = if emitted.max_element() > 0.0 {
            self.emitters.pdf(self.frame, hit.instance, hit.triangle, hit.t, sp.normal.dot(-ray.dir).abs())
        } else {
            0.0
        };
        let mut a = Arrival { emitted, area_pdf, rays: 1, ..Default::default() };
        if self.max_depth >= 2 {
            // The hit is the path's second vertex (the cache point is the first).
            let start = PathStart { depth: 2, model: None, punctual: true };
            let (l, rays) = self.pt().path(PathVertex::of(self.frame, &sp), -ray.dir, start, rng);
            a.reflected = l;
            a.rays += rays;
        }
        a
    }

    /// Irradiance ∫ L cos dω at a cache point without the direct light of punctual lights (the
    /// runtime traces those) unless `punctual_irradiance`: π × the radiance a white Lambertian
    /// vertex reflects.
    pub fn irradiance(&self, s: &SurfaceSample, rng: &mut Rng) -> (Vec3, u64) {
        let v = PathVertex {
            position: s.position,
            error_scale: s.error_scale,
            normal: s.normal,
            shading_normal: s.shading_normal,
            base: Vec3::ONE,
            metallic: 0.0,
            roughness: 1.0,
            clearcoat: 0.0,
            model: glimpse_scene::MaterialModel::Pbr,
            front_face: true,
            bump_shadowing: None,
        };
        let start = PathStart { depth: 1, model: Some(BrdfModel::Lambert), punctual: self.punctual_irradiance };
        let (l, rays) = self.pt().path(v, s.shading_normal, start, rng);
        (l * PI, rays)
    }

    /// The incident-radiance half-cube map (mean radiance per texel, row-major N×N) at a point
    /// `point` whose map frame is `frame` (z = its shading normal), from two strategies:
    /// - `samples` rays per texel, stratified, uniform in the texel's face area (density
    ///   1 / (face area × Jacobian) in solid angle), each returning its hit's emission and the
    ///   light the hit reflects ([`Self::arrival`]);
    /// - `light_samples` × the texels light samples for the whole map, shared by the area lights
    ///   and the environment, each a shadow ray whose light lands in the texel of its direction.
    ///
    /// Emission found either way is weighted by the balance heuristic over the three densities,
    /// so a texel's estimate is Σ L_e / (n_texel p_texel + n_area p_area + n_env p_env) + the
    /// reflected light's plain estimate: unbiased, and a small bright source inside one texel
    /// gets most of its samples from the light samplers.
    pub fn radiance_map(&self, point: &SurfaceSample, frame: &Frame, map: &MapSettings, rng: &mut Rng) -> RadianceMap {
        let MapSettings { res, samples, light_samples, split_env } = *map;
        let h = HalfCube::new(res);
        let s_count = samples.max(1);
        // A k×k grid of strata takes the first k² samples, the rest fall anywhere in the texel:
        // every sample's texel is covered evenly (so the texel density below holds for any
        // count; a ⌈√n⌉ grid filled in order left a non-square count's last rows unsampled).
        let k = (s_count as f32).sqrt().floor().max(1.0) as u32;
        let texel_area = (4.0 / res as f64).powi(2);
        let env = self.frame.scene.environment.as_ref();
        let has_area = self.frame.emissive_distribution.is_some();
        // Each texel's solid angle (0 for the unused corners).
        let d_omega: Vec<f64> = (0..h.texels() as u32).map(|t| h.solid_angle(t % res, t / res)).collect();
        // Light samples per strategy: the map's share split between the lights there are.
        let live_texels = d_omega.iter().filter(|&&a| a > 0.0).count();
        let strategies = has_area as u64 + env.is_some() as u64;
        let per_light = if strategies == 0 { 0 } else { (light_samples as u64 * live_texels as u64).div_ceil(strategies) };
        let (n_area, n_env) = (if has_area { per_light } else { 0 }, if env.is_some() { per_light } else { 0 });
        // n_texel p_texel + n_area p_area + n_env p_env at a direction (the texel strategy's
        // density from the Jacobian at the direction's face coordinates).
        let denominator = |local: Vec3, area_pdf: f32, env_pdf: f32| -> f64 {
            let j = HalfCube::jacobian(HalfCube::uv_of(local)) as f64;
            let texel = if j > 0.0 { s_count as f64 / (texel_area * j) } else { 0.0 };
            texel + n_area as f64 * area_pdf as f64 + n_env as f64 * env_pdf as f64
        };
        let mut rays = 0;
        // Per texel: the estimate of ∫_texel L dω.
        let mut integral = vec![[0.0f64; 3]; h.texels()];
        let mut add = |x: u32, y: u32, l: Vec3, w: f64| {
            let t = &mut integral[(y * res + x) as usize];
            for c in 0..3 {
                t[c] += l[c] as f64 * w;
            }
        };
        // `split_env`: the environment's direct light stays out of the map; per texel the
        // environment's light that arrives and the light that would arrive unoccluded, from
        // the same samples and weights (their ratio is the texel's visibility, weighted by the
        // map's radiance), and the texel rays that escaped of those cast (where the map is black).
        let mut vis = split_env.then(|| vec![[0.0f64; 4]; h.texels()]);
        for y in 0..res {
            for x in 0..res {
                if d_omega[(y * res + x) as usize] <= 0.0 {
                    continue;
                }
                for s in 0..s_count {
                    let f = if s < k * k { (Vec2::new((s % k) as f32, (s / k) as f32) + rng.next_2d()) / k as f32 } else { rng.next_2d() };
                    let uv = h.uv(x, y, f);
                    let Some(local) = HalfCube::direction(uv) else {
                        continue;
                    };
                    let dir = frame.to_world(local).normalize();
                    if dir.dot(point.normal) <= 0.0 {
                        continue;
                    }
                    let a = self.arrival(&Ray::spawn(point.position, point.normal, point.error_scale, dir), rng);
                    rays += a.rays;
                    if !is_finite3(a.emitted) || !is_finite3(a.reflected) {
                        continue;
                    }
                    add(x, y, a.reflected, HalfCube::jacobian(uv) as f64 * texel_area / s_count as f64);
                    if let (Some(vis), Some(env)) = (vis.as_mut(), env) {
                        // What the environment would send along the ray unoccluded (an escaped
                        // ray's arrival holds it already), weighted as the light samples are.
                        let (open, env_pdf) = if a.escaped { (a.emitted, a.env_pdf) } else { env.radiance_and_pdf(dir) };
                        let light = luminance(open) as f64 * (1.0 / denominator(local, 0.0, env_pdf));
                        let v = &mut vis[(y * res + x) as usize];
                        v[1] += light;
                        v[3] += 1.0;
                        if a.escaped {
                            v[0] += light;
                            v[2] += 1.0;
                            continue;
                        }
                    }
                    if a.emitted.max_element() > 0.0 {
                        add(x, y, a.emitted, 1.0 / denominator(local, a.area_pdf, a.env_pdf));
                    }
                }
            }
        }
        // The light samples: a direction, its light if unoccluded, into its texel.
        let mut splat = |dir: Vec3, le: Vec3, area_pdf: f32, env_pdf: f32, shadow: &Ray, t_max: f32, rays: &mut u64| {
            let local = frame.to_local(dir);
            if local.z <= 0.0 || dir.dot(point.normal) <= 0.0 || le.max_element() <= 0.0 || !is_finite3(le) {
                return;
            }
            *rays += 1;
            let (x, y) = h.texel_of(local);
            let w = 1.0 / denominator(local, area_pdf, env_pdf);
            let open = !self.tracer.occluded(shadow, t_max);
            if let Some(vis) = vis.as_mut().filter(|_| env_pdf > 0.0) {
                let v = &mut vis[(y * res + x) as usize];
                v[1] += luminance(le) as f64 * w;
                v[0] += if open { luminance(le) as f64 * w } else { 0.0 };
                return;
            }
            if open {
                add(x, y, le, w);
            }
        };
        for _ in 0..n_area {
            let (u_pick, u) = (rng.next_f32(), rng.next_2d());
            if let Some(ls) = sample_area_light(self.frame, point.position, point.normal, point.error_scale, u_pick, u) {
                splat(ls.wi, ls.radiance, ls.pdf, 0.0, &ls.shadow, ls.t_max, &mut rays);
            }
        }
        if let Some(env) = env {
            for _ in 0..n_env {
                let s = env.sample_direction(rng.next_2d());
                // `splat` drops a direction below the surface: no radiance lookup for it.
                if s.pdf <= 0.0 || s.dir.dot(point.normal) <= 0.0 {
                    continue;
                }
                let (d, le, pdf) = (s.dir, env.sample_radiance(&s), s.pdf);
                // Each light's emission is its own integrand, sampled by the texels and by its own
                // sampler: the environment's light is weighed against the texels alone (an area
                // light in the way occludes it), as the area lights' is ([`Self::arrival`] gives
                // a miss no area density and a hit no environment density).
                let shadow = Ray::spawn(point.position, point.normal, point.error_scale, d);
                splat(d, le, 0.0, pdf, &shadow, f32::INFINITY, &mut rays);
            }
        }
        let image = integral.iter().zip(&d_omega).map(|(sum, &a)| if a > 0.0 { sum.map(|v| v / a) } else { [0.0; 3] }).collect();
        let visibility = vis.map(|vis| {
            vis.iter()
                .map(|&[seen, open, escaped, cast]| {
                    let v = if open > 0.0 {
                        seen / open
                    } else if cast > 0.0 {
                        escaped / cast
                    } else {
                        0.0
                    };
                    (v.clamp(0.0, 1.0) * 255.0).round() as u8
                })
                .collect()
        });
        RadianceMap { image, visibility, rays }
    }
}

/// How a radiance map is baked ([`Integrator::radiance_map`]).
#[derive(Clone, Copy, Debug)]
pub struct MapSettings {
    /// N of the N × N half-cube map.
    pub res: u32,
    /// Rays per texel (`texel_samples`).
    pub samples: u32,
    /// Light samples per texel, on average (`texel_light_samples`).
    pub light_samples: u32,
    /// Leave the environment's direct light out and record its visibility (`env_direct`).
    pub split_env: bool,
}

/// One baked radiance map ([`Integrator::radiance_map`]).
pub struct RadianceMap {
    /// Mean radiance per texel, N × N (0 in the unused corners).
    pub image: Vec<[f64; 3]>,
    /// With `split_env`: per texel, the share of the environment's light arriving unoccluded
    /// (weighted by its radiance), 0–255.
    pub visibility: Option<Vec<u8>>,
    pub rays: u64,
}

/// What arrives at a cache point along one ray ([`Integrator::arrival`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Arrival {
    /// The first hit's emission, or the environment's radiance on a miss.
    pub emitted: Vec3,
    /// The area-light sampler's solid-angle density of the ray's direction (0 unless it hit an emitter).
    pub area_pdf: f32,
    /// The environment sampler's density of the ray's direction (0 unless it escaped).
    pub env_pdf: f32,
    /// The ray met no surface (`emitted` is the environment's).
    pub escaped: bool,
    /// The light the first hit reflects along the ray.
    pub reflected: Vec3,
    pub rays: u64,
}

/// Probe rays of [`Integrator::enclosed_share`].
pub const ENCLOSURE_RAYS: u32 = 16;

/// What a point's probe rays found ([`Integrator::enclosed_share`]).
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    /// The share that hit the back of a one-sided surface.
    pub enclosed: f32,
    /// The harmonic mean of their hit distances ([`CachePoint::reach`]).
    pub reach: f32,
    pub rays: u64,
}

impl Integrator<'_> {
    /// The share of `ENCLOSURE_RAYS` cosine-distributed rays from `s` whose first hit is the back
    /// of a one-sided surface (`two_sided(instance)` false): near 1 for a point buried inside a
    /// closed mesh (an eyeball's hidden half, an interpenetrating prop), whose cached light is
    /// the dark inside. Back faces of two-sided instances (leaves, cloth) count as front. And,
    /// from the same rays, the harmonic mean of their hit distances (misses count as infinitely
    /// far; [`NO_REACH`] where all miss): the point's reach, [`CachePoint::reach`].
    pub fn enclosed_share(&self, s: &SurfaceSample, two_sided: &dyn Fn(u32) -> bool, rng: &mut Rng) -> Probe {
        let frame = Frame::from_z(s.normal);
        let k = (ENCLOSURE_RAYS as f32).sqrt() as u32;
        let (mut back, mut inverse_sum) = (0, 0.0f64);
        for j in 0..ENCLOSURE_RAYS {
            let cell = Vec2::new((j % k) as f32, (j / k) as f32);
            let dir = frame.to_world(glimpse_core::sampling::cosine_hemisphere((cell + rng.next_2d()) / k as f32));
            let ray = Ray::spawn(s.position, s.normal, s.error_scale, dir);
            let hit = self.tracer.closest_hit(&ray, f32::INFINITY);
            if let Some(h) = &hit {
                inverse_sum += 1.0 / (h.t as f64).max(1e-12);
            }
            back += hit.is_some_and(|h| !two_sided(h.instance) && !SurfacePoint::from_hit(self.frame, &ray, &h).front_face) as u32;
        }
        let reach = if inverse_sum > 0.0 { ((ENCLOSURE_RAYS as f64 / inverse_sum) as f32).min(NO_REACH) } else { NO_REACH };
        Probe { enclosed: back as f32 / ENCLOSURE_RAYS as f32, reach, rays: ENCLOSURE_RAYS as u64 }
    }
}

/// Table 2: radiance-map resolution by roughness (None below the mirror threshold 0.1).
pub fn table2_resolution(roughness: f32) -> Option<u32> {
    if roughness < 0.1 {
        None
    } else if roughness <= 0.35 {
        Some(128)
    } else if roughness <= 0.55 {
        Some(64)
    } else if roughness <= 0.65 {
        Some(32)
    } else {
        Some(16)
    }
}

/// Per-point lighting of one instance, in parallel over points.
pub struct BakedMesh {
    pub samples: Vec<SurfaceSample>,
    pub energy: Vec<f32>,
    pub irradiance: Vec<Vec3>,
    pub maps: Vec<(Vec<HaarNode>, TreeRef)>,
    /// Per glossy point with `split_env`: its environment visibility map ([`RadianceMap::visibility`]).
    pub visibility: Vec<Vec<u8>>,
    /// Points buried inside a closed mesh (`enclosed_share`), not baked: dropped by the caller.
    pub enclosed: Vec<bool>,
    /// Per point: its reach ([`CachePoint::reach`]).
    pub reach: Vec<f32>,
    pub rays: u64,
}

/// One baked point: energy, irradiance, radiance tree (glossy) and its environment visibility
/// (`split_env`), rays traced, enclosed, reach.
type PointResult = (f32, Vec3, Option<(Vec<HaarNode>, TreeRef)>, Option<Vec<u8>>, u64, bool, f32);

/// Bakes the points of one instance (`class` Diffuse or Glossy).
pub fn bake_points(
    integ: &Integrator,
    samples: Vec<SurfaceSample>,
    class: Class,
    map: MapSettings,
    p: &WavecacheParams,
    seed: u64,
    tick: &(dyn Fn(u64) + Sync),
) -> BakedMesh {
    let results: Vec<PointResult> = samples
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let mut rng = Rng::new(seed, i as u64 ^ 0x9e37_79b9_7f4a_7c15u64.wrapping_mul(seed + 1));
            // Its own stream: the probe leaves the lighting's random numbers as they were.
            let mut probe_rng = Rng::new(seed ^ 0x5eed_e4c1_05ed, i as u64);
            let probe = if p.enclosed_share < 1.0 {
                integ.enclosed_share(s, &|inst| p.two_sided(inst as usize), &mut probe_rng)
            } else {
                Probe { enclosed: 0.0, reach: NO_REACH, rays: 0 }
            };
            let (probe_rays, reach) = (probe.rays, probe.reach);
            if probe.enclosed > p.enclosed_share {
                tick(1);
                let texels = (map.res * map.res) as usize;
                let tree = (class == Class::Glossy).then(|| {
                    let mut nodes = Vec::new();
                    let t = haar::build(&vec![[0.0; 3]; texels], map.res, 0.0, &mut nodes);
                    (nodes, t)
                });
                let vis = (class == Class::Glossy && map.split_env).then(|| vec![0; texels]);
                return (0.0, Vec3::ZERO, tree, vis, probe_rays, true, reach);
            }
            let out = match class {
                Class::Glossy => {
                    let frame = crate::halfcube::map_frame(s.shading_normal);
                    let baked = integ.radiance_map(s, &frame, &map, &mut rng);
                    let mut nodes = Vec::new();
                    let t = haar::build(&baked.image, map.res, p.radiance_beta as f64, &mut nodes);
                    let e = luminance(nodes[0].c());
                    (e, Vec3::ZERO, Some((nodes, t)), baked.visibility, baked.rays + probe_rays, false, reach)
                }
                _ => {
                    let (mut sum, mut rays) = (Vec3::ZERO, 0);
                    for _ in 0..p.irradiance_samples {
                        let (e, r) = integ.irradiance(s, &mut rng);
                        rays += r;
                        if is_finite3(e) {
                            sum += e;
                        }
                    }
                    let e = sum / p.irradiance_samples.max(1) as f32;
                    (luminance(e), e, None, None, rays + probe_rays, false, reach)
                }
            };
            tick(1);
            out
        })
        .collect();
    let mut b = BakedMesh {
        samples,
        energy: Vec::new(),
        irradiance: Vec::new(),
        maps: Vec::new(),
        visibility: Vec::new(),
        enclosed: Vec::new(),
        reach: Vec::new(),
        rays: 0,
    };
    for (e, irr, map, vis, rays, enclosed, reach) in results {
        b.energy.push(e);
        b.enclosed.push(enclosed);
        b.reach.push(reach);
        b.irradiance.push(irr);
        if let Some(m) = map {
            b.maps.push(m);
        }
        if let Some(v) = vis {
            b.visibility.push(v);
        }
        b.rays += rays;
    }
    b
}

/// Sec. 6's sparsification: which points to keep (see the module comment for the rule).
pub fn sparsify(positions: &[Vec3], energy: &[f32], r_max: f32, strength: f32, seed: u64) -> Vec<bool> {
    let n = positions.len();
    let mut keep = vec![true; n];
    if strength <= 0.0 || n < 8 {
        return keep;
    }
    let cell = 2.0 * r_max;
    let key = |p: Vec3| ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64);
    let mut grid: std::collections::HashMap<(i64, i64, i64), Vec<u32>> = std::collections::HashMap::new();
    for (i, p) in positions.iter().enumerate() {
        grid.entry(key(*p)).or_default().push(i as u32);
    }
    let neighbours: Vec<Vec<u32>> = (0..n)
        .map(|i| {
            let (kx, ky, kz) = key(positions[i]);
            let mut out = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for &j in grid.get(&(kx + dx, ky + dy, kz + dz)).map_or(&[][..], |v| &v[..]) {
                            if j as usize != i && positions[i].distance(positions[j as usize]) < cell {
                                out.push(j);
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    let diff: Vec<f32> = (0..n)
        .map(|i| {
            let nb = &neighbours[i];
            if nb.is_empty() {
                return f32::INFINITY;
            }
            nb.iter()
                .map(|&j| {
                    let (a, b) = (energy[i], energy[j as usize]);
                    (a - b).abs() / (0.5 * (a + b)).max(1e-6)
                })
                .sum::<f32>()
                / nb.len() as f32
        })
        .collect();
    let finite: Vec<f32> = diff.iter().copied().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return keep;
    }
    let mean = finite.iter().sum::<f32>() / finite.len() as f32;
    let mut rng = Rng::new(seed, 0x5ba7);
    let mut order: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        order.swap(i, rng.below(i as u32 + 1) as usize);
    }
    for &i in &order {
        let i = i as usize;
        if !diff[i].is_finite() || mean <= 0.0 || neighbours[i].iter().any(|&j| !keep[j as usize]) {
            continue;
        }
        let p_remove = strength * (1.0 - diff[i] / mean).max(0.0);
        if rng.next_f32() < p_remove {
            keep[i] = false;
        }
    }
    keep
}

/// World-space mesh of instance `i`.
pub fn world_mesh(frame: &SceneFrame, i: usize) -> WorldMesh {
    let scene = frame.scene;
    let inst = &scene.instances[i];
    let mesh = &scene.meshes[inst.mesh as usize];
    let m = frame.transforms[i];
    let pos = &frame.positions[inst.mesh as usize];
    let nor = &frame.normals[inst.mesh as usize];
    let nm = frame.normal_matrices[i];
    let mut wm = WorldMesh { triangles: Vec::with_capacity(mesh.indices.len()), normals: Vec::with_capacity(mesh.indices.len()) };
    for t in &mesh.indices {
        let idx = t.map(|k| k as usize);
        let tri = idx.map(|k| m.transform_point3(pos[k]));
        let g = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or(Vec3::Y);
        let ns = if nor.is_empty() { [g; 3] } else { idx.map(|k| (nm * nor[k]).normalize_or(g)) };
        wm.triangles.push(tri);
        wm.normals.push(ns);
    }
    wm
}

/// Octree over the kept points of one mesh; returns the nodes and the leaf order.
pub fn octree(points: &[CachePoint]) -> (Vec<OctNode>, Vec<u32>) {
    let pos: Vec<Vec3> = points.iter().map(|p| Vec3::from(p.position)).collect();
    let nor: Vec<Vec3> = points.iter().map(|p| Vec3::from(p.shading_normal)).collect();
    points::build_octree(&pos, &nor)
}

/// The glossy BRDF tables' β for a roughness: the paper's (0.1/0.2) × `scale`, relative.
pub fn brdf_beta(roughness: f32, scale: f32) -> f64 {
    brdf::paper_brdf_beta(roughness) * scale as f64
}

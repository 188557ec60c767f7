//! `lights-ism`: imperfect shadow maps (Ritschel et al., SIGGRAPH Asia 2008), the voxel-array
//! paper's ISM baseline (Wang et al. 2017, §5, Table 1, Fig. 7): the scene approximated by point
//! samples, one small depth map per light splatted from its own subset of the points, holes
//! filled by pull-push. The paper's setting: a 128×128 map per light from about 11,000 points.
//!
//! Gaps filled: the lights here are omnidirectional point lights, so each map is an octahedral
//! map of the whole sphere (the original uses paraboloid maps of VPL hemispheres); a directional
//! light gets an orthographic map fitted to the scene's bounds ([`crate::ortho`]; not to the
//! occluders' box as `lights-shadowmap`'s `focus`, see [`PerLightMaps::FOCUS`]). Each point is
//! splatted with its distance as a square of texels covering its share of the surface area seen
//! from the light (the area per point × |cos| at the point over the distance², against a texel's
//! solid angle; at most 9×9 texels), as ISM's points are drawn with a distance-dependent size: a one-texel splat
//! leaves holes in occluders near the light, which pull-push then fills with the farther depths
//! around them, and light leaks through (measured on floors under tables; see
//! docs/techniques/many-lights.md). Pull averages the valid children, push fills empty texels
//! from the coarser level. Points: a seeded pool of 8× the per-map count sampled
//! uniformly by area; light `l` uses a contiguous window of the pool at a seeded offset.
//! The lookup moves the shaded point along its normal by `bias` texel footprints and compares
//! distances with the same tolerance. `prepare` builds the maps; `render` only looks them up.

use crate::ortho::OrthoMap;
use crate::per_light_maps::{LightsWithMaps, Occluders, PerLightMaps};
use glimpse_core::{Rng, Vec2, Vec3};
use glimpse_render::{ParamError, Params, TechniqueInfo};
use glimpse_scene::{LightKind, Scene, WorldLight};
use rayon::prelude::*;
use std::f32::consts::PI;

/// ISM settings. `Default` = the paper's: 128×128 per light, 11,000 points per map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsmParams {
    pub resolution: u32,
    pub points_per_map: u32,
    pub bias_texels: f32,
    pub seed: u64,
}

impl Default for IsmParams {
    fn default() -> Self {
        Self { resolution: 128, points_per_map: 11_000, bias_texels: 1.5, seed: 0 }
    }
}

impl IsmParams {
    pub fn read(self, params: &Params) -> Result<Self, ParamError> {
        Ok(Self {
            resolution: params.u32("resolution", self.resolution, 4, 1024)?,
            points_per_map: params.u32("points", self.points_per_map, 1, 10_000_000)?,
            bias_texels: params.f32("bias", self.bias_texels, 0.0, 64.0)?,
            seed: self.seed,
        })
    }
}

/// Octahedral map of a unit direction to [0, 1)².
#[inline]
fn oct_encode(d: Vec3) -> Vec2 {
    let d = d / (d.x.abs() + d.y.abs() + d.z.abs()).max(1e-20);
    let p = if d.z >= 0.0 { Vec2::new(d.x, d.y) } else { Vec2::new((1.0 - d.y.abs()) * d.x.signum(), (1.0 - d.x.abs()) * d.y.signum()) };
    p * 0.5 + Vec2::splat(0.5)
}

/// How a light's imperfect map projects the points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IsmProjection {
    /// Octahedral map of distances around a point or spot light at this position.
    Octahedral(Vec3),
    /// Orthographic map of depths along a directional light.
    Ortho(OrthoMap),
}

/// Largest splat half-width, texels (a point very near the light covers at most 9×9 texels).
const MAX_SPLAT_RADIUS: i64 = 4;

/// Imperfect shadow maps of every light: `depth[light·r² + y·r + x]` (distance to the light, or
/// depth along a directional light).
#[derive(Clone, Debug)]
pub struct ImperfectShadowMaps {
    pub resolution: u32,
    pub depth: Vec<f32>,
    pub lights: Vec<IsmProjection>,
    pub bias_texels: f32,
    pub points: usize,
}

/// Writes `depth` into the texels within `radius` texels of (x, y), keeping the nearest.
fn splat(map: &mut [f32], r: usize, x: f32, y: f32, radius: f32, depth: f32) {
    let half = (radius - 0.5).ceil().clamp(0.0, MAX_SPLAT_RADIUS as f32) as i64;
    let (cx, cy) = (x as i64, y as i64);
    for ty in (cy - half).max(0)..=(cy + half).min(r as i64 - 1) {
        for tx in (cx - half).max(0)..=(cx + half).min(r as i64 - 1) {
            let t = &mut map[ty as usize * r + tx as usize];
            *t = t.min(depth);
        }
    }
}

impl ImperfectShadowMaps {
    pub fn build(occluders: &Occluders, lights: &[WorldLight], p: &IsmParams) -> Self {
        let tris = &occluders.triangles;
        let pool = sample_points(occluders, 8 * p.points_per_map as usize, p.seed);
        let total_area: f64 = tris.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64).sum();
        let r = p.resolution as usize;
        let mut depth = vec![f32::INFINITY; lights.len() * r * r];
        let projections: Vec<IsmProjection> = lights
            .iter()
            .map(|l| match l.kind {
                LightKind::Directional => IsmProjection::Ortho(OrthoMap::fit(l.direction, &occluders.bounds, p.resolution)),
                LightKind::Point | LightKind::Spot { .. } => IsmProjection::Octahedral(l.position),
            })
            .collect();
        let m = (p.points_per_map as usize).min(pool.len());
        // The surface area each of a map's points stands for.
        let area_per_point = (total_area / m.max(1) as f64) as f32;
        let texel_solid_angle = 4.0 * PI / (r * r) as f32;
        depth.par_chunks_mut(r * r).zip(&projections).enumerate().for_each(|(l, (map, projection))| {
            if pool.is_empty() {
                return;
            }
            let start = (Rng::new(p.seed ^ 0x15a, l as u64).next_f32() * pool.len() as f32) as usize;
            for k in 0..m {
                let (point, normal) = pool[(start + k) % pool.len()];
                match projection {
                    IsmProjection::Octahedral(lp) => {
                        let d = point - *lp;
                        let dist = d.length();
                        if dist <= 0.0 {
                            continue;
                        }
                        let uv = oct_encode(d / dist) * r as f32;
                        // Texels the point's disk covers: its projected solid angle over a texel's.
                        let texels = area_per_point * normal.dot(d / dist).abs() / (dist * dist) / texel_solid_angle;
                        splat(map, r, uv.x.min(r as f32 - 1.0), uv.y.min(r as f32 - 1.0), (texels / PI).sqrt(), dist);
                    }
                    IsmProjection::Ortho(o) => {
                        let q = o.project(point);
                        if o.texel_of(q).is_some() {
                            let texels = area_per_point * normal.dot(o.direction()).abs() / (o.texel() * o.texel());
                            splat(map, r, q.x, q.y, (texels / PI).sqrt(), q.z);
                        }
                    }
                }
            }
            pull_push(map, r);
        });
        Self { resolution: p.resolution, depth, lights: projections, bias_texels: p.bias_texels, points: pool.len() }
    }

    pub fn memory_bytes(&self) -> usize {
        self.depth.len() * 4 + self.points * 24
    }

    /// Whether light `l` is hidden from the surface point `p` (normal `n`).
    #[inline]
    pub fn shadowed(&self, l: usize, p: Vec3, n: Vec3) -> bool {
        let r = self.resolution as usize;
        let lp = match &self.lights[l] {
            IsmProjection::Octahedral(lp) => *lp,
            IsmProjection::Ortho(o) => return o.shadowed(&self.depth[l * r * r..][..r * r], p, n, self.bias_texels),
        };
        let d0 = p - lp;
        let footprint = d0.length() * (4.0 * PI).sqrt() / r as f32;
        let nn = if n.dot(-d0) < 0.0 { -n } else { n };
        let d = d0 + nn * (self.bias_texels * footprint);
        let dist = d.length();
        let uv = oct_encode(d / dist.max(1e-20)) * r as f32;
        let (x, y) = ((uv.x.max(0.0) as usize).min(r - 1), (uv.y.max(0.0) as usize).min(r - 1));
        dist > self.depth[l * r * r + y * r + x] + self.bias_texels * footprint
    }
}

/// Pull-push hole filling of a square map (`INFINITY` = empty), in place.
fn pull_push(map: &mut [f32], r: usize) {
    // Pull: a pyramid of averages of the valid children.
    let mut levels: Vec<(usize, Vec<f32>)> = Vec::new();
    let (mut size, mut cur) = (r, map.to_vec());
    while size > 1 {
        let half = size.div_ceil(2);
        let mut next = vec![f32::INFINITY; half * half];
        for y in 0..half {
            for x in 0..half {
                let (mut sum, mut n) = (0.0, 0);
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (cx, cy) = (2 * x + dx, 2 * y + dy);
                    if cx < size && cy < size && cur[cy * size + cx].is_finite() {
                        sum += cur[cy * size + cx];
                        n += 1;
                    }
                }
                if n > 0 {
                    next[y * half + x] = sum / n as f32;
                }
            }
        }
        levels.push((size, cur));
        size = half;
        cur = next;
    }
    // Push: fill the empty texels of each level from its parent, coarse to fine.
    let mut parent = (size, cur);
    while let Some((s, mut lvl)) = levels.pop() {
        for y in 0..s {
            for x in 0..s {
                if !lvl[y * s + x].is_finite() {
                    lvl[y * s + x] = parent.1[(y / 2) * parent.0 + x / 2];
                }
            }
        }
        parent = (s, lvl);
    }
    map.copy_from_slice(&parent.1);
}

/// `count` points uniformly by area over the occluders (seeded), each with its triangle's unit
/// normal; those that fall in an alpha mask's cut-out are dropped (the surface is not there).
fn sample_points(occluders: &Occluders, count: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let tris = &occluders.triangles;
    let mut cdf = Vec::with_capacity(tris.len());
    let mut total = 0.0f64;
    for t in tris {
        total += 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64;
        cdf.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let mut rng = Rng::new(seed, 0x15a);
    (0..count)
        .filter_map(|_| {
            let u = rng.next_f32() as f64 * total;
            let k = cdf.partition_point(|&c| c < u).min(tris.len() - 1);
            let b = glimpse_core::sampling::uniform_triangle(rng.next_2d());
            let t = tris[k];
            let point = (t[0] * (1.0 - b.x - b.y) + t[1] * b.x + t[2] * b.y, (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Y));
            (!occluders.hole(k, b.x, b.y)).then_some(point)
        })
        .collect()
}

/// `lights-ism`: [`ImperfectShadowMaps`] through the shared many-light shell.
pub type LightsIsm = LightsWithMaps<ImperfectShadowMaps>;

impl PerLightMaps for ImperfectShadowMaps {
    type Params = IsmParams;
    const ID: &'static str = "lights-ism";
    const STAGE: &'static str = "imperfect shadow maps";
    /// Not focused: pull-push fills every empty texel from its neighbours, so a map without the
    /// ground under its objects would be filled with their depths (measured on `outdoor-sun`:
    /// ε_s 3.7 % → 31.5 %); ISM's point cloud must cover the receivers too.
    const FOCUS: bool = false;

    fn read_params(defaults: IsmParams, params: &Params) -> Result<IsmParams, ParamError> {
        defaults.read(params)
    }

    fn build(occluders: &Occluders, lights: &[WorldLight], p: &IsmParams) -> Self {
        ImperfectShadowMaps::build(occluders, lights, p)
    }

    fn shadowed(&self, l: usize, p: Vec3, n: Vec3) -> bool {
        ImperfectShadowMaps::shadowed(self, l, p, n)
    }

    fn memory_bytes(&self) -> usize {
        ImperfectShadowMaps::memory_bytes(self)
    }

    /// The maps (r² depths per light) and the point pool (8 × `points` positions and normals).
    fn estimate(lights: usize, p: &IsmParams) -> (String, u64) {
        let r = p.resolution as u64;
        let pool = 8 * p.points_per_map as u64 * 24;
        (
            format!("{lights} imperfect shadow maps of {r}² depths and a pool of {} points", 8 * p.points_per_map as u64),
            lights as u64 * r * r * 4 + pool,
        )
    }
}

impl LightsIsm {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "lights-ism",
            family: "many lights",
            reference: Some("lights-exact"),
            description: "every light at every pixel through imperfect shadow maps (points, one octahedral map per light, pull-push); resolution, points, bias, lights, epsilon",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "lights-ism", glimpse_render::Need::PunctualLights)?;
                Ok(Box::new(LightsIsm::new(scene, settings, params)?))
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_01_pull_push_fills_every_hole() {
        let r = 16;
        let mut map = vec![f32::INFINITY; r * r];
        map[3 * r + 4] = 2.0;
        map[12 * r + 10] = 6.0;
        pull_push(&mut map, r);
        let (lo, hi) = map.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        println!(
            "pull-push from 2 of 256 texels: every texel filled, values in [{lo}, {hi}], the samples kept: {} {}",
            map[3 * r + 4],
            map[12 * r + 10]
        );
        assert!(map.iter().all(|v| v.is_finite()));
        assert_eq!((map[3 * r + 4], map[12 * r + 10]), (2.0, 6.0));
        assert!(lo >= 2.0 && hi <= 6.0);
    }

    #[test]
    fn check_02_imperfect_shadow_maps_agree_with_exact_rays() {
        let maps = std::sync::OnceLock::new();
        let p = IsmParams::default();
        let (a, n) = crate::shadowmap::tests::agreement(|frame, lights, l, pt, nrm| {
            maps.get_or_init(|| ImperfectShadowMaps::build(&Occluders::whole(frame), lights, &p)).shadowed(l, pt, nrm)
        });
        println!(
            "imperfect shadow maps 128², 11,000 points, Cornell box, 8 point lights: {:.2}% of {n} facing decisions agree with exact rays",
            100.0 * a
        );
        assert!(a > 0.8);
    }
}

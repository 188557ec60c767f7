//! `lights-shadowmap`: conventional shadow mapping, the voxel-array paper's "SM" baseline
//! (Wang et al. 2017, §5, Table 5): one shadow map per light, its resolution chosen per scene
//! for the same ε_v as the voxel array (the paper: 36–384).
//!
//! Gaps filled (the paper does not say which shadow-map type it used for point lights): a cube
//! map per point or spot light (six 90° faces of `resolution²` texels), storing the nearest
//! depth along the face axis, rasterized on the CPU (triangles clipped at the near plane,
//! perspective-correct depth at texel centres). The lookup moves the shaded point along its
//! normal by `bias` texel footprints at its depth and compares with the same tolerance.
//! A directional light gets one orthographic map of `resolution²` texels along its direction,
//! fitted to the scene's bounds ([`crate::ortho`]; with `focus=auto`, ours, to the occluders'
//! box, [`Occluders`]), with the same bias in its texels. `prepare` builds every map (in
//! parallel over lights); `render` only looks them up.

use crate::ortho::OrthoMap;
use crate::per_light_maps::{LightsWithMaps, Occluders, PerLightMaps};
use glimpse_core::Vec3;
use glimpse_render::{ParamError, Params, TechniqueInfo};
use glimpse_scene::{LightKind, Scene, WorldLight};
use rayon::prelude::*;

/// Shadow-map settings. `Default`: 128² per face (the paper's per-scene values range 36–384;
/// pick with `resolution=` for equal ε_v), 1.5 texels of normal offset and depth tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowMapParams {
    pub resolution: u32,
    pub bias_texels: f32,
}

impl Default for ShadowMapParams {
    fn default() -> Self {
        Self { resolution: 128, bias_texels: 1.5 }
    }
}

impl ShadowMapParams {
    pub fn read(self, params: &Params) -> Result<Self, ParamError> {
        Ok(Self {
            resolution: params.u32("resolution", self.resolution, 4, 1024)?,
            bias_texels: params.f32("bias", self.bias_texels, 0.0, 64.0)?,
        })
    }
}

/// Face `f` coordinates (a, b, w) of a direction: w along the face axis, a and b across it.
#[inline]
fn face_coords(face: usize, d: Vec3) -> (f32, f32, f32) {
    match face {
        0 => (-d.z, -d.y, d.x),
        1 => (d.z, -d.y, -d.x),
        2 => (d.x, d.z, d.y),
        3 => (d.x, -d.z, -d.y),
        4 => (d.x, -d.y, d.z),
        _ => (-d.x, -d.y, -d.z),
    }
}

#[inline]
fn major_face(d: Vec3) -> usize {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        if d.x >= 0.0 { 0 } else { 1 }
    } else if a.y >= a.z {
        if d.y >= 0.0 { 2 } else { 3 }
    } else if d.z >= 0.0 {
        4
    } else {
        5
    }
}

/// How a light's map projects the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightProjection {
    /// Six 90° faces around a point or spot light at this position.
    Cube(Vec3),
    /// One orthographic map along a directional light (its first face's storage).
    Ortho(OrthoMap),
}

impl LightProjection {
    pub fn of(light: &WorldLight, bounds: &glimpse_core::Aabb, resolution: u32) -> LightProjection {
        match light.kind {
            LightKind::Directional => LightProjection::Ortho(OrthoMap::fit(light.direction, bounds, resolution)),
            LightKind::Point | LightKind::Spot { .. } => LightProjection::Cube(light.position),
        }
    }
}

/// Shadow maps of every light: `depth[(light·6 + face)·r² + y·r + x]` (a directional light uses
/// face 0 only).
#[derive(Clone, Debug)]
pub struct CubeShadowMaps {
    pub resolution: u32,
    pub depth: Vec<f32>,
    pub lights: Vec<LightProjection>,
    pub bias_texels: f32,
}

const NEAR: f32 = 1e-3;

impl CubeShadowMaps {
    pub fn build(occluders: &Occluders, lights: &[WorldLight], p: &ShadowMapParams) -> Self {
        let tris = &occluders.triangles;
        let r = p.resolution as usize;
        let per_light = 6 * r * r;
        let mut depth = vec![f32::INFINITY; lights.len() * per_light];
        let projections: Vec<LightProjection> = lights.iter().map(|l| LightProjection::of(l, &occluders.bounds, p.resolution)).collect();
        depth.par_chunks_mut(per_light).zip(&projections).for_each(|(maps, projection)| {
            let lp = match projection {
                LightProjection::Cube(lp) => lp,
                LightProjection::Ortho(m) => {
                    for (k, t) in tris.iter().enumerate() {
                        m.raster(&mut maps[..r * r], t, occluders.has_holes().then_some(|b1, b2| occluders.hole(k, b1, b2)));
                    }
                    return;
                }
            };
            for (k, t) in tris.iter().enumerate() {
                let d = t.map(|v| v - *lp);
                for face in 0..6 {
                    let q = d.map(|v| face_coords(face, v));
                    // Outside one frustum plane with all three vertices → not in this face.
                    if q.iter().all(|v| v.2 < NEAR)
                        || q.iter().all(|v| v.0 > v.2)
                        || q.iter().all(|v| -v.0 > v.2)
                        || q.iter().all(|v| v.1 > v.2)
                        || q.iter().all(|v| -v.1 > v.2)
                    {
                        continue;
                    }
                    let hole = occluders.has_holes().then_some(|b1, b2| occluders.hole(k, b1, b2));
                    raster_face(&mut maps[face * r * r..(face + 1) * r * r], r, q, hole);
                }
            }
        });
        Self { resolution: p.resolution, depth, lights: projections, bias_texels: p.bias_texels }
    }

    pub fn memory_bytes(&self) -> usize {
        self.depth.len() * 4
    }

    /// Whether light `l` is hidden from the surface point `p` (normal `n`).
    #[inline]
    pub fn shadowed(&self, l: usize, p: Vec3, n: Vec3) -> bool {
        let r = self.resolution as usize;
        let lp = match &self.lights[l] {
            LightProjection::Cube(lp) => *lp,
            LightProjection::Ortho(m) => return m.shadowed(&self.depth[l * 6 * r * r..][..r * r], p, n, self.bias_texels),
        };
        let d0 = p - lp;
        let face0 = major_face(d0);
        let w0 = face_coords(face0, d0).2.max(NEAR);
        let footprint = 2.0 * w0 / r as f32;
        let nn = if n.dot(-d0) < 0.0 { -n } else { n };
        let d = d0 + nn * (self.bias_texels * footprint);
        let face = major_face(d);
        let (a, b, w) = face_coords(face, d);
        if w <= NEAR {
            return false;
        }
        let x = (((a / w) * 0.5 + 0.5) * r as f32).clamp(0.0, r as f32 - 1.0) as usize;
        let y = (((b / w) * 0.5 + 0.5) * r as f32).clamp(0.0, r as f32 - 1.0) as usize;
        let stored = self.depth[(l * 6 + face) * r * r + y * r + x];
        w > stored + self.bias_texels * footprint
    }
}

/// Rasterizes one triangle (face coordinates) into one face: min depth at texel centres, but
/// where `hole(b1, b2)` (the triangle's own barycentrics of vertices 1 and 2 there,
/// perspective-correct: an alpha mask's cut-out; `None` in a scene without masks).
fn raster_face(map: &mut [f32], r: usize, q: [(f32, f32, f32); 3], hole: Option<impl Fn(f32, f32) -> bool>) {
    // Clip against w ≥ NEAR (Sutherland–Hodgman), at most 4 vertices, each with the
    // triangle's barycentrics (b1, b2) at it.
    let bary = [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0)];
    let mut poly = [(0.0f32, 0.0f32, 0.0f32); 4];
    let mut attr = [(0.0f32, 0.0f32); 4];
    let mut n = 0;
    for i in 0..3 {
        let j = (i + 1) % 3;
        let (a, b) = (q[i], q[j]);
        if a.2 >= NEAR {
            (poly[n], attr[n]) = (a, bary[i]);
            n += 1;
        }
        if (a.2 >= NEAR) != (b.2 >= NEAR) {
            let t = (NEAR - a.2) / (b.2 - a.2);
            poly[n] = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t, NEAR);
            attr[n] = (bary[i].0 + (bary[j].0 - bary[i].0) * t, bary[i].1 + (bary[j].1 - bary[i].1) * t);
            n += 1;
        }
    }
    if n < 3 {
        return;
    }
    let rf = r as f32;
    // Screen position and 1/w per vertex.
    let s: Vec<(f32, f32, f32)> =
        poly[..n].iter().map(|v| (((v.0 / v.2) * 0.5 + 0.5) * rf, ((v.1 / v.2) * 0.5 + 0.5) * rf, 1.0 / v.2)).collect();
    for k in 1..n - 1 {
        let (p0, p1, p2) = (s[0], s[k], s[k + 1]);
        let (a0, a1, a2) = (attr[0], attr[k], attr[k + 1]);
        let area = (p1.0 - p0.0) * (p2.1 - p0.1) - (p1.1 - p0.1) * (p2.0 - p0.0);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = (p0.0.min(p1.0).min(p2.0) - 0.5).ceil().max(0.0);
        let x1 = (p0.0.max(p1.0).max(p2.0) - 0.5).floor().min(rf - 1.0);
        let y0 = (p0.1.min(p1.1).min(p2.1) - 0.5).ceil().max(0.0);
        let y1 = (p0.1.max(p1.1).max(p2.1) - 0.5).floor().min(rf - 1.0);
        if x0 > x1 || y0 > y1 {
            continue;
        }
        let inv = 1.0 / area;
        for y in y0 as usize..=y1 as usize {
            let py = y as f32 + 0.5;
            for x in x0 as usize..=x1 as usize {
                let px = x as f32 + 0.5;
                let b0 = ((p1.0 - px) * (p2.1 - py) - (p1.1 - py) * (p2.0 - px)) * inv;
                let b1 = ((p2.0 - px) * (p0.1 - py) - (p2.1 - py) * (p0.0 - px)) * inv;
                let b2 = 1.0 - b0 - b1;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let w = 1.0 / (b0 * p0.2 + b1 * p1.2 + b2 * p2.2);
                if let Some(hole) = &hole {
                    // Attributes interpolate linearly in 1/w (perspective-correct).
                    let (c0, c1, c2) = (b0 * p0.2 * w, b1 * p1.2 * w, b2 * p2.2 * w);
                    if hole(c0 * a0.0 + c1 * a1.0 + c2 * a2.0, c0 * a0.1 + c1 * a1.1 + c2 * a2.1) {
                        continue;
                    }
                }
                let t = &mut map[y * r + x];
                if w < *t {
                    *t = w;
                }
            }
        }
    }
}

/// `lights-shadowmap`: [`CubeShadowMaps`] through the shared many-light shell.
pub type LightsShadowMap = LightsWithMaps<CubeShadowMaps>;

impl PerLightMaps for CubeShadowMaps {
    type Params = ShadowMapParams;
    const ID: &'static str = "lights-shadowmap";
    const STAGE: &'static str = "shadow maps";
    const FOCUS: bool = true;

    fn read_params(defaults: ShadowMapParams, params: &Params) -> Result<ShadowMapParams, ParamError> {
        defaults.read(params)
    }

    fn build(occluders: &Occluders, lights: &[WorldLight], p: &ShadowMapParams) -> Self {
        CubeShadowMaps::build(occluders, lights, p)
    }

    fn shadowed(&self, l: usize, p: Vec3, n: Vec3) -> bool {
        CubeShadowMaps::shadowed(self, l, p, n)
    }

    fn memory_bytes(&self) -> usize {
        CubeShadowMaps::memory_bytes(self)
    }

    fn estimate(lights: usize, p: &ShadowMapParams) -> (String, u64) {
        let r = p.resolution as u64;
        (format!("{lights} cube shadow maps of 6 × {r}² depths"), lights as u64 * 6 * r * r * 4)
    }
}

impl LightsShadowMap {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "lights-shadowmap",
            family: "many lights",
            reference: Some("lights-exact"),
            description: "every light at every pixel through one cube shadow map per light (the voxel-array paper's SM baseline); resolution, bias, lights, epsilon, focus (ours: auto, scene)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "lights-shadowmap", glimpse_render::Need::PunctualLights)?;
                Ok(Box::new(LightsShadowMap::new(scene, settings, params)?))
            },
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use glimpse_render::direct::{self, Shading};
    use glimpse_scene::SceneFrame;
    use glimpse_trace::{ExactTracer, GBuffer};

    /// Agreement with exact shadow rays on the Cornell box with eight point lights inside it.
    pub(crate) fn agreement(shadowed: impl Fn(&SceneFrame, &[WorldLight], usize, Vec3, Vec3) -> bool) -> (f64, usize) {
        let mut scene = glimpse_scene::load("cornell").unwrap();
        let b = scene.at(0.0).bounds;
        for k in 0..8 {
            let f = Vec3::new(0.2 + 0.08 * k as f32, 0.85, 0.3 + 0.05 * k as f32);
            scene.lights.push(glimpse_scene::Light::point(b.min + (b.max - b.min) * f, Vec3::splat(1.0)));
        }
        let frame = scene.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let g = GBuffer::new(&frame, &tracer, &scene.camera_or_default(1.0), 32, 32);
        let (mut same, mut total) = (0, 0);
        for i in (0..g.len()).filter(|&i| g.is_hit(i)) {
            let s = Shading::from_gbuffer(&g, i).unwrap();
            for (l, light) in frame.lights.iter().enumerate() {
                let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
                if s.cos(ps.wi) <= 0.0 {
                    continue;
                }
                let exact = tracer.occluded(&ps.shadow, ps.t_max);
                same += (exact == shadowed(&frame, &frame.lights, l, s.position, s.normal)) as usize;
                total += 1;
            }
        }
        (same as f64 / total as f64, total)
    }

    #[test]
    fn check_01_cube_shadow_maps_agree_with_exact_rays() {
        let maps = std::sync::OnceLock::new();
        let (a, n) = agreement(|frame, lights, l, p, nrm| {
            maps.get_or_init(|| CubeShadowMaps::build(&Occluders::whole(frame), lights, &ShadowMapParams::default())).shadowed(l, p, nrm)
        });
        println!("cube shadow maps 128², Cornell box, 8 point lights: {:.2}% of {n} facing decisions agree with exact rays", 100.0 * a);
        assert!(a > 0.95);
    }
}

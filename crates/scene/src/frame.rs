//! The scene evaluated at one time: world-space instance transforms, deformed positions,
//! world-space lights and the list of emissive triangles, sampled by power.

use crate::{LightKind, Mesh, Scene};
use glimpse_core::distribution::Distribution1D;
use glimpse_core::{Aabb, Mat4, Vec2, Vec3};
use std::borrow::Cow;

/// A punctual light at the frame's time, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldLight {
    pub kind: LightKind,
    pub intensity: Vec3,
    pub position: Vec3,
    /// Unit direction the light travels (spot, directional).
    pub direction: Vec3,
}

impl WorldLight {
    /// Direction from `p` towards the light, the distance to it (∞ for directional) and the
    /// radiance-like incident quantity: irradiance on a surface facing the light.
    pub fn incident(&self, p: Vec3) -> (Vec3, f32, Vec3) {
        match self.kind {
            LightKind::Directional => (-self.direction, f32::INFINITY, self.intensity),
            LightKind::Point | LightKind::Spot { .. } => {
                let to = self.position - p;
                let d2 = to.length_squared().max(1e-12);
                let d = d2.sqrt();
                let wi = to / d;
                let mut e = self.intensity / d2;
                if let LightKind::Spot { inner_angle, outer_angle } = self.kind {
                    e *= spot_falloff((-wi).dot(self.direction), inner_angle, outer_angle);
                }
                (wi, d, e)
            }
        }
    }
}

/// glTF's smooth spot falloff between the cosines of the outer and inner angles.
pub fn spot_falloff(cos_angle: f32, inner: f32, outer: f32) -> f32 {
    let (ci, co) = (inner.cos(), outer.cos());
    ((cos_angle - co) / (ci - co).max(1e-4)).clamp(0.0, 1.0).powi(2)
}

/// One emissive triangle in world space (an area-light piece).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissiveTriangle {
    pub vertices: [Vec3; 3],
    pub normal: Vec3,
    pub area: f32,
    pub radiance: Vec3,
    pub instance: u32,
    pub triangle: u32,
}

impl EmissiveTriangle {
    /// Uniform point on the triangle.
    pub fn sample_point(&self, u: Vec2) -> Vec3 {
        self.sample(u).0
    }

    /// Uniform point on the triangle and the magnitude its rounding error is relative to
    /// ([`glimpse_core::ray::error_scale`]).
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let b = glimpse_core::sampling::uniform_triangle(u);
        let [a, bb, c] = self.vertices;
        let w = [1.0 - b.x - b.y, b.x, b.y];
        (a * w[0] + bb * w[1] + c * w[2], glimpse_core::ray::error_scale(&self.vertices, w))
    }
}

/// The scene at one time.
pub struct SceneFrame<'a> {
    pub scene: &'a Scene,
    pub time: f32,
    /// Object-to-world matrix per instance.
    pub transforms: Vec<Mat4>,
    /// Object-space positions per mesh at this time (borrowed when the mesh does not deform).
    pub positions: Vec<Cow<'a, [Vec3]>>,
    /// Object-space normals per mesh (recomputed for deformed meshes; empty if the mesh has none).
    pub normals: Vec<Cow<'a, [Vec3]>>,
    pub lights: Vec<WorldLight>,
    pub emissive: Vec<EmissiveTriangle>,
    /// Chooses an emissive triangle with probability proportional to its power.
    pub emissive_distribution: Option<Distribution1D>,
    pub bounds: Aabb,
}

impl Scene {
    /// Evaluates every animation at time `t` (seconds).
    pub fn at(&self, t: f32) -> SceneFrame<'_> {
        let transforms: Vec<Mat4> = self.instances.iter().map(|i| i.motion.at(t)).collect();
        let (positions, normals): (Vec<_>, Vec<_>) = self
            .meshes
            .iter()
            .map(|m| match &m.deformation {
                None => (Cow::Borrowed(&m.positions[..]), Cow::Borrowed(&m.normals[..])),
                Some(d) => {
                    let p = d.positions_at(&m.positions, t);
                    let n = if m.normals.is_empty() { Vec::new() } else { Mesh::vertex_normals(&p, &m.indices) };
                    (Cow::Owned(p), Cow::Owned(n))
                }
            })
            .unzip();
        let lights = self
            .lights
            .iter()
            .map(|l| {
                let m = l.motion.at(t);
                WorldLight {
                    kind: l.kind,
                    intensity: l.intensity,
                    position: m.transform_point3(l.position),
                    direction: m.transform_vector3(l.direction).normalize_or(-Vec3::Y),
                }
            })
            .collect();
        let mut bounds = Aabb::EMPTY;
        let mut emissive = Vec::new();
        for (ii, inst) in self.instances.iter().enumerate() {
            let mesh = &self.meshes[inst.mesh as usize];
            let m = transforms[ii];
            let pos = &positions[inst.mesh as usize];
            bounds = bounds.union(Aabb::from_points(pos.iter()).transform(&m));
            let mat = &self.materials[mesh.material as usize];
            if !mat.is_emissive() {
                continue;
            }
            for (ti, tri) in mesh.indices.iter().enumerate() {
                let v = tri.map(|i| m.transform_point3(pos[i as usize]));
                let cross = (v[1] - v[0]).cross(v[2] - v[0]);
                let area = 0.5 * cross.length();
                if area > 0.0 {
                    emissive.push(EmissiveTriangle {
                        vertices: v,
                        normal: cross.normalize(),
                        area,
                        radiance: mat.emission,
                        instance: ii as u32,
                        triangle: ti as u32,
                    });
                }
            }
        }
        let emissive_distribution = (!emissive.is_empty())
            .then(|| Distribution1D::new(&emissive.iter().map(|e| e.area * glimpse_core::luminance(e.radiance)).collect::<Vec<_>>()));
        SceneFrame { scene: self, time: t, transforms, positions, normals, lights, emissive, emissive_distribution, bounds }
    }
}

impl SceneFrame<'_> {
    /// Every triangle of every instance in world space, instance by instance (the input of the
    /// voxelizers and shadow-map baselines, which do not need triangle ids).
    /// Each of [`SceneFrame::world_triangles`]' triangles' (instance, triangle), in its order.
    pub fn world_triangle_ids(&self) -> Vec<(u32, u32)> {
        let scene = self.scene;
        let mut out = Vec::with_capacity(scene.triangle_count());
        for (ii, inst) in scene.instances.iter().enumerate() {
            out.extend((0..scene.meshes[inst.mesh as usize].indices.len() as u32).map(|t| (ii as u32, t)));
        }
        out
    }

    pub fn world_triangles(&self) -> Vec<[Vec3; 3]> {
        let scene = self.scene;
        let mut out = Vec::with_capacity(scene.triangle_count());
        for (ii, inst) in scene.instances.iter().enumerate() {
            let m = self.transforms[ii];
            let pos = &self.positions[inst.mesh as usize];
            out.extend(scene.meshes[inst.mesh as usize].indices.iter().map(|t| t.map(|i| m.transform_point3(pos[i as usize]))));
        }
        out
    }
}

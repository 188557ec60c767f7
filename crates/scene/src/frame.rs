//! The scene evaluated at one time: world-space instance transforms, deformed positions,
//! world-space lights and the list of emissive triangles, sampled by power.

use crate::{LightKind, Mesh, Scene};
use glimpse_core::distribution::Distribution1D;
use glimpse_core::{Aabb, Mat3, Mat4, Vec2, Vec3};
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
    /// Per instance, the matrix that takes its object-space normals to world space (the inverse
    /// transpose of the transform's 3×3 part), computed once here rather than at every hit.
    pub normal_matrices: Vec<Mat3>,
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
        let normal_matrices = transforms.iter().map(|&m| Mat3::from_mat4(m).inverse().transpose()).collect();
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
        SceneFrame {
            scene: self,
            time: t,
            transforms,
            normal_matrices,
            positions,
            normals,
            lights,
            emissive,
            emissive_distribution,
            bounds,
        }
    }
}

impl SceneFrame<'_> {
    /// [`SceneFrame::world_triangles`] for structures voxelized or rasterized from the
    /// triangles (grids, arrays), with each alpha-masked triangle ([`crate::AlphaMask`])
    /// replaced by the pieces of its regular subdivision whose centres are covered: pieces at
    /// most 1/512 of the scene's diagonal long (under half a cell of a 128³ grid around the
    /// scene), at most 64 × 64 per triangle, and coarser where there would be over 2M in all
    /// (about twice the suite's largest scene). A grid built from them has the mask's holes,
    /// closed where a hole is under about a cell. The same list as `world_triangles` in a scene
    /// without masks. For conservative voxelizations (ROMA's and the distance field's): a
    /// voxelization that samples cell centres (the voxel array's) misses pieces under a cell.
    pub fn occluding_triangles(&self) -> Vec<[Vec3; 3]> {
        let scene = self.scene;
        let world = self.world_triangles();
        if !scene.has_alpha_masks() {
            return world;
        }
        let ids = self.world_triangle_ids();
        let masked = |instance: u32| {
            let mesh = &scene.meshes[scene.instances[instance as usize].mesh as usize];
            scene.materials[mesh.material as usize].alpha_mask.is_some()
        };
        let longest = |t: &[Vec3; 3]| (t[1] - t[0]).length().max((t[2] - t[1]).length()).max((t[0] - t[2]).length());
        // Pieces under 1/512 of the diagonal, coarser where that would pass MAX_PIECES (2M) in all
        // (a scene of many large masked triangles would otherwise take gigabytes).
        const MAX_PIECES: f64 = 2e6;
        let pieces = |max_edge: f32| -> f64 {
            world
                .iter()
                .zip(&ids)
                .filter(|(_, id)| masked(id.0))
                .map(|(t, _)| ((longest(t) / max_edge).ceil().clamp(1.0, 64.0) as f64).powi(2))
                .sum()
        };
        // Never fewer than one piece per masked triangle (each whole).
        let floor = ids.iter().filter(|id| masked(id.0)).count() as f64;
        let mut max_edge = self.bounds.extent().length() / 512.0;
        while pieces(max_edge) > MAX_PIECES.max(floor) {
            max_edge *= 1.5;
        }
        let mut out = Vec::with_capacity(world.len());
        for (t, (instance, triangle)) in world.iter().copied().zip(ids) {
            if !masked(instance) {
                out.push(t);
                continue;
            }
            let n = ((longest(&t) / max_edge).ceil() as usize).clamp(1, 64);
            let at = |i: usize, j: usize| {
                let (b1, b2) = (i as f32 / n as f32, j as f32 / n as f32);
                t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2
            };
            // Point (c1, c2) of the n × n lattice of barycentrics is covered. A piece is kept
            // where its centre is: the pieces' boundary is the mask's, to within a piece.
            let covered = |c1: f32, c2: f32| !self.cut_out_at(instance, triangle, c1 / n as f32, c2 / n as f32);
            let keep = |corners: [(f32, f32); 3]| {
                let (c1, c2) = corners.iter().fold((0.0, 0.0), |a, c| (a.0 + c.0 / 3.0, a.1 + c.1 / 3.0));
                covered(c1, c2)
            };
            for i in 0..n {
                for j in 0..n - i {
                    // The piece with its corner at (i, j), and the one turned the other way beside it.
                    let (x, y) = (i as f32, j as f32);
                    if keep([(x, y), (x + 1.0, y), (x, y + 1.0)]) {
                        out.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                    }
                    if j + 1 < n - i && keep([(x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)]) {
                        out.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                    }
                }
            }
        }
        out
    }

    /// Whether the point at barycentrics (`b1`, `b2`) of `triangle` of `instance` is cut out
    /// ([`crate::AlphaMask`]; false at once for a material without a mask).
    pub fn cut_out_at(&self, instance: u32, triangle: u32, b1: f32, b2: f32) -> bool {
        let scene = self.scene;
        let material = scene.meshes[scene.instances[instance as usize].mesh as usize].material;
        scene.materials[material as usize].alpha_mask.is_some() && scene.cut_out(material, self.uv_at(instance, triangle, b1, b2))
    }

    /// The radiance emitter `tri` emits at its barycentrics (`b1`, `b2`): its material's
    /// [`crate::EmissionMap`] texel where it has one, else `tri.radiance`; `None` where the
    /// point is cut out ([`crate::AlphaMask`]).
    pub fn emitted_at(&self, tri: &EmissiveTriangle, b1: f32, b2: f32) -> Option<Vec3> {
        let scene = self.scene;
        let material = scene.meshes[scene.instances[tri.instance as usize].mesh as usize].material;
        let m = &scene.materials[material as usize];
        if m.alpha_mask.is_none() && m.emission_map.is_none() {
            return Some(tri.radiance);
        }
        let uv = self.uv_at(tri.instance, tri.triangle, b1, b2);
        (!scene.cut_out(material, uv)).then(|| scene.emission(material, uv))
    }

    /// Texture coordinates at barycentrics (`b1`, `b2`) of `triangle` of `instance` (the
    /// barycentrics themselves where the mesh has no uvs, as the tracer's surface points).
    fn uv_at(&self, instance: u32, triangle: u32, b1: f32, b2: f32) -> Vec2 {
        let mesh = &self.scene.meshes[self.scene.instances[instance as usize].mesh as usize];
        if mesh.uvs.is_empty() {
            Vec2::new(b1, b2)
        } else {
            let [u0, u1, u2] = mesh.indices[triangle as usize].map(|i| mesh.uvs[i as usize]);
            u0 * (1.0 - b1 - b2) + u1 * b1 + u2 * b2
        }
    }

    /// Each of [`SceneFrame::world_triangles`]' triangles' (instance, triangle), in its order.
    pub fn world_triangle_ids(&self) -> Vec<(u32, u32)> {
        let scene = self.scene;
        let mut out = Vec::with_capacity(scene.triangle_count());
        for (ii, inst) in scene.instances.iter().enumerate() {
            out.extend((0..scene.meshes[inst.mesh as usize].indices.len() as u32).map(|t| (ii as u32, t)));
        }
        out
    }

    /// Every triangle of every instance in world space, instance by instance (the input of the
    /// voxelizers and shadow-map baselines, which do not need triangle ids).
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

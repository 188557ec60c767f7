//! Surface data at a hit: world position, normals, texture coordinates, material and albedo.
//!
//! Shading is two-sided: `normal` (geometric) and `shading_normal` are flipped to face the side
//! the ray came from; `front_face` records whether the triangle's winding faced the ray, which
//! one-sided emitters (area lights) need.

use crate::{Hit, SceneFrame};
use glimpse_core::{Image, Mat3, Ray, Vec2, Vec3};
use glimpse_scene::{BumpShadowing, NormalMap, NormalMapShadowing};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// The magnitude `position`'s rounding error is relative to ([`glimpse_core::ray::error_scale`]):
    /// rays leaving the surface are offset by 10⁻⁴ of it.
    pub error_scale: f32,
    /// Unit geometric normal, facing the ray's origin.
    pub normal: Vec3,
    /// Unit interpolated normal (geometric where the mesh has none), bent by the material's
    /// normal map where it has one, in `normal`'s hemisphere.
    pub shading_normal: Vec3,
    pub front_face: bool,
    pub uv: Vec2,
    /// The mesh's vertex colour here (1 where it has none), a factor of the base colour.
    pub color: Vec3,
    /// Where the material's normal map bent the normal and its format's renderer shadows the
    /// bend ([`glimpse_scene::NormalMapShadowing::Microfacet`]): the BSDF's light factor.
    pub bump_shadowing: Option<BumpShadowing>,
    pub material: u32,
    pub instance: u32,
    pub triangle: u32,
}

/// A normal map's bent normal at `uv` on the triangle with world corners `p` and texture
/// coordinates `uvs`, whose authored normal there is `n` (unit: the interpolated vertex normal,
/// or the winding's where the mesh has none). It is the front's (the side `n` points to); seen
/// from the back it is reversed whole (glTF's double-sided rule). `None` where the triangle's
/// uvs are degenerate.
fn normal_mapped(map: &NormalMap, texture: &Image, uv: Vec2, p: &[Vec3; 3], uvs: &[Vec2; 3], n: Vec3) -> Option<Vec3> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (d1, d2) = (uvs[1] - uvs[0], uvs[2] - uvs[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 {
        return None;
    }
    let dpdu = (e1 * d2.y - e2 * d1.y) / det;
    let dpdv = (e2 * d1.x - e1 * d2.x) / det;
    map.perturb(texture, uv, n, dpdu, dpdv)
}

impl SurfacePoint {
    pub fn from_hit(frame: &SceneFrame, ray: &Ray, hit: &Hit) -> Self {
        let scene = frame.scene;
        let inst = &scene.instances[hit.instance as usize];
        let mesh = &scene.meshes[inst.mesh as usize];
        let m = frame.transforms[hit.instance as usize];
        let [i0, i1, i2] = mesh.indices[hit.triangle as usize].map(|i| i as usize);
        let pos = &frame.positions[inst.mesh as usize];
        let b0 = 1.0 - hit.b1 - hit.b2;
        let p = [pos[i0], pos[i1], pos[i2]].map(|v| m.transform_point3(v));
        // Interpolating the vertices is more precise than origin + t·dir for long rays; the
        // inset keeps the point off edges shared with other meshes (see `spawn`).
        let (position, error_scale) = crate::spawn::surface_point(&p, [b0, hit.b1, hit.b2]);
        let raw = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or(Vec3::Y);
        let front_face = raw.dot(ray.dir) < 0.0;
        let normal = if front_face { raw } else { -raw };
        let uv =
            if mesh.uvs.is_empty() { Vec2::new(hit.b1, hit.b2) } else { mesh.uvs[i0] * b0 + mesh.uvs[i1] * hit.b1 + mesh.uvs[i2] * hit.b2 };
        let color =
            if mesh.colors.is_empty() { Vec3::ONE } else { mesh.colors[i0] * b0 + mesh.colors[i1] * hit.b1 + mesh.colors[i2] * hit.b2 };
        let normals = &frame.normals[inst.mesh as usize];
        let authored = if normals.is_empty() {
            raw
        } else {
            (frame.normal_matrices[hit.instance as usize] * (normals[i0] * b0 + normals[i1] * hit.b1 + normals[i2] * hit.b2))
                .normalize_or(raw)
        };
        let facing = |n: Vec3| if n.dot(normal) < 0.0 { -n } else { n };
        let mut shading_normal = facing(authored);
        let mut bump_shadowing = None;
        if let Some(map) = scene.materials[mesh.material as usize].normal_map
            && !mesh.uvs.is_empty()
        {
            let texture = &scene.textures[map.texture as usize];
            let bent = if !mesh.tangents.is_empty() && mesh.deformation.is_none() {
                // The authored tangents (their w the bitangent's sign, which a mirroring
                // placement reverses: B follows the placement, n × T does not).
                let [t0, t1, t2] = [mesh.tangents[i0], mesh.tangents[i1], mesh.tangents[i2]];
                let tangent = Mat3::from_mat4(m) * (t0.truncate() * b0 + t1.truncate() * hit.b1 + t2.truncate() * hit.b2);
                let sign = t0.w.signum() * m.determinant().signum();
                map.perturb_along(texture, uv, authored, tangent, sign)
            } else {
                let uvs = [mesh.uvs[i0], mesh.uvs[i1], mesh.uvs[i2]];
                normal_mapped(&map, texture, uv, &p, &uvs, authored)
            };
            // Reversed with the authored normal; one bent out of `normal`'s hemisphere is not used.
            let bent = bent.map(|b| if authored.dot(normal) < 0.0 { -b } else { b }).filter(|b| b.dot(normal) > 0.0);
            if let Some(bent) = bent {
                shading_normal = bent;
                bump_shadowing = (map.shadowing == NormalMapShadowing::Microfacet).then(|| BumpShadowing::new(authored, bent));
            }
        }
        SurfacePoint {
            position,
            error_scale,
            normal,
            shading_normal,
            front_face,
            uv,
            color,
            bump_shadowing,
            material: mesh.material,
            instance: hit.instance,
            triangle: hit.triangle,
        }
    }

    /// A ray leaving the surface along `dir` (either side).
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray::spawn(self.position, self.normal, self.error_scale, dir)
    }

    /// Diffuse albedo: base colour × texture × vertex colour.
    pub fn base_color(&self, frame: &SceneFrame) -> Vec3 {
        frame.scene.base_color(self.material, self.uv) * self.color
    }

    /// Emitted radiance towards the ray's origin (area lights emit from their front face only).
    pub fn emission(&self, frame: &SceneFrame) -> Vec3 {
        if self.front_face { frame.scene.emission(self.material, self.uv) } else { Vec3::ZERO }
    }
}

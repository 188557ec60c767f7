//! CS1 of the paper (§3.2, Table 1 row 1, Fig. 4): per-triangle area and normal, one parallel
//! pass over the triangles, after the CPU "animation update" that writes the world-space vertices.
//!
//! `area = ½|(B−A)×(C−A)|`, `n = normalize((B−A)×(C−A))` (the winding's geometric normal; the
//! spec's §4.3 reading). Deviation: a degenerate triangle gets area 0 and normal 0 (the paper does
//! not say); it then receives no point sample (Eq. 1 gives ⌈0⌉ = 0).

use glimpse_core::Vec3;
use glimpse_scene::SceneFrame;
use rayon::prelude::*;

/// Every triangle of the frame in world space: vertices of all instances concatenated (the
/// paper's Vertices SSBO) and indices into them (its Indices SSBO).
#[derive(Clone, Debug, Default)]
pub struct WorldMesh {
    pub vertices: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per triangle: whether its samples also trace the back hemisphere (`sides`).
    pub back: Vec<bool>,
}

impl WorldMesh {
    /// The CPU "animation update": transforms every instance's (possibly deformed) positions.
    /// `back_instances` (sorted) are the instances whose triangles sample both hemispheres.
    pub fn gather(frame: &SceneFrame, back_instances: &[u32]) -> WorldMesh {
        let mut mesh = WorldMesh::default();
        for (ii, inst) in frame.scene.instances.iter().enumerate() {
            let m = frame.transforms[ii];
            let pos = &frame.positions[inst.mesh as usize];
            let base = mesh.vertices.len() as u32;
            mesh.vertices.par_extend(pos.par_iter().map(|&p| m.transform_point3(p)));
            let indices = &frame.scene.meshes[inst.mesh as usize].indices;
            mesh.indices.extend(indices.iter().map(|t| t.map(|i| i + base)));
            let back = back_instances.binary_search(&(ii as u32)).is_ok();
            mesh.back.extend(std::iter::repeat_n(back, indices.len()));
        }
        mesh
    }

    pub fn triangle(&self, k: usize) -> [Vec3; 3] {
        self.indices[k].map(|i| self.vertices[i as usize])
    }

    pub fn memory_bytes(&self) -> usize {
        self.vertices.len() * 12 + self.indices.len() * 13
    }
}

/// Area and unit normal of one triangle (zero normal when degenerate).
pub fn area_and_normal([a, b, c]: [Vec3; 3]) -> (f32, Vec3) {
    let cross = (b - a).cross(c - a);
    (0.5 * cross.length(), cross.normalize_or_zero())
}

/// CS1: areas and normals of every triangle, in parallel.
pub fn areas_and_normals(mesh: &WorldMesh) -> (Vec<f32>, Vec<Vec3>) {
    (0..mesh.indices.len()).into_par_iter().map(|k| area_and_normal(mesh.triangle(k))).unzip()
}

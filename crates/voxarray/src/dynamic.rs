//! Dynamic scenes (§4).
//!
//! - Alg. 5, rigid instances: one array per object *type* (a mesh), built once in the mesh's own
//!   frame and shared by every instance of it; a segment is tested against the static array and
//!   then, moved into each instance's local frame by the inverse instance transform, against its
//!   type's array (one lookup per instance). The static array excludes the moving instances.
//! - Alg. 6, deforming or complex scenes: the array is rebuilt every frame from *one*
//!   rasterization: the fragments of the scene seen by V[0][0]'s orthographic view are rotated by
//!   the precomputed R(θ_i, φ_j) (no trigonometry per fragment) and set their voxel in V[i][j]
//!   and the transposed voxel in V[i][j+n/2]. Stored uncompressed (§4: compression is too slow
//!   per frame).
//!
//! Gaps filled: Alg. 6's single view rasterizes along the three axes of V[0][0] (as
//! `SPVoxelization` does), so surfaces parallel to one view axis are still sampled; fragments
//! keep their exact depth (not the voxel centre) before rotation. Parallel over θ with rayon,
//! each task owning its θ-slab (the GPU's atomic OR is not needed).

use crate::directions::Directions;
use crate::row::Row;
use crate::voxelize::{Grid, alloc_rows, rasterize, set_voxel};
use crate::{Array, Rows, VoxArray, VoxArrayParams};
use glimpse_core::{Mat4, Vec3};
use glimpse_render::direct::PunctualSample;
use glimpse_scene::SceneFrame;
use glimpse_trace::Visibility;
use rayon::prelude::*;

/// Fragment positions (cells of V[0][0]'s frame) of the three axis rasterizations.
pub fn fragments(triangles: &[[Vec3; 3]], grid: &Grid) -> Vec<Vec3> {
    let r = glimpse_core::Mat3::IDENTITY; // R(0, 0)
    let n = grid.resolution;
    triangles
        .par_chunks(1024)
        .flat_map_iter(|chunk| {
            let mut out = Vec::new();
            for t in chunk {
                let q = t.map(|p| grid.to_cells(&r, p));
                for axis in 0..3 {
                    rasterize_points(&q, axis, n, &mut out);
                }
            }
            out
        })
        .collect()
}

/// Like [`rasterize`] but emitting the fragment's position (pixel centre, exact depth).
fn rasterize_points(q: &[Vec3; 3], axis: usize, n: u32, out: &mut Vec<Vec3>) {
    let (cu, cv) = ((axis + 1) % 3, (axis + 2) % 3);
    let nrm = (q[1] - q[0]).cross(q[2] - q[0]);
    if nrm[axis].abs() < 1e-12 {
        return;
    }
    rasterize(q, axis, n, |c| {
        let mut p = Vec3::ZERO;
        p[cu] = c[cu] as f32 + 0.5;
        p[cv] = c[cv] as f32 + 0.5;
        // Depth from the plane through q[0] with normal nrm.
        p[axis] = q[0][axis] - (nrm[cu] * (p[cu] - q[0][cu]) + nrm[cv] * (p[cv] - q[0][cv])) / nrm[axis];
        out.push(p);
    });
}

/// Alg. 6: the whole array from the fragments of one rasterization.
pub fn rebuild_from_fragments<R: Row>(triangles: &[[Vec3; 3]], grid: Grid, p: &VoxArrayParams) -> Array<R> {
    let dirs = Directions::new(p.directions);
    let sw = std::time::Instant::now();
    let frags = fragments(triangles, &grid);
    let nres = R::BITS as usize;
    let per_vox = nres * nres;
    let n = dirs.n as usize;
    let half = n / 2;
    let c = Vec3::splat(grid.resolution as f32 * 0.5);
    let nf = grid.resolution as f32;
    let mut rows = alloc_rows::<R>(n * n * per_vox);
    rows.par_chunks_mut(n * per_vox).enumerate().for_each(|(i, slab)| {
        let (first, second) = slab.split_at_mut(half * per_vox);
        for j in 0..half {
            let r = dirs.rotation(i as u32, j as u32);
            let vox = &mut first[j * per_vox..(j + 1) * per_vox];
            let tra = &mut second[j * per_vox..(j + 1) * per_vox];
            for f in &frags {
                let q = r * (*f - c) + c;
                if q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0 && q.x < nf && q.y < nf && q.z < nf {
                    let (x, y, z) = (q.x as u32, q.y as u32, q.z as u32);
                    set_voxel(vox, R::BITS, x, y, z);
                    set_voxel(tra, R::BITS, x, R::BITS - 1 - z, y);
                }
            }
        }
    });
    let build_ms = sw.elapsed().as_secs_f64() * 1e3;
    Array {
        grid,
        dirs,
        rows: Rows::Plain(rows),
        bias_start_cells: p.bias_start_cells,
        bias_end_cells: p.bias_end_cells,
        normal_offset_cells: p.normal_offset_cells,
        skip_start_run: p.skip_start_run,
        build_ms,
        compression: None,
        clip_to_sphere: false,
    }
}

/// Alg. 6 over a frame at the run-time resolution.
pub fn rebuild(frame: &SceneFrame, p: &VoxArrayParams) -> VoxArray {
    let tris = frame.world_triangles();
    match p.resolution {
        32 => VoxArray::R32(rebuild_from_fragments(&tris, Grid::around(&tris, 32), p)),
        64 => VoxArray::R64(rebuild_from_fragments(&tris, Grid::around(&tris, 64), p)),
        _ => VoxArray::R128(rebuild_from_fragments(&tris, Grid::around(&tris, 128), p)),
    }
}

/// Alg. 5: a static array plus one array per object type for the rigid moving instances.
#[derive(Clone, Debug)]
pub struct Instanced {
    /// The instances that do not move (`None` if there are none).
    pub static_part: Option<VoxArray>,
    /// Per mesh index: the type's array in the mesh's own frame (built once).
    pub types: Vec<Option<VoxArray>>,
    /// (type = mesh index, world-to-local transform) of every moving instance at this frame.
    pub instances: Vec<(u32, Mat4)>,
    pub build_ms: f64,
}

impl Instanced {
    /// Builds the static array (instances with static motion) and one array per mesh used by a
    /// moving instance, with `p` for the static part and `p_types` for the types.
    pub fn build(frame: &SceneFrame, p: &VoxArrayParams, p_types: &VoxArrayParams) -> Self {
        let sw = std::time::Instant::now();
        let scene = frame.scene;
        let mut statics = Vec::new();
        let mut types: Vec<Option<VoxArray>> = vec![None; scene.meshes.len()];
        for (ii, inst) in scene.instances.iter().enumerate() {
            let mesh = &scene.meshes[inst.mesh as usize];
            let pos = &frame.positions[inst.mesh as usize];
            if inst.motion.is_static() {
                let m = frame.transforms[ii];
                statics.extend(mesh.indices.iter().map(|t| t.map(|i| m.transform_point3(pos[i as usize]))));
            } else if types[inst.mesh as usize].is_none() {
                let local: Vec<[Vec3; 3]> = mesh.indices.iter().map(|t| t.map(|i| pos[i as usize])).collect();
                types[inst.mesh as usize] = Some(VoxArray::from_triangles(&local, p_types));
            }
        }
        let static_part = (!statics.is_empty()).then(|| VoxArray::from_triangles(&statics, p));
        let mut s = Self { static_part, types, instances: Vec::new(), build_ms: 0.0 };
        s.update(frame);
        s.build_ms = sw.elapsed().as_secs_f64() * 1e3;
        s
    }

    /// Moves the instances to `frame` (no array is rebuilt).
    pub fn update(&mut self, frame: &SceneFrame) {
        self.instances = frame
            .scene
            .instances
            .iter()
            .enumerate()
            .filter(|(_, inst)| !inst.motion.is_static())
            .map(|(ii, inst)| (inst.mesh, frame.transforms[ii].inverse()))
            .collect();
    }

    /// Alg. 5 on the segment `start → end`.
    pub fn occluded_segment(&self, start: Vec3, end: Vec3) -> bool {
        if self.static_part.as_ref().is_some_and(|a| a.occluded_segment(start, end)) {
            return true;
        }
        self.instances.iter().any(|(t, inv)| {
            self.types[*t as usize].as_ref().is_some_and(|a| a.occluded_segment(inv.transform_point3(start), inv.transform_point3(end)))
        })
    }

    /// Alg. 5 on a shadow sample of a surface point: [`Self::surface_segment`]'s segment.
    pub fn occluded_from_surface(&self, ps: &PunctualSample, normal: Vec3) -> bool {
        let (start, end) = self.surface_segment(ps, normal);
        self.occluded_segment(start, end)
    }

    /// The segment [`Self::occluded_from_surface`] queries: the start moved along the normal by
    /// the static array's `normal_offset_cells` (see [`crate::Array::occluded_from_surface`]),
    /// the end cut where the shadow ray leaves the static array's grid (its cells, not a type's,
    /// measure the offset and the cut: the segment starts and ends in the world).
    pub fn surface_segment(&self, ps: &PunctualSample, normal: Vec3) -> (Vec3, Vec3) {
        let (cell, off, far) = self.static_part.as_ref().map_or((0.0, 0.0, 1e6), |a| {
            let g = a.grid();
            (1.0 / g.scale, a.normal_offset_cells(), (ps.shadow.origin - g.center).length() + 0.87 * g.resolution as f32 / g.scale)
        });
        let n = if normal.dot(ps.shadow.dir) < 0.0 { -normal } else { normal };
        (ps.shadow.origin + n * (off * cell), ps.shadow.at(ps.t_max.min(far)))
    }

    pub fn memory_bytes(&self) -> usize {
        self.static_part.as_ref().map_or(0, |a| a.memory_bytes()) + self.types.iter().flatten().map(|a| a.memory_bytes()).sum::<usize>()
    }
}

impl Visibility for Instanced {
    fn occluded(&self, ray: &glimpse_core::Ray, t_max: f32) -> bool {
        let far = self.static_part.as_ref().map_or(1e6, |a| {
            let g = a.grid();
            (ray.origin - g.center).length() + 0.87 * g.resolution as f32 / g.scale
        });
        self.occluded_segment(ray.origin, ray.at(t_max.min(far)))
    }
}

//! Alg. 1, "Construction of 2D array of voxelizations", and its `SPVoxelization` (§3.1): for every
//! (θ, φ) the scene is voxelized in the rotated frame by the single-pass method of [28]
//! (Eisemann & Décoret: rasterize with an orthographic view, set the bit of the voxel containing
//! each fragment), once along each of the rotated x, y and z axes, OR-ed into one grid (§3.1:
//! "voxelization is performed three times … once for each of the x, y, and z directions").
//! The (θ, φ+90°) voxelization is the index transposition of the (θ, φ) one
//! (`y' = N−1−z, z' = y`; spec §2.2), written in the same pass.
//!
//! Deviations and gaps filled:
//! - CPU rasterization, not the GPU: fragments are pixel centres `(u+½, v+½)` inside the
//!   projected triangle (edges inclusive), depth interpolated from the triangle's plane.
//! - The loops run over θ_i, i < n, and φ_j, j < n/2, in parallel over i with rayon (the paper's
//!   GPU runs them sequentially); each task owns its θ-slab of the flat row array, so no locks.
//! - One cube grid for all rotations: centred at the bounding-sphere centre (the AABB centre),
//!   side = 2 × the largest vertex distance from it (spec §2.2), so every rotation fits and 90°
//!   rotations map the grid onto itself.

use crate::directions::Directions;
use crate::row::Row;
use glimpse_core::{Mat3, Vec3};
use rayon::prelude::*;

/// The shared cube of every voxelization: `q = R·(p − center)·scale + N/2` (cells).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub resolution: u32,
    pub center: Vec3,
    /// Cells per world unit (N / side).
    pub scale: f32,
}

impl Grid {
    /// The cube around `triangles` (world space); a unit cube at the origin if there are none.
    pub fn around(triangles: &[[Vec3; 3]], resolution: u32) -> Grid {
        let (lo, hi) = triangles
            .iter()
            .flatten()
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let center = if lo.x <= hi.x { (lo + hi) * 0.5 } else { Vec3::ZERO };
        let radius = triangles.iter().flatten().fold(0.0f32, |r, p| r.max((*p - center).length()));
        let side = (2.0 * radius * 1.001).max(1e-3);
        Grid { resolution, center, scale: resolution as f32 / side }
    }

    pub fn cell_size_world(&self) -> f32 {
        1.0 / self.scale
    }

    /// [`Grid::to_cells`] for voxelization (i, j), rotating with `dirs`' cos/sin table.
    #[inline]
    pub fn to_cells_ij(&self, dirs: &Directions, i: u32, j: u32, p: Vec3) -> Vec3 {
        dirs.rotate(i, j, (p - self.center) * self.scale) + Vec3::splat(self.resolution as f32 * 0.5)
    }

    #[inline]
    pub fn to_cells(&self, rotation: &Mat3, p: Vec3) -> Vec3 {
        *rotation * ((p - self.center) * self.scale) + Vec3::splat(self.resolution as f32 * 0.5)
    }
}

/// Sets voxel (x, y, z) of one voxelization (rows along z, row index `y·N + x`).
#[inline]
pub fn set_voxel<R: Row>(vox: &mut [R], n: u32, x: u32, y: u32, z: u32) {
    let r = &mut vox[(y * n + x) as usize];
    *r = r.or(R::bit(z));
}

/// `SPVoxelization` of one frame: the triangles (already in cells of that frame) rasterized
/// along x, y and z into `vox` (N² rows).
pub fn sp_voxelization<R: Row>(cells: &[[Vec3; 3]], vox: &mut [R]) {
    let n = R::BITS;
    for t in cells {
        for axis in 0..3 {
            rasterize(t, axis, n, |c| set_voxel(vox, n, c[0], c[1], c[2]));
        }
    }
}

/// Fragments of triangle `q` (cells) rasterized orthographically along `axis`: one voxel per
/// covered pixel centre, at the depth of the triangle's plane there. Calls `emit([x, y, z])`.
#[inline]
pub fn rasterize(q: &[Vec3; 3], axis: usize, n: u32, mut emit: impl FnMut([u32; 3])) {
    let (cu, cv) = ((axis + 1) % 3, (axis + 2) % 3);
    let (a, b, c) = (q[0], q[1], q[2]);
    let area = (b[cu] - a[cu]) * (c[cv] - a[cv]) - (b[cv] - a[cv]) * (c[cu] - a[cu]);
    if area.abs() < 1e-12 {
        return; // edge-on in this view: no fragments
    }
    let lo_u = a[cu].min(b[cu]).min(c[cu]);
    let hi_u = a[cu].max(b[cu]).max(c[cu]);
    let lo_v = a[cv].min(b[cv]).min(c[cv]);
    let hi_v = a[cv].max(b[cv]).max(c[cv]);
    // Pixel centres u + ½ in [lo, hi].
    let u0 = (lo_u - 0.5).ceil().max(0.0);
    let u1 = (hi_u - 0.5).floor().min(n as f32 - 1.0);
    let v0 = (lo_v - 0.5).ceil().max(0.0);
    let v1 = (hi_v - 0.5).floor().min(n as f32 - 1.0);
    if u0 > u1 || v0 > v1 {
        return;
    }
    let inv = 1.0 / area;
    let edge = |p: Vec3, q: Vec3, u: f32, v: f32| (q[cu] - p[cu]) * (v - p[cv]) - (q[cv] - p[cv]) * (u - p[cu]);
    for v in v0 as u32..=v1 as u32 {
        let pv = v as f32 + 0.5;
        for u in u0 as u32..=u1 as u32 {
            let pu = u as f32 + 0.5;
            let w0 = edge(b, c, pu, pv) * inv;
            let w1 = edge(c, a, pu, pv) * inv;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let depth = w0 * a[axis] + w1 * b[axis] + w2 * c[axis];
            if !(0.0..n as f32).contains(&depth) {
                continue;
            }
            let mut cell = [0u32; 3];
            cell[cu] = u;
            cell[cv] = v;
            cell[axis] = depth as u32;
            emit(cell);
        }
    }
}

/// Writes the 90°-rotated copy of `vox` into `out` (both N² rows): the voxel (x, y, z) of `vox`
/// becomes (x, N−1−z, y) of `out` (spec §2.2: `R(θ, φ+90°) = Rx(90°)·R(θ, φ)`).
pub fn transpose<R: Row>(vox: &[R], out: &mut [R]) {
    let n = R::BITS;
    out.fill(R::ZERO);
    for y in 0..n {
        for x in 0..n {
            let mut bits = vox[(y * n + x) as usize].to_u128();
            while bits != 0 {
                let z = bits.trailing_zeros();
                bits &= bits - 1;
                set_voxel(out, n, x, n - 1 - z, y);
            }
        }
    }
}

/// Alg. 1: every voxelization of the `n × n` array, rows flat at `((i·n + j)·N + y)·N + x`.
pub fn build_array<R: Row>(triangles: &[[Vec3; 3]], grid: &Grid, dirs: &Directions) -> Vec<R> {
    let nres = R::BITS as usize;
    let per_vox = nres * nres;
    let n = dirs.n as usize;
    let half = n / 2;
    let mut rows = alloc_rows::<R>(n * n * per_vox);
    rows.par_chunks_mut(n * per_vox).enumerate().for_each(|(i, slab)| {
        let (first, second) = slab.split_at_mut(half * per_vox);
        let mut cells = Vec::with_capacity(triangles.len());
        for j in 0..half {
            let r = dirs.rotation(i as u32, j as u32);
            cells.clear();
            cells.extend(triangles.iter().map(|t| t.map(|p| grid.to_cells(&r, p))));
            let vox = &mut first[j * per_vox..(j + 1) * per_vox];
            sp_voxelization(&cells, vox);
            transpose(vox, &mut second[j * per_vox..(j + 1) * per_vox]);
        }
    });
    rows
}

/// A zeroed row array, backed by transparent huge pages where the OS allows (Linux madvise):
/// the query is one random row load per ray, and 4 KiB pages make that a TLB miss too.
pub fn alloc_rows<R: Row>(len: usize) -> Vec<R> {
    let mut v: Vec<R> = Vec::with_capacity(len);
    #[cfg(target_os = "linux")]
    {
        let bytes = len * std::mem::size_of::<R>();
        let start = v.as_mut_ptr() as usize;
        let aligned = start.next_multiple_of(4096);
        if bytes > (4 << 20) && aligned < start + bytes {
            // SAFETY: the range lies inside `v`'s allocation (capacity `len`); MADV_HUGEPAGE only
            // changes how the kernel backs the pages and never their contents.
            unsafe {
                libc::madvise(aligned as *mut libc::c_void, start + bytes - aligned, libc::MADV_HUGEPAGE);
            }
        }
    }
    v.resize(len, R::ZERO);
    v
}

/// One voxelization computed directly at rotation `r` (for the transposition check).
pub fn voxelize_direct<R: Row>(triangles: &[[Vec3; 3]], grid: &Grid, r: &Mat3) -> Vec<R> {
    let n = R::BITS as usize;
    let mut vox = vec![R::ZERO; n * n];
    let cells: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|p| grid.to_cells(r, p))).collect();
    sp_voxelization(&cells, &mut vox);
    vox
}

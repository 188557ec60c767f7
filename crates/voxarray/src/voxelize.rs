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

    /// The cube around the bounding sphere of `bounds` (a focus: [`glimpse_render::focus`]).
    pub fn around_box(bounds: glimpse_core::Aabb, resolution: u32) -> Grid {
        let side = (bounds.extent().length() * 1.001).max(1e-3);
        Grid { resolution, center: bounds.center(), scale: resolution as f32 / side }
    }

    /// Whether a triangle can set a voxel a query inside the grid's sphere reads: its box
    /// overlaps the sphere (grown by two cells).
    pub fn may_touch(&self, t: &[Vec3; 3]) -> bool {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        let nearest = self.center.clamp(lo, hi);
        let reach = (0.5 * self.resolution as f32 + 2.0) / self.scale;
        (nearest - self.center).length_squared() <= reach * reach
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

/// `SPVoxelization` of one frame: the triangles (in cells of that frame) rasterized along x, y
/// and z into `vox` (N² rows). They come as an iterator, so a caller transforms them on the way
/// without a scratch buffer.
pub fn sp_voxelization<R: Row>(cells: impl IntoIterator<Item = [Vec3; 3]>, vox: &mut [R]) {
    let n = R::BITS;
    for t in cells {
        let t = &t;
        // Most triangles of a detailed mesh are smaller than a cell and cover no pixel centre
        // in any of the three views: one test of the three coordinate ranges skips them (each
        // view needs a centre in both of its pixel coordinates). The fragments are the same.
        let centred = centre_ranges(t, n);
        if centred & 0b110 == 0b110 {
            rasterize_along::<0>(t, n, |c| set_voxel(vox, n, c[0], c[1], c[2]));
        }
        if centred & 0b101 == 0b101 {
            rasterize_along::<1>(t, n, |c| set_voxel(vox, n, c[0], c[1], c[2]));
        }
        if centred & 0b011 == 0b011 {
            rasterize_along::<2>(t, n, |c| set_voxel(vox, n, c[0], c[1], c[2]));
        }
    }
}

/// Bit `a` set where the triangle's range along coordinate `a` holds a pixel centre k + ½ of
/// the grid (0 ≤ k < n): [`rasterize_along`]'s first rejection, with the same arithmetic.
#[inline]
fn centre_ranges(q: &[Vec3; 3], n: u32) -> u32 {
    let lo = q[0].min(q[1]).min(q[2]);
    let hi = q[0].max(q[1]).max(q[2]);
    let first = (lo - 0.5).ceil().max(Vec3::ZERO);
    let last = (hi - 0.5).floor().min(Vec3::splat(n as f32 - 1.0));
    first.cmple(last).bitmask()
}

/// Fragments of triangle `q` (cells) rasterized orthographically along `axis`: one voxel per
/// covered pixel centre, at the depth of the triangle's plane there. Calls `emit([x, y, z])`.
#[inline]
pub fn rasterize(q: &[Vec3; 3], axis: usize, n: u32, emit: impl FnMut([u32; 3])) {
    match axis {
        0 => rasterize_along::<0>(q, n, emit),
        1 => rasterize_along::<1>(q, n, emit),
        _ => rasterize_along::<2>(q, n, emit),
    }
}

/// [`rasterize`] with the axis known at compile time (the coordinate picks are then plain
/// fields, not a run-time `Vec3` index in the fragment loop). Each scanline visits only the
/// pixels between its conservative edge crossings (widened by a pixel), and tests each with the
/// same arithmetic as a full bounding-box scan, so the fragments are the same.
#[inline]
fn rasterize_along<const AXIS: usize>(q: &[Vec3; 3], n: u32, mut emit: impl FnMut([u32; 3])) {
    let (cu, cv) = ((AXIS + 1) % 3, (AXIS + 2) % 3);
    let pick = |p: Vec3| (p[cu], p[cv], p[AXIS]);
    let ((au, av, ad), (bu, bv, bd), (cu_, cv_, cd)) = (pick(q[0]), pick(q[1]), pick(q[2]));
    let area = (bu - au) * (cv_ - av) - (bv - av) * (cu_ - au);
    if area.abs() < 1e-12 {
        return; // edge-on in this view: no fragments
    }
    let lo_u = au.min(bu).min(cu_);
    let hi_u = au.max(bu).max(cu_);
    let lo_v = av.min(bv).min(cv_);
    let hi_v = av.max(bv).max(cv_);
    // Pixel centres u + ½ in [lo, hi].
    let u0 = (lo_u - 0.5).ceil().max(0.0);
    let u1 = (hi_u - 0.5).floor().min(n as f32 - 1.0);
    let v0 = (lo_v - 0.5).ceil().max(0.0);
    let v1 = (hi_v - 0.5).floor().min(n as f32 - 1.0);
    if u0 > u1 || v0 > v1 {
        return;
    }
    let inv = 1.0 / area;
    let edge = |pu: f32, pv: f32, qu: f32, qv: f32, u: f32, v: f32| (qu - pu) * (v - pv) - (qv - pv) * (u - pu);
    let nf = n as f32;
    let edges = [(bu, bv, cu_, cv_), (cu_, cv_, au, av), (au, av, bu, bv)];
    for v in v0 as u32..=v1 as u32 {
        let pv = v as f32 + 0.5;
        // Where this scanline crosses each edge's line; the inside is on one side of each. A
        // pixel beyond a crossing by more than a pixel is outside whatever the rounding.
        let (mut lo, mut hi) = (u0, u1);
        for &(pu_, pv_, qu, qv) in &edges {
            let dv = qv - pv_;
            if dv.abs() < 1e-6 {
                continue; // (nearly) parallel to the scanline: no bound from this edge
            }
            let cross = pu_ + (qu - pu_) * (pv - pv_) / dv;
            // e(u) = (qu−pu)(v−pv) − dv (u − pu): falls with u when dv·inv > 0, so the inside
            // (e·inv ≥ 0) is u ≤ cross there, u ≥ cross otherwise.
            if (dv > 0.0) == (inv > 0.0) {
                hi = hi.min((cross + 1.0).floor());
            } else {
                lo = lo.max((cross - 1.0).ceil());
            }
        }
        if lo > hi {
            continue;
        }
        for u in lo as u32..=hi as u32 {
            let pu = u as f32 + 0.5;
            let w0 = edge(bu, bv, cu_, cv_, pu, pv) * inv;
            let w1 = edge(cu_, cv_, au, av, pu, pv) * inv;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let depth = w0 * ad + w1 * bd + w2 * cd;
            if !(0.0..nf).contains(&depth) {
                continue;
            }
            let mut cell = [0u32; 3];
            cell[cu] = u;
            cell[cv] = v;
            cell[AXIS] = depth as u32;
            emit(cell);
        }
    }
}

/// Writes the 90°-rotated copy of `vox` into `out` (both N² rows): the voxel (x, y, z) of `vox`
/// becomes (x, N−1−z, y) of `out` (spec §2.2: `R(θ, φ+90°) = Rx(90°)·R(θ, φ)`).
///
/// For each x the N rows `vox[y·N + x]` form an N × N bit matrix M (row y, bit z), and
/// `out[y'·N + x]` has bit y set where M has bit N−1−y' in row y: row N−1−y' of Mᵀ. The matrix
/// is transposed by log2 N rounds of block swaps (Hacker's Delight §7-3), not bit by bit.
pub fn transpose<R: Row>(vox: &[R], out: &mut [R]) {
    let n = R::BITS as usize;
    let mut m = [0u128; 128];
    for x in 0..n {
        for (y, w) in m[..n].iter_mut().enumerate() {
            *w = vox[y * n + x].to_u128();
        }
        transpose_bits(&mut m[..n]);
        for y_out in 0..n {
            out[y_out * n + x] = R::from_u128(m[n - 1 - y_out]);
        }
    }
}

/// `CLEAR_BIT_MASKS[k]`: the bit positions b < 128 whose bit `1 << k` is clear.
const CLEAR_BIT_MASKS: [u128; 7] = {
    let mut m = [0u128; 7];
    let mut k = 0;
    while k < 7 {
        let mut b = 0;
        while b < 128 {
            if b & (1 << k) == 0 {
                m[k] |= 1 << b;
            }
            b += 1;
        }
        k += 1;
    }
    m
};

/// In-place transpose of an n × n bit matrix (n = `a.len()`, a power of two ≤ 128; bit b of
/// word i is element (i, b)): each round swaps, in every 2j × 2j block, element (k, b + j) with
/// (k + j, b) for the rows k and bits b whose j bit is clear.
fn transpose_bits(a: &mut [u128]) {
    let n = a.len();
    let mut j = n / 2;
    while j > 0 {
        let mask = CLEAR_BIT_MASKS[j.trailing_zeros() as usize];
        for k in (0..n).filter(|k| k & j == 0) {
            let t = ((a[k] >> j) ^ a[k + j]) & mask;
            a[k + j] ^= t;
            a[k] ^= t << j;
        }
        j /= 2;
    }
}

/// The triangles with their vertices clustered to cubes of `quantum_cells` cells (each vertex
/// moved to the mean of the vertices in its cube), dropping those that collapse (two corners in
/// one cube) and repeats. A deviation from the paper (`cluster=0` turns it off): its GPU
/// rasterizes a million triangles per voxelization at little cost, while here each triangle costs
/// its setup in every one of the n²/2 voxelizations even when it is far smaller than a voxel and
/// covers no pixel centre (the 1M-triangle suite scene: 311 s). Clustering at a quarter cell
/// keeps every surface within ≈ 0.2 cells of where it was and leaves meshes of voxel-sized or
/// larger triangles as they are (a vertex alone in its cube, or its exact duplicates, keeps its
/// position bit for bit: the mean is summed in f64).
pub fn cluster_vertices(triangles: &[[Vec3; 3]], grid: &Grid, quantum_cells: f32) -> Vec<[Vec3; 3]> {
    use rustc_hash::{FxHashMap, FxHashSet};
    type Key = (i32, i32, i32);
    let per_world = grid.scale / quantum_cells;
    let key = |p: Vec3| -> Key {
        let c = ((p - grid.center) * per_world).floor();
        (c.x as i32, c.y as i32, c.z as i32)
    };
    let mut sums: FxHashMap<Key, ([f64; 3], u32)> = FxHashMap::default();
    for p in triangles.iter().flatten() {
        let e = sums.entry(key(*p)).or_insert(([0.0; 3], 0));
        (e.0[0], e.0[1], e.0[2], e.1) = (e.0[0] + p.x as f64, e.0[1] + p.y as f64, e.0[2] + p.z as f64, e.1 + 1);
    }
    let mean = |k: &Key| -> Vec3 {
        let (s, c) = sums[k];
        Vec3::new((s[0] / c as f64) as f32, (s[1] / c as f64) as f32, (s[2] / c as f64) as f32)
    };
    let mut seen: FxHashSet<[Key; 3]> = FxHashSet::default();
    let mut out = Vec::new();
    for t in triangles {
        let k = t.map(key);
        if k[0] == k[1] || k[1] == k[2] || k[0] == k[2] {
            continue;
        }
        let mut sorted = k;
        sorted.sort_unstable();
        if seen.insert(sorted) {
            out.push([mean(&k[0]), mean(&k[1]), mean(&k[2])]);
        }
    }
    out
}

/// Alg. 1: every voxelization of the `n × n` array, rows flat at `((i·n + j)·N + y)·N + x`.
pub fn build_array<R: Row>(triangles: &[[Vec3; 3]], grid: &Grid, dirs: &Directions) -> Vec<R> {
    let per_slab = slab_rows::<R>(dirs);
    let mut rows = alloc_rows::<R>(dirs.n as usize * per_slab);
    rows.par_chunks_mut(per_slab).enumerate().for_each(|(i, slab)| voxelize_slab(triangles, grid, dirs, i, slab));
    rows
}

/// Rows of one θ-slab (the `n` voxelizations of one θ_i).
pub fn slab_rows<R: Row>(dirs: &Directions) -> usize {
    dirs.n as usize * (R::BITS as usize).pow(2)
}

/// The voxelizations (θ_i, φ_j) for every j into `slab` (zeroed, [`slab_rows`] long): the first
/// half rasterized, the second half their 90° transpositions.
pub fn voxelize_slab<R: Row>(triangles: &[[Vec3; 3]], grid: &Grid, dirs: &Directions, i: usize, slab: &mut [R]) {
    let per_vox = (R::BITS as usize).pow(2);
    let half = dirs.n as usize / 2;
    let (first, second) = slab.split_at_mut(half * per_vox);
    // `Grid::to_cells` in two parts: the grid's offset and scale once per slab, the rotation per
    // voxelization (the same operations in the same order, so the same cells).
    let scaled: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|p| (p - grid.center) * grid.scale)).collect();
    let half_grid = Vec3::splat(grid.resolution as f32 * 0.5);
    for j in 0..half {
        let r = dirs.rotation(i as u32, j as u32);
        let vox = &mut first[j * per_vox..(j + 1) * per_vox];
        sp_voxelization(scaled.iter().map(|t| t.map(|q| r * q + half_grid)), vox);
        transpose(vox, &mut second[j * per_vox..(j + 1) * per_vox]);
    }
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
    sp_voxelization(triangles.iter().map(|t| t.map(|p| grid.to_cells(r, p))), &mut vox);
    vox
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first version: every pixel of the bounding box tested (the reference for the spans).
    fn full_scan(q: &[Vec3; 3], axis: usize, n: u32) -> Vec<[u32; 3]> {
        let (cu, cv) = ((axis + 1) % 3, (axis + 2) % 3);
        let (a, b, c) = (q[0], q[1], q[2]);
        let area = (b[cu] - a[cu]) * (c[cv] - a[cv]) - (b[cv] - a[cv]) * (c[cu] - a[cu]);
        let mut out = Vec::new();
        if area.abs() < 1e-12 {
            return out;
        }
        let u0 = (a[cu].min(b[cu]).min(c[cu]) - 0.5).ceil().max(0.0);
        let u1 = (a[cu].max(b[cu]).max(c[cu]) - 0.5).floor().min(n as f32 - 1.0);
        let v0 = (a[cv].min(b[cv]).min(c[cv]) - 0.5).ceil().max(0.0);
        let v1 = (a[cv].max(b[cv]).max(c[cv]) - 0.5).floor().min(n as f32 - 1.0);
        if u0 > u1 || v0 > v1 {
            return out;
        }
        let inv = 1.0 / area;
        let edge = |p: Vec3, q: Vec3, u: f32, v: f32| (q[cu] - p[cu]) * (v - p[cv]) - (q[cv] - p[cv]) * (u - p[cu]);
        for v in v0 as u32..=v1 as u32 {
            for u in u0 as u32..=u1 as u32 {
                let (pu, pv) = (u as f32 + 0.5, v as f32 + 0.5);
                let (w0, w1) = (edge(b, c, pu, pv) * inv, edge(c, a, pu, pv) * inv);
                let w2 = 1.0 - w0 - w1;
                let depth = w0 * a[axis] + w1 * b[axis] + w2 * c[axis];
                if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 && (0.0..n as f32).contains(&depth) {
                    let mut cell = [0u32; 3];
                    (cell[cu], cell[cv], cell[axis]) = (u, v, depth as u32);
                    out.push(cell);
                }
            }
        }
        out
    }

    /// The block transposition equals the bit-by-bit one (the first version) on random sparse
    /// voxelizations at every row width.
    #[test]
    fn block_transpose_equals_bitwise() {
        fn bitwise<R: Row>(vox: &[R]) -> Vec<R> {
            let n = R::BITS;
            let mut out = vec![R::ZERO; vox.len()];
            for y in 0..n {
                for x in 0..n {
                    let mut bits = vox[(y * n + x) as usize].to_u128();
                    while bits != 0 {
                        let z = bits.trailing_zeros();
                        bits &= bits - 1;
                        set_voxel(&mut out, n, x, n - 1 - z, y);
                    }
                }
            }
            out
        }
        fn check<R: Row>(seed: u64) {
            let mut s = seed;
            let mut next = || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                s
            };
            let n = R::BITS as usize;
            let vox: Vec<R> =
                (0..n * n).map(|_| R::from_u128(((next() & next() & next()) as u128) << 64 | (next() & next()) as u128)).collect();
            let mut out = vec![R::ZERO; n * n];
            transpose(&vox, &mut out);
            assert_eq!(out, bitwise(&vox), "{n}-bit rows");
        }
        check::<u32>(1);
        check::<u64>(2);
        check::<u128>(3);
    }

    /// The span-bounded rasterizer emits exactly the full scan's fragments, for random
    /// triangles of every size (sub-pixel to the whole grid), pixel-aligned vertices and slivers.
    #[test]
    fn spans_emit_the_full_scans_fragments() {
        let mut state = 11u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let n = 64u32;
        let (mut triangles, mut fragments, mut differ, mut voxels_differ) = (0, 0, 0, 0);
        for k in 0..20_000 {
            let scale = [0.3, 2.0, 10.0, 80.0][k % 4];
            let c = Vec3::new(rnd(), rnd(), rnd()) * 70.0 - Vec3::splat(3.0);
            let mut q = [0; 3].map(|_| c + (Vec3::new(rnd(), rnd(), rnd()) - Vec3::splat(0.5)) * scale);
            match k % 7 {
                5 => q = q.map(|p| (p * 2.0).round() * 0.5), // on pixel centres and edges
                6 => q[2] = q[0] + (q[1] - q[0]) * rnd() + Vec3::splat(1e-3 * rnd()), // a sliver
                _ => {}
            }
            let mut want_voxels = vec![0u64; (n * n) as usize];
            for axis in 0..3 {
                let want = full_scan(&q, axis, n);
                let mut got = Vec::new();
                rasterize(&q, axis, n, |c| got.push(c));
                triangles += 1;
                fragments += want.len();
                differ += (got != want) as usize;
                want.iter().for_each(|c| set_voxel(&mut want_voxels, n, c[0], c[1], c[2]));
            }
            // The whole SPVoxelization, with its skip of triangles that cover no pixel centre.
            let mut voxels = vec![0u64; (n * n) as usize];
            sp_voxelization([q], &mut voxels);
            voxels_differ += (voxels != want_voxels) as usize;
        }
        println!(
            "{triangles} triangle-axis rasterizations, {fragments} fragments; {differ} differ from the full scan, \
             {voxels_differ} voxelizations"
        );
        assert_eq!(differ, 0);
        assert_eq!(voxels_differ, 0);
    }
}

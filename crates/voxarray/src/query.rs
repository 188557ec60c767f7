//! Alg. 3, `Intersect((V', D), k, r)`: pick the voxelization whose rows are most aligned with the
//! segment (line 1), fetch the row through the segment's midpoint (line 3), clip it to the
//! segment's extent along the row (lines 4–6) and report any set bit (line 7).
//!
//! Deviations and gaps filled (spec §2.5):
//! - Erratum fixed: the clip is inclusive, `[s, e]` — the literal lines 5–6,
//!   `(row << s) >> (s + L − e)`, drop voxel `e`, contradicting the Fig. 4 example. We clip with
//!   a mask (`row & mask(s..=e)`), which also avoids shifting by the full row width when
//!   `s = 0` or `e = L−1`. [`clip_msb_first`] is the corrected shift form, kept to pin Fig. 4.
//! - Grid frame: `q = R_ij·(p − c)·scale + N/2`; the row is `(⌊q_mid.x⌋, ⌊q_mid.y⌋)`; a midpoint
//!   outside the grid's N² rows means "no hit".
//! - Bias (the paper has none; a surface point lies in an occupied voxel, so a literal query
//!   would report every light occluded): the extent is shrunk by `bias_start_cells` at the
//!   segment's start (the shaded point) and `bias_end_cells` at its end (the light, which may sit
//!   on a surface: the paper's TV and VPLs), measured in cells along the row axis:
//!   `s = ⌊z_start + b_start⌋`, `e = ⌊z_end − b_end⌋` (for a start below the end; mirrored
//!   otherwise). Callers that know the surface normal (`lights-voxarray`, the ε metrics) also
//!   move the start along it ([`crate::VoxArrayParams::normal_offset_cells`]); the
//!   `Visibility` trait, which gets no normal, instead skips the run of occupied voxels touching
//!   the start ([`clip_hits_after_start_run`]) when `skip_start_run` is on.

use crate::directions::Directions;
use crate::row::Row;
use crate::voxelize::Grid;
use glimpse_core::Vec3;

/// Which row, and which voxels of it, a segment covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Extent {
    /// Voxelization `i·n + j`.
    pub voxelization: u32,
    pub x: u32,
    pub y: u32,
    /// First and last voxel, inclusive (`s ≤ e < N`).
    pub s: u32,
    pub e: u32,
    /// The segment's start (the shaded point) is at the `s` end of the row.
    pub start_low: bool,
}

impl Extent {
    /// Index of the row in the flat row array.
    #[inline]
    pub fn row_index(&self, n_res: u32) -> usize {
        ((self.voxelization as usize * n_res as usize + self.y as usize) * n_res as usize) + self.x as usize
    }
}

/// Alg. 3 lines 1–4: voxelization, row and clipped extent of the segment `start → end`, or
/// `None` if the segment covers no voxel of any row (midpoint outside, or the bias ate it).
#[inline]
pub fn extent(grid: &Grid, dirs: &Directions, start: Vec3, end: Vec3, bias_start_cells: f32, bias_end_cells: f32) -> Option<Extent> {
    let (i, j) = dirs.discretize(end - start);
    let (q0, q1) = (grid.to_cells_ij(dirs, i, j, start), grid.to_cells_ij(dirs, i, j, end));
    let m = (q0 + q1) * 0.5;
    let nf = grid.resolution as f32;
    if !(m.x >= 0.0 && m.x < nf && m.y >= 0.0 && m.y < nf) {
        return None;
    }
    let (lo, hi) =
        if q0.z <= q1.z { (q0.z + bias_start_cells, q1.z - bias_end_cells) } else { (q1.z + bias_end_cells, q0.z - bias_start_cells) };
    let (lo, hi) = (lo.max(0.0), hi.min(nf - 1e-3));
    if lo > hi || lo.is_nan() || hi.is_nan() {
        return None;
    }
    let (s, e) = (lo as u32, hi as u32);
    Some(Extent { voxelization: i * dirs.n + j, x: m.x as u32, y: m.y as u32, s, e, start_low: q0.z <= q1.z })
}

/// Alg. 3 lines 5–7 on a fetched row.
#[inline]
pub fn clip_hits<R: Row>(row: R, s: u32, e: u32) -> bool {
    !row.and(R::mask(s, e)).is_zero()
}

/// Alg. 3 lines 5–7 ignoring the run of occupied voxels that touches the start end of `[s, e]`
/// (our heuristic for callers without a surface normal: that run is, most often, the surface
/// the segment starts on, read along a grazing row). A blocker touching that surface is missed.
#[inline]
pub fn clip_hits_after_start_run<R: Row>(row: R, x: &Extent) -> bool {
    let m = row.and(R::mask(x.s, x.e)).to_u128();
    if m == 0 {
        return false;
    }
    if x.start_low {
        let y = m >> x.s;
        let k = y.trailing_ones();
        k < 128 && (y >> k) != 0
    } else {
        let y = m << (127 - x.e);
        let k = y.leading_ones();
        k < 128 && (y << k) != 0
    }
}

/// Alg. 3 lines 5–6 as the paper writes them, MSB-first (position 0 = leftmost bit), with the
/// off-by-one fixed: `(row << s) >> (s + L − e − 1)` keeps positions `s..=e` inclusive, as in
/// Fig. 4. Computed in 64 bits so no shift reaches the width.
pub fn clip_msb_first(row: u32, s: u32, e: u32) -> u32 {
    assert!(s <= e && e < 32);
    let shifted = ((row as u64) << s) & 0xffff_ffff;
    (shifted >> (s + 32 - e - 1)) as u32
}

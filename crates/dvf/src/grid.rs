//! The uniform grid G and the per-cell octahedral masks O_c^V, O_c^O (Algorithm 2 lines 18–21,
//! Fig. 4's "DVF Masks Image Array", §2.1 of the spec).
//!
//! Gaps filled: the grid spans the frame's bounds (recomputed every frame) with cubic cells,
//! `grid` cells along the longest axis (the paper's Sponza grid 77×48×34 has near-cubic cells,
//! 77 along its longest axis); a point outside is clamped into the nearest cell. The octahedral
//! map covers the full sphere of world directions (masks of samples with different normals are
//! OR-ed together) at `R × R` pixels (the paper never states R; default 8, see docs).
//!
//! Deviation: each mask is packed as R² bits in `u64` words (`words_per_mask = ⌈R²/64⌉`),
//! visible and occluded in two flat arrays, instead of one R32_UINT texel per pixel using bits 7
//! and 6: the same information in 1/16 of the memory, and one atomic word per 64 pixels.

use glimpse_core::{Aabb, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub origin: Vec3,
    pub cell_size_world: f32,
    pub dims: [u32; 3],
}

impl Grid {
    /// Cubic cells over `bounds`, `longest` cells along its longest axis.
    pub fn from_bounds(bounds: Aabb, longest: u32) -> Grid {
        let (min, ext) = if bounds.is_empty() { (Vec3::ZERO, Vec3::ONE) } else { (bounds.min, bounds.extent()) };
        let longest = longest.max(1);
        // A hair larger than extent/longest so the maximum corner falls in the last cell.
        let cell = (ext.max_element() / longest as f32).max(1e-6) * (1.0 + 1e-5);
        let dims = (ext / cell).ceil().max(Vec3::ONE).to_array().map(|d| (d as u32).clamp(1, longest));
        Grid { origin: min, cell_size_world: cell, dims }
    }

    pub fn cell_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Row-major index of the cell containing `p` (clamped into the grid).
    #[inline]
    pub fn cell_of(&self, p: Vec3) -> usize {
        let q = ((p - self.origin) / self.cell_size_world).floor();
        let c = |a: usize| (q[a].max(0.0) as u32).min(self.dims[a] - 1) as usize;
        (c(2) * self.dims[1] as usize + c(1)) * self.dims[0] as usize + c(0)
    }

    /// The 2×2×2 cells whose centres surround `p` (clamped into the grid; repeated at its faces).
    pub fn cells_around(&self, p: Vec3) -> [usize; 8] {
        let q = (p - self.origin) / self.cell_size_world - Vec3::splat(0.5);
        let base = q.floor();
        let axis = |a: usize, o: u32| ((base[a].max(-1.0) as i64 + o as i64).clamp(0, self.dims[a] as i64 - 1)) as usize;
        let mut out = [0; 8];
        for (i, c) in out.iter_mut().enumerate() {
            let (x, y, z) = (axis(0, i as u32 & 1), axis(1, (i as u32 >> 1) & 1), axis(2, (i as u32 >> 2) & 1));
            *c = (z * self.dims[1] as usize + y) * self.dims[0] as usize + x;
        }
        out
    }
}

/// Pixel index `py·R + px` of unit direction `d` in the R×R octahedral map (Cigolle et al.'s
/// encoding, as `glimpse_core::sampling::octahedral_encode`, written with selects instead of a
/// branch on the hemisphere: this runs for every ray of every pixel).
#[inline]
pub fn octahedral_pixel(d: Vec3, r: u32) -> u32 {
    let inv_l1 = 1.0 / (d.x.abs() + d.y.abs() + d.z.abs());
    let (x, y) = (d.x * inv_l1, d.y * inv_l1);
    let sx = if x >= 0.0 { 1.0 } else { -1.0 };
    let sy = if y >= 0.0 { 1.0 } else { -1.0 };
    let lower = d.z < 0.0;
    let fx = if lower { (1.0 - y.abs()) * sx } else { x };
    let fy = if lower { (1.0 - x.abs()) * sy } else { y };
    let half = r as f32 * 0.5;
    let px = ((fx * half + half) as u32).min(r - 1);
    let py = ((fy * half + half) as u32).min(r - 1);
    py * r + px
}

/// Largest supported R (words per mask ≤ [`MAX_WORDS`]).
pub const MAX_RESOLUTION: u32 = 32;
pub const MAX_WORDS: usize = (MAX_RESOLUTION * MAX_RESOLUTION / 64) as usize;

/// The two masks of every cell, as atomics (the GPU image the build writes with atomic OR).
#[derive(Debug)]
pub struct Masks {
    pub resolution: u32,
    pub words_per_mask: usize,
    /// Cell c's visibility map: words `c·words_per_mask ..`.
    pub visible: Vec<AtomicU64>,
    /// Cell c's occlusion map.
    pub occluded: Vec<AtomicU64>,
}

impl Masks {
    pub fn new(cells: usize, resolution: u32) -> Masks {
        let words_per_mask = ((resolution * resolution) as usize).div_ceil(64);
        let zeros = |n: usize| (0..n).map(|_| AtomicU64::new(0)).collect();
        Masks { resolution, words_per_mask, visible: zeros(cells * words_per_mask), occluded: zeros(cells * words_per_mask) }
    }

    pub fn cells(&self) -> usize {
        self.visible.len() / self.words_per_mask
    }

    /// Clears every word (in parallel), keeping the allocation when the size is unchanged.
    pub fn reset(&mut self, cells: usize, resolution: u32) {
        use rayon::prelude::*;
        let words = ((resolution * resolution) as usize).div_ceil(64);
        if self.resolution != resolution || self.visible.len() != cells * words {
            *self = Masks::new(cells, resolution);
            return;
        }
        self.visible.par_iter().chain(self.occluded.par_iter()).for_each(|w| w.store(0, Ordering::Relaxed));
    }

    /// Atomic OR of one pixel bit (the paper's `imageAtomicOr`, per ray).
    #[inline]
    pub fn or_pixel(&self, cell: usize, pixel: u32, hit: bool) {
        let target = if hit { &self.occluded } else { &self.visible };
        target[cell * self.words_per_mask + pixel as usize / 64].fetch_or(1 << (pixel % 64), Ordering::Relaxed);
    }

    /// Atomic OR of a whole per-sample map (Algorithm 2's merge step).
    #[inline]
    pub fn or_words(&self, cell: usize, visible: &[u64], occluded: &[u64]) {
        let base = cell * self.words_per_mask;
        for (w, (&v, &o)) in visible.iter().zip(occluded).enumerate() {
            if v != 0 {
                self.visible[base + w].fetch_or(v, Ordering::Relaxed);
            }
            if o != 0 {
                self.occluded[base + w].fetch_or(o, Ordering::Relaxed);
            }
        }
    }

    /// Is pixel `pixel` set in cell `cell`'s visible (`hit = false`) or occluded map?
    #[inline]
    pub fn get(&self, cell: usize, pixel: u32, occluded: bool) -> bool {
        let src = if occluded { &self.occluded } else { &self.visible };
        src[cell * self.words_per_mask + pixel as usize / 64].load(Ordering::Relaxed) >> (pixel % 64) & 1 == 1
    }

    /// Both bits of one pixel: (visible, occluded).
    #[inline]
    pub fn bits(&self, cell: usize, pixel: u32) -> (bool, bool) {
        let i = cell * self.words_per_mask + pixel as usize / 64;
        let bit = 1u64 << (pixel % 64);
        (self.visible[i].load(Ordering::Relaxed) & bit != 0, self.occluded[i].load(Ordering::Relaxed) & bit != 0)
    }

    /// Set pixels in cell `cell`'s (visible, occluded) maps: N_vis, N_occ.
    pub fn counts(&self, cell: usize) -> (u32, u32) {
        let range = cell * self.words_per_mask..(cell + 1) * self.words_per_mask;
        let pop = |a: &[AtomicU64]| a[range.clone()].iter().map(|w| w.load(Ordering::Relaxed).count_ones()).sum();
        (pop(&self.visible), pop(&self.occluded))
    }

    /// Plain copies of the words (for comparisons).
    pub fn snapshot(&self) -> (Vec<u64>, Vec<u64>) {
        let load = |a: &[AtomicU64]| a.iter().map(|w| w.load(Ordering::Relaxed)).collect();
        (load(&self.visible), load(&self.occluded))
    }

    /// Sets every pixel of one map of every cell (for the estimator identities).
    pub fn fill(&self, occluded: bool) {
        let target = if occluded { &self.occluded } else { &self.visible };
        for w in target {
            w.store(!0, Ordering::Relaxed);
        }
    }

    pub fn memory_bytes(&self) -> usize {
        (self.visible.len() + self.occluded.len()) * 8
    }
}

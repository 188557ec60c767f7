//! `Generate` (paper Alg. 1, §3.2): "rotate" the BOM into one ray-aligned occupancy map per
//! candidate direction, by nearest-neighbour resampling, in parallel over the maps' texels.
//!
//! For texel `(x, y)` of OM k the `B` cell centres `(x+½, y+½, i+½)` are mapped to BOM cell
//! coordinates and bit `i` is set when the BOM cell containing the mapped point is occupied.
//! Since both maps are cubes with the same centre and cell size ([`crate::grid`]), the mapping
//! is `start + i·d_k` in cell units (Alg. 1 lines 2–7 and 17, with the endpoints computed
//! directly rather than accumulated).
//!
//! Errata fixed (spec §11): line 16 accumulates into `U_aligned` (the listing says `U_result`);
//! the BOM fetch uses logical shifts on unsigned words (`Word::has_slice`); points outside the
//! BOM are empty (the paper has no bounds test; the Mitsuba prototype of spec Appendix B does).
//!
//! CPU form (bit-identical; acceptance checks 3–5): the BOM is read through a flat bit array
//! ([`BomBits`]), the column walk samples only the part of the column inside the BOM's box, and
//! the output word is built by shifting in one bit per sample. Skipping empty 8³ blocks of the
//! BOM was tried and was not faster (the per-sample block test costs as much as the read).

use crate::occupancy::OccupancyMap;
use crate::word::Word;
use glimpse_core::{Frame, Vec3};
use rayon::prelude::*;

/// The BOM-cell coordinates of the centre of cell `(x, y, 0)` of the map with axes `axes`, and
/// the step to the next slice.
#[inline]
pub fn column_start_and_step(axes: &Frame, x: u32, y: u32, resolution: u32) -> (Vec3, Vec3) {
    let half = resolution as f32 * 0.5;
    let local = Vec3::new(x as f32 + 0.5 - half, y as f32 + 0.5 - half, 0.5 - half);
    // Only rotation: BOM axes are the world axes and the cubes share centre and cell size.
    (axes.to_world(local) + Vec3::splat(half), axes.z)
}

/// The BOM as a flat bit array (bit `(z·R + y)·R + x`), for the random single-cell reads of
/// the rotation: one 64-bit load and shift per read instead of a `u128` variable shift.
#[derive(Clone, Debug)]
pub struct BomBits {
    resolution: u32,
    bits: Vec<u64>,
}

impl BomBits {
    pub fn new<W: Word>(bom: &OccupancyMap<W>) -> Self {
        let r = W::BITS;
        let mut bits = vec![0u64; ((r * r * r) as usize).div_ceil(64)];
        for y in 0..r {
            for x in 0..r {
                let w = bom.word(x, y);
                if w == W::ZERO {
                    continue;
                }
                for z in (0..r).filter(|&z| w.has_slice(z)) {
                    let b = ((z * r + y) * r + x) as usize;
                    bits[b / 64] |= 1 << (b % 64);
                }
            }
        }
        Self { resolution: r, bits }
    }

    /// Is the cell containing `q` occupied? (Outside the grid: no.)
    #[inline]
    pub fn get_at(&self, q: Vec3) -> bool {
        let r = self.resolution;
        let rf = r as f32;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0 && q.x < rf && q.y < rf && q.z < rf) {
            return false;
        }
        let b = ((q.z as u32 * r + q.y as u32) * r + q.x as u32) as usize;
        self.bits[b / 64] >> (b % 64) & 1 == 1
    }
}

/// One texel of a ray-aligned OM (Alg. 1's body).
#[inline]
pub fn generate_texel<W: Word>(bom: &BomBits, axes: &Frame, x: u32, y: u32) -> W {
    let (start, step) = column_start_and_step(axes, x, y, W::BITS);
    let r = W::BITS as f32;
    // Only the samples i with start + i·step inside [0, R)³, widened by one sample for rounding
    // (every sample is still bounds-checked by `get_at`).
    let (mut lo, mut hi) = (0.0f32, r - 1.0);
    for c in 0..3 {
        if step[c].abs() > 1e-9 {
            let (a, b) = ((0.0 - start[c]) / step[c], (r - start[c]) / step[c]);
            lo = lo.max(a.min(b) - 1.0);
            hi = hi.min(a.max(b) + 1.0);
        } else if start[c] < 0.0 || start[c] >= r {
            return W::ZERO;
        }
    }
    if lo > hi {
        return W::ZERO;
    }
    let (first, last) = (lo.ceil() as u32, hi.floor() as u32);
    // Slice i ends up at bit B−1−i: shift in one bit per sample, then align.
    let mut out = W::ZERO;
    for i in first..=last {
        out = out << 1 | W::from_u128(bom.get_at(start + step * i as f32) as u128);
    }
    out << (W::BITS - 1 - last)
}

/// One ray-aligned OM, as a stand-alone map (for tests).
pub fn generate_map<W: Word>(bom: &OccupancyMap<W>, axes: &Frame) -> OccupancyMap<W> {
    let r = W::BITS;
    let bits = BomBits::new(bom);
    let words = (0..r * r).into_par_iter().map(|i| generate_texel(&bits, axes, i % r, i / r)).collect();
    OccupancyMap { words }
}

/// Every OM of the array, layer-major: word `k·R² + y·R + x`.
pub fn generate_all<W: Word>(bom: &OccupancyMap<W>, axes: &[Frame]) -> Vec<W> {
    let r = W::BITS as usize;
    let bits = BomBits::new(bom);
    let mut maps = vec![W::ZERO; axes.len() * r * r];
    maps.par_chunks_mut(r).enumerate().for_each(|(row, words)| {
        let (k, y) = (row / r, (row % r) as u32);
        for (x, w) in words.iter_mut().enumerate() {
            *w = generate_texel(&bits, &axes[k], x as u32, y);
        }
    });
    maps
}

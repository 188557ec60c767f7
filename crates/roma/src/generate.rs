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
//! the output word is built by shifting in one bit per sample. With AVX2 (detected at run time)
//! eight texels of a row are generated together, one gather per sample step; each lane repeats
//! the scalar float operations, so the words are the same (unit test `simd_equals_scalar`). Skipping empty 8³ blocks of the
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

/// The BOM as a flat bit array (bit `(z·R + y)·R + x`, in 32-bit words), for the random
/// single-cell reads of the rotation: one load and shift per read instead of a `u128` variable
/// shift, and the word size of an AVX2 gather.
#[derive(Clone, Debug)]
pub struct BomBits {
    resolution: u32,
    bits: Vec<u32>,
}

impl BomBits {
    pub fn new<W: Word>(bom: &OccupancyMap<W>) -> Self {
        let r = W::BITS;
        let mut bits = vec![0u32; ((r * r * r) as usize).div_ceil(32)];
        for y in 0..r {
            for x in 0..r {
                let w = bom.word(x, y);
                if w == W::ZERO {
                    continue;
                }
                for z in (0..r).filter(|&z| w.has_slice(z)) {
                    let b = ((z * r + y) * r + x) as usize;
                    bits[b / 32] |= 1 << (b % 32);
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
        self.bits[b / 32] >> (b % 32) & 1 == 1
    }
}

/// The samples `first..=last` of the column starting at `start` (BOM cells) with step `step`
/// that can lie inside `[0, r)³` (widened by one sample for rounding; every sample is still
/// bounds-checked), or `None` when the column misses the BOM's box.
#[inline]
fn column_samples(start: Vec3, step: Vec3, r: f32) -> Option<(u32, u32)> {
    let (mut lo, mut hi) = (0.0f32, r - 1.0);
    for c in 0..3 {
        if step[c].abs() > 1e-9 {
            let (a, b) = ((0.0 - start[c]) / step[c], (r - start[c]) / step[c]);
            lo = lo.max(a.min(b) - 1.0);
            hi = hi.min(a.max(b) + 1.0);
        } else if start[c] < 0.0 || start[c] >= r {
            return None;
        }
    }
    (lo <= hi).then(|| (lo.ceil() as u32, hi.floor() as u32))
}

/// One texel of a ray-aligned OM (Alg. 1's body).
#[inline]
pub fn generate_texel<W: Word>(bom: &BomBits, axes: &Frame, x: u32, y: u32) -> W {
    let (start, step) = column_start_and_step(axes, x, y, W::BITS);
    let Some((first, last)) = column_samples(start, step, W::BITS as f32) else {
        return W::ZERO;
    };
    // Slice i ends up at bit B−1−i: shift in one bit per sample, then align.
    let mut out = W::ZERO;
    for i in first..=last {
        out = out << 1 | W::from_u128(bom.get_at(start + step * i as f32) as u128);
    }
    out << (W::BITS - 1 - last)
}

/// Texels `x0 .. x0 + out.len()` of row `y` of one OM: eight at a time with AVX2 where the CPU
/// has it (checked once per process), else one at a time. The same words either way.
#[inline]
pub fn generate_texels<W: Word>(bom: &BomBits, axes: &Frame, x0: u32, y: u32, out: &mut [W]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        let mut chunks = out.chunks_exact_mut(avx2::LANES);
        let mut x = x0;
        for chunk in &mut chunks {
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { avx2::generate_lanes(bom, axes, x, y, chunk) };
            x += avx2::LANES as u32;
        }
        for (i, w) in chunks.into_remainder().iter_mut().enumerate() {
            *w = generate_texel(bom, axes, x + i as u32, y);
        }
        return;
    }
    for (i, w) in out.iter_mut().enumerate() {
        *w = generate_texel(bom, axes, x0 + i as u32, y);
    }
}

/// Alg. 1 for eight neighbouring texels of a row at once (SoA over x): each lane performs the
/// scalar [`generate_texel`]'s float operations in the same order (no FMA contraction), so the
/// sampled cells, and the words, are bit-identical; the BOM reads become one 8-wide gather.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{BomBits, Word, column_samples, column_start_and_step};
    use glimpse_core::{Frame, Vec3};
    use std::arch::x86_64::*;

    pub const LANES: usize = 8;

    /// # Safety
    /// The CPU must support AVX2; `out.len() == LANES`.
    #[target_feature(enable = "avx2")]
    pub unsafe fn generate_lanes<W: Word>(bom: &BomBits, axes: &Frame, x0: u32, y: u32, out: &mut [W]) {
        debug_assert_eq!(out.len(), LANES);
        let r = W::BITS;
        let log2_r = r.trailing_zeros() as i32;
        let (mut sx, mut sy, mut sz) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        // Lanes with no sample get the empty range first = 1 > last = 0.
        let (mut first, mut last) = ([1i32; LANES], [0i32; LANES]);
        let mut step = Vec3::ZERO;
        let (mut lo, mut hi) = (u32::MAX, 0u32);
        for l in 0..LANES {
            let (start, s) = column_start_and_step(axes, x0 + l as u32, y, r);
            step = s;
            (sx[l], sy[l], sz[l]) = (start.x, start.y, start.z);
            if let Some((f, t)) = column_samples(start, s, r as f32) {
                (first[l], last[l]) = (f as i32, t as i32);
                (lo, hi) = (lo.min(f), hi.max(t));
            }
        }
        out.fill(W::ZERO);
        if lo > hi {
            return;
        }
        // SAFETY (of every intrinsic below): AVX2 is enabled on this function; the loads read
        // `LANES` values from arrays of `LANES`; the gather reads `bits[index]` with `index` in
        // range (masked lanes read word 0; a valid lane's cell index is < R³, its word < R³/32).
        unsafe {
            let load = |a: &[f32; LANES]| _mm256_loadu_ps(a.as_ptr());
            let (sx, sy, sz) = (load(&sx), load(&sy), load(&sz));
            let (dx, dy, dz) = (_mm256_set1_ps(step.x), _mm256_set1_ps(step.y), _mm256_set1_ps(step.z));
            let first = _mm256_loadu_si256(first.as_ptr() as *const __m256i);
            let last = _mm256_loadu_si256(last.as_ptr() as *const __m256i);
            let (zero, rf) = (_mm256_setzero_ps(), _mm256_set1_ps(r as f32));
            let (one, bit_mask) = (_mm256_set1_epi32(1), _mm256_set1_epi32(31));
            let shift = _mm_cvtsi32_si128(log2_r);
            let bits = bom.bits.as_ptr() as *const i32;
            // 32 samples per accumulator: sample 32c + j lands at bit 31 − j of chunk c.
            for c in lo / 32..=hi / 32 {
                let mut acc = _mm256_setzero_si256();
                for j in 0..32 {
                    let i = (c * 32 + j) as i32;
                    let fi = _mm256_set1_ps(i as f32);
                    let qx = _mm256_add_ps(sx, _mm256_mul_ps(dx, fi));
                    let qy = _mm256_add_ps(sy, _mm256_mul_ps(dy, fi));
                    let qz = _mm256_add_ps(sz, _mm256_mul_ps(dz, fi));
                    let inside = |q| _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(q, zero), _mm256_cmp_ps::<_CMP_LT_OQ>(q, rf));
                    let inside = _mm256_castps_si256(_mm256_and_ps(_mm256_and_ps(inside(qx), inside(qy)), inside(qz)));
                    let iv = _mm256_set1_epi32(i);
                    let outside_range = _mm256_or_si256(_mm256_cmpgt_epi32(first, iv), _mm256_cmpgt_epi32(iv, last));
                    let valid = _mm256_andnot_si256(outside_range, inside);
                    let (ix, iy, iz) = (_mm256_cvttps_epi32(qx), _mm256_cvttps_epi32(qy), _mm256_cvttps_epi32(qz));
                    let cell = _mm256_add_epi32(_mm256_sll_epi32(_mm256_add_epi32(_mm256_sll_epi32(iz, shift), iy), shift), ix);
                    let cell = _mm256_and_si256(cell, valid);
                    let words = _mm256_i32gather_epi32::<4>(bits, _mm256_srli_epi32::<5>(cell));
                    let bit = _mm256_and_si256(_mm256_srlv_epi32(words, _mm256_and_si256(cell, bit_mask)), one);
                    acc = _mm256_or_si256(_mm256_slli_epi32::<1>(acc), _mm256_and_si256(bit, valid));
                }
                let mut chunk = [0u32; LANES];
                _mm256_storeu_si256(chunk.as_mut_ptr() as *mut __m256i, acc);
                for (w, &v) in out.iter_mut().zip(&chunk) {
                    *w |= W::from_u128((v as u128) << (r - 32 * (c + 1)));
                }
            }
        }
    }
}

/// One ray-aligned OM, as a stand-alone map (for tests).
pub fn generate_map<W: Word>(bom: &OccupancyMap<W>, axes: &Frame) -> OccupancyMap<W> {
    let r = W::BITS;
    let bits = BomBits::new(bom);
    let mut words = vec![W::ZERO; (r * r) as usize];
    words.par_chunks_mut(r as usize).enumerate().for_each(|(y, row)| generate_texels(&bits, axes, 0, y as u32, row));
    OccupancyMap { words }
}

/// Every OM of the array, layer-major: word `k·R² + y·R + x`.
pub fn generate_all<W: Word>(bom: &OccupancyMap<W>, axes: &[Frame]) -> Vec<W> {
    let r = W::BITS as usize;
    let bits = BomBits::new(bom);
    let mut maps = vec![W::ZERO; axes.len() * r * r];
    maps.par_chunks_mut(r).enumerate().for_each(|(row, words)| {
        let (k, y) = (row / r, (row % r) as u32);
        generate_texels(&bits, &axes[k], 0, y, words);
    });
    maps
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Rng;
    use glimpse_core::sampling::uniform_sphere;

    /// The batched (AVX2 where available) texels equal the scalar texels, bit for bit, for random
    /// BOMs and directions at every word width, including axis-aligned and near-axis directions.
    #[test]
    fn simd_equals_scalar() {
        fn run<W: Word>(seed: u64) -> (usize, usize) {
            let r = W::BITS;
            let mut rng = Rng::new(seed, 1);
            let words = (0..r * r)
                .map(|_| {
                    let v = (rng.next_u32() as u128) << 96
                        | (rng.next_u32() as u128) << 64
                        | (rng.next_u32() as u128) << 32
                        | rng.next_u32() as u128;
                    // Sparse, as scenes are: about one bit in eight set.
                    let m = (rng.next_u32() as u128) << 96
                        | (rng.next_u32() as u128) << 64
                        | (rng.next_u32() as u128) << 32
                        | rng.next_u32() as u128;
                    W::from_u128(v & m & (m >> 1))
                })
                .collect();
            let bom = OccupancyMap::<W> { words };
            let bits = BomBits::new(&bom);
            let mut dirs: Vec<Vec3> = (0..24).map(|_| uniform_sphere(rng.next_2d())).collect();
            dirs.extend([Vec3::X, -Vec3::Y, Vec3::Z, Vec3::new(1e-7, 0.0, 1.0).normalize(), Vec3::new(0.6, 0.8, 1e-8).normalize()]);
            let (mut texels, mut differ) = (0, 0);
            for d in dirs {
                let axes = crate::grid::om_axes(d);
                for y in 0..r {
                    let mut row = vec![W::ZERO; r as usize];
                    generate_texels(&bits, &axes, 0, y, &mut row);
                    for (x, w) in row.iter().enumerate() {
                        differ += (*w != generate_texel::<W>(&bits, &axes, x as u32, y)) as usize;
                        texels += 1;
                    }
                }
            }
            (texels, differ)
        }
        for (texels, differ) in [run::<u32>(1), run::<u64>(2), run::<u128>(3)] {
            println!(
                "batched Generate vs scalar: {differ} of {texels} texels differ (avx2: {})",
                cfg!(target_arch = "x86_64") && std::arch::is_x86_feature_detected!("avx2")
            );
            assert_eq!(differ, 0);
        }
    }
}

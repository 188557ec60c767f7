//! The distance-field baseline of the ROMA paper (§6 "Distance fields", [RT06], [Aal18]): from
//! the same BOM as ROMA, a 3D jump-flooding pass gives every cell the distance to the centre of
//! the nearest occupied cell; three mip levels accelerate sphere tracing.
//!
//! - Jump flooding (Rong and Tan 2006): seeds are the occupied cells; passes with step
//!   `R/2, R/4, …, 1`, each cell looking at its 26 neighbours at ± step and keeping the nearest
//!   seed, then one more step-1 pass ("JFA+1", which removes most of JFA's rare errors).
//!   Double-buffered, parallel over z-slices.
//! - Storage: 2 bytes per cell as the paper's float16, here as `u16` fixed point in 1/256 cell
//!   (exact to 0.002 cell up to 255 cells, more than the √3·128 = 222 a 128³ grid needs); so a
//!   128³ field is 4 MiB, equal to ROMA at 4² (paper §7.1 "equal storage").
//! - Mip levels 1 and 2 (`R/2`, `R/4`) store **lower bounds** of the distance for every point
//!   of the coarse cell: level 1 = min over its 8 children − √3/2 (a point lies within √3/2 of
//!   its own level-0 centre), level 2 = min over its 8 level-1 children. Sphere tracing steps by
//!   the coarsest bound that is large enough ([Aal18]'s mip-accelerated tracing). The paper does
//!   not say how its mips are built; min-bounds keep the steps safe.
//! - Level 0 is sampled trilinearly between cell centres (the paper: hardware trilinear).

use glimpse_core::Vec3;
use glimpse_voxel::occupancy::OccupancyMap;
use glimpse_voxel::{Grid, Word};
use rayon::prelude::*;

/// Fixed-point scale: stored value = distance in cells × 256.
pub const FIXED_SCALE: f32 = 256.0;
const NO_SEED: u32 = u32::MAX;

/// A distance field with three mip levels over ROMA's grid.
#[derive(Clone, Debug)]
pub struct DistanceField {
    pub grid: Grid,
    /// Cells per axis at level 0.
    pub resolution: u32,
    /// Levels 0, 1, 2: `(R >> l)³` values each, index `(z·r + y)·r + x`.
    pub levels: [Vec<u16>; 3],
}

#[inline]
fn pack(x: u32, y: u32, z: u32) -> u32 {
    x | y << 10 | z << 20
}

#[inline]
fn unpack(s: u32) -> (u32, u32, u32) {
    (s & 1023, (s >> 10) & 1023, s >> 20)
}

#[inline]
fn dist2(s: u32, x: u32, y: u32, z: u32) -> u32 {
    let (sx, sy, sz) = unpack(s);
    let (dx, dy, dz) = (sx.abs_diff(x), sy.abs_diff(y), sz.abs_diff(z));
    dx * dx + dy * dy + dz * dz
}

/// Nearest occupied cell of every cell by jump flooding (JFA+1); `NO_SEED` if the map is empty.
pub fn jump_flood<W: Word>(bom: &OccupancyMap<W>) -> Vec<u32> {
    let fastest = *FloodIsa::available().last().expect("the baseline is always available");
    jump_flood_with(bom, fastest)
}

fn jump_flood_with<W: Word>(bom: &OccupancyMap<W>, isa: FloodIsa) -> Vec<u32> {
    let r = W::BITS;
    let n = (r * r * r) as usize;
    let idx = |x: u32, y: u32, z: u32| ((z * r + y) * r + x) as usize;
    let mut seeds = vec![NO_SEED; n];
    for y in 0..r {
        for x in 0..r {
            let w = bom.word(x, y);
            if w == W::ZERO {
                continue;
            }
            for z in 0..r {
                if w.has_slice(z) {
                    seeds[idx(x, y, z)] = pack(x, y, z);
                }
            }
        }
    }
    let mut steps = Vec::new();
    let mut s = r / 2;
    while s >= 1 {
        steps.push(s);
        s /= 2;
    }
    steps.push(1);
    let mut next = vec![NO_SEED; n];
    for step in steps {
        let step = step as i32;
        // Row by row: each of the 26 neighbour offsets reads one contiguous neighbour row, so the
        // bounds tests leave the per-cell loop. Candidates are visited in the same order for
        // every cell (own seed, then dz, dy, dx), so ties resolve as in a cell-by-cell loop.
        next.par_chunks_mut((r * r) as usize).enumerate().for_each(|(z, slice)| flood_slice(isa, &seeds, slice, z as u32, r, step));
        std::mem::swap(&mut seeds, &mut next);
    }
    seeds
}

/// The instruction sets one jump-flooding pass is compiled for: its 32-bit lane multiplies need
/// SSE4.1 at least, and the baseline x86-64 target has SSE2 (`mixed-lights`' 128³ field on
/// 2 cores: 333 ms baseline, 175 ms AVX2, 110 ms AVX-512). Integer arithmetic only, so every
/// version gives the same seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FloodIsa {
    Baseline,
    Avx2,
    Avx512,
}

impl FloodIsa {
    /// The versions this CPU can run, fastest last.
    fn available() -> Vec<FloodIsa> {
        let mut isas = vec![FloodIsa::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                isas.push(FloodIsa::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                isas.push(FloodIsa::Avx512);
            }
        }
        isas
    }
}

/// One jump-flooding pass over the z-slice `slice` of `next` (`r × r` cells at depth `z`),
/// reading the previous pass's `seeds`, with `isa` (one of [`FloodIsa::available`]).
fn flood_slice(isa: FloodIsa, seeds: &[u32], slice: &mut [u32], z: u32, r: u32, step: i32) {
    match isa {
        // SAFETY: `available` listed the ISA, so the CPU supports it.
        #[cfg(target_arch = "x86_64")]
        FloodIsa::Avx512 => unsafe { flood_slice_avx512(seeds, slice, z, r, step) },
        #[cfg(target_arch = "x86_64")]
        FloodIsa::Avx2 => unsafe { flood_slice_avx2(seeds, slice, z, r, step) },
        _ => flood_slice_body(seeds, slice, z, r, step),
    }
}

/// [`flood_slice`] compiled with AVX-512F.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn flood_slice_avx512(seeds: &[u32], slice: &mut [u32], z: u32, r: u32, step: i32) {
    flood_slice_body(seeds, slice, z, r, step)
}

/// [`flood_slice`] compiled with AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn flood_slice_avx2(seeds: &[u32], slice: &mut [u32], z: u32, r: u32, step: i32) {
    flood_slice_body(seeds, slice, z, r, step)
}

#[inline(always)]
fn flood_slice_body(seeds: &[u32], slice: &mut [u32], z: u32, r: u32, step: i32) {
    let idx = |x: u32, y: u32, z: u32| ((z * r + y) * r + x) as usize;
    let mut best_d = [0u32; 128];
    for y in 0..r {
        let out = &mut slice[(y * r) as usize..((y + 1) * r) as usize];
        out.copy_from_slice(&seeds[idx(0, y, z)..idx(0, y, z) + r as usize]);
        for (x, (&b, d)) in out.iter().zip(best_d.iter_mut()).enumerate() {
            *d = if b == NO_SEED { u32::MAX } else { dist2(b, x as u32, y, z) };
        }
        for dz in [-step, 0, step] {
            let nz = z as i32 + dz;
            if nz < 0 || nz >= r as i32 {
                continue;
            }
            for dy in [-step, 0, step] {
                let ny = y as i32 + dy;
                if ny < 0 || ny >= r as i32 {
                    continue;
                }
                let row = &seeds[idx(0, ny as u32, nz as u32)..idx(0, ny as u32, nz as u32) + r as usize];
                for dx in [-step, 0, step] {
                    if dx == 0 && dy == 0 && dz == 0 {
                        continue;
                    }
                    let lo = (-dx).max(0) as usize;
                    let hi = (r as i32 - dx.max(0)) as usize;
                    let from = &row[(lo as i32 + dx) as usize..(hi as i32 + dx) as usize];
                    // Branch-free, so it vectorizes: NO_SEED unpacks to (1023, 1023,
                    // 4095), farther than any real seed, so it can only replace another
                    // NO_SEED and never a seed.
                    for (k, (&s, (o, b))) in from.iter().zip(out[lo..hi].iter_mut().zip(&mut best_d[lo..hi])).enumerate() {
                        let d = dist2(s, (lo + k) as u32, y, z);
                        let better = d < *b;
                        *b = if better { d } else { *b };
                        *o = if better { s } else { *o };
                    }
                }
            }
        }
    }
}

fn to_fixed(d: f32) -> u16 {
    (d * FIXED_SCALE).round().clamp(0.0, u16::MAX as f32) as u16
}

impl DistanceField {
    /// The field of `bom` (which lives in `grid`).
    pub fn from_bom<W: Word>(bom: &OccupancyMap<W>, grid: Grid) -> DistanceField {
        let r = W::BITS;
        let seeds = jump_flood(bom);
        let far = 2.0 * r as f32; // empty scene: everything is far
        let level0: Vec<u16> = seeds
            .par_iter()
            .enumerate()
            .map(|(i, &s)| {
                let (x, y, z) = (i as u32 % r, (i as u32 / r) % r, i as u32 / (r * r));
                to_fixed(if s == NO_SEED { far } else { (dist2(s, x, y, z) as f32).sqrt() })
            })
            .collect();
        let half_diagonal = to_fixed(3f32.sqrt() * 0.5);
        let level1 = downsample_min(&level0, r, half_diagonal);
        let level2 = downsample_min(&level1, r / 2, 0);
        DistanceField { grid, resolution: r, levels: [level0, level1, level2] }
    }

    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.len() * 2).sum()
    }

    /// Level-0 distance at cell `(x, y, z)`, in cells.
    #[inline]
    pub fn cell(&self, x: u32, y: u32, z: u32) -> f32 {
        let r = self.resolution;
        self.levels[0][((z * r + y) * r + x) as usize] as f32 / FIXED_SCALE
    }

    /// Lower bound of the distance (cells) anywhere in the level-`l` cell containing `q` (level-0
    /// cell coordinates inside the grid).
    #[inline]
    pub fn bound(&self, level: usize, q: Vec3) -> f32 {
        let r = self.resolution >> level;
        let c = (q / (1 << level) as f32).as_uvec3().min(glimpse_core::glam::UVec3::splat(r - 1));
        self.levels[level][((c.z * r + c.y) * r + c.x) as usize] as f32 / FIXED_SCALE
    }

    /// Level-0 distance (cells) trilinearly interpolated between cell centres at `q`.
    #[inline]
    pub fn trilinear(&self, q: Vec3) -> f32 {
        let r = self.resolution;
        let p = (q - Vec3::splat(0.5)).clamp(Vec3::ZERO, Vec3::splat(r as f32 - 1.0));
        let i = p.floor().as_uvec3().min(glimpse_core::glam::UVec3::splat(r - 2));
        let f = p - i.as_vec3();
        let at = |dx: u32, dy: u32, dz: u32| self.levels[0][(((i.z + dz) * r + i.y + dy) * r + i.x + dx) as usize] as f32;
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(at(0, 0, 0), at(1, 0, 0), f.x);
        let c10 = lerp(at(0, 1, 0), at(1, 1, 0), f.x);
        let c01 = lerp(at(0, 0, 1), at(1, 0, 1), f.x);
        let c11 = lerp(at(0, 1, 1), at(1, 1, 1), f.x);
        lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z) / FIXED_SCALE
    }
}

/// Half-resolution level: min over each 2×2×2 block, minus `subtract` (fixed point), at 0.
fn downsample_min(fine: &[u16], r: u32, subtract: u16) -> Vec<u16> {
    let h = r / 2;
    (0..h * h * h)
        .into_par_iter()
        .map(|i| {
            let (x, y, z) = (i % h, (i / h) % h, i / (h * h));
            let mut m = u16::MAX;
            for c in 0..8u32 {
                let (fx, fy, fz) = (2 * x + (c & 1), 2 * y + (c >> 1 & 1), 2 * z + (c >> 2));
                m = m.min(fine[((fz * r + fy) * r + fx) as usize]);
            }
            m.saturating_sub(subtract)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Rng;

    /// The flood cell by cell, as first written: the row-wise loop must give the same seeds,
    /// ties included.
    fn jump_flood_cell_by_cell<W: Word>(bom: &OccupancyMap<W>) -> Vec<u32> {
        let r = W::BITS;
        let idx = |x: u32, y: u32, z: u32| ((z * r + y) * r + x) as usize;
        let mut seeds = vec![NO_SEED; (r * r * r) as usize];
        for (z, y, x) in (0..r).flat_map(|z| (0..r).flat_map(move |y| (0..r).map(move |x| (z, y, x)))) {
            if bom.word(x, y).has_slice(z) {
                seeds[idx(x, y, z)] = pack(x, y, z);
            }
        }
        let mut steps: Vec<i32> = std::iter::successors(Some(r as i32 / 2), |s| (*s > 1).then_some(s / 2)).collect();
        steps.push(1);
        for step in steps {
            let mut next = seeds.clone();
            for (z, y, x) in (0..r).flat_map(|z| (0..r).flat_map(move |y| (0..r).map(move |x| (z, y, x)))) {
                let mut best = seeds[idx(x, y, z)];
                let mut best_d = if best == NO_SEED { u32::MAX } else { dist2(best, x, y, z) };
                for dz in [-step, 0, step] {
                    for dy in [-step, 0, step] {
                        for dx in [-step, 0, step] {
                            let (nx, ny, nz) = (x as i32 + dx, y as i32 + dy, z as i32 + dz);
                            let inside = [nx, ny, nz].iter().all(|&c| (0..r as i32).contains(&c));
                            if !inside || (dx, dy, dz) == (0, 0, 0) {
                                continue;
                            }
                            let s = seeds[idx(nx as u32, ny as u32, nz as u32)];
                            if s != NO_SEED && dist2(s, x, y, z) < best_d {
                                best_d = dist2(s, x, y, z);
                                best = s;
                            }
                        }
                    }
                }
                next[idx(x, y, z)] = best;
            }
            seeds = next;
        }
        seeds
    }

    #[test]
    fn row_wise_flood_equals_the_cell_by_cell_flood() {
        let mut rng = Rng::new(11, 0);
        for count in [1, 7, 300] {
            let mut bom = OccupancyMap::<u32>::empty();
            for _ in 0..count {
                bom.set(rng.below(32), rng.below(32), rng.below(32));
            }
            let expected = jump_flood_cell_by_cell(&bom);
            for isa in FloodIsa::available() {
                assert_eq!(jump_flood_with(&bom, isa), expected, "{count} seeds, {isa:?}");
            }
        }
        assert!(jump_flood(&OccupancyMap::<u32>::empty()).iter().all(|&s| s == NO_SEED));
    }
}

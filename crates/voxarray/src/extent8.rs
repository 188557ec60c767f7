//! [`crate::query::extent`] for eight segments at once with AVX2 (issue #14):
//! pass 1 of the batched query ([`crate::batch`]) in structure-of-arrays form.
//!
//! Every lane performs exactly the scalar code's float operations in the same order — the
//! `normalize_or(Vec3::Z)` of [`crate::directions::discretize`], the polynomial arc tangents of
//! [`glimpse_core::fast_math`] (multiplies then adds, no FMA), the same clamps, comparisons
//! (ordered, so NaN compares false as in Rust), `f32::min`/`f32::max` NaN rules and truncations,
//! the rotation through the cos/sin table (gathered) and the clip — so the extents are
//! bit-identical to the scalar ones (`tests/batch.rs` compares them on random and adversarial
//! segment sets). The AVX2 path is chosen at run time ([`avx2_available`], detected once); the
//! scalar [`crate::query::extent`] is the fallback and the only path off x86-64.

use crate::batch::LANES;
use crate::directions::Directions;
use crate::query::{self, Extent};
use crate::voxelize::Grid;
use glimpse_core::Vec3;

/// Set (to anything but `0`) to force the scalar pass 1, e.g. to time it against the AVX2 one
/// in the same binary.
pub const SCALAR_ENV: &str = "GLIMPSE_VOXARRAY_SCALAR";

/// Whether the batched query uses the AVX2 pass 1: the CPU has AVX2 and [`SCALAR_ENV`] is not
/// set (both read on the first call, then cached).
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
        *AVX2.get_or_init(|| {
            let forced_scalar = std::env::var(SCALAR_ENV).is_ok_and(|v| v != "0");
            !forced_scalar && std::arch::is_x86_feature_detected!("avx2")
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The scalar extents of eight segments `starts[k] → ends[k]` (the reference for the SIMD path).
pub fn extents_scalar(
    grid: &Grid,
    dirs: &Directions,
    starts: &[Vec3; LANES],
    ends: &[Vec3; LANES],
    bias_start_cells: f32,
    bias_end_cells: f32,
) -> [Option<Extent>; LANES] {
    std::array::from_fn(|k| query::extent(grid, dirs, starts[k], ends[k], bias_start_cells, bias_end_cells))
}

/// The extents of eight segments with AVX2, or `None` where the CPU lacks it (callers then use
/// [`extents_scalar`]). Bit-identical to [`extents_scalar`].
#[inline]
pub fn extents_simd(
    grid: &Grid,
    dirs: &Directions,
    starts: &[Vec3; LANES],
    ends: &[Vec3; LANES],
    bias_start_cells: f32,
    bias_end_cells: f32,
) -> Option<[Option<Extent>; LANES]> {
    #[cfg(target_arch = "x86_64")]
    if avx2_available() {
        // SAFETY: AVX2 was detected on this CPU.
        return Some(unsafe { avx2::extents(grid, dirs, starts, ends, bias_start_cells, bias_end_cells) });
    }
    let _ = (grid, dirs, starts, ends, bias_start_cells, bias_end_cells);
    None
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use super::*;
    use std::arch::x86_64::*;
    use std::f32::consts::{FRAC_PI_2, PI};

    pub(crate) type V = __m256;

    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn splat(x: f32) -> V {
        _mm256_set1_ps(x)
    }

    /// Rust's `a.min(b)` (LLVM `minnum`): the non-NaN operand if exactly one is NaN.
    /// `_mm256_min_ps(a, b)` returns `b` when either is NaN, so patch the lanes where `b` is.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn rmin(a: V, b: V) -> V {
        _mm256_blendv_ps(_mm256_min_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
    }

    /// Rust's `a.max(b)`, as [`rmin`].
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn rmax(a: V, b: V) -> V {
        _mm256_blendv_ps(_mm256_max_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn neg(a: V) -> V {
        _mm256_xor_ps(a, splat(-0.0))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn abs(a: V) -> V {
        _mm256_andnot_ps(splat(-0.0), a)
    }

    /// `if mask { b } else { a }` per lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn select(mask: V, b: V, a: V) -> V {
        _mm256_blendv_ps(a, b, mask)
    }

    /// [`glimpse_core::fast_math::atan_unit`], Horner step by step (mul, then add).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn atan_unit(x: V) -> V {
        let x2 = _mm256_mul_ps(x, x);
        let mut t = _mm256_mul_ps(x2, splat(-0.011_721_2));
        t = _mm256_add_ps(splat(0.052_653_32), t);
        t = _mm256_mul_ps(x2, t);
        t = _mm256_add_ps(splat(-0.116_432_87), t);
        t = _mm256_mul_ps(x2, t);
        t = _mm256_add_ps(splat(0.193_543_46), t);
        t = _mm256_mul_ps(x2, t);
        t = _mm256_add_ps(splat(-0.332_623_47), t);
        t = _mm256_mul_ps(x2, t);
        t = _mm256_add_ps(splat(0.999_977_26), t);
        _mm256_mul_ps(x, t)
    }

    /// [`glimpse_core::fast_math::atan2`].
    #[inline]
    #[target_feature(enable = "avx2")]
    fn atan2(y: V, x: V) -> V {
        let zero = _mm256_setzero_ps();
        let (ax, ay) = (abs(x), abs(y));
        let (lo, hi) = (rmin(ax, ay), rmax(ax, ay));
        let a = select(_mm256_cmp_ps::<_CMP_GT_OQ>(hi, zero), atan_unit(_mm256_div_ps(lo, hi)), zero);
        let a = select(_mm256_cmp_ps::<_CMP_GT_OQ>(ay, ax), _mm256_sub_ps(splat(FRAC_PI_2), a), a);
        let a = select(_mm256_cmp_ps::<_CMP_LT_OQ>(x, zero), _mm256_sub_ps(splat(PI), a), a);
        select(_mm256_cmp_ps::<_CMP_LT_OQ>(y, zero), neg(a), a)
    }

    /// [`glimpse_core::fast_math::asin`].
    #[inline]
    #[target_feature(enable = "avx2")]
    fn asin(y: V) -> V {
        // `f32::clamp`: `if y < min { min }`, then `if y > max { max }` (NaN passes through).
        let y = select(_mm256_cmp_ps::<_CMP_LT_OQ>(y, splat(-1.0)), splat(-1.0), y);
        let y = select(_mm256_cmp_ps::<_CMP_GT_OQ>(y, splat(1.0)), splat(1.0), y);
        let c = rmax(_mm256_sub_ps(splat(1.0), _mm256_mul_ps(y, y)), _mm256_setzero_ps());
        atan2(y, _mm256_sqrt_ps(c))
    }

    /// Eight lanes of `x.field` from an array of `Vec3` (SoA transpose).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes(v: &[Vec3; LANES], field: impl Fn(&Vec3) -> f32) -> V {
        _mm256_setr_ps(field(&v[0]), field(&v[1]), field(&v[2]), field(&v[3]), field(&v[4]), field(&v[5]), field(&v[6]), field(&v[7]))
    }

    /// [`Grid::to_cells_ij`] of the points `(x, y, z)` with the gathered (cos, sin) of θ_i and φ_j.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_cells(grid: &Grid, (ct, st, cp, sp): (V, V, V, V), (x, y, z): (V, V, V)) -> (V, V, V) {
        let scale = splat(grid.scale);
        let vx = _mm256_mul_ps(_mm256_sub_ps(x, splat(grid.center.x)), scale);
        let vy = _mm256_mul_ps(_mm256_sub_ps(y, splat(grid.center.y)), scale);
        let vz = _mm256_mul_ps(_mm256_sub_ps(z, splat(grid.center.z)), scale);
        // `Directions::rotate`.
        let ux = _mm256_add_ps(_mm256_mul_ps(ct, vx), _mm256_mul_ps(st, vz));
        let uz = _mm256_add_ps(_mm256_mul_ps(neg(st), vx), _mm256_mul_ps(ct, vz));
        let ry = _mm256_sub_ps(_mm256_mul_ps(cp, vy), _mm256_mul_ps(sp, uz));
        let rz = _mm256_add_ps(_mm256_mul_ps(sp, vy), _mm256_mul_ps(cp, uz));
        let h = splat(grid.resolution as f32 * 0.5);
        (_mm256_add_ps(ux, h), _mm256_add_ps(ry, h), _mm256_add_ps(rz, h))
    }

    /// Eight extents in lanes: the fields of [`Extent`] as `u32` lanes, `valid` and `start_low`
    /// as bit masks (bit `k` = lane `k`). Lanes not in `valid` hold garbage.
    #[derive(Clone, Copy, Debug)]
    pub struct Raw {
        pub voxelization: [u32; LANES],
        pub x: [u32; LANES],
        pub y: [u32; LANES],
        pub s: [u32; LANES],
        pub e: [u32; LANES],
        pub valid: u32,
        pub start_low: u32,
    }

    impl Raw {
        /// Lane `k` as an [`Extent`], `None` where not valid.
        #[inline]
        pub fn extent(&self, k: usize) -> Option<Extent> {
            (self.valid >> k & 1 != 0).then_some(Extent {
                voxelization: self.voxelization[k],
                x: self.x[k],
                y: self.y[k],
                s: self.s[k],
                e: self.e[k],
                start_low: self.start_low >> k & 1 != 0,
            })
        }
    }

    /// [`super::extents_scalar`], eight lanes in AVX2 registers.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn extents(
        grid: &Grid,
        dirs: &Directions,
        starts: &[Vec3; LANES],
        ends: &[Vec3; LANES],
        bias_start_cells: f32,
        bias_end_cells: f32,
    ) -> [Option<Extent>; LANES] {
        let x = |v: &[Vec3; LANES]| (lanes(v, |v| v.x), lanes(v, |v| v.y), lanes(v, |v| v.z));
        let raw = unsafe { extents_raw(grid, dirs, x(starts), x(ends), bias_start_cells, bias_end_cells) };
        std::array::from_fn(|k| raw.extent(k))
    }

    /// [`extents`] of the segments `start → end` given in lanes (structure of arrays).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn extents_raw(
        grid: &Grid,
        dirs: &Directions,
        start: (V, V, V),
        end: (V, V, V),
        bias_start_cells: f32,
        bias_end_cells: f32,
    ) -> Raw {
        let r = unsafe { extents_regs(grid, dirs, start, end, bias_start_cells, bias_end_cells) };
        let mut raw = Raw {
            voxelization: [0; LANES],
            x: [0; LANES],
            y: [0; LANES],
            s: [0; LANES],
            e: [0; LANES],
            valid: r.valid,
            start_low: r.start_low,
        };
        let store = |o: &mut [u32; LANES], v: __m256i| unsafe { _mm256_storeu_si256(o.as_mut_ptr() as *mut __m256i, v) };
        store(&mut raw.voxelization, r.voxelization);
        store(&mut raw.x, r.x);
        store(&mut raw.y, r.y);
        store(&mut raw.s, r.s);
        store(&mut raw.e, r.e);
        raw
    }

    /// Eight extents in registers: the fields of [`Extent`] as `u32` lanes, `valid` and
    /// `start_low` as bit masks. Lanes not in `valid` hold garbage.
    #[derive(Clone, Copy, Debug)]
    pub struct Regs {
        pub voxelization: __m256i,
        pub x: __m256i,
        pub y: __m256i,
        pub s: __m256i,
        pub e: __m256i,
        pub valid: u32,
        pub start_low: u32,
    }

    /// [`extents_raw`], left in registers.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn extents_regs(
        grid: &Grid,
        dirs: &Directions,
        (sx, sy, sz): (V, V, V),
        (ex, ey, ez): (V, V, V),
        bias_start_cells: f32,
        bias_end_cells: f32,
    ) -> Regs {
        // The table is gathered as flat f32s: (f32, f32) has no guaranteed layout, so read it.
        const {
            assert!(std::mem::size_of::<(f32, f32)>() == 8);
            assert!(std::mem::offset_of!((f32, f32), 0) % 4 == 0 && std::mem::offset_of!((f32, f32), 1) % 4 == 0);
        }
        let cos_at = (std::mem::offset_of!((f32, f32), 0) / 4) as i32;
        let sin_at = (std::mem::offset_of!((f32, f32), 1) / 4) as i32;
        let n = dirs.n as i32;
        assert!(dirs.cos_sin.len() == dirs.n as usize && n > 0);
        unsafe {
            let zero = _mm256_setzero_ps();

            // `discretize(end − start)`: `normalize_or(Vec3::Z)`.
            let dx = _mm256_sub_ps(ex, sx);
            let dy = _mm256_sub_ps(ey, sy);
            let dz = _mm256_sub_ps(ez, sz);
            let dot = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
            let rcp = _mm256_div_ps(splat(1.0), _mm256_sqrt_ps(dot));
            let ok = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(abs(rcp), splat(f32::INFINITY)), _mm256_cmp_ps::<_CMP_GT_OQ>(rcp, zero));
            let dx = select(ok, _mm256_mul_ps(dx, rcp), zero);
            let dy = select(ok, _mm256_mul_ps(dy, rcp), zero);
            let dz = select(ok, _mm256_mul_ps(dz, rcp), splat(1.0));
            // Line symmetry: `if d.y < 0 { d = −d }`.
            let flip = _mm256_cmp_ps::<_CMP_LT_OQ>(dy, zero);
            let (dx, dy, dz) = (select(flip, neg(dx), dx), select(flip, neg(dy), dy), select(flip, neg(dz), dz));
            let mut phi = asin(dy);
            let mut theta = atan2(neg(dx), dz);
            let pi = splat(PI);
            let m = _mm256_cmp_ps::<_CMP_LT_OQ>(theta, zero);
            theta = select(m, _mm256_add_ps(theta, pi), theta);
            phi = select(m, _mm256_sub_ps(pi, phi), phi);
            let m = _mm256_cmp_ps::<_CMP_GE_OQ>(theta, pi);
            theta = select(m, _mm256_sub_ps(theta, pi), theta);
            phi = select(m, _mm256_sub_ps(pi, phi), phi);
            let step = splat(PI / dirs.n as f32);
            let half = splat(0.5);
            // θ, φ are finite and in [0, π] here (d is a finite unit vector), so the truncation
            // to i32 equals the scalar `as i64`.
            let i = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_div_ps(theta, step), half));
            let j = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_div_ps(phi, step), half));
            let nv = _mm256_set1_epi32(n);
            let wrap = _mm256_cmpgt_epi32(i, _mm256_set1_epi32(n - 1));
            let i = _mm256_blendv_epi8(i, _mm256_setzero_si256(), wrap);
            let j = _mm256_blendv_epi8(j, _mm256_sub_epi32(nv, j), wrap);
            // `j.rem_euclid(n)` for j in [−n, 2n) (here j is in [0, n]).
            let j = _mm256_add_epi32(j, _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), j), nv));
            let j = _mm256_sub_epi32(j, _mm256_and_si256(_mm256_cmpgt_epi32(j, _mm256_set1_epi32(n - 1)), nv));
            // Memory safety of the gathers whatever the arithmetic gave (a no-op for [0, n)).
            let last = _mm256_set1_epi32(n - 1);
            let i = _mm256_min_epu32(i, last);
            let j = _mm256_min_epu32(j, last);

            // The cos/sin table, gathered.
            let table = dirs.cos_sin.as_ptr() as *const f32;
            let gather =
                |k: __m256i, at: i32| _mm256_i32gather_ps::<4>(table, _mm256_add_epi32(_mm256_slli_epi32::<1>(k), _mm256_set1_epi32(at)));
            let cs = (gather(i, cos_at), gather(i, sin_at), gather(j, cos_at), gather(j, sin_at));
            let (q0x, q0y, q0z) = to_cells(grid, cs, (sx, sy, sz));
            let (q1x, q1y, q1z) = to_cells(grid, cs, (ex, ey, ez));
            let mx = _mm256_mul_ps(_mm256_add_ps(q0x, q1x), half);
            let my = _mm256_mul_ps(_mm256_add_ps(q0y, q1y), half);
            let nf = splat(grid.resolution as f32);
            let inside = _mm256_and_ps(
                _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(mx, zero), _mm256_cmp_ps::<_CMP_LT_OQ>(mx, nf)),
                _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(my, zero), _mm256_cmp_ps::<_CMP_LT_OQ>(my, nf)),
            );
            let low = _mm256_cmp_ps::<_CMP_LE_OQ>(q0z, q1z);
            let (bs, be) = (splat(bias_start_cells), splat(bias_end_cells));
            let lo = select(low, _mm256_add_ps(q0z, bs), _mm256_add_ps(q1z, be));
            let hi = select(low, _mm256_sub_ps(q1z, be), _mm256_sub_ps(q0z, bs));
            let lo = rmax(lo, zero);
            let hi = rmin(hi, splat(grid.resolution as f32 - 1e-3));
            let bad = _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(lo, hi),
                _mm256_or_ps(_mm256_cmp_ps::<_CMP_UNORD_Q>(lo, lo), _mm256_cmp_ps::<_CMP_UNORD_Q>(hi, hi)),
            );
            let valid = _mm256_movemask_ps(_mm256_andnot_ps(bad, inside)) as u32;
            let low = _mm256_movemask_ps(low) as u32;

            Regs {
                voxelization: _mm256_add_epi32(_mm256_mullo_epi32(i, nv), j),
                x: _mm256_cvttps_epi32(mx),
                y: _mm256_cvttps_epi32(my),
                s: _mm256_cvttps_epi32(lo),
                e: _mm256_cvttps_epi32(hi),
                valid,
                start_low: low,
            }
        }
    }
}

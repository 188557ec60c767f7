//! The runtime's untraced per-ray work for a whole ray set at once (issue #14): a fragment's N_r
//! directions formed together into a stack block (SoA), with each one's octahedral pixel and
//! whether it lies above both horizons (`Shading::cos > 0`), so that [`crate::technique::Runtime`]
//! then traces only the rays its masks select.
//!
//! Exactness: the directions are bit-identical to [`RaySet::direction`] (hence to `env-exact`'s
//! rays), the pixels to [`crate::grid::octahedral_pixel`] and the horizon test to
//! `Shading::cos(d) > 0`: the same IEEE operations in the same order, no FMA, with
//! - the Hammersley point's (k + ½)/N_r and radical inverse (the latter from a table made by
//!   [`radical_inverse_base2`] itself),
//! - the Cranley-Patterson wrap `v − ⌊v⌋` (AVX `floor`), the concentric map's branch as selects,
//! - `sin θ`, `cos θ` of the concentric map: the one call that is not an IEEE basic operation.
//!   The scalar code calls glibc's `sincosf`; on x86-64 with AVX2 and FMA glibc (≥ 2.28,
//!   checked against 2.36) runs `__sincosf_fma`, whose every operation (the double-precision
//!   reduction by π/2 and its two polynomials, fused exactly where that build fuses them) is
//!   reproduced here on four lanes (`avx2::sincos4_glibc`, constants from glibc's
//!   `__sincosf_table`). Because another libm rounds differently, the AVX2 former is enabled
//!   only after a one-time self-check against `RaySet::direction` (128 ray sets of 1–128 rays,
//!   both rotations) and against `sin_cos` on a dense sweep of the concentric map's angles and
//!   glibc's band edges (see [`simd_enabled`]); otherwise, or with `GLIMPSE_DVF_SCALAR=1`, each
//!   direction is `RaySet::direction` (scalar) and only the pixel and horizon work is shared. A
//!   libm that disagreed only very rarely (e.g. glibc's non-FMA variant, which differs from the
//!   FMA one only where a double result lies within ~2^-50 of a float rounding boundary) could
//!   pass the self-check; `dvf_sincos_check` settles a platform exhaustively.
//!
//! The example `dvf_sincos_check` compares [`sincos_lanes`] with the platform's `sin_cos` on
//! every f32 in [−1, 2.5] (the concentric map's angles lie in [−π/4, 3π/4]).

use crate::rays::RaySet;
use glimpse_core::Vec3;
use glimpse_core::sampling::radical_inverse_base2;
use glimpse_scene::Environment;
use std::sync::LazyLock;

/// The largest ray set formed in a block; larger sets take the per-ray path.
pub const MAX_RAYS: usize = 256;
/// Words of a per-ray bit set.
pub const RAY_WORDS: usize = MAX_RAYS / 64;

/// One fragment's rays: world directions (SoA), octahedral pixels, horizon bits.
#[repr(C, align(32))]
pub struct Block {
    pub x: [f32; MAX_RAYS],
    pub y: [f32; MAX_RAYS],
    pub z: [f32; MAX_RAYS],
    pub pixel: [u32; MAX_RAYS],
    /// Bit k: ray k is above the geometric and the shading normal's horizons (`cos > 0`).
    pub used: [u64; RAY_WORDS],
    pub count: usize,
}

impl Default for Block {
    fn default() -> Self {
        Block { x: [0.0; MAX_RAYS], y: [0.0; MAX_RAYS], z: [0.0; MAX_RAYS], pixel: [0; MAX_RAYS], used: [0; RAY_WORDS], count: 0 }
    }
}

impl Block {
    #[inline]
    pub fn direction(&self, k: usize) -> Vec3 {
        Vec3::new(self.x[k], self.y[k], self.z[k])
    }
}

/// `radical_inverse_base2(k)` for k < MAX_RAYS (Hammersley's second coordinate).
static RADICAL: LazyLock<[f32; MAX_RAYS]> = LazyLock::new(|| std::array::from_fn(|k| radical_inverse_base2(k as u32)));

/// Which former [`form`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Former {
    /// AVX2 + FMA, 8 rays at a time (only where [`simd_enabled`]).
    Simd,
    /// `RaySet::direction` per ray, then the scalar pixel and horizon tests.
    Scalar,
}

/// Whether the AVX2 former is usable here: the CPU has AVX2 and FMA, `GLIMPSE_DVF_SCALAR` is
/// unset, and the one-time self-check found it bit-identical to `RaySet::direction` (cached).
pub fn simd_enabled() -> bool {
    static ENABLED: LazyLock<bool> = LazyLock::new(|| {
        if std::env::var_os("GLIMPSE_DVF_SCALAR").is_some_and(|v| v != "0") || !simd_supported() {
            return false;
        }
        let ok = self_check();
        if !ok {
            eprintln!("env-dvf: the AVX2 ray former disagrees with RaySet::direction on this platform's libm; using the scalar former");
        }
        ok
    });
    *ENABLED
}

/// The CPU supports the AVX2 former (regardless of the self-check).
pub fn simd_supported() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static S: LazyLock<bool> = LazyLock::new(|| is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"));
        *S
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The former the runtime uses by default.
pub fn default_former() -> Former {
    if simd_enabled() { Former::Simd } else { Former::Scalar }
}

/// Forms `set`'s directions, pixels (R = `resolution`) and horizon bits against the geometric
/// `normal` and `shading_normal` into `out` (`set.count ≤ MAX_RAYS`).
pub fn form(set: &RaySet, normal: Vec3, shading_normal: Vec3, resolution: u32, former: Former, out: &mut Block) {
    let n = set.count as usize;
    assert!(n <= MAX_RAYS, "ray set of {n} > {MAX_RAYS}");
    out.count = n;
    #[cfg(target_arch = "x86_64")]
    if former == Former::Simd && simd_supported() {
        // SAFETY: AVX2 and FMA were detected at run time.
        unsafe { avx2::form(set, normal, shading_normal, resolution, out) };
        return;
    }
    let _ = former;
    form_scalar(set, normal, shading_normal, resolution, out);
}

fn form_scalar(set: &RaySet, normal: Vec3, shading_normal: Vec3, resolution: u32, out: &mut Block) {
    out.used = [0; RAY_WORDS];
    for k in 0..out.count {
        let d = set.direction(k as u32);
        out.x[k] = d.x;
        out.y[k] = d.y;
        out.z[k] = d.z;
        out.pixel[k] = crate::grid::octahedral_pixel(d, resolution);
        // `Shading::cos(d) > 0`: above the geometric horizon, then the shading one.
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN: as `Shading::cos`
        let used = !(normal.dot(d) <= 0.0) && shading_normal.dot(d).max(0.0) > 0.0;
        out.used[k / 64] |= (used as u64) << (k % 64);
    }
}

/// [`crate::grid::octahedral_pixel`] of 8 directions (AVX2 when supported; for the tests).
pub fn octahedral_pixels8(x: [f32; 8], y: [f32; 8], z: [f32; 8], r: u32) -> [u32; 8] {
    #[cfg(target_arch = "x86_64")]
    if simd_supported() {
        // SAFETY: AVX2 was detected at run time.
        return unsafe { avx2::octahedral_pixels8(x, y, z, r) };
    }
    std::array::from_fn(|i| crate::grid::octahedral_pixel(Vec3::new(x[i], y[i], z[i]), r))
}

/// (sin, cos) of 8 angles by the glibc `__sincosf_fma` replica, `None` without AVX2 + FMA or
/// where a lane is outside the replica's range (|θ| ≥ 120, NaN).
pub fn sincos_lanes(theta: [f32; 8]) -> Option<([f32; 8], [f32; 8])> {
    #[cfg(target_arch = "x86_64")]
    if simd_supported() {
        // SAFETY: AVX2 and FMA were detected at run time.
        return unsafe { avx2::sincos_lanes(theta) };
    }
    let _ = theta;
    None
}

/// The AVX2 former against `RaySet::direction` (and its pixels and horizon bits against the
/// scalar former's) on 128 random ray sets of 128 rays, both rotations; and the concentric
/// map's angles against `sin_cos` on a dense sweep of [−π/4, 3π/4] with its band edges.
fn self_check() -> bool {
    use glimpse_core::Rng;
    let mut rng = Rng::new(0x05ee_dd1f, 7);
    let (mut a, mut b) = (Box::<Block>::default(), Box::<Block>::default());
    for i in 0..128 {
        let normal = glimpse_core::sampling::uniform_sphere(rng.next_2d());
        let set = RaySet::new(normal, if i % 3 == 0 { 128 } else { 1 + i as u32 }, rng.next_2d(), i % 4 == 1);
        let geometric = (normal + glimpse_core::sampling::uniform_sphere(rng.next_2d()) * 0.3).normalize();
        form(&set, geometric, normal, 8, Former::Simd, &mut a);
        form(&set, geometric, normal, 8, Former::Scalar, &mut b);
        let n = set.count as usize;
        let same = (0..n).all(|k| {
            a.x[k].to_bits() == b.x[k].to_bits()
                && a.y[k].to_bits() == b.y[k].to_bits()
                && a.z[k].to_bits() == b.z[k].to_bits()
                && a.pixel[k] == b.pixel[k]
        });
        if !same || a.used != b.used {
            return false;
        }
    }
    let mut specials: Vec<f32> = vec![0.0, -0.0, 0.75, -0.75, 2f32.powi(-12), -(2f32.powi(-12)), 1e-30, -1e-30];
    for c in [
        std::f32::consts::FRAC_PI_4,
        -std::f32::consts::FRAC_PI_4,
        std::f32::consts::FRAC_PI_2,
        0.75,
        2.0 * std::f32::consts::FRAC_PI_3,
        3.0 * std::f32::consts::FRAC_PI_4,
    ] {
        let bits = c.to_bits();
        specials.extend((0..64).flat_map(|d| [f32::from_bits(bits + d), f32::from_bits(bits - d)]));
    }
    let steps = 1 << 16;
    let sweep = (0..steps).map(|i| -std::f32::consts::FRAC_PI_4 + std::f32::consts::PI * (i as f32 + 0.37) / steps as f32);
    let all: Vec<f32> = specials.into_iter().chain(sweep).collect();
    for chunk in all.chunks(8) {
        let mut t = [0.0f32; 8];
        t[..chunk.len()].copy_from_slice(chunk);
        let Some((s, c)) = sincos_lanes(t) else { return false };
        for i in 0..8 {
            let (rs, rc) = std::hint::black_box(t[i]).sin_cos();
            if s[i].to_bits() != rs.to_bits() || c[i].to_bits() != rc.to_bits() {
                return false;
            }
        }
    }
    true
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Block, MAX_RAYS, RADICAL};
    use crate::rays::RaySet;
    use glimpse_core::Vec3;
    use std::arch::x86_64::*;

    /// glibc's `__sincosf_table` (sysdeps/ieee754/flt-32/s_sincosf.c, x86 layout): entry 0,
    /// and entry 1's cosine coefficients (its sine ones and the rest equal entry 0's).
    const HPI_INV: f64 = f64::from_bits(0x4164_5f30_6dc9_c883); // 2^24·2/π
    const HPI: f64 = f64::from_bits(0x3ff9_21fb_5444_2d18); // π/2
    const C0: f64 = 1.0;
    const C1: f64 = f64::from_bits(0xbfdf_ffff_fd0c_621c);
    const S1: f64 = f64::from_bits(0xbfc5_5554_5995_a603);
    const C2: f64 = f64::from_bits(0x3fa5_5553_e106_8f19);
    const S2: f64 = f64::from_bits(0x3f81_1076_0523_0bc4);
    const C3: f64 = f64::from_bits(0xbf56_c087_e89a_359d);
    const S3: f64 = f64::from_bits(0xbf29_94eb_3774_cf24);
    const C4: f64 = f64::from_bits(0x3ef9_9343_027b_f8c3);

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn wide(m: __m128i) -> __m256d {
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(m))
    }

    /// glibc 2.36 `__sincosf_fma` on 4 lanes with |y| < 120 (the caller checks): tiny lanes
    /// (|y| < 2^-12) give (y, 1); the others reduce by n = round(y·2/π) (n = 0 below 0.75, as
    /// glibc's small path) and evaluate its polynomials, swapped for odd n.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn sincos4_glibc(y: __m128) -> (__m128, __m128) {
        let x = _mm256_cvtps_pd(y);
        let bits = _mm_castps_si128(y);
        let top12 = _mm_and_si128(_mm_srli_epi32::<20>(bits), _mm_set1_epi32(0x7ff));
        let tiny = _mm_castsi128_ps(_mm_cmplt_epi32(top12, _mm_set1_epi32(0x398)));
        let r = _mm256_mul_pd(x, _mm256_set1_pd(HPI_INV));
        let n = _mm_srai_epi32::<24>(_mm_add_epi32(_mm256_cvttpd_epi32(r), _mm_set1_epi32(0x80_0000)));
        let xr = _mm256_fnmadd_pd(_mm256_cvtepi32_pd(n), _mm256_set1_pd(HPI), x);
        let n3 = _mm_and_si128(n, _mm_set1_epi32(3));
        let neg = wide(_mm_or_si128(_mm_cmpeq_epi32(n3, _mm_set1_epi32(1)), _mm_cmpeq_epi32(n3, _mm_set1_epi32(2))));
        let tab1 = wide(_mm_cmpeq_epi32(_mm_and_si128(n, _mm_set1_epi32(2)), _mm_set1_epi32(2)));
        let odd = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(n, _mm_set1_epi32(1)), _mm_set1_epi32(1)));
        let sign = _mm256_blendv_pd(_mm256_set1_pd(1.0), _mm256_set1_pd(-1.0), neg);
        let coef = |c: f64| _mm256_blendv_pd(_mm256_set1_pd(c), _mm256_set1_pd(-c), tab1);
        let xs = _mm256_mul_pd(xr, sign);
        let x2 = _mm256_mul_pd(xr, xr);
        let x3 = _mm256_mul_pd(x2, xs);
        let x4 = _mm256_mul_pd(x2, x2);
        let x5 = _mm256_mul_pd(x2, x3);
        let x6 = _mm256_mul_pd(x2, x4);
        let a_s = _mm256_fmadd_pd(x2, _mm256_set1_pd(S3), _mm256_set1_pd(S2));
        let a_c = _mm256_fmadd_pd(x2, coef(C4), coef(C3));
        let c_lo = _mm256_fmadd_pd(x2, coef(C1), coef(C0));
        let b_s = _mm256_fmadd_pd(x3, _mm256_set1_pd(S1), xs);
        let b_c = _mm256_fmadd_pd(x4, coef(C2), c_lo);
        let lo = _mm256_cvtpd_ps(_mm256_fmadd_pd(a_s, x5, b_s));
        let hi = _mm256_cvtpd_ps(_mm256_fmadd_pd(a_c, x6, b_c));
        let sin = _mm_blendv_ps(lo, hi, odd);
        let cos = _mm_blendv_ps(hi, lo, odd);
        (_mm_blendv_ps(sin, y, tiny), _mm_blendv_ps(cos, _mm_set1_ps(1.0), tiny))
    }

    /// Any lane outside the replica's range: |θ| ≥ 120 (top12 > 0x42e) or not finite.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn out_of_range(t: __m256) -> bool {
        let top12 = _mm256_and_si256(_mm256_srli_epi32::<20>(_mm256_castps_si256(t)), _mm256_set1_epi32(0x7ff));
        _mm256_movemask_epi8(_mm256_cmpgt_epi32(top12, _mm256_set1_epi32(0x42e))) != 0
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn sincos8(t: __m256) -> (__m256, __m256) {
        let (s0, c0) = sincos4_glibc(_mm256_castps256_ps128(t));
        let (s1, c1) = sincos4_glibc(_mm256_extractf128_ps::<1>(t));
        (_mm256_set_m128(s1, s0), _mm256_set_m128(c1, c0))
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn sincos_lanes(theta: [f32; 8]) -> Option<([f32; 8], [f32; 8])> {
        // SAFETY: 8 f32 read from and written to arrays of 8.
        unsafe {
            let t = _mm256_loadu_ps(theta.as_ptr());
            if out_of_range(t) {
                return None;
            }
            let (s, c) = sincos8(t);
            let (mut so, mut co) = ([0.0f32; 8], [0.0f32; 8]);
            _mm256_storeu_ps(so.as_mut_ptr(), s);
            _mm256_storeu_ps(co.as_mut_ptr(), c);
            Some((so, co))
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn abs(v: __m256) -> __m256 {
        _mm256_andnot_ps(_mm256_set1_ps(-0.0), v)
    }

    /// `grid::octahedral_pixel` on 8 lanes: the same operations (`as u32`'s saturation as a
    /// clamp of the truncation to [0, r − 1]; equal for every |f| < 2^31, NaN included).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn octahedral8(x: __m256, y: __m256, z: __m256, r: u32) -> __m256i {
        let one = _mm256_set1_ps(1.0);
        let inv_l1 = _mm256_div_ps(one, _mm256_add_ps(_mm256_add_ps(abs(x), abs(y)), abs(z)));
        let (x, y) = (_mm256_mul_ps(x, inv_l1), _mm256_mul_ps(y, inv_l1));
        let zero = _mm256_setzero_ps();
        let sx = _mm256_blendv_ps(_mm256_set1_ps(-1.0), one, _mm256_cmp_ps::<_CMP_GE_OQ>(x, zero));
        let sy = _mm256_blendv_ps(_mm256_set1_ps(-1.0), one, _mm256_cmp_ps::<_CMP_GE_OQ>(y, zero));
        let lower = _mm256_cmp_ps::<_CMP_LT_OQ>(z, zero);
        let fx = _mm256_blendv_ps(x, _mm256_mul_ps(_mm256_sub_ps(one, abs(y)), sx), lower);
        let fy = _mm256_blendv_ps(y, _mm256_mul_ps(_mm256_sub_ps(one, abs(x)), sy), lower);
        let half = _mm256_set1_ps(r as f32 * 0.5);
        let max = _mm256_set1_epi32(r as i32 - 1);
        let cell = |f: __m256| {
            let i = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(f, half), half));
            _mm256_min_epi32(_mm256_max_epi32(i, _mm256_setzero_si256()), max)
        };
        _mm256_add_epi32(_mm256_mullo_epi32(cell(fy), _mm256_set1_epi32(r as i32)), cell(fx))
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn octahedral_pixels8(x: [f32; 8], y: [f32; 8], z: [f32; 8], r: u32) -> [u32; 8] {
        let mut out = [0u32; 8];
        // SAFETY: arrays of 8 lanes.
        unsafe {
            let p = octahedral8(_mm256_loadu_ps(x.as_ptr()), _mm256_loadu_ps(y.as_ptr()), _mm256_loadu_ps(z.as_ptr()), r);
            _mm256_storeu_si256(out.as_mut_ptr().cast(), p);
        }
        out
    }

    /// `dot(a, d)` as glam's `Vec3::dot`: (a.x·x + a.y·y) + a.z·z.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn dot(a: Vec3, x: __m256, y: __m256, z: __m256) -> __m256 {
        let m = |c: f32, v: __m256| _mm256_mul_ps(_mm256_set1_ps(c), v);
        _mm256_add_ps(_mm256_add_ps(m(a.x, x), m(a.y, y)), m(a.z, z))
    }

    /// `RaySet::direction` for k = 0 .. count (8 at a time), with pixels and horizon bits.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn form(set: &RaySet, normal: Vec3, shading_normal: Vec3, r: u32, out: &mut Block) {
        let n = set.count as usize;
        let radical = &*RADICAL;
        let (half, one, two, zero) = (_mm256_set1_ps(0.5), _mm256_set1_ps(1.0), _mm256_set1_ps(2.0), _mm256_setzero_ps());
        let count = _mm256_set1_ps(set.count as f32);
        let (shift_x, shift_y) = (_mm256_set1_ps(set.shift.x), _mm256_set1_ps(set.shift.y));
        let (sin_a, cos_a) = set.rotation();
        let f = set.frame;
        out.used = [0; super::RAY_WORDS];
        let mut base = 0;
        while base < n {
            // SAFETY: base + 8 ≤ MAX_RAYS (MAX_RAYS is a multiple of 8 and base < n ≤ MAX_RAYS);
            // every pointer is into an array of MAX_RAYS.
            unsafe {
                debug_assert!(base + 8 <= MAX_RAYS);
                // hammersley(k, n) = ((k + 0.5) / n, radical_inverse(k)).
                let k = _mm256_add_epi32(_mm256_set1_epi32(base as i32), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
                let mut ux = _mm256_div_ps(_mm256_add_ps(_mm256_cvtepi32_ps(k), half), count);
                let mut uy = _mm256_loadu_ps(radical.as_ptr().add(base));
                if !set.about_normal {
                    // rotate_sample: v − ⌊v⌋ of v = u + shift.
                    ux = _mm256_add_ps(ux, shift_x);
                    uy = _mm256_add_ps(uy, shift_y);
                    ux = _mm256_sub_ps(ux, _mm256_floor_ps(ux));
                    uy = _mm256_sub_ps(uy, _mm256_floor_ps(uy));
                }
                // concentric_disk.
                let ox = _mm256_sub_ps(_mm256_mul_ps(ux, two), one);
                let oy = _mm256_sub_ps(_mm256_mul_ps(uy, two), one);
                let origin = _mm256_and_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(ox, zero), _mm256_cmp_ps::<_CMP_EQ_OQ>(oy, zero));
                let x_major = _mm256_cmp_ps::<_CMP_GT_OQ>(abs(ox), abs(oy));
                let rad = _mm256_blendv_ps(oy, ox, x_major);
                let num = _mm256_blendv_ps(ox, oy, x_major);
                let q = _mm256_div_ps(num, rad);
                let pi4 = _mm256_set1_ps(std::f32::consts::FRAC_PI_4);
                let theta = _mm256_blendv_ps(
                    _mm256_sub_ps(_mm256_set1_ps(std::f32::consts::PI / 2.0), _mm256_mul_ps(pi4, q)),
                    _mm256_mul_ps(pi4, q),
                    x_major,
                );
                let theta = _mm256_blendv_ps(theta, zero, origin);
                let (mut lx, mut ly, lz);
                if out_of_range(theta) {
                    // Unreachable for finite inputs (|θ| ≤ 3π/4); the scalar code, to be exact.
                    for i in 0..8.min(n - base) {
                        let d = set.direction((base + i) as u32);
                        out.x[base + i] = d.x;
                        out.y[base + i] = d.y;
                        out.z[base + i] = d.z;
                    }
                    let (x, y, z) = (
                        _mm256_loadu_ps(out.x.as_ptr().add(base)),
                        _mm256_loadu_ps(out.y.as_ptr().add(base)),
                        _mm256_loadu_ps(out.z.as_ptr().add(base)),
                    );
                    finish(normal, shading_normal, r, out, base, n, x, y, z);
                    base += 8;
                    continue;
                }
                let (s, c) = sincos8(theta);
                lx = _mm256_blendv_ps(_mm256_mul_ps(rad, c), zero, origin);
                ly = _mm256_blendv_ps(_mm256_mul_ps(rad, s), zero, origin);
                // cosine_hemisphere: z = √max(1 − |d|², 0).
                let len2 = _mm256_add_ps(_mm256_mul_ps(lx, lx), _mm256_mul_ps(ly, ly));
                lz = _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, len2), zero));
                if set.about_normal {
                    let (sa, ca) = (_mm256_set1_ps(sin_a), _mm256_set1_ps(cos_a));
                    let rx = _mm256_sub_ps(_mm256_mul_ps(lx, ca), _mm256_mul_ps(ly, sa));
                    let ry = _mm256_add_ps(_mm256_mul_ps(lx, sa), _mm256_mul_ps(ly, ca));
                    (lx, ly) = (rx, ry);
                }
                // Frame::to_world: (X·lx + Y·ly) + Z·lz per component.
                let w = |a: f32, b: f32, c: f32| {
                    _mm256_add_ps(
                        _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(a), lx), _mm256_mul_ps(_mm256_set1_ps(b), ly)),
                        _mm256_mul_ps(_mm256_set1_ps(c), lz),
                    )
                };
                let (x, y, z) = (w(f.x.x, f.y.x, f.z.x), w(f.x.y, f.y.y, f.z.y), w(f.x.z, f.y.z, f.z.z));
                _mm256_storeu_ps(out.x.as_mut_ptr().add(base), x);
                _mm256_storeu_ps(out.y.as_mut_ptr().add(base), y);
                _mm256_storeu_ps(out.z.as_mut_ptr().add(base), z);
                finish(normal, shading_normal, r, out, base, n, x, y, z);
            }
            base += 8;
        }
    }

    /// Pixels and horizon bits of the 8 directions at `base`.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    fn finish(normal: Vec3, shading_normal: Vec3, r: u32, out: &mut Block, base: usize, n: usize, x: __m256, y: __m256, z: __m256) {
        let zero = _mm256_setzero_ps();
        // Shading::cos(d) > 0: !(n·d ≤ 0) and max(s·d, 0) > 0.
        let above = _mm256_cmp_ps::<_CMP_NLE_UQ>(dot(normal, x, y, z), zero);
        let lit = _mm256_cmp_ps::<_CMP_GT_OQ>(dot(shading_normal, x, y, z), zero);
        let lanes = (n - base).min(8);
        let bits = (_mm256_movemask_ps(_mm256_and_ps(above, lit)) as u32 as u64) & ((1u64 << lanes) - 1);
        out.used[base / 64] |= bits << (base % 64);
        // SAFETY: base + 8 ≤ MAX_RAYS.
        unsafe { _mm256_storeu_si256(out.pixel.as_mut_ptr().add(base).cast(), octahedral8(x, y, z, r)) };
    }
}

/// The four texels and weights of `env.radiance(d)`'s bilinear lookup ([`radiance`] in two
/// steps, so that a batch of lookups can prefetch its texels before reading any).
#[derive(Clone, Copy, Debug, Default)]
pub struct Tap {
    /// Texel indices: (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1).
    pub texels: [usize; 4],
    pub fx: f32,
    pub fy: f32,
}

/// `env.radiance(d)`'s texels and weights: the same `dir_to_uv` and the same arithmetic as
/// `Image::sample_bilinear(u, v, false)`, with the column wrap `rem_euclid` (a 64-bit division
/// per fetch, 4 per lookup) taken only for columns outside [0, w) (never, for u in [0, 1]).
#[inline]
pub fn tap(env: &Environment, d: Vec3) -> Tap {
    let uv = Environment::dir_to_uv(d);
    let img = &env.image;
    let (w, h) = (img.width as i64, img.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let index = |xi: i64, yi: i64| {
        let xi = if (0..w).contains(&xi) { xi } else { xi.rem_euclid(w) };
        let yi = yi.clamp(0, h - 1);
        (yi * w + xi) as usize
    };
    let (x0, y0) = (x0 as i64, y0 as i64);
    Tap { texels: [index(x0, y0), index(x0 + 1, y0), index(x0, y0 + 1), index(x0 + 1, y0 + 1)], fx, fy }
}

/// Asks for a tap's texels to be brought into cache (a hint; no effect on results).
#[inline]
pub fn prefetch(env: &Environment, t: &Tap) {
    #[cfg(target_arch = "x86_64")]
    for &i in &[t.texels[0], t.texels[2]] {
        if let Some(p) = env.image.pixels.get(i) {
            // SAFETY: a prefetch of a valid address; SSE is baseline on x86-64.
            unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((p as *const Vec3).cast()) };
        }
    }
    let _ = (env, t);
}

/// The radiance of a tap: `sample_bilinear`'s lerps, times the map's scale.
#[inline]
pub fn tap_radiance(env: &Environment, t: &Tap) -> Vec3 {
    let p = &env.image.pixels;
    let top = p[t.texels[0]].lerp(p[t.texels[1]], t.fx);
    let bottom = p[t.texels[2]].lerp(p[t.texels[3]], t.fx);
    top.lerp(bottom, t.fy) * env.scale
}

/// `env.radiance(d)`, bit for bit ([`tap`] then [`tap_radiance`]).
#[inline]
pub fn radiance(env: &Environment, d: Vec3) -> Vec3 {
    tap_radiance(env, &tap(env, d))
}

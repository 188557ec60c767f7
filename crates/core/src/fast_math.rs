//! Polynomial arc tangents for hot loops that only need to pick a bin (ROMA's stratum, the voxel
//! array's direction index): several times faster than libm's `atanf`/`atan2f`/`asinf`, which
//! the default x86-64 target calls out of line. Maximum error 1.7e-6 rad, so a bin boundary moves
//! by less than that; callers that need exact angles use `f32::atan2`.

use std::f32::consts::{FRAC_PI_2, PI};

/// arctan on [−1, 1] by an odd minimax polynomial (max error 1.7e-6 rad).
#[inline]
pub fn atan_unit(x: f32) -> f32 {
    let x2 = x * x;
    x * (0.999_977_26 + x2 * (-0.332_623_47 + x2 * (0.193_543_46 + x2 * (-0.116_432_87 + x2 * (0.052_653_32 + x2 * -0.011_721_2)))))
}

/// `y.atan2(x)` to 1.7e-6 rad, in (−π, π]; `(±0, ±0)` gives 0 and `y = −0` counts as `+0`.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { atan_unit(lo / hi) } else { 0.0 };
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 { -a } else { a }
}

/// `y.asin()` for `y` in [−1, 1] (clamped) to 1.7e-6 rad, as `atan2(y, √(1 − y²))`.
#[inline]
pub fn asin(y: f32) -> f32 {
    let y = y.clamp(-1.0, 1.0);
    atan2(y, (1.0 - y * y).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_against_libm() {
        let n = 2001;
        let unit = (0..n).map(|i| -1.0 + 2.0 * i as f32 / (n - 1) as f32);
        let e_atan = unit.clone().map(|x| (atan_unit(x) - x.atan()).abs()).fold(0.0, f32::max);
        let e_asin = unit.map(|y| (asin(y) - y.asin()).abs()).fold(0.0, f32::max);
        let mut e_atan2 = 0.0f32;
        for k in 0..3600 {
            let t = k as f32 * (std::f32::consts::TAU / 3600.0) - PI + 1e-4;
            for r in [1e-3f32, 1.0, 7.5] {
                let (y, x) = (r * t.sin(), r * t.cos());
                e_atan2 = e_atan2.max((atan2(y, x) - y.atan2(x)).abs());
            }
        }
        println!("max error (rad): atan_unit {e_atan:e}, atan2 {e_atan2:e}, asin {e_asin:e}");
        assert!(e_atan < 3e-6 && e_atan2 < 5e-6 && e_asin < 5e-6);
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert!((atan2(0.0, -1.0) - PI).abs() < 1e-6 && (atan2(-0.0, -1.0) - PI).abs() < 1e-6);
        assert!((atan2(1.0, 0.0) - FRAC_PI_2).abs() < 1e-6 && (atan2(-1.0, 0.0) + FRAC_PI_2).abs() < 1e-6);
        assert!((asin(1.0) - FRAC_PI_2).abs() < 1e-6 && (asin(-1.0) + FRAC_PI_2).abs() < 1e-6);
    }
}

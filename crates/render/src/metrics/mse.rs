//! Mean squared error and its root.
//!
//! `MSE = 1/(3·N) · Σ_p Σ_c (t_c(p) − r_c(p))²` over the N included pixels and the 3 linear RGB
//! channels (no clamping, no tone mapping: HDR values count as they are), `RMSE = √MSE`. This is
//! the textbook definition (e.g. Wang & Bovik, "Mean squared error: love it or leave it?",
//! IEEE Signal Processing Magazine 26(1), 2009, eq. 1). Accumulation is in f64, in fixed chunks
//! summed in order, so a result does not depend on the number of threads.

use super::error::{MetricsError, check_mask, check_pair};
use glimpse_core::Image;
use rayon::prelude::*;

/// Pixels per chunk of the parallel sums (a fixed size keeps the summation order fixed).
const CHUNK: usize = 4096;

/// MSE over the 3 channels; `mask` (one entry per pixel, `true` = include) restricts the mean to
/// some pixels, e.g. those covered by geometry.
pub fn mse(test: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<f64, MetricsError> {
    mean_over_channels(test, reference, mask, |t, r| (t - r) * (t - r))
}

/// `√MSE` (see [`mse()`]).
pub fn rmse(test: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<f64, MetricsError> {
    mse(test, reference, mask).map(f64::sqrt)
}

/// MSE over the pixels left when the `fraction` of pixels with the largest squared error (at least
/// one when `fraction` > 0) are set aside: how much of an MSE a few outliers carry. A Monte Carlo
/// estimator's rare bright samples, or one jamb of a window, can decide an MSE comparison that
/// the rest of the image reverses (issue #13: the light cuts on `interior-openings`).
pub fn mse_without_worst(test: &Image, reference: &Image, fraction: f64) -> Result<f64, MetricsError> {
    check_pair(test, reference)?;
    let mut errors: Vec<f64> =
        test.pixels.iter().zip(&reference.pixels).map(|(t, r)| (0..3).map(|c| (f64::from(t[c]) - f64::from(r[c])).powi(2)).sum()).collect();
    let n = errors.len();
    let drop = if fraction > 0.0 && n > 1 { ((fraction * n as f64).ceil() as usize).clamp(1, n - 1) } else { 0 };
    // Ascending with NaN last (`total_cmp`): a NaN pixel is the first set aside.
    errors.sort_unstable_by(f64::total_cmp);
    let kept = &errors[..n - drop];
    Ok(kept.iter().sum::<f64>() / (3.0 * kept.len().max(1) as f64))
}

/// The mean of `f(test_c, reference_c)` over the included pixels and the 3 channels, after
/// [`check_pair`] and [`check_mask`].
pub(crate) fn mean_over_channels(
    test: &Image,
    reference: &Image,
    mask: Option<&[bool]>,
    f: impl Fn(f64, f64) -> f64 + Sync,
) -> Result<f64, MetricsError> {
    check_pair(test, reference)?;
    let included = check_mask(mask, test.pixels.len())?;
    let pixel = |i: usize| -> f64 {
        if mask.is_some_and(|m| !m[i]) {
            return 0.0;
        }
        let (t, r) = (test.pixels[i], reference.pixels[i]);
        (0..3).map(|c| f(f64::from(t[c]), f64::from(r[c]))).sum()
    };
    let n = test.pixels.len();
    let partial: Vec<f64> =
        (0..n.div_ceil(CHUNK)).into_par_iter().map(|k| (k * CHUNK..((k + 1) * CHUNK).min(n)).map(pixel).sum()).collect();
    Ok(partial.iter().sum::<f64>() / (3.0 * included as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Vec3;

    #[test]
    fn the_worst_pixels_are_set_aside() {
        // 1,000 pixels off by 0.1 in every channel, and one off by 10: it holds 99 % of the MSE.
        let reference = Image::filled(1001, 1, Vec3::ZERO);
        let mut test = Image::filled(1001, 1, Vec3::splat(0.1));
        test.pixels[500] = Vec3::splat(10.0);
        let all = mse(&test, &reference, None).unwrap();
        let trimmed = mse_without_worst(&test, &reference, 0.001).unwrap();
        println!("MSE {all:.4e}, without the worst 0.1 %: {trimmed:.4e}");
        assert!((all - (1000.0 * 0.01 + 100.0) / 1001.0).abs() < 1e-9);
        assert!((trimmed - 0.01).abs() < 1e-9, "the outlier is gone, the rest kept");
        assert!((mse_without_worst(&test, &reference, 0.0).unwrap() - all).abs() < 1e-12);
        // One pixel: nothing is set aside (an empty mean would say nothing).
        let one = Image::filled(1, 1, Vec3::splat(2.0));
        assert_eq!(mse_without_worst(&one, &Image::filled(1, 1, Vec3::ZERO), 0.5).unwrap(), 4.0);
        assert!(mse_without_worst(&one, &reference, 0.1).is_err(), "sizes differ");
    }
}

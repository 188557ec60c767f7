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

//! Peak signal-to-noise ratio.
//!
//! `PSNR = 10 · log10(peak² / MSE)` in decibels, with the MSE of [`super::mse()`] over the 3 linear
//! channels (no clamping). The peak is the largest value the signal can take: 1 for images in the
//! LDR range `[0,1]` ([`psnr()`]); for HDR images there is no natural peak, so pass one explicitly to
//! [`psnr_with_peak`] (e.g. the reference's maximum) and report it with the number. Identical
//! images give `+∞` dB (MSE = 0). Textbook definition, e.g. Huynh-Thu & Ghanbari, "Scope of
//! validity of PSNR in image/video quality assessment", Electronics Letters 44(13), 2008.

use super::error::MetricsError;
use super::mse::mse;
use glimpse_core::Image;

/// PSNR in dB with peak 1 (images in the LDR range `[0,1]`); `+∞` for identical images.
pub fn psnr(test: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<f64, MetricsError> {
    psnr_with_peak(test, reference, mask, 1.0)
}

/// PSNR in dB with the given peak value (finite and > 0).
pub fn psnr_with_peak(test: &Image, reference: &Image, mask: Option<&[bool]>, peak: f64) -> Result<f64, MetricsError> {
    if !(peak.is_finite() && peak > 0.0) {
        return Err(MetricsError::InvalidParameter(format!("PSNR peak must be finite and positive, got {peak}")));
    }
    let mse = mse(test, reference, mask)?;
    Ok(if mse == 0.0 { f64::INFINITY } else { 10.0 * (peak * peak / mse).log10() })
}

//! All image metrics of a test image against its reference in one struct.
//!
//! Each field is the metric of its own module (definitions and sources there): [`super::mse()`],
//! [`super::rmse()`], [`super::relmse()`] (ε = 1e-2), [`super::psnr()`] (peak 1, dB, `+∞` for
//! identical images), [`super::ssim()`] (Wang et al. 2004, channel-averaged, linear values
//! clamped to `[0,1]`) and `flip` = HDR-FLIP ([`super::flip_hdr`], automatic exposures), since our
//! images are linear radiance that may exceed 1. Images smaller than 11×11 are an error (SSIM's
//! window does not fit). Plain fields, no serde; [`Metrics::to_pairs`] lists them in a fixed
//! order for a JSON writer.

use super::error::MetricsError;
use super::hdr_flip::flip_hdr;
use super::mse::mse;
use super::psnr::psnr;
use super::relmse::relmse;
use super::ssim::ssim;
use glimpse_core::Image;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    pub mse: f64,
    pub rmse: f64,
    pub relmse: f64,
    /// dB, peak 1; `+∞` when the images are identical (write it as a string or null in JSON).
    pub psnr: f64,
    pub ssim: f64,
    /// Mean HDR-FLIP error.
    pub flip: f64,
}

impl Metrics {
    /// Every metric over the whole image.
    pub fn compute(test: &Image, reference: &Image) -> Result<Metrics, MetricsError> {
        Self::compute_masked(test, reference, None)
    }

    /// As [`Metrics::compute`], with the per-pixel metrics (MSE, RMSE, relMSE, PSNR) restricted
    /// to the pixels where `mask` is `true`. SSIM and FLIP compare neighbourhoods and always use
    /// the whole image.
    pub fn compute_masked(test: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<Metrics, MetricsError> {
        let mse = mse(test, reference, mask)?;
        Ok(Metrics {
            mse,
            rmse: mse.sqrt(),
            relmse: relmse(test, reference, mask)?,
            psnr: psnr(test, reference, mask)?,
            ssim: ssim(test, reference)?,
            flip: flip_hdr(test, reference)?.0,
        })
    }

    /// `(name, value)` in a fixed order: mse, rmse, relmse, psnr, ssim, flip.
    pub fn to_pairs(&self) -> [(&'static str, f64); 6] {
        [("mse", self.mse), ("rmse", self.rmse), ("relmse", self.relmse), ("psnr", self.psnr), ("ssim", self.ssim), ("flip", self.flip)]
    }
}

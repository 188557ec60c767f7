//! Error-map images for reports: a per-pixel error through the magma colour map
//! ([`super::colormap`]: black = no error, pale yellow = the top of the scale).
//!
//! The scales are fixed by the caller (or by the metric's own range), never by the image's own
//! maximum, so maps of different techniques against the same reference are comparable:
//! - [`ErrorMapKind::AbsDifference`]: `mean_c |t_c − r_c| / max` (linear values).
//! - [`ErrorMapKind::RelativeSquared`]: the per-pixel relMSE `mean_c (t_c − r_c)² / (r_c² + ε)`
//!   (ε = [`super::RELMSE_EPSILON`]) `/ max`.
//! - [`ErrorMapKind::Ssim`]: `1 − SSIM` (the channel-averaged SSIM map), clamped to `[0,1]`. SSIM
//!   has no value within 5 pixels of the border (its window does not fit); those pixels repeat
//!   the nearest evaluated value.
//! - [`ErrorMapKind::FlipLdr`] / [`ErrorMapKind::FlipHdr`]: the FLIP error map, already in
//!   `[0,1]` — the same picture FLIP's tool draws.
//!
//! The result is a linear [`Image`]; written as PNG with exposure 0 it shows the colour map's
//! exact 8-bit sRGB colours.

use super::colormap::{colorize, magma};
use super::error::{MetricsError, check_pair};
use super::flip::flip_ldr;
use super::hdr_flip::flip_hdr;
use super::map::ScalarMap;
use super::relmse::relative_squared_error;
use super::ssim::{SSIM_RADIUS, ssim_map};
use glimpse_core::Image;

/// What an error map shows, and its scale (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ErrorMapKind {
    /// Mean absolute channel difference; `max` is the difference shown brightest.
    AbsDifference { max: f32 },
    /// Per-pixel relative squared error; `max` is the value shown brightest.
    RelativeSquared { max: f32 },
    /// `1 − SSIM`.
    Ssim,
    /// LDR-FLIP of the clamped, sRGB-encoded images.
    FlipLdr,
    /// HDR-FLIP with the automatic exposures.
    FlipHdr,
}

/// The error map of `test` against `reference` as a magma image of the same size.
pub fn error_map(test: &Image, reference: &Image, kind: ErrorMapKind) -> Result<Image, MetricsError> {
    check_pair(test, reference)?;
    let per_pixel = |f: &dyn Fn(f64, f64) -> f64| ScalarMap {
        width: test.width,
        height: test.height,
        values: test
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(t, r)| ((0..3).map(|c| f(f64::from(t[c]), f64::from(r[c]))).sum::<f64>() / 3.0) as f32)
            .collect(),
    };
    let positive = |max: f32| {
        if max.is_finite() && max > 0.0 {
            Ok(max)
        } else {
            Err(MetricsError::InvalidParameter(format!("error-map scale must be finite and positive, got {max}")))
        }
    };
    Ok(match kind {
        ErrorMapKind::AbsDifference { max } => colorize(&per_pixel(&|t, r| (t - r).abs()), positive(max)?),
        ErrorMapKind::RelativeSquared { max } => colorize(&per_pixel(&relative_squared_error), positive(max)?),
        ErrorMapKind::FlipLdr => colorize(&flip_ldr(test, reference)?.1, 1.0),
        ErrorMapKind::FlipHdr => colorize(&flip_hdr(test, reference)?.1, 1.0),
        ErrorMapKind::Ssim => {
            let (_, map) = ssim_map(test, reference)?;
            let r = SSIM_RADIUS as i64;
            Image::from_fn(test.width, test.height, |x, y| {
                let mx = (x as i64 - r).clamp(0, map.width as i64 - 1) as u32;
                let my = (y as i64 - r).clamp(0, map.height as i64 - 1) as u32;
                magma(1.0 - map.get(mx, my))
            })
        }
    })
}

//! Structural similarity (SSIM), in-house.
//!
//! Definition: Wang, Bovik, Sheikh & Simoncelli, "Image Quality Assessment: From Error
//! Visibility to Structural Similarity", IEEE Transactions on Image Processing 13(4), 2004,
//! eq. 13, with the paper's parameters and its reference implementation `ssim_index.m`:
//!
//! ```text
//! SSIM(x, y) = (2 μx μy + C1)(2 σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2))
//! C1 = (K1 L)², C2 = (K2 L)², K1 = 0.01, K2 = 0.03, L = 1
//! ```
//!
//! - μ, σ², σxy are local statistics under an 11×11 Gaussian window with σ = 1.5, normalised to
//!   sum 1 (`fspecial('gaussian', 11, 1.5)`); σ² = `E[x²]` − μ² (population moments, not the
//!   N−1 sample form), computed in f64.
//! - Only windows that lie fully inside the image are evaluated (MATLAB's `filter2(…, 'valid')`),
//!   so the map is `(w − 10) × (h − 10)`: map pixel `(x, y)` is centred on image pixel
//!   `(x + 5, y + 5)`. Images smaller than 11×11 are an error. Mean SSIM is the mean of the map.
//!   This equals scikit-image's `structural_similarity(gaussian_weights=True, sigma=1.5,
//!   use_sample_covariance=False, data_range=1)`, which also crops the 5-pixel border.
//! - No downsampling (the later `ssim.m` downsamples images larger than 256 pixels; the 2004
//!   paper and `ssim_index.m` do not).
//! - Colour: SSIM is computed on each of the 3 channels separately and the channel results
//!   are averaged (the map too), as scikit-image does with `channel_axis`. This keeps chroma
//!   errors and needs no luminance weights.
//! - Range: values are the linear RGB values clamped to `[0,1]`, so L = 1. Our images are linear
//!   radiance; SSIM is not computed on display-encoded (sRGB) values, so errors in dark regions
//!   weigh less than in an SSIM of the PNGs. HDR values above 1 are clamped away: tone-map or
//!   expose first if highlights matter.

use super::error::{MetricsError, check_pair};
use super::map::ScalarMap;
use glimpse_core::Image;
use rayon::prelude::*;

/// Radius of the Gaussian window (11×11 = 2·5 + 1).
pub const SSIM_RADIUS: u32 = 5;
/// Standard deviation of the Gaussian window, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
pub const SSIM_K1: f64 = 0.01;
pub const SSIM_K2: f64 = 0.03;
/// Dynamic range of the (clamped) values.
pub const SSIM_L: f64 = 1.0;

const TAPS: usize = 2 * SSIM_RADIUS as usize + 1;

/// Mean SSIM of `test` against `reference` (see the module doc).
pub fn ssim(test: &Image, reference: &Image) -> Result<f64, MetricsError> {
    ssim_map(test, reference).map(|(mean, _)| mean)
}

/// Mean SSIM and the SSIM map over the valid region (`(w − 10) × (h − 10)`, map pixel `(x, y)`
/// centred on image pixel `(x + SSIM_RADIUS, y + SSIM_RADIUS)`), averaged over the 3 channels.
pub fn ssim_map(test: &Image, reference: &Image) -> Result<(f64, ScalarMap), MetricsError> {
    check_pair(test, reference)?;
    let (w, h) = (test.width as usize, test.height as usize);
    if w < TAPS || h < TAPS {
        return Err(MetricsError::TooSmallForSsim { width: test.width, height: test.height, min: TAPS as u32 });
    }
    let (ow, oh) = (w - TAPS + 1, h - TAPS + 1);
    let kernel = gaussian_kernel();
    let mut sum = vec![0.0f64; ow * oh];
    for c in 0..3 {
        let x: Vec<f64> = test.pixels.iter().map(|p| f64::from(p[c].clamp(0.0, 1.0))).collect();
        let y: Vec<f64> = reference.pixels.iter().map(|p| f64::from(p[c].clamp(0.0, 1.0))).collect();
        let map = channel_map(&x, &y, w, h, &kernel);
        sum.iter_mut().zip(&map).for_each(|(s, m)| *s += m);
    }
    let values: Vec<f32> = sum.iter().map(|s| (s / 3.0) as f32).collect();
    let mean = sum.iter().sum::<f64>() / (3.0 * sum.len() as f64);
    Ok((mean, ScalarMap { width: ow as u32, height: oh as u32, values }))
}

/// The normalised 1-D Gaussian; its outer product is the normalised 2-D window.
fn gaussian_kernel() -> [f64; TAPS] {
    let r = SSIM_RADIUS as f64;
    let mut k = [0.0; TAPS];
    for (i, v) in k.iter_mut().enumerate() {
        let d = i as f64 - r;
        *v = (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let total: f64 = k.iter().sum();
    k.map(|v| v / total)
}

/// SSIM of one channel over the valid region, row-major `(w − 10) × (h − 10)`.
fn channel_map(x: &[f64], y: &[f64], w: usize, h: usize, k: &[f64; TAPS]) -> Vec<f64> {
    let ow = w - TAPS + 1;
    let oh = h - TAPS + 1;
    // Horizontal pass: per input row, the 5 filtered moments (x, y, x², y², xy) at each valid column.
    let rows: Vec<[f64; 5]> = (0..h)
        .into_par_iter()
        .flat_map_iter(|row| {
            let (xr, yr) = (&x[row * w..(row + 1) * w], &y[row * w..(row + 1) * w]);
            (0..ow).map(move |col| {
                let mut m = [0.0; 5];
                for (t, &kt) in k.iter().enumerate() {
                    let (a, b) = (xr[col + t], yr[col + t]);
                    m[0] += kt * a;
                    m[1] += kt * b;
                    m[2] += kt * a * a;
                    m[3] += kt * b * b;
                    m[4] += kt * a * b;
                }
                m
            })
        })
        .collect();
    let (c1, c2) = ((SSIM_K1 * SSIM_L).powi(2), (SSIM_K2 * SSIM_L).powi(2));
    // Vertical pass and the SSIM formula.
    (0..oh)
        .into_par_iter()
        .flat_map_iter(|orow| {
            let rows = &rows;
            (0..ow).map(move |col| {
                let mut m = [0.0; 5];
                for (t, &kt) in k.iter().enumerate() {
                    let r = &rows[(orow + t) * ow + col];
                    for q in 0..5 {
                        m[q] += kt * r[q];
                    }
                }
                let [mx, my, exx, eyy, exy] = m;
                let (vx, vy, cxy) = (exx - mx * mx, eyy - my * my, exy - mx * my);
                ((2.0 * mx * my + c1) * (2.0 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
            })
        })
        .collect()
}

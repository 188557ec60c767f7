//! HDR-FLIP, built on LDR-FLIP ([`super::flip`]).
//!
//! Definition: Andersson, Nilsson, Shirley & Akenine-Möller, "Visualizing Errors in Rendered
//! High Dynamic Range Images", Eurographics 2021 (short papers), and NVIDIA's reference code
//! (NVlabs/flip: `FLIP::evaluate` and `image::computeExposures` in `FLIP.h`, v1.7, the code of
//! the `flip-evaluator` Python package), which this module follows step by step:
//!
//! 1. Tone mapper: the ACES filmic fit of Narkowicz ("ACES Filmic Tone Mapping Curve", 2016),
//!    `f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, applied per channel to `0.6·x` (FLIP's
//!    "pre-exposure cancellation"), i.e. coefficients
//!    `(0.6²·2.51 x² + 0.6·0.03 x) / (0.6²·2.43 x² + 0.6·0.59 x + 0.14)`; see [`aces_tone_map`].
//! 2. Exposures from the reference's luminance `Y = 0.2126 R + 0.7152 G + 0.0722 B`:
//!    `c_start = log2(x_max / Y_max)`, `c_stop = log2(x_max / Y_median)`, where `x_max` solves
//!    `f(x) = 0.85` (the larger root of the quadratic, ≈ 2.119) — so at `c_start` the brightest
//!    reference pixel maps to 0.85, at `c_stop` the median one does. `Y_median` is the element
//!    at index ⌊n/2⌋ of the sorted luminances (v1.7's `nth_element`; v1.2 averaged the two middle
//!    elements). See [`HdrFlipExposures::from_reference`].
//! 3. `N = max(2, ⌈c_stop − c_start⌉)` exposures, evenly spaced from `c_start` to `c_stop`
//!    inclusive.
//! 4. Per exposure `c`: both images are scaled by `2^c`, tone-mapped, clamped to `[0,1]` and
//!    compared with LDR-FLIP in floating point (v1.7 passes the linear tone-mapped values to
//!    `LDR_FLIP`; the v1.2 tool sRGB-encoded them first, which FLIP decodes again).
//! 5. The HDR-FLIP map is the per-pixel maximum over the exposures (ties keep the earlier
//!    exposure); the summary is its mean. The exposure map holds `i / (N − 1)` of the exposure
//!    that gave each pixel's maximum (0 where every exposure gave 0).
//!
//! All of it runs in f32 like the reference. LDR-FLIP here is `flip_core.rs` (private), a port of
//! the reference C++ that takes floats: `nv-flip` only accepts 8-bit sRGB, and rounding each
//! tone-mapped exposure to 8 bits changed the mean HDR-FLIP of a 5 %-noise test image by +23 %
//! against `flip-evaluator` (2.9 % at 20 % noise), because the rounding steps are as large as
//! the differences being measured. Where this module departs from the reference:
//! - Degenerate references, where the reference code is undefined: an all-black reference
//!   (`Y_max = 0`, `c_start = +∞`) uses `c_start = c_stop = 0`; a reference with at least half of
//!   its pixels black (`Y_median = 0`, `c_stop = +∞`, an integer overflow in the reference's `N`)
//!   uses the median of the non-zero luminances instead.

use super::error::{MetricsError, check_pair};
use super::flip::FLIP_PIXELS_PER_DEGREE;
use super::flip_core::ldr_flip_linear;
use super::map::ScalarMap;
use glimpse_core::{Image, Vec3};
use rayon::prelude::*;

/// The rational tone-curve coefficients `(a, b, c, d, e, f)` of
/// `(a x² + b x + c) / (d x² + e x + f)`: Narkowicz's ACES fit with FLIP's 0.6 pre-exposure.
pub const ACES_COEFFICIENTS: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];

/// The tone-mapped value at which the automatic exposures put the brightest (start) and median
/// (stop) reference luminance.
pub const EXPOSURE_TARGET: f32 = 0.85;

/// FLIP's ACES tone curve for one channel value (not clamped; see the module doc).
pub fn aces_tone_map(x: f32) -> f32 {
    let [a, b, c, d, e, f] = ACES_COEFFICIENTS;
    (x * x * a + x * b + c) / (x * x * d + x * e + f)
}

/// The exposures (in stops) at which HDR-FLIP compares the images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HdrFlipExposures {
    pub start: f32,
    pub stop: f32,
    /// At least 2 (with `start == stop` both exposures are the same).
    pub count: u32,
}

impl HdrFlipExposures {
    /// The automatic exposures of the paper from the reference's luminance (module doc, step 2).
    pub fn from_reference(reference: &Image) -> Self {
        let x_max = exposure_target_input();
        let mut lum: Vec<f32> = reference.pixels.iter().map(|p| 0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z).collect();
        let y_max = lum.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        if lum.is_empty() || y_max.is_nan() || y_max <= 0.0 {
            return Self { start: 0.0, stop: 0.0, count: 2 };
        }
        let mid = lum.len() / 2;
        let mut y_median = *lum.select_nth_unstable_by(mid, f32::total_cmp).1;
        if y_median <= 0.0 {
            let mut positive: Vec<f32> = lum.into_iter().filter(|&y| y > 0.0).collect();
            let mid = positive.len() / 2;
            y_median = *positive.select_nth_unstable_by(mid, f32::total_cmp).1;
        }
        let start = (x_max / y_max).log2();
        let stop = (x_max / y_median).log2();
        Self::new(start, stop)
    }

    /// `count = max(2, ⌈stop − start⌉)` (module doc, step 3).
    pub fn new(start: f32, stop: f32) -> Self {
        Self { start, stop, count: ((stop - start).ceil().max(2.0)) as u32 }
    }

    /// The exposure (stops) of step `i` in `0..count`.
    pub fn exposure(&self, i: u32) -> f32 {
        let step = (self.stop - self.start) / (self.count - 1) as f32;
        self.start + i as f32 * step
    }
}

/// `x_max`: the larger root of `f(x) = 0.85` for the ACES curve, as FLIP's `solveSecondDegree`.
fn exposure_target_input() -> f32 {
    let [a0, b0, c0, d0, e0, f0] = ACES_COEFFICIENTS;
    let t = EXPOSURE_TARGET;
    let (a, b, c) = (a0 - t * d0, b0 - t * e0, c0 - t * f0);
    if a == 0.0 {
        return -c / b;
    }
    let d1 = -0.5 * (b / a);
    let d2 = (d1 * d1 - c / a).sqrt();
    d1 + d2
}

/// The full HDR-FLIP result.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrFlip {
    /// Mean of `map`.
    pub mean: f64,
    /// Per-pixel maximum of the LDR-FLIP maps over the exposures, in `[0,1]`.
    pub map: ScalarMap,
    /// `i / (count − 1)` of the exposure that gave each pixel's maximum.
    pub exposure_map: ScalarMap,
    pub exposures: HdrFlipExposures,
}

/// HDR-FLIP of two linear HDR images with the automatic exposures: the mean error and the map.
pub fn flip_hdr(test: &Image, reference: &Image) -> Result<(f64, ScalarMap), MetricsError> {
    check_pair(test, reference)?;
    let r = flip_hdr_with(test, reference, HdrFlipExposures::from_reference(reference))?;
    Ok((r.mean, r.map))
}

/// HDR-FLIP with the given exposures (e.g. to compare several techniques at the same exposures).
pub fn flip_hdr_with(test: &Image, reference: &Image, exposures: HdrFlipExposures) -> Result<HdrFlip, MetricsError> {
    check_pair(test, reference)?;
    if !(exposures.start.is_finite() && exposures.stop.is_finite() && exposures.start <= exposures.stop && exposures.count >= 2) {
        return Err(MetricsError::InvalidParameter(format!(
            "HDR-FLIP exposures must be finite, start ≤ stop and count ≥ 2: {exposures:?}"
        )));
    }
    let (w, h) = (test.width, test.height);
    let maps: Vec<Vec<f32>> = (0..exposures.count)
        .into_par_iter()
        .map(|i| {
            let scale = 2f32.powf(exposures.exposure(i));
            ldr_flip_linear(&exposed(reference, scale), &exposed(test, scale), w as usize, h as usize, FLIP_PIXELS_PER_DEGREE)
        })
        .collect();
    let n = test.pixels.len();
    let mut map = ScalarMap { width: w, height: h, values: vec![0.0; n] };
    let mut exposure_map = map.clone();
    for (i, m) in maps.iter().enumerate() {
        let level = i as f32 / (exposures.count - 1) as f32;
        for ((best, at), &v) in map.values.iter_mut().zip(exposure_map.values.iter_mut()).zip(m) {
            if v > *best {
                *best = v;
                *at = level;
            }
        }
    }
    Ok(HdrFlip { mean: map.mean(), map, exposure_map, exposures })
}

/// `image · scale`, tone-mapped and clamped to `[0,1]` per channel (step 4).
fn exposed(image: &Image, scale: f32) -> Vec<Vec3> {
    image.pixels.iter().map(|p| (*p * scale).to_array().map(|v| aces_tone_map(v).clamp(0.0, 1.0)).into()).collect()
}

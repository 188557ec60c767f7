//! Shadow-decision errors ε_v and ε_s of many-light visibility.
//!
//! Definition: the voxel-array shadows paper as summarised in
//! `shared/specs/voxel-array-shadows.md` (§ Metrics, lines 515–535). Per pixel p with n lights,
//! compared with exact visibility (ray tracing):
//!
//! ```text
//! FV = lights wrongly labelled visible, FI = lights wrongly labelled invisible
//! ε_v(p) = (FV + FI) / n     fraction of light rays whose visibility is wrong
//! ε_s(p) = (FV − FI) / n     shadow-value error; errors of opposite sign cancel
//! example: n = 1000, FV = 10, FI = 5  →  ε_v = 1.5 %, ε_s = 0.5 %
//! ```
//!
//! The reported numbers are "average pixel" errors. The paper does not say which pixels count
//! nor how ε_s is averaged; following the spec's inference, the averages are over pixels covered
//! by geometry (the caller adds only those), and ε_s is averaged as |ε_s(p)|
//! ([`ShadowErrors::epsilon_s_abs`]); the signed mean is reported too
//! ([`ShadowErrors::epsilon_s_signed`]). All values are fractions (0.015 = 1.5 %).

use super::error::MetricsError;

/// Running sums of the per-pixel shadow errors; merge partial sums from threads with
/// [`ShadowErrors::merge`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadowErrors {
    pixels: u64,
    sum_v: f64,
    sum_s: f64,
    sum_s_abs: f64,
}

impl ShadowErrors {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one pixel (covered by geometry) with `fv` lights wrongly visible and `fi` wrongly
    /// invisible out of `n` lights. A pixel with `n == 0` has no defined error and is not
    /// counted. `fv + fi ≤ n` is the caller's contract (checked in debug builds).
    pub fn add_pixel(&mut self, fv: u32, fi: u32, n: u32) {
        debug_assert!(u64::from(fv) + u64::from(fi) <= u64::from(n), "FV + FI exceeds the light count: {fv} + {fi} > {n}");
        if n == 0 {
            return;
        }
        let n = f64::from(n);
        let s = (f64::from(fv) - f64::from(fi)) / n;
        self.pixels += 1;
        self.sum_v += (f64::from(fv) + f64::from(fi)) / n;
        self.sum_s += s;
        self.sum_s_abs += s.abs();
    }

    /// Adds another accumulator's pixels.
    pub fn merge(&mut self, other: &ShadowErrors) {
        self.pixels += other.pixels;
        self.sum_v += other.sum_v;
        self.sum_s += other.sum_s;
        self.sum_s_abs += other.sum_s_abs;
    }

    /// Number of pixels added.
    pub fn pixels(&self) -> u64 {
        self.pixels
    }

    /// Mean ε_v(p) (0 with no pixels).
    pub fn epsilon_v(&self) -> f64 {
        self.mean(self.sum_v)
    }

    /// Mean |ε_s(p)| (0 with no pixels): the spec's reading of the paper's ε_s.
    pub fn epsilon_s_abs(&self) -> f64 {
        self.mean(self.sum_s_abs)
    }

    /// Mean signed ε_s(p) (0 with no pixels): positive = too much light overall.
    pub fn epsilon_s_signed(&self) -> f64 {
        self.mean(self.sum_s)
    }

    fn mean(&self, sum: f64) -> f64 {
        if self.pixels == 0 { 0.0 } else { sum / self.pixels as f64 }
    }
}

/// 64-bit words per pixel in the visibility bitsets of [`shadow_errors_from_visibility`].
pub fn visibility_words_per_pixel(lights: usize) -> usize {
    lights.div_ceil(64)
}

/// Compares per-pixel-per-light visibility bitsets. Pixel `p`'s lights occupy the words
/// `p·k .. (p+1)·k` with `k = visibility_words_per_pixel(lights)`; light `l` is bit `l % 64` of
/// word `l / 64`, set = visible. Bits past `lights` in the last word are ignored. `covered`
/// (one entry per pixel, `true` = covered by geometry) selects the pixels that count; without
/// it every pixel counts.
pub fn shadow_errors_from_visibility(
    test: &[u64],
    reference: &[u64],
    lights: usize,
    covered: Option<&[bool]>,
) -> Result<ShadowErrors, MetricsError> {
    let bad = |m: String| Err(MetricsError::Visibility(m));
    if lights == 0 || lights > u32::MAX as usize {
        return bad(format!("the light count must be in 1..=2^32−1, got {lights}"));
    }
    let k = visibility_words_per_pixel(lights);
    if test.len() != reference.len() || !test.len().is_multiple_of(k) {
        return bad(format!(
            "test has {} words and reference {}; both must be the same multiple of {k} (words per pixel for {lights} lights)",
            test.len(),
            reference.len()
        ));
    }
    let pixels = test.len() / k;
    if let Some(c) = covered
        && c.len() != pixels
    {
        return bad(format!("the coverage mask has {} entries for {pixels} pixels", c.len()));
    }
    let tail = lights % 64;
    let last_mask = if tail == 0 { u64::MAX } else { (1u64 << tail) - 1 };
    let mut errors = ShadowErrors::new();
    for p in (0..pixels).filter(|&p| covered.is_none_or(|c| c[p])) {
        let (mut fv, mut fi) = (0u32, 0u32);
        for j in 0..k {
            let keep = if j + 1 == k { last_mask } else { u64::MAX };
            let (t, r) = (test[p * k + j] & keep, reference[p * k + j] & keep);
            fv += (t & !r).count_ones();
            fi += (!t & r).count_ones();
        }
        errors.add_pixel(fv, fi, lights as u32);
    }
    Ok(errors)
}

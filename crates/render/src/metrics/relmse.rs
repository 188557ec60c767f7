//! Relative mean squared error.
//!
//! `relMSE = 1/(3·N) · Σ_p Σ_c (t_c(p) − r_c(p))² / (r_c(p)² + ε)` with `ε = 1e-2`, over the N
//! included pixels and the 3 linear RGB channels; `r` is the reference. Dividing by the squared
//! reference weighs an error in a dark region like the same relative error in a bright one, as
//! the eye roughly does; ε keeps black reference pixels from dominating (or dividing by zero).
//! The metric comes from the Monte Carlo adaptive-sampling and denoising literature (Rousselle,
//! Knaus & Zwicker, "Adaptive Sampling and Reconstruction using Greedy Error Minimization", ACM
//! TOG 30(6), SIGGRAPH Asia 2011, and the denoising papers after it); ε = 0.01 is the value most of
//! them use, but papers differ (0.001 also occurs), so check a paper's ε before comparing numbers
//! with it. Per channel, f64 accumulation (see [`super::mse()`]).

use super::error::MetricsError;
use super::mse::mean_over_channels;
use glimpse_core::Image;

/// The ε in the denominator of [`relmse()`]: `(t − r)² / (r² + ε)`.
pub const RELMSE_EPSILON: f64 = 1e-2;

/// Relative MSE (see the module doc); `mask` (`true` = include) restricts the mean.
pub fn relmse(test: &Image, reference: &Image, mask: Option<&[bool]>) -> Result<f64, MetricsError> {
    mean_over_channels(test, reference, mask, relative_squared_error)
}

/// `(t − r)² / (r² + ε)` for one channel value (see [`RELMSE_EPSILON`]).
pub fn relative_squared_error(t: f64, r: f64) -> f64 {
    (t - r) * (t - r) / (r * r + RELMSE_EPSILON)
}

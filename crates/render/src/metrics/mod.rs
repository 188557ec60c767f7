//! Image metrics: how far an approximate technique's image is from the exact reference.
//!
//! Every metric takes `(test, reference)` linear RGB [`glimpse_core::Image`]s of the same size
//! and returns a [`MetricsError`] (never panics) for a size mismatch, an empty or malformed
//! image, or a NaN/infinite value (naming the image, pixel and channel). One concept per file,
//! each with its definition and source at the top; `docs/metrics.md` is the overview.
//!
//! - [`mse()`], [`rmse()`], [`relmse()`], [`psnr()`]: per-pixel errors over the 3 channels, f64
//!   accumulation, optional pixel mask.
//! - [`ssim()`], [`ssim_map`]: in-house SSIM (Wang et al. 2004).
//! - [`flip_ldr`] (NVIDIA's C++ through `nv-flip`), [`flip_hdr`] (HDR-FLIP on top of it).
//! - [`ShadowErrors`]: the ε_v / ε_s shadow-decision errors of many-light visibility.
//! - [`error_map()`]: magma error-map images for reports.
//! - [`Metrics`]: all image metrics at once.

pub mod colormap;
pub mod epsilon;
pub mod error;
pub mod error_map;
pub mod flip;
mod flip_core;
pub mod hdr_flip;
pub mod map;
pub mod mse;
pub mod psnr;
pub mod relmse;
pub mod shadow;
pub mod ssim;
pub mod summary;

pub use colormap::{colorize, magma};
pub use error::{MetricsError, Which};
pub use error_map::{ErrorMapKind, error_map};
pub use flip::{FLIP_PIXELS_PER_DEGREE, flip_ldr};
pub use hdr_flip::{HdrFlip, HdrFlipExposures, aces_tone_map, flip_hdr, flip_hdr_with};
pub use map::ScalarMap;
pub use mse::{mse, mse_without_worst, rmse};
pub use psnr::{psnr, psnr_with_peak};
pub use relmse::{RELMSE_EPSILON, relmse};
pub use shadow::{ShadowErrors, shadow_errors_from_visibility, visibility_words_per_pixel};
pub use ssim::{ssim, ssim_map};
pub use summary::Metrics;

//! LDR-FLIP, through NVIDIA's C++ reference code (the `nv-flip` crate).
//!
//! Definition: Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström & Fairchild, "FLIP: A
//! Difference Evaluator for Alternating Images", Proc. ACM Comput. Graph. Interact. Tech. 3(2)
//! (HPG 2020). The per-pixel error map is in `[0,1]` (0 = no perceived difference); the summary
//! number is its mean, as the authors recommend. The computation is the `nv-flip` crate (0.1,
//! gfx-rs), which builds the C++ implementation of NVlabs/flip (`FLIP::image::FLIP`, v1.2-era
//! code) with the system C++ compiler.
//!
//! Inputs. FLIP's LDR mode expects sRGB-encoded images in `[0,1]`, and `nv-flip` takes them as
//! 8-bit sRGB. [`flip_ldr`] therefore takes our linear images and converts each exactly as our PNG
//! writer does (`Image::to_srgb8` with exposure 0: clamp to `[0,1]`, sRGB-encode, round to 8 bits),
//! so `flip_ldr(test, reference)` is the LDR-FLIP of the two PNGs the project writes. Values
//! above 1 are clipped: use [`super::flip_hdr`] for HDR radiance.
//!
//! Viewing condition: [`FLIP_PIXELS_PER_DEGREE`] = 0.7 m from a 0.7 m wide 3840-pixel display
//! (≈ 67.02 ppd), the default of NVIDIA's tool and of the `flip-evaluator` package.

use super::error::{MetricsError, check_pair};
use super::map::ScalarMap;
use glimpse_core::{Image, ToneMap};

/// Pixels per degree of visual angle: 0.7 m from a 0.7 m wide 4K (3840-pixel) monitor, as in
/// NVIDIA's FLIP tool and `flip-evaluator` (`calculatePPD(0.7, 3840, 0.7)` ≈ 67.02; `nv-flip`'s
/// `DEFAULT_PIXELS_PER_DEGREE` rounds it to 67.0, which we do not use).
pub const FLIP_PIXELS_PER_DEGREE: f32 = 0.7 * (3840.0 / 0.7) * (std::f32::consts::PI / 180.0);

/// LDR-FLIP of two linear images, each clamped, sRGB-encoded and rounded to 8 bits first (see
/// the module doc). Returns the mean error and the error map.
pub fn flip_ldr(test: &Image, reference: &Image) -> Result<(f64, ScalarMap), MetricsError> {
    check_pair(test, reference)?;
    let t = test.to_srgb8(ToneMap::default());
    let r = reference.to_srgb8(ToneMap::default());
    let map = flip_srgb8(t.as_raw(), r.as_raw(), test.width, test.height);
    Ok((map.mean(), map))
}

/// LDR-FLIP of two 8-bit sRGB images (`width·height·3` bytes each, row-major RGB). The caller
/// guarantees the sizes.
pub(crate) fn flip_srgb8(test: &[u8], reference: &[u8], width: u32, height: u32) -> ScalarMap {
    let t = nv_flip::FlipImageRgb8::with_data(width, height, test);
    let r = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let map = nv_flip::flip(r, t, FLIP_PIXELS_PER_DEGREE);
    ScalarMap { width, height, values: map.to_vec() }
}

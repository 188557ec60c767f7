//! The magma colour map, for error-map images.
//!
//! Magma is the perceptually uniform, monotonically brightening map of van der Walt & Smith
//! (matplotlib, 2015): black-purple at 0, through red and orange, to pale yellow at 1. It is the
//! map FLIP shows its error maps with, and we use FLIP's own 256-entry table (`MapMagma` of
//! NVlabs/flip, read through `nv_flip::magma_lut`) so our maps match FLIP's pictures. A value
//! `t` in `[0,1]` picks entry `round(255·t)` (FLIP's `colorMap` indexing). The table's entries are
//! 8-bit sRGB; [`magma`] returns them decoded to linear RGB, so an [`Image`] holding them is
//! written by our PNG writer (`Image::write`, exposure 0) with exactly FLIP's 8-bit colours.

use glimpse_core::image::srgb_decode;
use glimpse_core::{Image, Vec3};
use std::sync::OnceLock;

use super::map::ScalarMap;

/// FLIP's table, 8-bit sRGB.
fn table_srgb8() -> &'static [[u8; 3]; 256] {
    static TABLE: OnceLock<[[u8; 3]; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let bytes = nv_flip::magma_lut().to_vec();
        std::array::from_fn(|i| [bytes[3 * i], bytes[3 * i + 1], bytes[3 * i + 2]])
    })
}

/// The same table decoded to linear RGB.
fn table_linear() -> &'static [Vec3; 256] {
    static TABLE: OnceLock<[Vec3; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        table_srgb8().map(|c| {
            let d = |v: u8| srgb_decode(f32::from(v) / 255.0);
            Vec3::new(d(c[0]), d(c[1]), d(c[2]))
        })
    })
}

/// The table index of `t`: `round(255·t)` after clamping to `[0,1]` (NaN picks 0).
fn index(t: f32) -> usize {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    (t * 255.0).round() as usize
}

/// The magma colour (linear RGB) of `t`, clamped to `[0,1]` (NaN maps to 0).
pub fn magma(t: f32) -> Vec3 {
    table_linear()[index(t)]
}

/// The 8-bit sRGB magma colour of `t` (FLIP's table entry).
pub fn magma_srgb8(t: f32) -> [u8; 3] {
    table_srgb8()[index(t)]
}

/// A scalar map as a magma image, `value / max` giving the colour (`max` > 0; values at or above
/// it are the brightest colour).
pub fn colorize(map: &ScalarMap, max: f32) -> Image {
    let inv = if max > 0.0 { 1.0 / max } else { 0.0 };
    Image { width: map.width, height: map.height, pixels: map.values.iter().map(|&v| magma(v * inv)).collect() }
}

//! Half-resolution GI and joint bilateral upsampling (thesis Ch. 6, §7.4): the GI is computed at
//! ⌈W/2⌉×⌈H/2⌉ pixels, low-resolution pixel (X, Y) shading the full-resolution G-buffer surface of
//! pixel (2X, 2Y); each full-resolution pixel takes the four surrounding low-resolution samples
//! with bilinear weights × S (Eq. 5.3), normalized. Gap filled: when all four weights are 0 the
//! plain bilinear weights are used (spec §6.8 leaves it open).

use crate::vpl::Similarity;
use glimpse_core::Vec3;

/// A low-resolution GI image with the surfaces its samples shaded.
#[derive(Clone, Debug, Default)]
pub struct LowRes {
    pub width: u32,
    pub height: u32,
    pub value: Vec<Vec3>,
    pub position: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    /// False where the sample sees no geometry (S = 0).
    pub valid: Vec<bool>,
}

/// Joint bilateral upsampling of `low` to pixel (px, py) whose surface is (`p`, `n`).
pub fn upsample_pixel(low: &LowRes, px: u32, py: u32, p: Vec3, n: Vec3, sim: Similarity) -> Vec3 {
    // Low pixel X's sample sits at full-resolution pixel 2X: full pixel x is at X = x / 2.
    let gx = px as f32 / 2.0;
    let gy = py as f32 / 2.0;
    let (x0, y0) = (gx.floor(), gy.floor());
    let (tx, ty) = (gx - x0, gy - y0);
    let cx = |x: f32| (x as u32).min(low.width - 1);
    let cy = |y: f32| (y as u32).min(low.height - 1);
    let taps = [
        (cx(x0), cy(y0), (1.0 - tx) * (1.0 - ty)),
        (cx(x0 + 1.0), cy(y0), tx * (1.0 - ty)),
        (cx(x0), cy(y0 + 1.0), (1.0 - tx) * ty),
        (cx(x0 + 1.0), cy(y0 + 1.0), tx * ty),
    ];
    let (mut acc, mut wsum) = (Vec3::ZERO, 0.0);
    let (mut plain, mut psum) = (Vec3::ZERO, 0.0);
    for (x, y, w) in taps {
        let i = (y * low.width + x) as usize;
        if !low.valid[i] {
            continue;
        }
        plain += low.value[i] * w;
        psum += w;
        if sim.similar(p, n, low.position[i], low.normal[i]) {
            acc += low.value[i] * w;
            wsum += w;
        }
    }
    if wsum > 0.0 {
        acc / wsum
    } else if psum > 0.0 {
        plain / psum
    } else {
        Vec3::ZERO
    }
}

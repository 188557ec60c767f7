//! LDR-FLIP on floating-point linear RGB, for HDR-FLIP.
//!
//! Definition: Andersson et al., "FLIP: A Difference Evaluator for Alternating Images", HPG 2020,
//! as implemented in NVIDIA's reference C++ (NVlabs/flip, `FLIP.h` v1.7: `LDR_FLIP`,
//! `computeColorDifference`, `computeFeatureDifferenceAndFinalError`, `setSpatialFilters`,
//! `setFeatureFilter`, the `color3` transforms and constants; the same code `nv-flip` builds in
//! its v1.2-era form). This is a line-by-line Rust port in f32 with the reference's operation
//! order, because `nv-flip` only accepts 8-bit sRGB and HDR-FLIP must compare its tone-mapped
//! exposures unrounded, as the reference does. The test suite checks the port against `nv-flip`
//! on 8-bit inputs (per pixel) and HDR-FLIP built on it against NVIDIA's `flip-evaluator`.
//!
//! Steps, both images in linear RGB in `[0,1]`:
//! 1. linear RGB → XYZ (D65) → YCxCz (opponent space).
//! 2. Colour pipeline: each channel filtered with the contrast sensitivity functions (sums of
//!    Gaussians, separable, clamp-to-edge), back to linear RGB and clamped, → CIELab, Hunt
//!    adjustment (a, b scaled by 0.01·L), HyAB distance, `^0.7`, and remapped to `[0,1]` so that
//!    `0.4·cmax` (cmax: green–blue distance) maps to 0.95.
//! 3. Feature pipeline on the achromatic channel normalised to `[0,1]`: edge (1st derivative of
//!    Gaussian) and point (2nd derivative) magnitudes, σ = 0.5·0.082·ppd;
//!    `f = (max(|Δedge|, |Δpoint|) / √2)^0.5`.
//! 4. Per pixel `FLIP = colour^(1 − f)`.

// The constants are NVIDIA's decimal literals, kept digit for digit.
#![allow(clippy::excessive_precision)]

use glimpse_core::Vec3;
use rayon::prelude::*;

/// NVIDIA writes 3.14159265358979f, the same f32.
const PI: f32 = std::f32::consts::PI;
const GQC: f32 = 0.7;
const GPC: f32 = 0.4;
const GPT: f32 = 0.95;
const GW: f32 = 0.082;
const GQF: f32 = 0.5;
/// Contrast sensitivity Gaussians `a·√(π/b)·exp(−π² x² / b)` (paper's constants).
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2: [f32; 3] = [0.0, 0.0, 13.5];
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];
const ILLUMINANT: [f32; 3] = [0.950428545, 1.0, 1.088900371];
const INV_ILLUMINANT: [f32; 3] = [1.052156925, 1.0, 0.918357670];

fn linear_rgb_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let a11 = 10135552.0f32 / 24577794.0;
    let a12 = 8788810.0f32 / 24577794.0;
    let a13 = 4435075.0f32 / 24577794.0;
    let a21 = 2613072.0f32 / 12288897.0;
    let a22 = 8788810.0f32 / 12288897.0;
    let a23 = 887015.0f32 / 12288897.0;
    let a31 = 1425312.0f32 / 73733382.0;
    let a32 = 8788810.0f32 / 73733382.0;
    let a33 = 70074185.0f32 / 73733382.0;
    [a11 * c[0] + a12 * c[1] + a13 * c[2], a21 * c[0] + a22 * c[1] + a23 * c[2], a31 * c[0] + a32 * c[1] + a33 * c[2]]
}

fn xyz_to_linear_rgb(c: [f32; 3]) -> [f32; 3] {
    let (a11, a12, a13) = (3.241003275f32, -1.537398934f32, -0.498615861f32);
    let (a21, a22, a23) = (-0.969224334f32, 1.875930071f32, 0.041554224f32);
    let (a31, a32, a33) = (0.055639423f32, -0.204011202f32, 1.057148933f32);
    [a11 * c[0] + a12 * c[1] + a13 * c[2], a21 * c[0] + a22 * c[1] + a23 * c[2], a31 * c[0] + a32 * c[1] + a33 * c[2]]
}

fn xyz_to_ycxcz(c: [f32; 3]) -> [f32; 3] {
    let (x, y, z) = (c[0] * INV_ILLUMINANT[0], c[1] * INV_ILLUMINANT[1], c[2] * INV_ILLUMINANT[2]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let y = (c[0] + 16.0) / 116.0;
    let cx = c[1] / 500.0;
    let cz = c[2] / 200.0;
    [(y + cx) * ILLUMINANT[0], y * ILLUMINANT[1], (y - cz) * ILLUMINANT[2]]
}

fn xyz_to_cielab(c: [f32; 3]) -> [f32; 3] {
    let delta = 6.0f32 / 29.0;
    let delta_square = delta * delta;
    let delta_cube = delta * delta_square;
    let factor = 1.0 / (3.0 * delta_square);
    let term = 4.0f32 / 29.0;
    let f = |v: f32| if v > delta_cube { v.powf(1.0 / 3.0) } else { factor * v + term };
    let (x, y, z) = (f(c[0] * INV_ILLUMINANT[0]), f(c[1] * INV_ILLUMINANT[1]), f(c[2] * INV_ILLUMINANT[2]));
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn hunt(luminance: f32, chrominance: f32) -> f32 {
    0.01 * luminance * chrominance
}

fn hyab(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] - b[0]).abs() + ((a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])).sqrt()
}

fn lab_hunt(lab: [f32; 3]) -> [f32; 3] {
    [lab[0], hunt(lab[0], lab[1]), hunt(lab[0], lab[2])]
}

fn max_distance() -> f32 {
    let green = lab_hunt(xyz_to_cielab(linear_rgb_to_xyz([0.0, 1.0, 0.0])));
    let blue = lab_hunt(xyz_to_cielab(linear_rgb_to_xyz([0.0, 0.0, 1.0])));
    hyab(green, blue).powf(GQC)
}

fn gaussian_ab(x2: f32, a: f32, b: f32) -> f32 {
    a * (PI / b).sqrt() * (-(PI * PI) * x2 / b).exp()
}

fn gaussian_ab_sqrt(x2: f32, a: f32, b: f32) -> f32 {
    (a * (PI / b).sqrt()).sqrt() * (-(PI * PI) * x2 / b).exp()
}

/// The separable CSF filters: per tap `(Y, Cx)` weights and the two `Cz` Gaussians.
fn spatial_filters(ppd: f32) -> (Vec<[f32; 2]>, Vec<[f32; 2]>) {
    let max_b = B1.iter().chain(&B2).copied().fold(f32::MIN, f32::max);
    let radius = (3.0 * (max_b / (2.0 * (PI * PI))).sqrt() * ppd).ceil() as i32;
    let dx = 1.0 / ppd;
    let mut ycx = Vec::new();
    let mut cz = Vec::new();
    let (mut sum_ycx, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
    for x in -radius..=radius {
        let ix = x as f32 * dx;
        let ix2 = ix * ix;
        let v = [gaussian_ab(ix2, A1[0], B1[0]), gaussian_ab(ix2, A1[1], B1[1])];
        let c = [gaussian_ab_sqrt(ix2, A1[2], B1[2]), gaussian_ab_sqrt(ix2, A2[2], B2[2])];
        sum_ycx = [sum_ycx[0] + v[0], sum_ycx[1] + v[1]];
        sum_cz = [sum_cz[0] + c[0], sum_cz[1] + c[1]];
        ycx.push(v);
        cz.push(c);
    }
    let norm_ycx = [1.0 / sum_ycx[0], 1.0 / sum_ycx[1]];
    let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
    for v in &mut ycx {
        *v = [v[0] * norm_ycx[0], v[1] * norm_ycx[1]];
    }
    for c in &mut cz {
        *c = [c[0] * norm_cz, c[1] * norm_cz];
    }
    (ycx, cz)
}

/// The separable feature filter: per tap (Gaussian, 1st derivative, 2nd derivative), each
/// normalised as the reference does.
fn feature_filter(ppd: f32) -> Vec<[f32; 3]> {
    let std_dev = 0.5 * GW * ppd;
    let radius = (3.0 * std_dev).ceil() as i32;
    let mut taps = Vec::new();
    let (mut g_sum, mut dg_pos, mut dg_neg, mut ddg_pos, mut ddg_neg) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for xx in -radius..=radius {
        let x = xx as f32;
        let g = (-(x * x) / (2.0 * std_dev * std_dev)).exp();
        g_sum += g;
        let dg = -x * g;
        if dg > 0.0 {
            dg_pos += dg;
        } else {
            dg_neg -= dg;
        }
        let ddg = (x * x / (std_dev * std_dev) - 1.0) * g;
        if ddg > 0.0 {
            ddg_pos += ddg;
        } else {
            ddg_neg -= ddg;
        }
        taps.push([g, dg, ddg]);
    }
    for t in &mut taps {
        *t = [t[0] / g_sum, t[1] / if t[1] > 0.0 { dg_pos } else { dg_neg }, t[2] / if t[2] > 0.0 { ddg_pos } else { ddg_neg }];
    }
    taps
}

/// Row-parallel separable pass: `f(x, y)` for every pixel, row-major.
fn per_pixel<T: Send>(w: usize, h: usize, f: impl Fn(usize, usize) -> T + Sync) -> Vec<T> {
    (0..h).into_par_iter().flat_map_iter(|y| (0..w).map(|x| f(x, y)).collect::<Vec<_>>()).collect()
}

/// The LDR-FLIP error map of two linear RGB images in `[0,1]` (`w·h` pixels, row-major).
pub(crate) fn ldr_flip_linear(reference: &[Vec3], test: &[Vec3], w: usize, h: usize, ppd: f32) -> Vec<f32> {
    let to_ycxcz = |img: &[Vec3]| -> Vec<[f32; 3]> { img.iter().map(|c| xyz_to_ycxcz(linear_rgb_to_xyz(c.to_array()))).collect() };
    let (r, t) = (to_ycxcz(reference), to_ycxcz(test));
    let clamp_x = |x: usize, d: i32| (x as i32 + d).clamp(0, w as i32 - 1) as usize;
    let clamp_y = |y: usize, d: i32| (y as i32 + d).clamp(0, h as i32 - 1) as usize;

    // Colour pipeline.
    let (f_ycx, f_cz) = spatial_filters(ppd);
    let half = (f_ycx.len() / 2) as i32;
    let cmax = max_distance();
    let pccmax = GPC * cmax;
    // x pass: per pixel and image (Y, Cx, Cz·g1, Cz·g2).
    let pass_x = per_pixel(w, h, |x, y| {
        let mut acc = [[0.0f32; 4]; 2];
        for i in -half..=half {
            let xx = clamp_x(x, i);
            let (wy, wc) = (f_ycx[(i + half) as usize], f_cz[(i + half) as usize]);
            for (a, img) in acc.iter_mut().zip([&r, &t]) {
                let c = img[y * w + xx];
                a[0] += wy[0] * c[0];
                a[1] += wy[1] * c[1];
                a[2] += wc[0] * c[2];
                a[3] += wc[1] * c[2];
            }
        }
        acc
    });
    let color = per_pixel(w, h, |x, y| {
        let mut acc = [[0.0f32; 4]; 2];
        for i in -half..=half {
            let yy = clamp_y(y, i);
            let (wy, wc) = (f_ycx[(i + half) as usize], f_cz[(i + half) as usize]);
            let p = &pass_x[yy * w + x];
            for (a, q) in acc.iter_mut().zip(p) {
                a[0] += wy[0] * q[0];
                a[1] += wy[1] * q[1];
                a[2] += wc[0] * q[2];
                a[3] += wc[1] * q[3];
            }
        }
        let lab = acc.map(|a| {
            let rgb = xyz_to_linear_rgb(ycxcz_to_xyz([a[0], a[1], a[2] + a[3]])).map(|v| v.clamp(0.0, 1.0));
            lab_hunt(xyz_to_cielab(linear_rgb_to_xyz(rgb)))
        });
        let d = hyab(lab[0], lab[1]).powf(GQC);
        if d < pccmax { d * (GPT / pccmax) } else { GPT + ((d - pccmax) / (cmax - pccmax)) * (1.0 - GPT) }
    });

    // Feature pipeline.
    let ff = feature_filter(ppd);
    let half = (ff.len() / 2) as i32;
    let (one_over_116, sixteen_over_116) = (1.0f32 / 116.0, 16.0f32 / 116.0);
    // x pass: per image (dx, ddx, gaussian).
    let feat_x = per_pixel(w, h, |x, y| {
        let mut acc = [[0.0f32; 3]; 2];
        for i in -half..=half {
            let xx = clamp_x(x, i);
            let k = ff[(i + half) as usize];
            for (a, img) in acc.iter_mut().zip([&r, &t]) {
                let yn = img[y * w + xx][0] * one_over_116 + sixteen_over_116;
                a[0] += k[1] * yn;
                a[1] += k[2] * yn;
                a[2] += k[0] * yn;
            }
        }
        acc
    });
    let normalization = 1.0 / 2.0f32.sqrt();
    per_pixel(w, h, |x, y| {
        // per image (dx, ddx, dy, ddy)
        let mut acc = [[0.0f32; 4]; 2];
        for i in -half..=half {
            let yy = clamp_y(y, i);
            let k = ff[(i + half) as usize];
            for (a, q) in acc.iter_mut().zip(&feat_x[yy * w + x]) {
                a[0] += k[0] * q[0];
                a[1] += k[0] * q[1];
                a[2] += k[1] * q[2];
                a[3] += k[2] * q[2];
            }
        }
        let [rf, tf] = acc;
        let edge = |a: [f32; 4]| (a[0] * a[0] + a[2] * a[2]).sqrt();
        let point = |a: [f32; 4]| (a[1] * a[1] + a[3] * a[3]).sqrt();
        let edge_difference = (edge(rf) - edge(tf)).abs();
        let point_difference = (point(rf) - point(tf)).abs();
        let feature_difference = (normalization * edge_difference.max(point_difference)).powf(GQF);
        color[y * w + x].powf(1.0 - feature_difference)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::flip::{FLIP_PIXELS_PER_DEGREE, flip_srgb8};
    use glimpse_core::image::srgb_decode;

    /// The port against `nv-flip` (NVIDIA's C++) on the same 8-bit sRGB images, per pixel.
    #[test]
    fn port_matches_nv_flip_per_pixel() {
        let (w, h) = (45usize, 37usize);
        let byte = |i: usize, seed: usize| {
            let v = (i.wrapping_mul(2_654_435_761) ^ seed.wrapping_mul(40_503)) >> 7;
            // A smooth ramp plus noise, so both the colour and the feature pipeline matter.
            ((i % w) * 4 + (i / w) * 2 + v % 23) as u8
        };
        let reference: Vec<u8> = (0..w * h * 3).map(|i| byte(i, 1)).collect();
        let test: Vec<u8> = (0..w * h * 3).map(|i| if i % 7 == 0 { byte(i, 2) } else { byte(i, 1) }).collect();
        let linear = |bytes: &[u8]| -> Vec<Vec3> {
            bytes.chunks(3).map(|c| Vec3::from_array([0, 1, 2].map(|k| srgb_decode(f32::from(c[k]) / 255.0)))).collect()
        };
        let ours = ldr_flip_linear(&linear(&reference), &linear(&test), w, h, FLIP_PIXELS_PER_DEGREE);
        let theirs = flip_srgb8(&test, &reference, w as u32, h as u32).values;
        let worst = ours.iter().zip(&theirs).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        let mean = |v: &[f32]| v.iter().map(|&x| f64::from(x)).sum::<f64>() / v.len() as f64;
        println!("port vs nv-flip: mean {:.7} vs {:.7}, worst pixel difference {worst:.2e}", mean(&ours), mean(&theirs));
        assert!(worst < 1e-4, "the port differs from NVIDIA's C++ by {worst}");
    }
}

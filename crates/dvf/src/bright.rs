//! The map's brightest directions, traced whatever the masks say (`bright`, ours; off in
//! `profile=paper`).
//!
//! DVF assumes low-frequency light. A cell's masks are shared by every fragment in it, over
//! octahedral pixels of about 0.2 sr, so a direction that a fragment sees open through a gap no
//! sample of its cell saw is skipped (label 1) or taken as open (label 0). Under a map whose
//! power comes from a few small bright regions (a sun, softboxes, a warehouse's lamps) the rays
//! toward them carry most of the image, and such a mistake blacks out or lights up a whole cell:
//! on `sponza-interior`, lit by the warehouse map through its roof, 5.4 % of the lit pixels came
//! out black. So a ray whose direction reads one of the map's brightest texels, at most
//! `bright_sr` sr of them (0.2 by default: 67 % of the warehouse map's power, 89 % of the studio
//! map's), is always traced. That is at most `bright_sr` / π of a fragment's cosine-weighted
//! rays (6 %), and the estimator stays Algorithm 3's: a traced ray adds what escapes (label 1)
//! or subtracts what is blocked (label 0), exactly as for a ray its masks selected.

use crate::grid::{MAX_WORDS, octahedral_pixel};
use glimpse_core::{Vec2, Vec3, luminance};
use glimpse_scene::{BrightPart, Environment};

/// The least sample points along each side of a bright texel's bilinear footprint when marking
/// the octahedral pixels it touches; more for coarse maps ([`footprint_samples`]).
const FOOTPRINT_SAMPLES: u32 = 5;

/// The octahedral resolution of the bright test: 32² pixels of about 0.012 sr, one `u64` word
/// per 64 (the GPU's uniform holds them as 8 × 4 `u32`). The masks' R = 8 would be too coarse:
/// the warehouse map's bright texels touch 34 % of its pixels, 11 % of these.
pub const RESOLUTION: u32 = 32;
/// `u64` words of the bit set at [`RESOLUTION`].
pub const WORDS: usize = (RESOLUTION * RESOLUTION / 64) as usize;

/// Which rays are bright: their radiance's luminance is above `threshold`, which only a
/// direction inside one of `pixels` can read.
#[derive(Clone, Debug)]
pub struct BrightDirections {
    /// Luminance (scaled as `Environment::radiance`) above which a ray is traced.
    pub threshold: f32,
    /// The octahedral pixels at [`RESOLUTION`] that hold such directions, one bit each: only
    /// rays there look the map up.
    pub pixels: [u64; WORDS],
    /// The same at the masks' R (a pixel there is set when any of its pixels above is, or every
    /// pixel when R does not divide [`RESOLUTION`]): the cheap first test, on the pixel every
    /// ray already has.
    pub coarse: [u64; MAX_WORDS],
    /// What the part holds.
    pub part: BrightPart,
}

impl BrightDirections {
    /// The brightest `solid_angle` sr of `env`, for masks of R = `resolution`; `None` for a
    /// black or constant map (no texel brighter than the rest).
    pub fn new(env: &Environment, solid_angle: f32, resolution: u32) -> Option<Self> {
        let part = env.brightest_part(solid_angle)?;
        if env.scale <= 0.0 {
            return None;
        }
        let img = &env.image;
        let (w, h) = (img.width, img.height);
        let mut pixels = [0u64; WORDS];
        let n = footprint_samples(w);
        for (i, texel) in img.pixels.iter().enumerate() {
            if luminance(*texel).max(0.0) <= part.threshold {
                continue;
            }
            let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
            // The bilinear lookup reads this texel from lookup points within one texel of its
            // centre: u·w − 0.5 in (x − 1, x + 1), likewise v.
            for a in 0..n {
                for b in 0..n {
                    let t = |k: u32| k as f32 / (n - 1) as f32;
                    let u = (x - 0.5 + 2.0 * t(a)) / w as f32;
                    let v = ((y - 0.5 + 2.0 * t(b)) / h as f32).clamp(0.0, 1.0);
                    let d = Environment::uv_to_dir(Vec2::new(u - u.floor(), v));
                    set(&mut pixels, octahedral_pixel(d, RESOLUTION));
                }
            }
        }
        let mut coarse = [0u64; MAX_WORDS];
        let pixel_count = resolution * resolution;
        if RESOLUTION.is_multiple_of(resolution) {
            // The octahedral encoding scaled by a power of two: a pixel at RESOLUTION lies
            // inside pixel (x / k, y / k) at R (the same float operations, scaled exactly).
            let k = RESOLUTION / resolution;
            for p in (0..RESOLUTION * RESOLUTION).filter(|&p| bit(&pixels, p)) {
                set(&mut coarse, (p / RESOLUTION / k) * resolution + (p % RESOLUTION) / k);
            }
        } else {
            (0..pixel_count).for_each(|p| set(&mut coarse, p));
        }
        Some(Self { threshold: part.threshold * env.scale, pixels, coarse, part })
    }

    /// Whether a ray in the masks' octahedral pixel `pixel` may be bright (then ask
    /// [`Self::holds`]).
    #[inline]
    pub fn may_hold(&self, pixel: u32) -> bool {
        bit(&self.coarse, pixel)
    }

    /// Whether the ray along `d` is bright: its pixel at [`RESOLUTION`] holds bright texels and
    /// `radiance(d)` (only then looked up) is above the threshold.
    #[inline]
    pub fn holds(&self, d: Vec3, radiance: &dyn Fn() -> Vec3) -> bool {
        bit(&self.pixels, octahedral_pixel(d, RESOLUTION)) && luminance(radiance()) > self.threshold
    }
}

/// Sample points along each side of a footprint (two texels of a `width`-texel map): at most an
/// eighth of a pixel at [`RESOLUTION`] apart (about π / 32 rad wide), so only a pixel touching
/// the footprint by a sliver narrower than that can be left unmarked; its rays then follow the
/// masks alone. 5 for a 1k map (whose footprint is a tenth of a pixel), 16 for a 64-wide one.
fn footprint_samples(width: u32) -> u32 {
    FOOTPRINT_SAMPLES.max((8 * 4 * RESOLUTION).div_ceil(width.max(1)))
}

fn bit(words: &[u64], p: u32) -> bool {
    (words[p as usize / 64] >> (p % 64)) & 1 == 1
}

fn set(words: &mut [u64], p: u32) {
    words[p as usize / 64] |= 1 << (p % 64);
}

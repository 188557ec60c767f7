//! Candidate directions and their selection ("snapping"), paper §4.1–4.2 [SC97].
//!
//! - `n×n` strata of `[0,1)²`, one jittered point per stratum, re-drawn every frame (paper §4.3:
//!   "before rotating to ROMA, we resample candidate directions using stratified sampling").
//! - Square → disk by Shirley–Chiu's concentric map, disk → hemisphere by the area-preserving
//!   lift `z = 1 − r²`, `(x, y) = disk·√(2 − r²)` (spec §4.2 [INFERENCE]; the paper says only that
//!   the mapping "preserves fractional areas"), so every stratum covers `2π/n²` sr.
//! - The hemisphere is fixed in world space around **+y** (the paper does not say which; y is up
//!   in our scenes). A ray in the other hemisphere uses the candidate of `−d` and traces the
//!   map towards −z (spec §2.3).
//! - Selection inverts the lift and the concentric map, so the chosen candidate is always the
//!   one of the ray's own stratum: "close enough", not always the nearest (paper §4.2).

use glimpse_core::fast_math::atan_unit;
use glimpse_core::{Frame, Rng, Vec2, Vec3};
use std::f32::consts::FRAC_PI_4;

/// Rays processed together by the batch path ([`CandidateSet::select_lanes`]).
pub const LANES: usize = 8;

/// The world hemisphere the candidates are drawn on.
pub const HEMISPHERE_AXIS: Vec3 = Vec3::Y;

/// One frame's `n×n` candidate directions; candidate `k = a·n + b` lies in stratum `(a, b)`.
#[derive(Clone, Debug, PartialEq)]
pub struct CandidateSet {
    pub n: u32,
    /// Unit world directions, in the +y hemisphere.
    pub dirs: Vec<Vec3>,
    /// The hemisphere's frame (z = [`HEMISPHERE_AXIS`]).
    pub hemisphere: Frame,
}

impl CandidateSet {
    /// Draws one jittered direction per stratum (`jitter = false`: stratum centres).
    pub fn draw(n: u32, rng: &mut Rng, jitter: bool) -> CandidateSet {
        let hemisphere = Frame::from_z(HEMISPHERE_AXIS);
        debug_assert_eq!((hemisphere.x, hemisphere.y), (Vec3::X, -Vec3::Z), "select() hard-codes this frame");
        let dirs = (0..n * n)
            .map(|k| {
                let (a, b) = (k / n, k % n);
                let xi = if jitter { rng.next_2d() } else { Vec2::splat(0.5) };
                let u = Vec2::new((a as f32 + xi.x) / n as f32, (b as f32 + xi.y) / n as f32);
                hemisphere.to_world(square_to_hemisphere(u)).normalize()
            })
            .collect();
        CandidateSet { n, dirs, hemisphere }
    }

    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// The candidate of `d`'s stratum and the sign to trace it with: the snapped direction is
    /// `sign · dirs[k]`.
    #[inline(always)]
    pub fn select(&self, d: Vec3) -> (usize, f32) {
        // `hemisphere` is Duff et al.'s frame around +y: x = (1,0,0), y = (0,0,−1), z = (0,1,0),
        // so `to_local` is a swizzle (acceptance check 7 verifies the strata through `to_world`).
        let local = Vec3::new(d.x, -d.z, d.y);
        // Branch-free: the other hemisphere's rays use −d (a random 50% branch costs more).
        let sign = 1.0f32.copysign(local.z);
        let o = hemisphere_to_disk_square(local * sign);
        let half_n = 0.5 * self.n as f32;
        let a = (((o.x + 1.0) * half_n) as u32).min(self.n - 1);
        let b = (((o.y + 1.0) * half_n) as u32).min(self.n - 1);
        ((a * self.n + b) as usize, sign)
    }

    /// [`CandidateSet::select`] for `LANES` directions at once, written without branches over
    /// plain arrays so the compiler runs the lanes in SIMD registers (the batch path of
    /// [`crate::RomaMaps::occluded_rays`]). Same strata as `select` (acceptance check 7b).
    #[inline(always)]
    pub fn select_lanes(&self, dx: &[f32; LANES], dy: &[f32; LANES], dz: &[f32; LANES]) -> ([u32; LANES], [f32; LANES]) {
        let mut k = [0u32; LANES];
        let mut sign = [0f32; LANES];
        let half_n = 0.5 * self.n as f32;
        let last = (self.n - 1) as f32;
        for l in 0..LANES {
            // Local frame swizzle as in `select`: (x, −z, y), folded into the +z hemisphere.
            let s = 1.0f32.copysign(dy[l]);
            let (x, y, z) = (dx[l] * s, -dz[l] * s, dy[l] * s);
            let r = (1.0 - z.clamp(0.0, 1.0)).sqrt();
            let (ax, ay) = (x.abs(), y.abs());
            let swap = ay > ax;
            let major = if swap { y } else { x };
            let minor = if swap { x } else { y };
            let big = ax.max(ay);
            // A pole (r = 0) or a zero major axis maps to the square's centre, as in `select`.
            let ratio = if big > 0.0 { minor / major } else { 0.0 };
            let main = if r > 0.0 && big > 0.0 { r.copysign(major) } else { 0.0 };
            let other = main * atan_unit(ratio) * (1.0 / FRAC_PI_4);
            let (ox, oy) = if swap { (other, main) } else { (main, other) };
            let a = ((ox + 1.0) * half_n).max(0.0).min(last) as u32;
            let b = ((oy + 1.0) * half_n).max(0.0).min(last) as u32;
            k[l] = a * self.n + b;
            sign[l] = s;
        }
        (k, sign)
    }

    /// The snapped direction of `d`.
    #[inline]
    pub fn snap(&self, d: Vec3) -> (usize, Vec3) {
        let (k, sign) = self.select(d);
        (k, self.dirs[k] * sign)
    }
}

/// `[0,1)²` → unit +z hemisphere, area-preserving (concentric map, then `z = 1 − r²`).
pub fn square_to_hemisphere(u: Vec2) -> Vec3 {
    let p = glimpse_core::sampling::concentric_disk(u);
    let r2 = p.length_squared().min(1.0);
    let s = (2.0 - r2).sqrt();
    Vec3::new(p.x * s, p.y * s, 1.0 - r2)
}

/// Inverse of [`square_to_hemisphere`] for a unit direction with `z ≥ 0`.
#[inline(always)]
pub fn hemisphere_to_square(d: Vec3) -> Vec2 {
    (hemisphere_to_disk_square(d) + Vec2::ONE) * 0.5
}

/// [`hemisphere_to_square`] before the last step: the point of the concentric map's square
/// `[−1, 1]²`.
#[inline(always)]
pub fn hemisphere_to_disk_square(d: Vec3) -> Vec2 {
    // Undo the lift: r = √(1 − z); the disk point has the direction's azimuth, so the ratio of
    // its coordinates is y/x and no normalization is needed.
    let r = (1.0 - d.z.clamp(0.0, 1.0)).sqrt();
    let (ax, ay) = (d.x.abs(), d.y.abs());
    if r <= 0.0 || ax.max(ay) <= 0.0 {
        return Vec2::ZERO;
    }
    // Undo Shirley–Chiu: the wedge |x| ≥ |y| came from |o.x| > |o.y| (o.y/o.x = atan(y/x)/(π/4)),
    // the other from |o.y| ≥ |o.x|; written without a branch on the wedge.
    let swap = ay > ax;
    let (major, minor) = if swap { (d.y, d.x) } else { (d.x, d.y) };
    let main = r.copysign(major);
    let other = main * atan_unit(minor / major) * (1.0 / FRAC_PI_4);
    if swap { Vec2::new(other, main) } else { Vec2::new(main, other) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_round_trips() {
        let mut rng = Rng::new(3, 0);
        let mut worst = 0.0f32;
        for _ in 0..100_000 {
            let u = rng.next_2d();
            let back = hemisphere_to_square(square_to_hemisphere(u));
            worst = worst.max((back - u).abs().max_element());
        }
        println!("square → hemisphere → square: worst error {worst:e}");
        assert!(worst < 1e-3);
    }
}

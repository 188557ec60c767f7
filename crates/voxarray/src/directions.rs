//! The 2D array's direction parameterization (paper §3.1, Alg. 1 loops and Alg. 3 line 1,
//! `DiscretizeDirection`), with the spec's conventions (§2.2 [Inference]; the paper names no
//! rotation axes):
//!
//! - `R(θ, φ) = Rx(φ)·Ry(θ)`; rows run along the rotated frame's +z (the orthographic depth
//!   axis), so the world row direction is `d(θ, φ) = Rᵀ e_z = (−sinθ cosφ, sinφ, cosθ cosφ)`.
//! - `directions` = n angles per axis, `k = 180°/n`, θ_i = i·k for i < n, φ_j = j·k for j < n.
//!   Half-open loops (erratum: Alg. 1's "0 to 180" / "0 to 90" would give (n+1)²).
//! - Only lines are covered (d and −d share a voxelization), which suffices for segment tests.
//! - The transposed copy is `j + n/2`: `R(θ, φ+90°) = Rx(90°)·R(θ, φ)`, so `n` must be even.

use glimpse_core::fast_math;
use glimpse_core::{Mat3, Vec3};

/// The angle grid of one array.
#[derive(Clone, Debug, PartialEq)]
pub struct Directions {
    /// Angles per axis (90 for the paper's k = 2°).
    pub n: u32,
    /// `R(θ_i, φ_j)` at `i·n + j`, the lookup table of Alg. 6.
    pub rotations: Vec<Mat3>,
    /// (cos, sin) of angle index `k·180°/n`: the query rotates with these (a few hundred bytes,
    /// always in cache) rather than loading a 36-byte matrix from an 8,100-entry table.
    pub cos_sin: Vec<(f32, f32)>,
}

impl Directions {
    pub fn new(n: u32) -> Self {
        assert!(n >= 2 && n.is_multiple_of(2), "directions must be even and ≥ 2, got {n}");
        let mut rotations = Vec::with_capacity((n * n) as usize);
        for i in 0..n {
            for j in 0..n {
                rotations.push(rotation(angle_rad(n, i), angle_rad(n, j)));
            }
        }
        let cos_sin = (0..n).map(|k| (angle_rad(n, k).cos(), angle_rad(n, k).sin())).collect();
        Self { n, rotations, cos_sin }
    }

    /// `R(θ_i, φ_j)·v` from the cos/sin table.
    #[inline]
    pub fn rotate(&self, i: u32, j: u32, v: Vec3) -> Vec3 {
        let (ct, st) = self.cos_sin[i as usize];
        let (cp, sp) = self.cos_sin[j as usize];
        let (ux, uz) = (ct * v.x + st * v.z, -st * v.x + ct * v.z);
        Vec3::new(ux, cp * v.y - sp * uz, sp * v.y + cp * uz)
    }

    /// Angular increment k in degrees.
    pub fn k_deg(&self) -> f32 {
        180.0 / self.n as f32
    }

    pub fn rotation(&self, i: u32, j: u32) -> Mat3 {
        self.rotations[(i * self.n + j) as usize]
    }

    /// World-space unit row direction of voxelization (i, j).
    pub fn row_direction(&self, i: u32, j: u32) -> Vec3 {
        row_direction(angle_rad(self.n, i), angle_rad(self.n, j))
    }

    /// `DiscretizeDirection` (Alg. 3 line 1): the (i, j) whose row line is nearest `d`'s line.
    #[inline]
    pub fn discretize(&self, d: Vec3) -> (u32, u32) {
        discretize(d, self.n)
    }
}

/// Angle index → radians for `n` angles over 180°.
pub fn angle_rad(n: u32, index: u32) -> f32 {
    (index as f64 * std::f64::consts::PI / n as f64) as f32
}

/// `R(θ, φ) = Rx(φ)·Ry(θ)`.
pub fn rotation(theta: f32, phi: f32) -> Mat3 {
    Mat3::from_rotation_x(phi) * Mat3::from_rotation_y(theta)
}

/// `d(θ, φ) = R(θ, φ)ᵀ e_z`.
pub fn row_direction(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(-theta.sin() * phi.cos(), phi.sin(), theta.cos() * phi.cos())
}

/// The spec's `DiscretizeDirection` (§2.2) for `n` angles per axis.
#[inline]
pub fn discretize(d: Vec3, n: u32) -> (u32, u32) {
    let mut d = d.normalize_or(Vec3::Z);
    if d.y < 0.0 {
        d = -d; // line symmetry
    }
    // Polynomial arc tangents (1.7e-6 rad; a 2° bin boundary moves by less): libm's asinf and
    // atan2f were a quarter of `lights-voxarray`'s shading time.
    let mut phi = fast_math::asin(d.y); // [0, π/2]
    let mut theta = fast_math::atan2(-d.x, d.z); // (−π, π]
    let pi = std::f32::consts::PI;
    if theta < 0.0 {
        theta += pi;
        phi = pi - phi;
    }
    if theta >= pi {
        theta -= pi;
        phi = pi - phi;
    }
    let step = pi / n as f32;
    // θ, φ ≥ 0 here, so rounding is truncation of x + ½ (no out-of-line `roundf`).
    let mut i = (theta / step + 0.5) as i64;
    let mut j = (phi / step + 0.5) as i64;
    if i >= n as i64 {
        // θ = 180° is θ = 0 with φ → 180° − φ.
        i = 0;
        j = n as i64 - j;
    }
    j = j.rem_euclid(n as i64); // φ = 180° is the same line as φ = 0
    (i as u32, j as u32)
}

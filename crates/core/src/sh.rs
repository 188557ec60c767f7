//! Real spherical harmonics of order 2 (9 coefficients) and the clamped-cosine convolution of
//! Ramamoorthi and Hanrahan 2001 ("An Efficient Representation for Irradiance Environment
//! Maps"): project radiance, then evaluate irradiance E(n) for any normal.

use glam::Vec3;
use std::f32::consts::PI;

/// The 9 real SH basis functions at unit direction `d`, in the order (l,m) = (0,0), (1,-1),
/// (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2).
pub fn basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// RGB radiance projected onto the order-2 SH basis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sh9 {
    pub coeffs: [Vec3; 9],
}

impl Sh9 {
    /// Accumulates one radiance sample `l` from direction `d` with Monte-Carlo weight `w`
    /// (the sample's solid angle, or 1/pdf/N).
    pub fn add_sample(&mut self, d: Vec3, l: Vec3, w: f32) {
        for (c, b) in self.coeffs.iter_mut().zip(basis(d)) {
            *c += l * (b * w);
        }
    }

    /// Irradiance E(n) = ∫ L(ω) max(0, n·ω) dω, from the band-limited radiance.
    pub fn irradiance(&self, n: Vec3) -> Vec3 {
        // Convolution with the clamped cosine: Â_l = π, 2π/3, π/4 for l = 0, 1, 2.
        const A: [f32; 9] = [PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0];
        let b = basis(n);
        (0..9).map(|i| self.coeffs[i] * (A[i] * b[i])).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hammersley, uniform_sphere};

    #[test]
    fn constant_radiance_gives_pi_irradiance() {
        let n = 16_384;
        let mut sh = Sh9::default();
        for i in 0..n {
            sh.add_sample(uniform_sphere(hammersley(i, n)), Vec3::ONE, 4.0 * PI / n as f32);
        }
        let e = sh.irradiance(Vec3::new(0.3, -0.5, 0.81).normalize());
        println!("irradiance under L=1: {e} (expected π)");
        assert!((e - Vec3::splat(PI)).abs().max_element() < 2e-2);
    }

    #[test]
    fn upper_hemisphere_light_matches_analytic_irradiance() {
        // L = 1 for z > 0: E(+z) = π, E(-z) = 0, and E at the horizon = π/2.
        let n = 65_536;
        let mut sh = Sh9::default();
        for i in 0..n {
            let d = uniform_sphere(hammersley(i, n));
            sh.add_sample(d, Vec3::splat(if d.z > 0.0 { 1.0 } else { 0.0 }), 4.0 * PI / n as f32);
        }
        let (up, down, side) = (sh.irradiance(Vec3::Z).x, sh.irradiance(-Vec3::Z).x, sh.irradiance(Vec3::X).x);
        println!("E(+z)={up:.4} E(-z)={down:.4} E(x)={side:.4}");
        // Order-2 SH rings on a step: Ramamoorthi-Hanrahan's bound is ~9% average error.
        assert!((up - PI).abs() < 0.1 * PI && down.abs() < 0.1 * PI && (side - PI / 2.0).abs() < 0.05 * PI);
    }
}

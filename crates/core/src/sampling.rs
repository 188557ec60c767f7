//! Random numbers and the sample warps the techniques share: Hammersley points, the concentric
//! disk map (Shirley and Chiu), cosine-weighted hemisphere, sphere, triangle and the octahedral
//! map (Engelhardt and Dachsbacher). Every random choice in glimpse goes through [`Rng`], seeded
//! explicitly, so the same command gives the same image.

use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;
use rand_pcg::rand_core::RngCore;
use std::f32::consts::{FRAC_PI_4, PI};

/// A seeded PCG32 stream. `stream` selects one of 2^63 independent sequences, so a pixel or a
/// light can have its own without any shared state between threads.
#[derive(Clone, Debug)]
pub struct Rng(Pcg32);

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Self {
        Self(Pcg32::new(mix64(seed ^ 0x853c_49e6_748f_ea9b), stream))
    }

    /// The stream for pixel `pixel` in pass `pass` of a render seeded with `seed`.
    pub fn for_pixel(seed: u64, pixel: u64, pass: u64) -> Self {
        Self::new(seed, mix64(pixel.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ pass))
    }

    pub fn next_u32(&mut self) -> u32 {
        self.0.next_u32()
    }

    /// Uniform in [0, 1), never 1.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }

    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

/// SplitMix64 finalizer: a cheap, well-distributed 64-bit hash.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Van der Corput radical inverse in base 2.
pub fn radical_inverse_base2(i: u32) -> f32 {
    (i.reverse_bits() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Point `i` of an `n`-point Hammersley set in [0,1)².
pub fn hammersley(i: u32, n: u32) -> Vec2 {
    Vec2::new((i as f32 + 0.5) / n as f32, radical_inverse_base2(i))
}

/// Adds a per-pixel (Cranley-Patterson) rotation to a low-discrepancy point, wrapping to [0,1).
pub fn rotate_sample(u: Vec2, shift: Vec2) -> Vec2 {
    let v = u + shift;
    Vec2::new(v.x - v.x.floor(), v.y - v.y.floor())
}

/// Shirley-Chiu concentric map from [0,1)² to the unit disk; preserves stratification.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, PI / 2.0 - FRAC_PI_4 * (o.x / o.y)) };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

/// Cosine-weighted direction on the +z hemisphere (Malley's method); pdf = cos θ / π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Uniform direction on the unit sphere; pdf = 1 / 4π.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction on the +z hemisphere; pdf = 1 / 2π.
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform barycentrics (b1, b2) on a triangle (the square-root parameterization).
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let s = u.x.sqrt();
    Vec2::new(1.0 - s, u.y * s)
}

/// Octahedral map of a unit direction to [0,1)².
pub fn octahedral_encode(d: Vec3) -> Vec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let mut p = Vec2::new(d.x, d.y) / l1;
    if d.z < 0.0 {
        p = Vec2::new((1.0 - p.y.abs()) * sign_nz(p.x), (1.0 - p.x.abs()) * sign_nz(p.y));
    }
    p * 0.5 + Vec2::splat(0.5)
}

/// Inverse of [`octahedral_encode`]: [0,1)² to a unit direction.
pub fn octahedral_decode(u: Vec2) -> Vec3 {
    let p = u * 2.0 - Vec2::ONE;
    let z = 1.0 - p.x.abs() - p.y.abs();
    let t = (-z).max(0.0);
    let x = p.x - t * sign_nz(p.x);
    let y = p.y - t * sign_nz(p.y);
    Vec3::new(x, y, z).normalize()
}

fn sign_nz(v: f32) -> f32 {
    if v >= 0.0 { 1.0 } else { -1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_deterministic_and_uniform() {
        let mut a = Rng::new(42, 3);
        let mut b = Rng::new(42, 3);
        let mut sum = 0.0f64;
        for _ in 0..100_000 {
            let x = a.next_f32();
            assert_eq!(x, b.next_f32());
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        let mean = sum / 100_000.0;
        println!("mean of 1e5 uniforms: {mean:.5}");
        assert!((mean - 0.5).abs() < 0.005);
        assert_ne!(Rng::new(42, 3).next_u32(), Rng::new(42, 4).next_u32());
    }

    #[test]
    fn cosine_hemisphere_has_the_right_mean_cosine() {
        // E[cos θ] under pdf cos θ/π is 2/3.
        let n = 4096;
        let mean: f32 = (0..n).map(|i| cosine_hemisphere(hammersley(i, n)).z).sum::<f32>() / n as f32;
        println!("mean cos = {mean:.5} (expected 0.66667)");
        assert!((mean - 2.0 / 3.0).abs() < 1e-3);
        for i in 0..n {
            let d = cosine_hemisphere(hammersley(i, n));
            assert!((d.length() - 1.0).abs() < 1e-4 && d.z >= 0.0);
        }
    }

    #[test]
    fn octahedral_round_trip() {
        let mut rng = Rng::new(1, 1);
        let mut worst = 0.0f32;
        for _ in 0..10_000 {
            let d = uniform_sphere(rng.next_2d());
            let u = octahedral_encode(d);
            assert!((0.0..=1.0).contains(&u.x) && (0.0..=1.0).contains(&u.y));
            worst = worst.max((octahedral_decode(u) - d).length());
        }
        println!("octahedral round-trip worst error {worst:e}");
        assert!(worst < 1e-5);
    }

    #[test]
    fn concentric_disk_stays_in_disk() {
        for i in 0..1024 {
            assert!(concentric_disk(hammersley(i, 1024)).length() <= 1.0 + 1e-6);
        }
    }
}

//! A ray with an origin and a direction. Directions need not be normalized for the tracer, but
//! every technique in glimpse passes unit directions so that `t` is a distance.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// A ray leaving a surface point, its origin pushed off the surface along the normal (on the
    /// side the ray goes) by [`offset_origin`], so that the surface itself is never hit again at
    /// `t ≈ 0`. `error_scale` is the magnitude the point's rounding error is relative to
    /// ([`error_scale`]).
    pub fn spawn(point: Vec3, normal: Vec3, error_scale: f32, dir: Vec3) -> Self {
        let n = if normal.dot(dir) < 0.0 { -normal } else { normal };
        Self { origin: offset_origin(point, n, error_scale), dir }
    }
}

/// The offset of a ray origin off its surface, relative to [`error_scale`]: about 5 times the
/// point's rounding-error bound (γ₇ ≈ 4.2·10⁻⁷ of it). Rays from their own triangle hit it
/// again below about half the bound (`crates/trace/tests/exact_vs_brute.rs`: at 10⁻⁷, 68 of
/// 3,844 rays from a box 10 km out; 0 at 3·10⁻⁷ and above). Until session 25 it was 10⁻⁴
/// (Mitsuba 3's `RayEpsilon` is about as large): hundreds of bounds, no length near the origin,
/// but 1 m for a scene 10 km from it, whose references lost every contact shadow.
pub const RAY_OFFSET: f32 = 2e-6;

/// The magnitude a point interpolated from a triangle's vertices, `Σ bᵢ·pᵢ`, carries its rounding
/// error relative to: the largest coordinate of `Σ |bᵢ·pᵢ|` (pbrt-v4 eq. 6.21 without its γ₇).
/// It is at least the point's own largest coordinate, and exceeds it where the point lies near
/// the origin on a triangle that reaches far from it. It scales with the scene: no absolute
/// length enters the offset.
pub fn error_scale(p: &[Vec3; 3], b: [f32; 3]) -> f32 {
    error_magnitudes(p, b).max_element()
}

/// `Σ |bᵢ·pᵢ|` per coordinate: what the rounding error of `Σ bᵢ·pᵢ` is relative to, coordinate by
/// coordinate (× γ₇ it is pbrt-v4's bound, eq. 6.21).
pub fn error_magnitudes(p: &[Vec3; 3], b: [f32; 3]) -> Vec3 {
    (p[0] * b[0]).abs() + (p[1] * b[1]).abs() + (p[2] * b[2]).abs()
}

/// Moves `p` off the surface along `n` by [`RAY_OFFSET`] × the larger of `p`'s largest coordinate
/// and `error_scale` (a simplified form of Wächter and Binder's "A Fast and Robust Method for
/// Avoiding Self-Intersection", Ray Tracing Gems ch. 6, with pbrt-v4's error bound in place of an
/// absolute floor). A point that is not on a surface (a light's position) passes 0.
///
/// The offset had an absolute floor of 10⁻⁴ scene units (as Mitsuba 3's `spawn_ray` has), which
/// is 5 % of a scene 2 mm across; relative to the error scale, a scene renders the same at any
/// scale (`crates/eval/tests/scale_invariance.rs`).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, error_scale: f32) -> Vec3 {
    let scale = p.abs().max_element().max(error_scale);
    p + n * (RAY_OFFSET * scale)
}

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
    /// side the ray goes) by an offset that scales with the point's magnitude, so that the
    /// surface itself is never hit again at `t ≈ 0`.
    pub fn spawn(point: Vec3, normal: Vec3, dir: Vec3) -> Self {
        let n = if normal.dot(dir) < 0.0 { -normal } else { normal };
        Self { origin: offset_origin(point, n), dir }
    }
}

/// Moves `p` off the surface along `n` by a small offset relative to the coordinates' magnitude
/// (a simplified form of Wächter and Binder's "A Fast and Robust Method for Avoiding
/// Self-Intersection", Ray Tracing Gems ch. 6).
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let scale = p.abs().max_element().max(1.0);
    p + n * (1e-4 * scale)
}

//! glimpse-core: the math, sampling and image types every other glimpse crate stands on.
//!
//! Everything here is plain data (`Copy` structs, flat `Vec`s) so the same buffers can later be
//! uploaded to a GPU unchanged.

pub mod aabb;
pub mod atomic_file;
pub mod bounded_read;
pub mod cache_file;
pub mod catch_panic;
pub mod distribution;
pub mod fast_math;
pub mod frame;
pub mod image;
pub mod memory_budget;
pub mod mutate;
pub mod ray;
pub mod sampling;
pub mod sh;
pub mod suggest;
pub mod tev;

pub use aabb::Aabb;
pub use frame::Frame;
pub use glam;
pub use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec3A, Vec4};
pub use image::{Image, ImageError, ToneMap};
pub use ray::Ray;
pub use sampling::Rng;

/// Relative luminance of linear Rec.709 RGB.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// True when every component is finite (no NaN, no infinity).
pub fn is_finite3(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

//! The N_r ray directions of a point sample (precompute, §2.1.1) and of a fragment (runtime,
//! §2.1.2): the points of an N_r-point Hammersley set, cosine-weighted on the hemisphere of the
//! normal, randomly rotated. The construction is exactly `env-exact`'s (crates/render/src/env.rs),
//! so that at equal seeds the runtime traces the reference's own rays, bit for bit.
//!
//! Rotation (`rotation=cp`, the default, as env-exact's): a Cranley-Patterson shift of the set
//! by a random 2-D offset (unbiased). `rotation=normal`: the whole set rotated by one random
//! angle about the normal (the paper's wording; biased in θ, see env.rs). The paper draws the
//! runtime rotation from a blue-noise texture; we use the pixel's PCG stream, as the reference.

use glimpse_core::sampling::{cosine_hemisphere, hammersley, rotate_sample};
use glimpse_core::{Frame, Vec2, Vec3};

/// One rotated ray set about one normal.
#[derive(Clone, Copy, Debug)]
pub struct RaySet {
    pub frame: Frame,
    pub count: u32,
    pub shift: Vec2,
    pub about_normal: bool,
    sin_a: f32,
    cos_a: f32,
}

impl RaySet {
    pub fn new(normal: Vec3, count: u32, shift: Vec2, about_normal: bool) -> RaySet {
        // The angle of `rotation=normal` (unused by the Cranley-Patterson shift).
        let (sin_a, cos_a) = if about_normal { (std::f32::consts::TAU * shift.x).sin_cos() } else { (0.0, 1.0) };
        RaySet { frame: Frame::from_z(normal), count, shift, about_normal, sin_a, cos_a }
    }

    /// (sin, cos) of the rotation about the normal (`about_normal`; (0, 1) otherwise).
    #[inline]
    pub fn rotation(&self) -> (f32, f32) {
        (self.sin_a, self.cos_a)
    }

    /// World direction of ray k.
    #[inline]
    pub fn direction(&self, k: u32) -> Vec3 {
        let local = if self.about_normal {
            let d = cosine_hemisphere(hammersley(k, self.count));
            Vec3::new(d.x * self.cos_a - d.y * self.sin_a, d.x * self.sin_a + d.y * self.cos_a, d.z)
        } else {
            cosine_hemisphere(rotate_sample(hammersley(k, self.count), self.shift))
        };
        self.frame.to_world(local)
    }
}

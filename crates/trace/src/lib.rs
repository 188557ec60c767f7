//! glimpse-trace: the exact ray tracer every approximate technique is measured against.
//!
//! - [`bvh`]: binned-SAH BVH2 over boxes, parallel build, refit.
//! - [`triangle`]: the watertight ray–triangle test.
//! - [`tracer`]: [`ExactTracer`], the two-level BVH over a [`SceneFrame`].
//! - `packet`: one box against eight rays, for the tracer's shadow-ray packets.
//! - [`brute`]: every ray against every triangle, the oracle for the tracer's tests.
//! - [`surface`]: from a [`Hit`] to positions, normals, texture coordinates and albedo.
//! - [`gbuffer`]: primary visibility per pixel.
//! - [`spawn`]: robust hit points and secondary-ray origins.
//! - `embree` (feature): Intel Embree on the same scene, for cross-checks and benchmarks.

pub mod brute;
pub mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
pub mod gbuffer;
mod packet;
pub mod rays;
pub mod spawn;
pub mod surface;
pub mod tracer;
pub mod triangle;

pub use brute::BruteForce;
pub use gbuffer::GBuffer;
pub use surface::SurfacePoint;
pub use tracer::{ExactTracer, Hit, ShadowCache};

use glimpse_core::Ray;
pub use glimpse_scene::SceneFrame;

/// Exact or approximate answer to "is this segment blocked?": is anything hit at
/// `0 < t < t_max` along `ray`? Implemented by the exact BVH and by every approximate
/// visibility structure (ROMA, the voxelization array, the distance field), so that techniques
/// and benchmarks can swap one for another.
pub trait Visibility: Send + Sync {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;

    /// `occluded`, for one of a sequence of related rays sharing `cache` (one point's rays to
    /// a cluster of lights): the exact tracer first tests the triangle that blocked the
    /// previous one ([`ExactTracer::occluded_cached`]). The default ignores the cache.
    fn occluded_cached(&self, ray: &Ray, t_max: f32, _cache: &mut ShadowCache) -> bool {
        self.occluded(ray, t_max)
    }

    /// `out[i] = occluded(rays[i])` for a batch of independent rays (`out.len() == rays.len()`).
    /// Backends whose per-ray work vectorizes across rays (ROMA's stratum selection) override
    /// it, as a GPU runs a warp of rays together; the default answers one ray at a time.
    fn occluded_batch(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        for ((ray, t_max), o) in rays.iter().zip(out) {
            *o = self.occluded(ray, *t_max);
        }
    }
}

/// Visibility that also finds the first hit.
pub trait ClosestHit: Visibility {
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit>;
}

impl Visibility for ExactTracer {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        ExactTracer::occluded(self, ray, t_max)
    }

    fn occluded_cached(&self, ray: &Ray, t_max: f32, cache: &mut ShadowCache) -> bool {
        ExactTracer::occluded_cached(self, ray, t_max, cache)
    }

    fn occluded_batch(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        self.occluded_many(rays, out)
    }
}

impl ClosestHit for ExactTracer {
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        ExactTracer::closest_hit(self, ray, t_max)
    }
}

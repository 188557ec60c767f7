//! Shared by the GPU test files: the context (or a printed reason to skip) and comparisons of
//! GPU answers with the CPU `ExactTracer`'s. Not every test file uses every helper.
#![allow(dead_code)]

use glimpse_core::{Ray, Rng, Vec3};
use glimpse_gpu::{GpuContext, GpuHit};
use glimpse_trace::{ExactTracer, Hit};

/// The GPU context, or `None` after printing why the test is skipped.
pub fn context(test: &str) -> Option<GpuContext> {
    GpuContext::for_test(test)
}

/// `n` random rays through the box `[lo, hi]`: origins inside it, directions uniform on the
/// sphere, every third ray infinite and the others a random length up to the box's diagonal.
pub fn random_rays(lo: Vec3, hi: Vec3, n: usize, seed: u64) -> Vec<(Ray, f32)> {
    let mut rng = Rng::new(seed, 0);
    let diagonal = (hi - lo).length();
    (0..n)
        .map(|i| {
            let o = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = std::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let t_max = if i % 3 == 0 { f32::INFINITY } else { diagonal * rng.next_f32() };
            (Ray::new(o, d), t_max)
        })
        .collect()
}

/// Counts of a GPU-vs-CPU closest-hit comparison.
#[derive(Debug, Default)]
pub struct ClosestAgreement {
    pub hits: usize,
    /// Same triangle, `t` within the tolerance.
    pub same: usize,
    /// Another triangle at the same `t` (a ray through a shared edge or vertex).
    pub edge_ties: usize,
    /// Hit on one side and miss on the other, or a different `t`.
    pub disagree: usize,
    pub worst_relative_t: f32,
}

pub const T_TOLERANCE: f32 = 1e-5;

pub fn compare_closest(cpu: &ExactTracer, rays: &[(Ray, f32)], gpu: &[Option<GpuHit>]) -> ClosestAgreement {
    let mut a = ClosestAgreement::default();
    for ((ray, t_max), g) in rays.iter().zip(gpu) {
        let c: Option<Hit> = cpu.closest_hit(ray, *t_max);
        match (c, g) {
            (None, None) => a.same += 1,
            (Some(c), Some(g)) => {
                a.hits += 1;
                let rel = (c.t - g.t).abs() / c.t.abs().max(1e-6);
                a.worst_relative_t = a.worst_relative_t.max(rel);
                if rel > T_TOLERANCE {
                    a.disagree += 1;
                } else if (c.instance, c.triangle) == (g.instance, g.triangle) {
                    a.same += 1;
                } else {
                    a.edge_ties += 1;
                }
            }
            _ => a.disagree += 1,
        }
    }
    a
}

/// Rays whose any-hit answer differs between the CPU and the GPU.
pub fn occluded_disagreements(cpu: &ExactTracer, rays: &[(Ray, f32)], gpu: &[bool]) -> usize {
    rays.iter().zip(gpu).filter(|((ray, t_max), g)| cpu.occluded(ray, *t_max) != **g).count()
}

pub fn percent(part: usize, whole: usize) -> f64 {
    100.0 * part as f64 / whole.max(1) as f64
}

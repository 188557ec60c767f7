//! Sphere tracing the distance field with its mip levels (Hart 1996; the mip acceleration of
//! Aaltonen 2018, "GPU-based clay simulation and ray-tracing tech in Claybook"), at most
//! `max_steps` iterations (the ROMA paper: 64 for AO, 16 in its soft-shadow timing).
//!
//! The paper hand-tuned "the minimum ray propagation distance, the threshold value of ray
//! intersection, and the offset distance along the surface normals" per scene; ours are fixed:
//! - the surface is the union of balls of radius `surface_cells` = √3/2 around the occupied
//!   cells' centres (each ball holds its whole cell, like ROMA's conservative cells);
//! - a hit is a point within `hit_epsilon_cells` = 0.1 of that surface;
//! - each step is at least `min_step_cells` = 0.5 cell;
//! - a step uses the coarsest mip bound that still moves the ray by at least one cell, else the
//!   trilinear level-0 distance (each counts as one iteration);
//! - a ray that runs out of iterations before leaving the grid or reaching `t_max` is a miss
//!   (the usual choice: the ray is assumed to escape);
//! - ray origins: 1.5 cells along the normal in the techniques, like ROMA.

use crate::distance_field::DistanceField;
use glimpse_core::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereTraceParams {
    pub max_steps: u32,
    pub surface_cells: f32,
    pub hit_epsilon_cells: f32,
    pub min_step_cells: f32,
}

impl Default for SphereTraceParams {
    fn default() -> Self {
        Self { max_steps: 64, surface_cells: 3f32.sqrt() * 0.5, hit_epsilon_cells: 0.1, min_step_cells: 0.5 }
    }
}

/// What one trace did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceResult {
    /// World distance to the hit, if any.
    pub hit: Option<f32>,
    pub steps: u32,
}

impl DistanceField {
    /// Sphere-traces `origin + t·dir` (world, `dir` unit) for `t ∈ [0, t_max]`.
    pub fn sphere_trace(&self, origin: Vec3, dir: Vec3, t_max: f32, p: &SphereTraceParams) -> TraceResult {
        let cell = self.grid.cell_size_world;
        let q0 = self.grid.to_cells(origin);
        let r = self.resolution as f32;
        // Clip to the grid's box (in cells; `dir` is unit, so t in cells = t_world / cell).
        let (mut t0, mut t1) = (0.0f32, t_max / cell);
        for c in 0..3 {
            if dir[c].abs() < 1e-12 {
                if q0[c] < 0.0 || q0[c] > r {
                    return TraceResult { hit: None, steps: 0 };
                }
            } else {
                let (a, b) = ((0.0 - q0[c]) / dir[c], (r - q0[c]) / dir[c]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if t0 > t1 {
            return TraceResult { hit: None, steps: 0 };
        }
        let mut t = t0;
        let max_q = Vec3::splat(r - 1e-3);
        for step in 0..p.max_steps {
            if t > t1 {
                return TraceResult { hit: None, steps: step };
            }
            let q = (q0 + dir * t).clamp(Vec3::ZERO, max_q);
            let coarse = self.bound(2, q) - p.surface_cells;
            if coarse >= 1.0 {
                t += coarse;
                continue;
            }
            let mid = self.bound(1, q) - p.surface_cells;
            if mid >= 1.0 {
                t += mid;
                continue;
            }
            let d = self.trilinear(q) - p.surface_cells;
            if d < p.hit_epsilon_cells {
                return TraceResult { hit: Some(t * cell), steps: step + 1 };
            }
            t += d.max(p.min_step_cells);
        }
        TraceResult { hit: None, steps: p.max_steps }
    }
}

//! Where a frame's shadow rays can be blocked: the part of the scene a grid-based visibility
//! structure should cover, so its cells are sized by what the camera sees rather than by the
//! scene's bounds (a 100 m ground under a 1 m object made the voxel array's cells a third of a
//! metre and the object's shadow vanished under the start offset).
//!
//! A shadow ray from a surface the camera sees to a point or spot light stays inside the box of
//! those surfaces and the light (a box is convex); toward a directional light it leaves the scene
//! through its bounds, so the box is stretched toward that light up to them. Surfaces the camera
//! sees are sampled by a coarse grid of primary rays, so a pixel between the samples may lie
//! outside the box, and so do the farthest 1 % along each axis (a ground seen to the horizon):
//! callers trace such pixels exactly ([`Focus::contains`]).

use crate::FrameContext;
use glimpse_core::{Aabb, Vec3};
use glimpse_scene::{LightKind, WorldLight};

/// Primary rays per side of the grid that samples what the camera sees.
const PROBES: u32 = 64;
/// Share of the probes' hits left out of the seen surfaces' box at each end of each axis.
const TRIM: f32 = 0.01;
/// The seen surfaces' box grows by this share of its diagonal (the surfaces between the probes).
const MARGIN: f32 = 0.05;
/// A focus is used only when its diagonal is under this share of the scene's: in a room the
/// camera sees most of, the scene is the focus (and the structure is the paper's).
const WORTHWHILE: f32 = 0.5;

/// The box shadow rays of this frame's visible surfaces toward `lights` stay in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Focus {
    pub bounds: Aabb,
}

impl Focus {
    /// The focus of `ctx`'s camera for `lights`, or `None` where it would not be much smaller
    /// than the scene (or the camera sees nothing).
    pub fn for_shadows(ctx: &FrameContext, lights: &[WorldLight]) -> Option<Focus> {
        let scene = ctx.frame.bounds;
        let seen = seen_surfaces(ctx)?;
        let grown = Aabb::new(seen.min - seen.extent() * MARGIN, seen.max + seen.extent() * MARGIN);
        let mut b = grown;
        for light in lights {
            b = match light.kind {
                LightKind::Point | LightKind::Spot { .. } => b.grow(light.position),
                LightKind::Directional => corners(&grown).iter().fold(b, |b, &c| b.grow(to_bounds(&scene, c, -light.direction))),
            };
        }
        let bounds = Aabb::new(b.min.max(scene.min), b.max.min(scene.max));
        (bounds.extent().length() < WORTHWHILE * scene.extent().length()).then_some(Focus { bounds })
    }

    /// Whether `p` lies in the focus (a shadow ray from it may be answered by the structure).
    pub fn contains(&self, p: Vec3) -> bool {
        self.bounds.contains(p)
    }
}

/// The box of most of the surfaces a `PROBES` × `PROBES` grid of primary rays hits: per axis,
/// from the `TRIM` to the 1 − `TRIM` quantile of the hits, so a ground seen to the horizon (a
/// few pixels of it kilometres away) does not set the box's size.
fn seen_surfaces(ctx: &FrameContext) -> Option<Aabb> {
    let (w, h) = (ctx.width.max(1), ctx.height.max(1));
    let mut hits = Vec::with_capacity((PROBES * PROBES) as usize);
    for y in 0..PROBES {
        for x in 0..PROBES {
            let (px, py) = ((x as f32 + 0.5) / PROBES as f32 * w as f32, (y as f32 + 0.5) / PROBES as f32 * h as f32);
            let ray = ctx.camera.ray(px, py, w, h);
            if let Some(hit) = ctx.tracer.closest_hit(&ray, f32::INFINITY) {
                hits.push(ray.at(hit.t));
            }
        }
    }
    if hits.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = (Vec3::ZERO, Vec3::ZERO);
    let mut axis = Vec::with_capacity(hits.len());
    for c in 0..3 {
        axis.clear();
        axis.extend(hits.iter().map(|p| p[c]));
        axis.sort_unstable_by(f32::total_cmp);
        let at = |q: f32| axis[((axis.len() - 1) as f32 * q).round() as usize];
        (lo[c], hi[c]) = (at(TRIM), at(1.0 - TRIM));
    }
    Some(Aabb::new(lo, hi))
}

fn corners(b: &Aabb) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// Where the ray from `p` (inside `bounds` or not) along unit `dir` leaves `bounds`: `p` itself
/// if it never enters beyond `p`.
fn to_bounds(bounds: &Aabb, p: Vec3, dir: Vec3) -> Vec3 {
    let inv = Vec3::ONE / dir;
    match bounds.intersect(p, inv, 0.0, f32::INFINITY) {
        Some((_, t_exit)) if t_exit.is_finite() => p + dir * t_exit,
        _ => p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_leaves_the_bounds_where_it_should() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let exit = to_bounds(&b, Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0));
        assert!((exit - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-6, "{exit}");
        let outside = Vec3::new(0.0, 5.0, 0.0);
        assert_eq!(to_bounds(&b, outside, Vec3::new(0.0, 1.0, 0.0)), outside);
    }
}

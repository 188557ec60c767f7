//! Sampling the SST (thesis §5.2–5.3): stochastic traversal from a start node with the child
//! probabilities of Eq. 5.4 and the stopping rule of Eq. 5.6, cluster evaluation as a point light
//! at a point drawn from the node's substitute Gaussian (clamped to its box) with one exact
//! shadow ray, and the per-pixel estimators of the three strategies compared in §7.1:
//! - `Proposed`: blended shallow cut, traversal from each cut node, stopping at suitable nodes;
//! - `Sst` (Tatzgern et al.): n traversals from the root, stopping at suitable nodes, mean of n;
//! - `Rtslc` (Lin and Yuksel): blended shallow cut, traversal from each cut node to a leaf.
//!
//! Gaps filled (spec §6.5–6.6): every sample is divided by its traversal path probability P (as
//! SLC/RTSLC do), so with leaf stops the estimator is unbiased for the VPL sum; the point light
//! shades like a VPL: colour · cos_x · cos_y / (π · max(d², clamp²)) with the node's mean normal
//! (the VPL-side cosine of a Lambertian emitter), the same formula `vpl-exact` uses per VPL.

use crate::cut::{BlockCuts, Surface, mock_cut, stochastic_select, weight};
use crate::tree::{Sst, SstNode};
use crate::vpl::Similarity;
use glimpse_core::ray::offset_origin;
use glimpse_core::{Rng, Vec3};
use glimpse_render::direct::{Shading, segment};
use glimpse_trace::{ShadowCache, Visibility};
use std::f32::consts::PI;

/// Which tree sampling strategy (§7.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    Proposed,
    Sst,
    Rtslc,
}

/// The result of one traversal: the terminal node, its path probability, the steps taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Traversal {
    pub node: Option<(u32, f32)>,
    pub steps: u32,
}

/// Stochastic traversal (§5.2) from `start`: stop at a leaf, or, with `stop = Some(ratio)`, at an
/// inner node that [`stops_at`] accepts (`None`: leaves only, RTSLC); otherwise go left with
/// p = w_l/(w_l+w_r) (Eq. 5.4). Both weights 0: no sample.
pub fn traverse(tree: &Sst, start: u32, x: &Surface, stop: Option<f32>, clamp2: f32, rng: &mut Rng) -> Traversal {
    let (mut node, mut p, mut steps) = (start, 1.0f32, 0u32);
    loop {
        if tree.is_leaf(node) || stop.is_some_and(|r| stops_at(&tree.nodes[node as usize], x, r)) {
            return Traversal { node: Some((node, p)), steps };
        }
        let (l, r) = (2 * node, 2 * node + 1);
        let wl = weight(&tree.nodes[l as usize], x, clamp2);
        let wr = weight(&tree.nodes[r as usize], x, clamp2);
        if wl + wr <= 0.0 {
            return Traversal { node: None, steps };
        }
        let pl = wl / (wl + wr);
        steps += 1;
        if rng.next_f32() < pl {
            node = l;
            p *= pl;
        } else {
            node = r;
            p *= 1.0 - pl;
        }
    }
}

/// Whether a traversal stops at inner node `c`: Eq. 5.6's `suitable`, and (ours) the node's box
/// seen from `x` small: its diagonal at most `ratio` × the distance from `x` to its centre.
pub fn stops_at(c: &SstNode, x: &Surface, ratio: f32) -> bool {
    if !c.suitable {
        return false;
    }
    if ratio == f32::INFINITY {
        return true;
    }
    let diag2 = (c.bb_max - c.bb_min).length_squared();
    let d2 = ((c.bb_min + c.bb_max) * 0.5 - x.pos).length_squared();
    diag2 <= ratio * ratio * d2
}

/// A standard normal pair (Box–Muller).
fn gauss2(rng: &mut Rng) -> (f32, f32) {
    let u1 = 1.0 - rng.next_f32();
    let u2 = rng.next_f32();
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (2.0 * PI * u2).sin_cos();
    (r * c, r * s)
}

/// A point from the node's substitute distribution (§5.3): N(pos, var) in the node's frame,
/// to world, clamped to the box. A leaf (var = 0) gives its VPL's position exactly.
pub fn sample_point(node: &SstNode, rng: &mut Rng) -> Vec3 {
    if node.var == Vec3::ZERO {
        return node.pos;
    }
    let (a, b) = gauss2(rng);
    let (c, _) = gauss2(rng);
    let s = Vec3::new(a * node.var.x.max(0.0).sqrt(), b * node.var.y.max(0.0).sqrt(), c * node.var.z.max(0.0).sqrt());
    (node.pos + node.frame().to_world(s)).clamp(node.bb_min, node.bb_max)
}

/// Incident light from a Lambertian point emitter of flux `color` at `y` (normal `ny`), divided
/// by π (so that ρ × this is the reflected radiance): color·cos_x·cos_y/(π²·max(d², clamp²)),
/// and the unit direction to it. Zero when either side faces away.
pub fn vpl_term(s: &Shading, y: Vec3, ny: Vec3, color: Vec3, clamp2: f32) -> Vec3 {
    let to = y - s.position;
    let d2 = to.length_squared();
    if d2 <= 0.0 {
        return Vec3::ZERO;
    }
    let w = to / d2.sqrt();
    let cx = s.cos(w);
    let cy = ny.dot(-w).max(0.0);
    if cx <= 0.0 || cy <= 0.0 {
        return Vec3::ZERO;
    }
    color * (cx * cy / (PI * PI * d2.max(clamp2)))
}

/// `vpl_term` times exact visibility (one shadow ray when the term is non-zero); (value, rays).
/// The ray ends off the emitter's surface by the offset of `y_error_scale` (the node's,
/// [`SstNode::error_scale`]).
pub fn shade_point(vis: &dyn Visibility, s: &Shading, y: Vec3, ny: Vec3, y_error_scale: f32, color: Vec3, clamp2: f32) -> (Vec3, u64) {
    shade_point_cached(vis, s, y, ny, y_error_scale, color, clamp2, &mut ShadowCache::default())
}

/// [`shade_point`] for one of a sequence of VPLs near each other, sharing a shadow cache.
#[allow(clippy::too_many_arguments)]
fn shade_point_cached(
    vis: &dyn Visibility,
    s: &Shading,
    y: Vec3,
    ny: Vec3,
    y_error_scale: f32,
    color: Vec3,
    clamp2: f32,
    cache: &mut ShadowCache,
) -> (Vec3, u64) {
    let t = vpl_term(s, y, ny, color, clamp2);
    if t == Vec3::ZERO {
        return (Vec3::ZERO, 0);
    }
    let (ray, t_max) = segment(s.position, s.normal, s.error_scale, offset_origin(y, ny, y_error_scale));
    if vis.occluded_cached(&ray, t_max, cache) { (Vec3::ZERO, 1) } else { (t, 1) }
}

/// Everything the per-pixel estimator reads.
pub struct Sampler<'a> {
    pub tree: &'a Sst,
    pub vis: &'a dyn Visibility,
    pub cuts: Option<&'a BlockCuts>,
    pub strategy: Strategy,
    pub n: u32,
    pub clamp2: f32,
    pub similarity: Similarity,
    /// Inner nodes stop a traversal only when their box's diagonal is at most this × their
    /// distance (ours; ∞: Eq. 5.6 alone, the thesis).
    pub stop_ratio: f32,
}

/// What one pixel's estimate cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelCost {
    pub rays: u64,
    pub steps: u64,
    pub samples: u64,
    pub mock: bool,
}

impl Sampler<'_> {
    /// One traversal + evaluation from `start`, divided by the path probability.
    fn evaluate(&self, start: u32, s: &Shading, x: &Surface, stop: Option<f32>, rng: &mut Rng, cost: &mut PixelCost) -> Vec3 {
        let t = traverse(self.tree, start, x, stop, self.clamp2, rng);
        cost.steps += t.steps as u64;
        cost.samples += 1;
        let Some((node, p)) = t.node else {
            return Vec3::ZERO;
        };
        let c = &self.tree.nodes[node as usize];
        let y = sample_point(c, rng);
        let (v, rays) = shade_point(self.vis, s, y, c.normal, c.error_scale, c.color, self.clamp2);
        cost.rays += rays;
        if p > 0.0 { v / p } else { Vec3::ZERO }
    }

    /// The pixel's indirect estimate (÷π, before ρ) at GI pixel (px, py).
    pub fn pixel(&self, px: u32, py: u32, s: &Shading, rng: &mut Rng) -> (Vec3, PixelCost) {
        let x = Surface { pos: s.position, normal: s.normal };
        let mut cost = PixelCost::default();
        let mut sum = Vec3::ZERO;
        match self.strategy {
            Strategy::Sst => {
                for _ in 0..self.n {
                    sum += self.evaluate(1, s, &x, Some(self.stop_ratio), rng, &mut cost);
                }
                sum /= self.n.max(1) as f32;
            }
            Strategy::Proposed | Strategy::Rtslc => {
                let stop_inner = (self.strategy == Strategy::Proposed).then_some(self.stop_ratio);
                let cuts = self.cuts.expect("cut strategies have cuts");
                match cuts.blend_weights(px, py, &x, self.similarity) {
                    Some(p) => {
                        for i in 0..self.n as usize {
                            let b = stochastic_select(&p, rng.next_f32());
                            let node = cuts.cut(b as usize)[i];
                            if node != 0 {
                                sum += self.evaluate(node, s, &x, stop_inner, rng, &mut cost);
                            }
                        }
                    }
                    None => {
                        cost.mock = true;
                        for node in mock_cut(self.tree, self.n) {
                            sum += self.evaluate(node, s, &x, stop_inner, rng, &mut cost);
                        }
                    }
                }
            }
        }
        (sum, cost)
    }
}

/// The exact sum over every VPL (leaf) with a shadow ray each: `vpl-exact`'s pixel.
pub fn brute_force(tree: &Sst, vis: &dyn Visibility, s: &Shading, clamp2: f32) -> (Vec3, u64) {
    let (mut sum, mut rays) = (Vec3::ZERO, 0u64);
    // The leaves are in Morton order, so consecutive VPLs are near each other and often hidden
    // by the same triangle: on the suite's `sponza-interior` a third of the blocked rays are.
    let mut cache = ShadowCache::default();
    for leaf in &tree.nodes[tree.leaves as usize..] {
        let (v, r) = shade_point_cached(vis, s, leaf.pos, leaf.normal, leaf.error_scale, leaf.color, clamp2, &mut cache);
        sum += v;
        rays += r;
    }
    (sum, rays)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_node(suitable: bool) -> SstNode {
        SstNode {
            bb_min: Vec3::new(-0.5, 0.0, -0.5),
            bb_max: Vec3::new(0.5, 0.0, 0.5),
            color: Vec3::ONE,
            pos: Vec3::ZERO,
            normal: Vec3::Y,
            var: Vec3::new(0.1, 0.1, 0.0),
            v: 1.0,
            suitable,
            error_scale: 1.0,
        }
    }

    #[test]
    fn a_flat_cluster_stops_only_where_it_looks_small() {
        // Box diagonal √2 ≈ 1.41: a stop at ratio 0.1 needs a distance of at least 14.1.
        let at = |d: f32| Surface { pos: Vec3::new(0.0, d, 0.0), normal: -Vec3::Y };
        let node = flat_node(true);
        assert!(stops_at(&node, &at(0.2), f32::INFINITY), "the thesis' rule: every suitable node");
        assert!(!stops_at(&node, &at(14.0), 0.1));
        assert!(stops_at(&node, &at(14.2), 0.1));
        assert!(!stops_at(&flat_node(false), &at(1e6), 0.1), "an unsuitable node never stops");
    }
}

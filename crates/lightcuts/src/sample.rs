//! Sampling the SST (thesis §5.2–5.3): stochastic traversal from a start node with the child
//! probabilities of Eq. 5.4 and the stopping rule of Eq. 5.6, cluster evaluation with one exact
//! shadow ray (by one of the cluster's VPLs picked ∝ intensity, ours, or as the thesis does by a
//! point light drawn from the node's substitute Gaussian, see [`ClusterLight`]), and the
//! per-pixel estimators of the three strategies compared in §7.1:
//! - `Proposed`: blended shallow cut, traversal from each cut node, stopping at suitable nodes;
//! - `Sst` (Tatzgern et al.): n traversals from the root, stopping at suitable nodes, mean of n;
//! - `Rtslc` (Lin and Yuksel): blended shallow cut, traversal from each cut node to a leaf.
//!
//! Gaps filled (spec §6.5–6.6): every sample is divided by its traversal path probability P (as
//! SLC/RTSLC do), so with leaf stops the estimator is unbiased for the VPL sum; the point light
//! shades like a VPL: colour · cos_x · cos_y / (π · max(d², clamp²)) with the node's mean normal
//! (the VPL-side cosine of a Lambertian emitter), the same formula `vpl-exact` uses per VPL.

use crate::cut::{BlockCuts, Surface, completely_behind, mock_cut, stochastic_select, weight};
use crate::tree::{Sst, SstNode};
use crate::vpl::Similarity;
use glimpse_core::ray::offset_origin;
use glimpse_core::{Rng, Vec3};
use glimpse_render::direct::{Shading, segment, sum_unblocked};
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
    let stops = |node: u32| stop.is_some_and(|r| stops_at(&tree.nodes[node as usize], x, r));
    descend(tree, start, 1.0, rng, |n| weight(n, x, clamp2), stops)
}

/// The descent [`traverse`] and [`pick_vpl`] share: from `start`, reached with path probability
/// `p`, until a leaf or a node `stops` accepts, going left with probability w_l/(w_l+w_r) of the
/// children's `weight`s (both 0: no node). One random number per level.
fn descend(tree: &Sst, start: u32, p: f32, rng: &mut Rng, weight: impl Fn(&SstNode) -> f32, stops: impl Fn(u32) -> bool) -> Traversal {
    let (mut node, mut p, mut steps) = (start, p, 0u32);
    loop {
        if tree.is_leaf(node) || stops(node) {
            return Traversal { node: Some((node, p)), steps };
        }
        let (l, r) = (2 * node, 2 * node + 1);
        let wl = weight(&tree.nodes[l as usize]);
        let wr = weight(&tree.nodes[r as usize]);
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

/// How a traversal that stops at a cluster (an inner node) lights the shaded point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClusterLight {
    /// The thesis (§5.3, after SST): one point light at a point drawn from the cluster's
    /// substitute Gaussian, with the cluster's total colour and mean normal. Biased: on the
    /// suite's `glints` its 16-frame image is 0.4 % darker than `vpl-exact` on average (1–1.5 %
    /// on the lit wall), which is 77 % of its MSE there.
    Substitute,
    /// Ours: one of the cluster's VPLs, picked by descending its subtree with probability ∝ each
    /// child's intensity, skipping children entirely behind the shaded point's plane, shaded
    /// exactly and divided by that probability ([`pick_vpl`]). Unbiased for the cluster's sum;
    /// the descent reads two node intensities and tests 16 box corners per level, no box cosines.
    Vpl,
}

/// Below a stopped cluster `node` reached with path probability `p` (ours, [`ClusterLight::Vpl`]):
/// descend to a leaf, at each level choosing a child with probability ∝ its intensity, or 0 when
/// its box is entirely behind `x`'s plane (its VPLs cannot light `x`, so skipping it loses
/// nothing; without this test the light cuts' MSE on `thin-leaves` was 8 % above RTSLC's). In
/// front of the plane a leaf is reached with probability I_leaf / I_node. Returns the leaf, the
/// path probability including the descent, and the levels descended. `None` when no VPL of the
/// cluster with intensity is in front.
pub fn pick_vpl(tree: &Sst, node: u32, p: f32, x: &Surface, rng: &mut Rng) -> Option<(u32, f32, u32)> {
    let share = |n: &SstNode| if completely_behind(n, x) { 0.0 } else { n.intensity() };
    let t = descend(tree, node, p, rng, share, |_| false);
    t.node.map(|(leaf, p)| (leaf, p, t.steps))
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
    /// How a stopped cluster is evaluated.
    pub cluster_light: ClusterLight,
}

/// What one pixel's estimate cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelCost {
    pub rays: u64,
    /// Traversal steps (Eq. 5.4: two child weights each), the thesis' Fig. 7.2 count.
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
        let Some((mut node, mut p)) = t.node else {
            return Vec3::ZERO;
        };
        if self.cluster_light == ClusterLight::Vpl && !self.tree.is_leaf(node) {
            // The levels descended here are not counted in `cost.steps` (Fig. 7.2 counts Eq.
            // 5.4 steps; these read two intensities each).
            let Some((leaf, p_leaf, _)) = pick_vpl(self.tree, node, p, x, rng) else {
                return Vec3::ZERO;
            };
            (node, p) = (leaf, p_leaf);
        }
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
    // The leaves are in Morton order, so consecutive VPLs are near each other: their shadow
    // rays from this point go down the tree together (`sum_unblocked`).
    let lit = tree.nodes[tree.leaves as usize..].iter().filter_map(|leaf| {
        let t = vpl_term(s, leaf.pos, leaf.normal, leaf.color, clamp2);
        (t != Vec3::ZERO).then(|| {
            let (ray, t_max) = segment(s.position, s.normal, s.error_scale, offset_origin(leaf.pos, leaf.normal, leaf.error_scale));
            (t, ray, t_max)
        })
    });
    sum_unblocked(vis, lit, |&t| t)
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
    fn a_picked_vpl_has_its_share_of_the_clusters_intensity() {
        // Eight leaves of intensities 1..8 (two padding-like zeros among them), picked from the root.
        let colors = [1.0, 0.0, 3.0, 4.0, 0.0, 6.0, 7.0, 8.0];
        let mut nodes = vec![flat_node(true); 16];
        for (i, c) in colors.iter().enumerate() {
            nodes[8 + i].color = Vec3::splat(*c);
        }
        for i in (1..8).rev() {
            nodes[i].color = nodes[2 * i].color + nodes[2 * i + 1].color;
        }
        let tree = Sst { nodes, leaves: 8 };
        let total = tree.nodes[1].intensity();
        let mut rng = Rng::new(3, 0);
        let below = Surface { pos: Vec3::new(0.0, -1.0, 0.0), normal: Vec3::Y };
        let mut hits = [0u32; 8];
        let rounds = 80_000;
        for _ in 0..rounds {
            let (leaf, p, steps) = pick_vpl(&tree, 1, 0.5, &below, &mut rng).expect("the root has intensity");
            assert_eq!(steps, 3);
            let share = tree.nodes[leaf as usize].intensity() / total;
            assert!((p - 0.5 * share).abs() < 1e-6, "the path probability is the leaf's share: {p} vs {}", 0.5 * share);
            hits[leaf as usize - 8] += 1;
        }
        for (i, c) in colors.iter().enumerate() {
            let expected = c / colors.iter().sum::<f32>();
            let got = hits[i] as f32 / rounds as f32;
            assert!((got - expected).abs() < 0.005, "leaf {i}: picked {got}, expected {expected}");
        }
        let mut dark = tree.clone();
        dark.nodes.iter_mut().for_each(|n| n.color = Vec3::ZERO);
        assert_eq!(pick_vpl(&dark, 1, 1.0, &below, &mut rng), None, "a cluster without light has no VPL to pick");
        // Leaves 4..8 moved behind the receiver's plane: never picked, the others renormalized.
        let mut split = tree.clone();
        for i in [3usize, 6, 7, 12, 13, 14, 15] {
            split.nodes[i].bb_min.y = -2.0;
            split.nodes[i].bb_max.y = -1.5;
        }
        let front: f32 = colors[..4].iter().sum();
        for _ in 0..1000 {
            let (leaf, p, _) = pick_vpl(&split, 1, 1.0, &below, &mut rng).expect("leaves in front have light");
            assert!(leaf < 12, "leaf {leaf} is behind the plane");
            assert!((p - colors[leaf as usize - 8] / front).abs() < 1e-6);
        }
        let above = Surface { pos: Vec3::new(0.0, 1.0, 0.0), normal: Vec3::Y };
        assert_eq!(pick_vpl(&tree, 1, 1.0, &above, &mut rng), None, "every VPL behind the plane");
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

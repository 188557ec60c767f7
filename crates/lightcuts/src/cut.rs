//! Shallow light cuts and their stochastic blending (thesis §5.1): the expected cluster
//! contribution w of Eq. 5.5 with the bounding-box cosine of Eq. 5.2, one cut of at most n nodes
//! per k×k block split in order of highest w (§5.1.1), culling of children completely behind the
//! block-centre surface, blending of the four surrounding blocks' cuts with bilinear weights ×
//! the similarity S of Eq. 5.3 (Algorithm 1), and the mock cut (§5.1.4).
//!
//! Gaps filled (spec §6): the falloff is 1/max(d_min², clamp²) with d_min the distance to the
//! box (Lightcuts' bound; the clamp is the VPLs' own, so w > 0 wherever a VPL contributes); the
//! material term ρ/π is a constant per shading point and is left out (it cancels in Eq. 5.4 and
//! does not change one block's splitting order); cut nodes are ordered by their first leaf, so
//! index i of neighbouring cuts refers to nearby subtrees; a cut with fewer than n nodes (leaves
//! or culling) is padded with 0 (= no sample); border blocks are clamped.

use crate::tree::{Sst, SstNode};
use crate::vpl::Similarity;
use glimpse_core::Vec3;
use std::cmp::Ordering;

/// A receiver as the tree sees it: position and unit geometric normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub pos: Vec3,
    pub normal: Vec3,
}

/// Eq. 5.2's cosine term: the mean over the 8 box corners of max(0, ⟨n, (c−p)/|c−p|⟩).
pub fn box_cosine(node: &SstNode, x: &Surface) -> f32 {
    node.corners().iter().map(|c| x.normal.dot((*c - x.pos).normalize_or_zero()).max(0.0)).sum::<f32>() / 8.0
}

/// True when all 8 box corners lie on or behind the surface's plane.
pub fn completely_behind(node: &SstNode, x: &Surface) -> bool {
    node.corners().iter().all(|c| x.normal.dot(*c - x.pos) <= 0.0)
}

/// Expected contribution w (Eq. 5.5 without ρ/π, V = 1): Σ I · G_cos(5.2) / max(d_min², clamp²).
pub fn weight(node: &SstNode, x: &Surface, clamp2: f32) -> f32 {
    let i = node.intensity();
    if i <= 0.0 {
        return 0.0;
    }
    let g = box_cosine(node, x);
    if g <= 0.0 {
        return 0.0;
    }
    let nearest = x.pos.clamp(node.bb_min, node.bb_max);
    i * g / (nearest - x.pos).length_squared().max(clamp2)
}

/// The shallow light cut of one block centre (§5.1.1): start at the root, repeatedly replace the
/// node of highest w (ties: the smaller node id) by its children that are not completely behind,
/// until the cut holds `n` nodes or only leaves are left. A plain array scan (n ≈ 32). Returns the
/// nodes ordered by first leaf.
pub fn build_cut(tree: &Sst, x: &Surface, n: usize, clamp2: f32) -> Vec<u32> {
    let mut frontier: Vec<(f32, u32)> = Vec::with_capacity(n + 1);
    let mut done: Vec<u32> = Vec::new();
    if n > 0 && !completely_behind(tree.root(), x) {
        frontier.push((weight(tree.root(), x, clamp2), 1));
    }
    while frontier.len() + done.len() < n && !frontier.is_empty() {
        let best = (0..frontier.len()).max_by(|&a, &b| cmp_priority(frontier[a], frontier[b])).unwrap_or(0);
        let (_, node) = frontier.swap_remove(best);
        if tree.is_leaf(node) {
            done.push(node);
            continue;
        }
        for child in [2 * node, 2 * node + 1] {
            let c = &tree.nodes[child as usize];
            if !completely_behind(c, x) {
                frontier.push((weight(c, x, clamp2), child));
            }
        }
    }
    let mut cut: Vec<u32> = frontier.iter().map(|f| f.1).chain(done).collect();
    cut.sort_by_key(|&i| tree.leaf_range(i).0);
    cut
}

/// Priority order: higher w first, then the smaller node id.
pub fn cmp_priority(a: (f32, u32), b: (f32, u32)) -> Ordering {
    a.0.total_cmp(&b.0).then(b.1.cmp(&a.1))
}

/// The mock cut (§5.1.4): every node of level floor(log2 n) (at most the leaf level).
pub fn mock_cut(tree: &Sst, n: u32) -> std::ops::Range<u32> {
    let level = (31 - n.max(1).leading_zeros()).min(tree.levels());
    (1u32 << level)..(2u32 << level)
}

/// One cut per k×k block of a `width × height` image, flat: `n` node ids per block (0 = none).
#[derive(Clone, Debug, Default)]
pub struct BlockCuts {
    pub block: u32,
    pub n: u32,
    pub blocks_x: u32,
    pub blocks_y: u32,
    pub nodes: Vec<u32>,
    /// The block-centre surface the cut was built for (`valid` false: the block sees nothing).
    pub centre: Vec<Surface>,
    pub valid: Vec<bool>,
}

impl BlockCuts {
    pub fn cut(&self, b: usize) -> &[u32] {
        &self.nodes[b * self.n as usize..(b + 1) * self.n as usize]
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * 4 + self.centre.len() * 24 + self.valid.len()
    }

    /// Algorithm 1's lines 1–6 for pixel (px, py) with surface `x`: the four blocks whose centres
    /// surround it and p_k = bilinear × S, normalized; `None` when Σ p = 0 (mock-cut path).
    pub fn blend_weights(&self, px: u32, py: u32, x: &Surface, sim: Similarity) -> Option<[(u32, f32); 4]> {
        let k = self.block as f32;
        let half = (self.block / 2) as f32;
        let gx = (px as f32 - half) / k;
        let gy = (py as f32 - half) / k;
        let (bx0, by0) = (gx.floor(), gy.floor());
        let (tx, ty) = (gx - bx0, gy - by0);
        let clampx = |b: f32| (b.max(0.0) as u32).min(self.blocks_x - 1);
        let clampy = |b: f32| (b.max(0.0) as u32).min(self.blocks_y - 1);
        let cand = [
            (clampx(bx0), clampy(by0), (1.0 - tx) * (1.0 - ty)),
            (clampx(bx0 + 1.0), clampy(by0), tx * (1.0 - ty)),
            (clampx(bx0), clampy(by0 + 1.0), (1.0 - tx) * ty),
            (clampx(bx0 + 1.0), clampy(by0 + 1.0), tx * ty),
        ];
        let mut out = [(0u32, 0.0f32); 4];
        let mut sum = 0.0;
        for (o, (bx, by, w)) in out.iter_mut().zip(cand) {
            let b = (by * self.blocks_x + bx) as usize;
            let c = &self.centre[b];
            let s = self.valid[b] && sim.similar(x.pos, x.normal, c.pos, c.normal);
            *o = (b as u32, if s { w } else { 0.0 });
            sum += o.1;
        }
        if sum <= 0.0 {
            return None;
        }
        for o in &mut out {
            o.1 /= sum;
        }
        Some(out)
    }
}

/// Picks one of the four blocks with probability p_k (Algorithm 1, line 8).
pub fn stochastic_select(p: &[(u32, f32); 4], u: f32) -> u32 {
    let mut acc = 0.0;
    for &(b, w) in p {
        acc += w;
        if u < acc {
            return b;
        }
    }
    // Rounding: the last block with a positive weight.
    p.iter().rev().find(|e| e.1 > 0.0).map_or(p[0].0, |e| e.0)
}

//! The non-standard 2D Haar transform as a quadtree (paper Sec. 4.2 "Compression", Eq. 13), its
//! inverse, pruning by β, fp16 storage, and the coefficient dot product of Eq. 6 (the paper's
//! "convolution" ⊗, Sec. 5.2).
//!
//! Choices where the paper is silent (spec §5.5):
//! - child order c0 top-left, c1 top-right, c2 bottom-left, c3 bottom-right (implied by Eq. 13);
//! - leaf input = value / N (the orthonormal Haar basis of the unit square), so trees of different
//!   depths (BRDF against radiance maps of Table 2) multiply exactly;
//! - pruning reading (b): a discarded subtree means zero details (the cell is constant, the value
//!   its ancestors imply) — the standard nonlinear approximation whose squared L2 error is the sum
//!   of the dropped details squared; β compares |coefficient| per channel;
//! - β is relative to the root's scaling coefficient (max over channels), because the paper's
//!   absolute thresholds (0.1/0.2 for BRDFs, 1000 for radiance) depend on its unknown value scale;
//! - nodes are stored breadth-first, the four children of a node as one block of 4 (a pruned
//!   sibling inside a kept block keeps its C with zero details and no children).

use crate::half::{f16_to_f32_finite, f32_to_f16_finite};
use bytemuck::{Pod, Zeroable};
use glimpse_core::Vec3;

/// No child block.
pub const NONE: u32 = u32::MAX;

/// One quadtree node: the scaling coefficient C of its cell and the three details D0 (left −
/// right), D1 (top − bottom), D2 (diagonal) that split it into its 2×2 children, RGB, fp16.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HaarNode {
    pub c: [u16; 3],
    pub d: [[u16; 3]; 3],
    /// Index (relative to the tree's first node) of the first of 4 children, or [`NONE`].
    pub first_child: u32,
}

impl HaarNode {
    #[inline]
    pub fn c(&self) -> Vec3 {
        Vec3::new(f16_to_f32_finite(self.c[0]), f16_to_f32_finite(self.c[1]), f16_to_f32_finite(self.c[2]))
    }
    #[inline]
    pub fn d(&self, i: usize) -> Vec3 {
        let d = self.d[i];
        Vec3::new(f16_to_f32_finite(d[0]), f16_to_f32_finite(d[1]), f16_to_f32_finite(d[2]))
    }
}

/// A tree inside a flat node array: nodes `first..first + count`, root first.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct TreeRef {
    pub first: u32,
    pub count: u32,
    /// log2 N of the image it came from.
    pub levels: u32,
    /// Deepest level (root = 0) whose details are stored, + 1 (0: only the root's C).
    pub depth: u32,
}

/// Dense f64 coefficients of every level: `scaling[l]` and `details[l]` are 4^l cells (row-major
/// 2^l × 2^l), level 0 the root; the details of level l split its cells into level l+1.
#[derive(Clone, Debug)]
pub struct Pyramid {
    pub levels: u32,
    pub scaling: Vec<Vec<[f64; 3]>>,
    pub details: Vec<Vec<[[f64; 3]; 3]>>,
}

/// Forward transform (Eq. 13) of an N×N RGB image (row-major, N a power of two), with the
/// unit-square normalization (leaf input = value / N).
///
/// Panics when the image is not N×N with N a power of two: an internal invariant (every caller
/// passes a size that `WavecacheParams::read` validated).
pub fn forward(image: &[[f64; 3]], n: u32) -> Pyramid {
    assert!(n.is_power_of_two() && image.len() == (n * n) as usize, "image must be N×N with N a power of two");
    let levels = n.trailing_zeros();
    let mut scaling = vec![Vec::new(); levels as usize + 1];
    let mut details = vec![Vec::new(); levels as usize];
    scaling[levels as usize] = image.iter().map(|p| p.map(|v| v / n as f64)).collect();
    for l in (0..levels).rev() {
        let side = 1usize << l;
        let fine = &scaling[l as usize + 1];
        let (mut cs, mut ds) = (Vec::with_capacity(side * side), Vec::with_capacity(side * side));
        for y in 0..side {
            for x in 0..side {
                let at = |dx: usize, dy: usize| fine[(2 * y + dy) * 2 * side + 2 * x + dx];
                let (c0, c1, c2, c3) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
                let mut c = [0.0; 3];
                let mut d = [[0.0; 3]; 3];
                for k in 0..3 {
                    c[k] = (c0[k] + c1[k] + c2[k] + c3[k]) * 0.5;
                    d[0][k] = (c0[k] - c1[k] + c2[k] - c3[k]) * 0.5;
                    d[1][k] = (c0[k] + c1[k] - c2[k] - c3[k]) * 0.5;
                    d[2][k] = (c0[k] - c1[k] - c2[k] + c3[k]) * 0.5;
                }
                cs.push(c);
                ds.push(d);
            }
        }
        scaling[l as usize] = cs;
        details[l as usize] = ds;
    }
    Pyramid { levels, scaling, details }
}

/// Inverse transform: the N×N image (values, not divided by N) from the root scaling coefficient
/// and the details (H is its own inverse).
pub fn inverse(root: [f64; 3], details: &[Vec<[[f64; 3]; 3]>]) -> Vec<[f64; 3]> {
    let mut cur = vec![root];
    for (l, ds) in details.iter().enumerate() {
        let side = 1usize << l;
        let mut next = vec![[0.0; 3]; 4 * side * side];
        for y in 0..side {
            for x in 0..side {
                let (c, d) = (cur[y * side + x], ds[y * side + x]);
                for k in 0..3 {
                    let v = [
                        (c[k] + d[0][k] + d[1][k] + d[2][k]) * 0.5,
                        (c[k] - d[0][k] + d[1][k] - d[2][k]) * 0.5,
                        (c[k] + d[0][k] - d[1][k] - d[2][k]) * 0.5,
                        (c[k] - d[0][k] - d[1][k] + d[2][k]) * 0.5,
                    ];
                    for (q, val) in v.into_iter().enumerate() {
                        next[(2 * y + q / 2) * 2 * side + 2 * x + q % 2][k] = val;
                    }
                }
            }
        }
        cur = next;
    }
    let n = (1usize << details.len()) as f64;
    cur.into_iter().map(|p| p.map(|v| v * n)).collect()
}

/// Σ_p a_p b_p / N² by Parseval on two dense pyramids of the same size (f64): C·C + Σ D·D.
pub fn pyramid_product(a: &Pyramid, b: &Pyramid) -> [f64; 3] {
    let mut s = [0.0; 3];
    for k in 0..3 {
        s[k] = a.scaling[0][0][k] * b.scaling[0][0][k];
        for (la, lb) in a.details.iter().zip(&b.details) {
            for (da, db) in la.iter().zip(lb) {
                s[k] += da[0][k] * db[0][k] + da[1][k] * db[1][k] + da[2][k] * db[2][k];
            }
        }
    }
    s
}

/// Which cells' subtrees survive pruning: `needed[l][i]` when the details of cell i at level l
/// or of any descendant reach `beta_rel · max|C_root|` (monotone: a needed cell's ancestors are
/// needed). The packed tree stores exactly the details of needed cells.
pub fn needed(pyr: &Pyramid, beta_rel: f64) -> Vec<Vec<bool>> {
    let levels = pyr.levels as usize;
    let beta = beta_rel * pyr.scaling[0][0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut needed: Vec<Vec<bool>> = vec![Vec::new(); levels];
    for l in (0..levels).rev() {
        let side = 1usize << l;
        needed[l] = (0..side * side)
            .map(|i| {
                let own = pyr.details[l][i].iter().flatten().any(|v| v.abs() >= beta && *v != 0.0);
                let kids = l + 1 < levels && {
                    let (x, y) = (i % side, i / side);
                    (0..4).any(|q| needed[l + 1][(2 * y + q / 2) * 2 * side + 2 * x + q % 2])
                };
                own || kids
            })
            .collect();
    }
    needed
}

/// The pyramid with the details of pruned cells set to zero (reading (b)), and Σ of the dropped
/// details squared (per channel) — the squared L2 error of the reconstruction (÷ N² per pixel).
pub fn prune_pyramid(pyr: &Pyramid, beta_rel: f64) -> (Pyramid, [f64; 3]) {
    let keep = needed(pyr, beta_rel);
    let mut out = pyr.clone();
    let mut dropped = [0.0; 3];
    for (l, cells) in out.details.iter_mut().enumerate() {
        for (i, d) in cells.iter_mut().enumerate() {
            if !keep[l][i] {
                for row in d.iter() {
                    for k in 0..3 {
                        dropped[k] += row[k] * row[k];
                    }
                }
                *d = [[0.0; 3]; 3];
            }
        }
    }
    (out, dropped)
}

/// Packs `pyr` into nodes (appended to `out`), dropping every subtree whose node and descendant
/// details are all below `beta_rel · max|C_root|` in magnitude. Returns the tree's reference.
pub fn pack(pyr: &Pyramid, beta_rel: f64, out: &mut Vec<HaarNode>) -> TreeRef {
    let levels = pyr.levels as usize;
    let root_c = pyr.scaling[0][0];
    let needed = needed(pyr, beta_rel);
    let first = out.len();
    let enc = |v: [f64; 3]| v.map(|x| f32_to_f16_finite(x as f32));
    // Breadth-first: queue of (level, cell, node index).
    out.push(HaarNode { c: enc(root_c), d: [[0; 3]; 3], first_child: NONE });
    let mut queue = std::collections::VecDeque::from([(0usize, 0usize, first)]);
    let mut depth = 0u32;
    while let Some((l, i, at)) = queue.pop_front() {
        if l >= levels || !needed[l][i] {
            continue;
        }
        depth = depth.max(l as u32 + 1);
        out[at].d = pyr.details[l][i].map(enc);
        let side = 1usize << l;
        let (x, y) = (i % side, i / side);
        let kids: Vec<usize> = (0..4).map(|q| (2 * y + q / 2) * 2 * side + 2 * x + q % 2).collect();
        if l + 1 < levels && kids.iter().any(|&k| needed[l + 1][k]) {
            let block = out.len();
            out[at].first_child = (block - first) as u32;
            for (q, &k) in kids.iter().enumerate() {
                out.push(HaarNode { c: enc(pyr.scaling[l + 1][k]), d: [[0; 3]; 3], first_child: NONE });
                queue.push_back((l + 1, k, block + q));
            }
        }
    }
    TreeRef { first: first as u32, count: (out.len() - first) as u32, levels: pyr.levels, depth }
}

/// Builds and packs the tree of an N×N RGB image in one go.
pub fn build(image: &[[f64; 3]], n: u32, beta_rel: f64, out: &mut Vec<HaarNode>) -> TreeRef {
    pack(&forward(image, n), beta_rel, out)
}

/// The dot product of two trees (Eq. 6 with Eq. 13's coefficients), per RGB channel: root C·C
/// plus Σ D·D over nodes present in both, down to `layers` levels (u32::MAX: all). Trees of
/// different depths combine exactly (the shallower has zero details below its leaves).
#[inline]
pub fn product(a_nodes: &[HaarNode], a: TreeRef, b_nodes: &[HaarNode], b: TreeRef, layers: u32) -> Vec3 {
    let an = &a_nodes[a.first as usize..(a.first + a.count) as usize];
    let bn = &b_nodes[b.first as usize..(b.first + b.count) as usize];
    let mut s = an[0].c() * bn[0].c();
    // Stack of (node in a, node in b, level): at most 3 per level + 1.
    let mut stack = [(0u32, 0u32, 0u32); 64];
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let (ia, ib, l) = stack[top];
        if l >= layers {
            continue;
        }
        let (na, nb) = (&an[ia as usize], &bn[ib as usize]);
        s += na.d(0) * nb.d(0) + na.d(1) * nb.d(1) + na.d(2) * nb.d(2);
        if na.first_child != NONE && nb.first_child != NONE {
            for q in 0..4 {
                stack[top] = (na.first_child + q, nb.first_child + q, l + 1);
                top += 1;
            }
        }
    }
    s
}

/// Reconstructs the N×N image (values) a packed tree represents (tests, debugging).
pub fn reconstruct(nodes: &[HaarNode], t: TreeRef) -> Vec<[f64; 3]> {
    let levels = t.levels as usize;
    let nn = &nodes[t.first as usize..(t.first + t.count) as usize];
    let mut details: Vec<Vec<[[f64; 3]; 3]>> = (0..levels).map(|l| vec![[[0.0; 3]; 3]; 1 << (2 * l)]).collect();
    let mut stack = vec![(0usize, 0usize, 0usize)];
    while let Some((ni, l, cell)) = stack.pop() {
        if l >= levels {
            continue;
        }
        let node = &nn[ni];
        for (k, dk) in details[l][cell].iter_mut().enumerate() {
            let v = node.d(k);
            *dk = [v.x as f64, v.y as f64, v.z as f64];
        }
        if node.first_child != NONE {
            let side = 1usize << l;
            let (x, y) = (cell % side, cell / side);
            for q in 0..4 {
                stack.push((node.first_child as usize + q, l + 1, (2 * y + q / 2) * 2 * side + 2 * x + q % 2));
            }
        }
    }
    let c = nn[0].c();
    inverse([c.x as f64, c.y as f64, c.z as f64], &details)
}

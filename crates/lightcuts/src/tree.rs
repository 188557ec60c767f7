//! The Stochastic Substitute Tree (thesis §4.2, after Tatzgern et al. 2020 "SST"): 64-bit sort
//! keys (§4.2.1: Morton code of position and normal, plus the id), a bitonic sort of the keys
//! alone (Ch. 6), and a **perfect binary tree** merged bottom-up (§4.2.2, Eq. 4.1–4.3) with one
//! atomic counter per inner node, so that only the second thread to arrive merges (Ch. 6).
//!
//! Layout: the 1-based implicit heap: root = 1, children of i = 2i and 2i+1, the leaves are
//! N..2N−1 (N = VPL count, a power of two), index 0 unused. Gaps filled (spec §5):
//! - key bits: 39 bits of Morton position (13 per axis, over the VPLs' box), then the octahedral
//!   normal in the bits left over, then the id in log2(N) bits (12 for 4096): unique keys;
//! - variance Eq. 4.2 adds the children's variances unrotated, as the thesis writes it;
//! - σ_z in Eq. 5.6 is the *variance* along the normal ("the variance σ_z", §4.2), scene units²;
//! - grey intensity is Rec.709 luminance; both intensities 0 → equal weights; a vanishing
//!   summed normal falls back to the left child's normal.

use glimpse_core::sampling::octahedral_encode;
use glimpse_core::{Frame, Vec3, luminance};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// One virtual point light: a Lambertian emitter of flux `color` (W, after the importance
/// sampling weight Φ/(N p)), on a surface of unit normal `normal`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vpl {
    pub pos: Vec3,
    pub normal: Vec3,
    pub color: Vec3,
    /// The error scale of `pos` on its surface (`SurfacePoint::error_scale`): shadow rays end
    /// 10⁻⁴ of it off the surface.
    pub error_scale: f32,
}

/// A node of the SST: the cluster's box, summed colour and its plane-aligned Gaussian.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SstNode {
    pub bb_min: Vec3,
    pub bb_max: Vec3,
    /// Σ colours of the cluster's VPLs.
    pub color: Vec3,
    /// Intensity-weighted mean position (Eq. 4.1).
    pub pos: Vec3,
    /// Intensity-weighted mean normal, re-normalized.
    pub normal: Vec3,
    /// Variance in the node frame (tangent, bitangent, normal) (Eq. 4.2).
    pub var: Vec3,
    /// Normal similarity (Eq. 4.3).
    pub v: f32,
    /// Eq. 5.6 precomputed: `v ≥ v_min ∧ σ_z ≤ σ_max`; always true for leaves.
    pub suitable: bool,
    /// The largest error scale of the cluster's VPLs: the end offset of a shadow ray to a point
    /// sampled from the node (ours; a point drawn from the Gaussian has no triangle of its own).
    pub error_scale: f32,
}

impl SstNode {
    pub fn leaf(vpl: &Vpl) -> Self {
        SstNode {
            bb_min: vpl.pos,
            bb_max: vpl.pos,
            color: vpl.color,
            pos: vpl.pos,
            normal: vpl.normal,
            var: Vec3::ZERO,
            v: 1.0,
            suitable: true,
            error_scale: vpl.error_scale,
        }
    }

    pub fn intensity(&self) -> f32 {
        luminance(self.color)
    }

    /// The node's frame (tangent, bitangent, normal), Duff et al.'s basis.
    pub fn frame(&self) -> Frame {
        Frame::from_z(self.normal)
    }

    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.bb_min, self.bb_max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }
}

/// The early-termination thresholds of Eq. 5.6.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flatness {
    pub v_min: f32,
    pub sigma_max: f32,
}

impl Default for Flatness {
    fn default() -> Self {
        Self { v_min: 0.7, sigma_max: 0.3 }
    }
}

/// Merges two children into their parent (§4.2.2). Always called as (left, right), so that any
/// build order gives bit-identical nodes.
pub fn merge(a: &SstNode, b: &SstNode, flat: Flatness) -> SstNode {
    let (i1, i2) = (a.intensity(), b.intensity());
    let (w1, w2) = if i1 + i2 > 0.0 { (i1 / (i1 + i2), i2 / (i1 + i2)) } else { (0.5, 0.5) };
    let pos = a.pos * w1 + b.pos * w2;
    let n = a.normal * w1 + b.normal * w2;
    let normal = if n.length_squared() > 1e-12 { n.normalize() } else { a.normal };
    let f = Frame::from_z(normal);
    let d1 = f.to_local(a.pos - pos);
    let d2 = f.to_local(b.pos - pos);
    let var = (a.var + d1 * d1) * w1 + (b.var + d2 * d2) * w2;
    let v = a.v * b.v * a.normal.dot(b.normal).max(0.0);
    SstNode {
        bb_min: a.bb_min.min(b.bb_min),
        bb_max: a.bb_max.max(b.bb_max),
        color: a.color + b.color,
        pos,
        normal,
        var,
        v,
        suitable: v >= flat.v_min && var.z <= flat.sigma_max,
        error_scale: a.error_scale.max(b.error_scale),
    }
}

/// Spreads the low 13 bits of `x` to every third bit.
fn spread3(x: u64) -> u64 {
    let mut x = x & 0x1fff;
    x = (x | (x << 16)) & 0x0000_ff00_00ff;
    x = (x | (x << 8)) & 0x00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x0c30_c30c_30c3;
    (x | (x << 2)) & 0x2492_4924_9249
}

/// The 64-bit key of VPL `id` (of `count`, a power of two): 39 bits of Morton position over
/// `[lo, hi]`, the octahedral normal in the remaining bits above the id, the id in log2(count)
/// bits. Keys of distinct ids are distinct.
pub fn sort_key(vpl: &Vpl, id: u32, count: u32, lo: Vec3, hi: Vec3) -> u64 {
    let id_bits = count.trailing_zeros();
    let normal_bits = 25u32.saturating_sub(id_bits);
    let ext = (hi - lo).max(Vec3::splat(1e-20));
    let q = ((vpl.pos - lo) / ext).clamp(Vec3::ZERO, Vec3::ONE) * 8191.0;
    let morton = (spread3(q.x as u64) << 2) | (spread3(q.y as u64) << 1) | spread3(q.z as u64);
    let (nu, nv) = (normal_bits / 2, normal_bits - normal_bits / 2);
    let o = octahedral_encode(vpl.normal.normalize_or(Vec3::Z));
    let qu = ((o.x.clamp(0.0, 1.0) * ((1u64 << nu) - 1) as f32) as u64) << nv;
    let qv = (o.y.clamp(0.0, 1.0) * ((1u64 << nv) - 1) as f32) as u64;
    let normal = if normal_bits > 0 { qu | qv } else { 0 };
    (morton << 25) | (normal << id_bits) | id as u64
}

/// Bitonic sort (Batcher) of a power-of-two slice, each compare-exchange stage parallel over
/// pairs: O(log² n) stages, as the thesis runs it on the GPU.
pub fn bitonic_sort(keys: &mut [u64]) {
    let n = keys.len();
    assert!(n.is_power_of_two() || n <= 1, "bitonic sort needs a power-of-two length (got {n})");
    let mut k = 2;
    while k <= n {
        let mut j = k / 2;
        while j > 0 {
            // Blocks of 2j: the first half pairs with the second. Direction from bit k of the index.
            keys.par_chunks_mut(2 * j).enumerate().for_each(|(c, block)| {
                let ascending = (c * 2 * j) & k == 0;
                let (lo, hi) = block.split_at_mut(j);
                for (a, b) in lo.iter_mut().zip(hi.iter_mut()) {
                    if (*a > *b) == ascending {
                        std::mem::swap(a, b);
                    }
                }
            });
            j /= 2;
        }
        k *= 2;
    }
}

/// The VPLs sorted by key: sort (key) alone, then permute the VPLs once by the id in the low bits.
pub fn sort_vpls(vpls: &[Vpl]) -> Vec<Vpl> {
    let n = vpls.len() as u32;
    if n == 0 {
        return Vec::new();
    }
    let (lo, hi) = vpls.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), v| (a.min(v.pos), b.max(v.pos)));
    let mut keys: Vec<u64> = vpls.par_iter().enumerate().map(|(i, v)| sort_key(v, i as u32, n, lo, hi)).collect();
    bitonic_sort(&mut keys);
    let mask = (1u64 << n.trailing_zeros()) - 1;
    keys.par_iter().map(|k| vpls[(k & mask) as usize]).collect()
}

/// The perfect binary SST over sorted VPLs.
#[derive(Clone, Debug, Default)]
pub struct Sst {
    /// 2N entries; `nodes[0]` is unused, root = 1, leaves N..2N−1.
    pub nodes: Vec<SstNode>,
    /// Leaf count N (a power of two).
    pub leaves: u32,
}

impl Sst {
    pub fn root(&self) -> &SstNode {
        &self.nodes[1]
    }

    pub fn is_leaf(&self, i: u32) -> bool {
        i >= self.leaves
    }

    /// Depth of the tree (log2 N).
    pub fn levels(&self) -> u32 {
        self.leaves.trailing_zeros()
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<SstNode>()
    }

    /// The leaves below node `i`: `[first, first + count)` as VPL indices.
    pub fn leaf_range(&self, i: u32) -> (u32, u32) {
        let depth = 31 - i.leading_zeros();
        let below = self.levels() - depth;
        ((i << below) - self.leaves, 1 << below)
    }

    /// Level-by-level sequential build (the reference for the parallel one).
    pub fn build_sequential(sorted: &[Vpl], flat: Flatness) -> Sst {
        let n = sorted.len();
        assert!(n.is_power_of_two(), "the SST is a perfect binary tree: {n} VPLs is not a power of two");
        let mut nodes = vec![SstNode::default(); 2 * n];
        for (i, v) in sorted.iter().enumerate() {
            nodes[n + i] = SstNode::leaf(v);
        }
        for i in (1..n).rev() {
            nodes[i] = merge(&nodes[2 * i], &nodes[2 * i + 1], flat);
        }
        Sst { nodes, leaves: n as u32 }
    }

    /// The thesis' parallel build: one task per leaf pair merges its pair, then climbs; at each
    /// inner node an atomic counter lets only the second arrival merge (left, right) and go on.
    /// `counters` (N entries, reset here every frame) is passed in so a caller can keep it.
    pub fn build_parallel(sorted: &[Vpl], flat: Flatness, counters: &mut Vec<AtomicU32>) -> Sst {
        let n = sorted.len();
        assert!(n.is_power_of_two(), "the SST is a perfect binary tree: {n} VPLs is not a power of two");
        counters.resize_with(n, || AtomicU32::new(0));
        counters.iter().for_each(|c| c.store(0, Ordering::Relaxed));
        let mut nodes = vec![SstNode::default(); 2 * n];
        for (i, v) in sorted.iter().enumerate() {
            nodes[n + i] = SstNode::leaf(v);
        }
        if n == 1 {
            return Sst { nodes, leaves: 1 };
        }
        let shared = SharedNodes(nodes.as_mut_ptr());
        let counters: &[AtomicU32] = counters;
        (0..n / 2).into_par_iter().for_each(|pair| {
            let shared = &shared;
            let mut node = (n + 2 * pair) / 2;
            // SAFETY: each inner node is written by exactly one task (the second arrival, or the
            // pair's own task for the bottom level), and its children are read only after both
            // were written: the AcqRel counter orders the first arrival's writes before the
            // second arrival's reads. Leaves are written before the parallel loop.
            unsafe { shared.write(node, merge(&shared.read(2 * node), &shared.read(2 * node + 1), flat)) };
            while node > 1 {
                node /= 2;
                if counters[node].fetch_add(1, Ordering::AcqRel) == 0 {
                    return; // first arrival: the sibling subtree is not done yet
                }
                // SAFETY: as above.
                unsafe { shared.write(node, merge(&shared.read(2 * node), &shared.read(2 * node + 1), flat)) };
            }
        });
        Sst { nodes, leaves: n as u32 }
    }
}

struct SharedNodes(*mut SstNode);
// SAFETY: see `build_parallel`: disjoint writes, reads ordered by the atomic counters.
unsafe impl Sync for SharedNodes {}
unsafe impl Send for SharedNodes {}
impl SharedNodes {
    unsafe fn read(&self, i: usize) -> SstNode {
        unsafe { *self.0.add(i) }
    }
    unsafe fn write(&self, i: usize, v: SstNode) {
        unsafe { *self.0.add(i) = v }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_ranges_cover_the_leaves() {
        let vpls: Vec<Vpl> =
            (0..16).map(|i| Vpl { pos: Vec3::splat(i as f32), normal: Vec3::Y, color: Vec3::ONE, error_scale: 0.0 }).collect();
        let t = Sst::build_sequential(&vpls, Flatness::default());
        assert_eq!(t.leaf_range(1), (0, 16));
        assert_eq!(t.leaf_range(3), (8, 8));
        assert_eq!(t.leaf_range(31), (15, 1));
        println!("leaf ranges of 1, 3, 31: {:?} {:?} {:?}", t.leaf_range(1), t.leaf_range(3), t.leaf_range(31));
    }
}

//! A binary BVH over axis-aligned boxes, built top-down with the binned surface-area heuristic
//! (Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies"), subtrees built
//! in parallel with rayon. The same structure serves the triangle BLAS and the instance TLAS.
//!
//! Layout: a flat `Vec<BvhNode>` in depth-first order, so an interior node's left child is the
//! next node and only the right child's index is stored; leaves index a contiguous range of
//! `prim_order`. Nodes are 32 bytes of plain data, ready for a GPU buffer.
//!
//! [`Bvh4`] is the same tree collapsed to four children per node with structure-of-arrays
//! boxes: the layout the CPU traverses (see `tracer.rs`).

use glimpse_core::{Aabb, Vec3};

/// 32-byte node. `count > 0`: a leaf over `prim_order[first_or_right .. + count]`;
/// `count == 0`: interior, left child at `self + 1`, right child at `first_or_right`.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub first_or_right: u32,
    pub max: [f32; 3],
    pub count: u32,
}

impl BvhNode {
    pub fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::from(self.min), Vec3::from(self.max))
    }

    fn set_bounds(&mut self, b: Aabb) {
        self.min = b.min.to_array();
        self.max = b.max.to_array();
    }

    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Leaf ranges index this; it maps to the caller's primitive indices.
    pub prim_order: Vec<u32>,
}

/// Build parameters; the defaults are the usual ones for ray tracing triangles.
#[derive(Clone, Copy, Debug)]
pub struct BuildParams {
    pub bins: usize,
    pub max_leaf_size: usize,
    /// Cost of a traversal step relative to one primitive test.
    pub traversal_cost: f32,
}

impl Default for BuildParams {
    fn default() -> Self {
        Self { bins: 16, max_leaf_size: 4, traversal_cost: 1.0 }
    }
}

#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// Binary levels built by the SAH before object-median splits take over (see `build_recursive`).
const MAX_SAH_DEPTH: usize = 64;

/// Subtrees with fewer primitives than this are built on the current thread.
const PARALLEL_THRESHOLD: usize = 4096;

impl Bvh {
    /// Builds over primitives given by their bounds. Empty boxes (degenerate input) are kept as
    /// points at their centre so every primitive stays reachable by index.
    pub fn build(bounds: &[Aabb], params: BuildParams) -> Bvh {
        if bounds.is_empty() {
            return Bvh::default();
        }
        let mut prims: Vec<BuildPrim> = bounds
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let b = if b.is_empty() { Aabb::new(Vec3::ZERO, Vec3::ZERO) } else { *b };
                BuildPrim { bounds: b, centroid: b.center(), index: i as u32 }
            })
            .collect();
        let nodes = build_recursive(&mut prims, 0, 0, &params);
        Bvh { nodes, prim_order: prims.iter().map(|p| p.index).collect() }
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map(|n| n.bounds()).unwrap_or(Aabb::EMPTY)
    }

    /// Recomputes every node's box bottom-up from new primitive bounds (same topology): the
    /// cheap per-frame update for deforming meshes.
    pub fn refit(&mut self, bounds: &[Aabb]) {
        // Depth-first order puts children after parents, so a reverse sweep sees children first.
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            let b = if n.is_leaf() {
                let range = n.first_or_right as usize..(n.first_or_right + n.count) as usize;
                self.prim_order[range].iter().fold(Aabb::EMPTY, |acc, &p| acc.union(bounds[p as usize]))
            } else {
                self.nodes[i + 1].bounds().union(self.nodes[n.first_or_right as usize].bounds())
            };
            self.nodes[i].set_bounds(b);
        }
    }

    /// SAH cost of the tree (for comparing builds).
    pub fn sah_cost(&self, params: BuildParams) -> f32 {
        let root_area = self.bounds().half_area().max(f32::MIN_POSITIVE);
        self.nodes
            .iter()
            .map(|n| n.bounds().half_area() / root_area * if n.is_leaf() { n.count as f32 } else { params.traversal_cost })
            .sum()
    }
}

/// Children per [`Bvh4Node`].
pub const WIDTH: usize = 4;

/// A 4-wide node: its children's boxes as structure-of-arrays (`planes[axis][0][child]` holds the
/// boxes' minima along `axis`, `planes[axis][1][child]` their maxima), so that one ray is tested
/// against all four with 4-lane SIMD (the "QBVH" of Dammertz et al. 2008). Children
/// are interior nodes (`count == 0`, `child` = node index), leaves (`count > 0`, `child` = first
/// primitive in [`Bvh::prim_order`] order) or empty slots (`child == EMPTY_SLOT`, with the empty
/// box min = +∞ > max = −∞, which a slab test that takes each axis's near plane by the sign of the
/// ray's direction never enters). 128 bytes: two cache lines.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Bvh4Node {
    pub planes: [[[f32; WIDTH]; 2]; 3],
    pub child: [u32; WIDTH],
    pub count: [u32; WIDTH],
}

pub const EMPTY_SLOT: u32 = u32::MAX;

impl Bvh4Node {
    const EMPTY: Bvh4Node =
        Bvh4Node { planes: [[[f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]]; 3], child: [EMPTY_SLOT; WIDTH], count: [0; WIDTH] };

    fn set_child(&mut self, slot: usize, b: Aabb, child: u32, count: u32) {
        for axis in 0..3 {
            self.planes[axis][0][slot] = b.min[axis];
            self.planes[axis][1][slot] = b.max[axis];
        }
        self.child[slot] = child;
        self.count[slot] = count;
    }
}

/// The traversal layout of a [`Bvh`]: the binary tree collapsed into 4-wide nodes (each node
/// takes the largest-area grandchildren into its slots until it has four), so a ray visits about
/// half as many nodes and tests four boxes at a time. Leaves keep the binary tree's primitive
/// ranges; node 0 is the root. Rebuilt from the binary tree after a refit (linear time).
#[derive(Clone, Debug, Default)]
pub struct Bvh4 {
    pub nodes: Vec<Bvh4Node>,
}

impl Bvh4 {
    pub fn from_bvh2(bvh: &Bvh) -> Bvh4 {
        let mut nodes = Vec::with_capacity(bvh.nodes.len() / 2 + 1);
        if !bvh.nodes.is_empty() {
            collapse(bvh, 0, &mut nodes);
        }
        Bvh4 { nodes }
    }
}

/// Appends the 4-wide node whose children are the binary node `root` opened up to four ways;
/// returns its index.
fn collapse(bvh: &Bvh, root: usize, out: &mut Vec<Bvh4Node>) -> u32 {
    let mut kids = [0usize; WIDTH];
    let mut len = 1;
    kids[0] = root;
    // Open the interior child with the largest surface area until the node is full.
    while len < WIDTH {
        let open = (0..len)
            .filter(|&k| !bvh.nodes[kids[k]].is_leaf())
            .max_by(|&a, &b| bvh.nodes[kids[a]].bounds().half_area().total_cmp(&bvh.nodes[kids[b]].bounds().half_area()));
        let Some(k) = open else { break };
        // Its left child (the next node) takes its slot; its right child a new one.
        kids[len] = bvh.nodes[kids[k]].first_or_right as usize;
        kids[k] += 1;
        len += 1;
    }
    let index = out.len();
    out.push(Bvh4Node::EMPTY);
    for (slot, &k) in kids[..len].iter().enumerate() {
        let n = bvh.nodes[k];
        let (child, count) = if n.is_leaf() { (n.first_or_right, n.count) } else { (collapse(bvh, k, out), 0) };
        out[index].set_child(slot, n.bounds(), child, count);
    }
    index as u32
}

fn leaf(prims: &[BuildPrim], bounds: Aabb, first: usize) -> Vec<BvhNode> {
    let mut n = BvhNode { first_or_right: first as u32, count: prims.len() as u32, ..BvhNode::zeroed() };
    n.set_bounds(bounds);
    vec![n]
}

use bytemuck::Zeroable;

/// Builds the subtree over `prims`, whose first primitive has global index `first`; returns its
/// nodes with indices relative to the subtree's root.
fn build_recursive(prims: &mut [BuildPrim], first: usize, depth: usize, params: &BuildParams) -> Vec<BvhNode> {
    let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    if prims.len() <= 1 {
        return leaf(prims, bounds, first);
    }
    let centroid_bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    if depth >= MAX_SAH_DEPTH && prims.len() > params.max_leaf_size {
        // Adversarial inputs (nested or geometrically spaced boxes) can make the SAH peel off one
        // primitive per level; past this depth, object-median splits bound the tree's height
        // by MAX_SAH_DEPTH + log2(n), which keeps traversal stacks fixed-size.
        let axis = centroid_bounds.largest_axis();
        let mid = prims.len() / 2;
        prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        return join_children(prims, first, mid, depth, bounds, params);
    }
    let split = find_split(prims, centroid_bounds, params);
    let leaf_cost = prims.len() as f32;
    let mid = match split {
        Some((axis, pos, cost)) if cost < leaf_cost || prims.len() > params.max_leaf_size => {
            let mid = partition(prims, |p| p.centroid[axis] < pos);
            if mid == 0 || mid == prims.len() { prims.len() / 2 } else { mid }
        }
        // All centroids coincide: split in the middle if the leaf would be too large.
        None if prims.len() > params.max_leaf_size => prims.len() / 2,
        _ => return leaf(prims, bounds, first),
    };
    join_children(prims, first, mid, depth, bounds, params)
}

/// Builds both halves of `prims` (split at `mid`) and puts them under one interior node.
fn join_children(prims: &mut [BuildPrim], first: usize, mid: usize, depth: usize, bounds: Aabb, params: &BuildParams) -> Vec<BvhNode> {
    let (left, right) = prims.split_at_mut(mid);
    let (left_nodes, right_nodes) = if left.len() + right.len() > PARALLEL_THRESHOLD {
        rayon::join(|| build_recursive(left, first, depth + 1, params), || build_recursive(right, first + mid, depth + 1, params))
    } else {
        (build_recursive(left, first, depth + 1, params), build_recursive(right, first + mid, depth + 1, params))
    };
    let mut nodes = Vec::with_capacity(1 + left_nodes.len() + right_nodes.len());
    let right_index = 1 + left_nodes.len() as u32;
    let mut root = BvhNode { first_or_right: right_index, count: 0, ..BvhNode::zeroed() };
    root.set_bounds(bounds);
    nodes.push(root);
    let shift = |mut n: BvhNode, by: u32| {
        if !n.is_leaf() {
            n.first_or_right += by;
        }
        n
    };
    nodes.extend(left_nodes.into_iter().map(|n| shift(n, 1)));
    nodes.extend(right_nodes.into_iter().map(|n| shift(n, right_index)));
    nodes
}

/// Best binned-SAH split: (axis, centroid position, cost in primitive-test units).
fn find_split(prims: &[BuildPrim], centroid_bounds: Aabb, params: &BuildParams) -> Option<(usize, f32, f32)> {
    let nb = params.bins;
    let extent = centroid_bounds.extent();
    let parent_area = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds)).half_area().max(f32::MIN_POSITIVE);
    let mut best: Option<(usize, f32, f32)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = nb as f32 / extent[axis];
        let lo = centroid_bounds.min[axis];
        let mut bin_bounds = vec![Aabb::EMPTY; nb];
        let mut bin_count = vec![0usize; nb];
        for p in prims {
            let b = (((p.centroid[axis] - lo) * scale) as usize).min(nb - 1);
            bin_bounds[b] = bin_bounds[b].union(p.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right to get the area and count of every right side.
        let mut right_area = vec![0.0f32; nb];
        let mut right_count = vec![0usize; nb];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in (1..nb).rev() {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            right_area[i] = acc.half_area();
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in 0..nb - 1 {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = params.traversal_cost + (acc.half_area() * cnt as f32 + right_area[i + 1] * right_count[i + 1] as f32) / parent_area;
            if best.is_none_or(|b| cost < b.2) {
                best = Some((axis, lo + (i + 1) as f32 / scale, cost));
            }
        }
    }
    best
}

/// In-place partition; returns the number of elements for which `pred` holds (now first).
fn partition<T>(items: &mut [T], pred: impl Fn(&T) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Rng;

    fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rng = Rng::new(seed, 0);
        (0..n)
            .map(|_| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
                let e = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.2;
                Aabb::new(c - e, c + e)
            })
            .collect()
    }

    fn check_invariants(bvh: &Bvh, boxes: &[Aabb]) {
        let mut seen = vec![false; boxes.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = bvh.nodes[i];
            let nb = n.bounds();
            if n.is_leaf() {
                for &p in &bvh.prim_order[n.first_or_right as usize..(n.first_or_right + n.count) as usize] {
                    assert!(!seen[p as usize], "primitive {p} in two leaves");
                    seen[p as usize] = true;
                    let b = boxes[p as usize];
                    assert!(nb.contains(b.min) && nb.contains(b.max), "leaf box does not contain its primitive");
                }
            } else {
                for c in [i + 1, n.first_or_right as usize] {
                    let cb = bvh.nodes[c].bounds();
                    assert!(nb.contains(cb.min) && nb.contains(cb.max), "child box outside parent");
                    stack.push(c);
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "some primitive is in no leaf");
    }

    #[test]
    fn every_primitive_is_in_exactly_one_leaf_and_boxes_nest() {
        for n in [1, 2, 3, 7, 100, 10_000] {
            let boxes = random_boxes(n, n as u64);
            let bvh = Bvh::build(&boxes, BuildParams::default());
            check_invariants(&bvh, &boxes);
        }
    }

    #[test]
    fn the_4_wide_tree_has_the_same_leaves_and_boxes() {
        for n in [1, 2, 5, 100, 10_000] {
            let boxes = random_boxes(n, 40 + n as u64);
            let bvh = Bvh::build(&boxes, BuildParams::default());
            let wide = Bvh4::from_bvh2(&bvh);
            let bvh2_leaves: Vec<(u32, u32, Aabb)> =
                bvh.nodes.iter().filter(|n| n.is_leaf()).map(|n| (n.first_or_right, n.count, n.bounds())).collect();
            let mut wide_leaves = Vec::new();
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let node = &wide.nodes[i];
                for slot in 0..WIDTH {
                    if node.child[slot] == EMPTY_SLOT {
                        continue;
                    }
                    let p = &node.planes;
                    let b = Aabb::new(
                        Vec3::new(p[0][0][slot], p[1][0][slot], p[2][0][slot]),
                        Vec3::new(p[0][1][slot], p[1][1][slot], p[2][1][slot]),
                    );
                    if node.count[slot] > 0 {
                        wide_leaves.push((node.child[slot], node.count[slot], b));
                    } else {
                        stack.push(node.child[slot] as usize);
                    }
                }
            }
            let key = |l: &(u32, u32, Aabb)| l.0;
            let (mut a, mut b) = (bvh2_leaves, wide_leaves);
            a.sort_by_key(key);
            b.sort_by_key(key);
            assert_eq!(a, b, "{n} boxes: the wide tree's leaves differ");
            assert!(
                wide.nodes.len() <= bvh.nodes.len() / 2 + 1,
                "{n} boxes: {} wide nodes for {} binary",
                wide.nodes.len(),
                bvh.nodes.len()
            );
        }
    }

    #[test]
    fn identical_centroids_still_split() {
        let boxes = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 100];
        let bvh = Bvh::build(&boxes, BuildParams::default());
        check_invariants(&bvh, &boxes);
        assert!(bvh.nodes.iter().filter(|n| n.is_leaf()).all(|n| n.count as usize <= BuildParams::default().max_leaf_size));
    }

    #[test]
    fn refit_after_moving_matches_the_new_boxes() {
        let boxes = random_boxes(2000, 3);
        let mut bvh = Bvh::build(&boxes, BuildParams::default());
        let moved: Vec<Aabb> = boxes.iter().map(|b| Aabb::new(b.min * 1.5 + Vec3::Y, b.max * 1.5 + Vec3::Y)).collect();
        bvh.refit(&moved);
        check_invariants(&bvh, &moved);
        let full = Bvh::build(&moved, BuildParams::default());
        let p = BuildParams::default();
        println!("SAH cost: refit {:.2}, rebuilt {:.2}", bvh.sah_cost(p), full.sah_cost(p));
        assert!((bvh.bounds().min - full.bounds().min).length() < 1e-5);
    }

    #[test]
    fn nested_boxes_keep_the_tree_shallow() {
        // Each box contains the next: the SAH alone would peel them off one level at a time.
        let boxes: Vec<Aabb> = (0..3000).map(|i| Aabb::new(Vec3::ZERO, Vec3::splat(0.97f32.powi(i)))).collect();
        let bvh = Bvh::build(&boxes, BuildParams::default());
        check_invariants(&bvh, &boxes);
        fn depth(bvh: &Bvh, i: usize) -> usize {
            let n = bvh.nodes[i];
            if n.is_leaf() { 1 } else { 1 + depth(bvh, i + 1).max(depth(bvh, n.first_or_right as usize)) }
        }
        let d = depth(&bvh, 0);
        println!("depth of the BVH over 3000 nested boxes: {d}");
        assert!(d <= MAX_SAH_DEPTH + 14);
    }
}

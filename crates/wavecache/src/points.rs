//! Cache points and their octrees (paper Sec. 4.1 and 4.3, Sec. 6):
//! - Poisson-disk points per mesh by Yuksel's weighted sample elimination [21]: 5M candidates,
//!   area-proportional, W_ij = (1 − min(d_ij, 2r_max)/(2 r_max))^α with α = 8 and
//!   r_max = √(A / (2√3 M)) — Eq. 7 as printed divides by r_max, a typo against [21] (spec
//!   §5.1); neighbours are found in a uniform grid of cell 2 r_max (the paper says KD-tree: the
//!   same neighbour sets), the heap is a binary heap with lazy deletion;
//! - one octree per mesh, split uniformly while a leaf holds more than 30 points (depth guard 16);
//!   bottom-up AABBs and normalized mean normals;
//! - the query (Sec. 5.2, formula unspecified): maximize s = −|x − p|/r_max + λ (n_x · n_p), points
//!   with n_x · n_p < cos 30° only when no other exists, by branch and bound over the octree
//!   (a node is skipped when even its nearest corner and a perfect normal cannot beat the best),
//!   visiting nearer nodes first and stopping after `m` candidates (0: no cap, exact argmax).

use bytemuck::{Pod, Zeroable};
use glimpse_core::{Aabb, Rng, Vec3};
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

/// Yuksel's α.
pub const ALPHA: f32 = 8.0;
/// Candidates per output point.
pub const OVERSAMPLING: usize = 5;
/// Octree leaves split above this many points.
pub const LEAF_POINTS: usize = 30;
/// Octree depth guard (coincident points).
pub const MAX_DEPTH: u32 = 16;

/// A sampled surface point: position, geometric normal (the triangle's winding) and shading
/// normal (interpolated, on the geometric normal's side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    pub position: Vec3,
    /// The ray offset's scale ([`glimpse_core::ray::error_scale`]).
    pub error_scale: f32,
    pub normal: Vec3,
    pub shading_normal: Vec3,
}

/// A world-space triangle mesh (one instance).
pub struct WorldMesh {
    pub triangles: Vec<[Vec3; 3]>,
    /// Per-vertex shading normals per triangle (geometric when the mesh has none).
    pub normals: Vec<[Vec3; 3]>,
}

impl WorldMesh {
    pub fn area(&self) -> f32 {
        self.triangles.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).sum()
    }

    /// The solid angle (sr) of the directions its shading normals cover, on a grid of 16 × 32
    /// equal cells (0.0245 sr, about 9° across): 4π for a sphere, one cell for a plane. Each
    /// triangle's normals are interpolated over a barycentric grid fine enough to step under 4°
    /// between samples, so a coarse tessellation's smooth normals cover what they span.
    pub fn normal_coverage(&self) -> f32 {
        const BANDS: usize = 16;
        const SECTORS: usize = 32;
        let mut hit = [false; BANDS * SECTORS];
        let mut mark = |v: Vec3| {
            if !v.is_finite() || v.length_squared() <= 0.0 {
                return;
            }
            let v = v.normalize();
            // Bands uniform in z are equal in solid angle.
            let band = (((v.z + 1.0) * 0.5 * BANDS as f32) as usize).min(BANDS - 1);
            let phi = v.y.atan2(v.x) / std::f32::consts::TAU + 0.5;
            let sector = ((phi * SECTORS as f32) as usize).min(SECTORS - 1);
            hit[band * SECTORS + sector] = true;
        };
        for (t, n) in self.triangles.iter().zip(&self.normals) {
            if (t[1] - t[0]).cross(t[2] - t[0]).length_squared() <= 0.0 {
                continue;
            }
            let n = n.map(|v| v.normalize_or_zero());
            let cos = n[0].dot(n[1]).min(n[1].dot(n[2])).min(n[2].dot(n[0])).clamp(-1.0, 1.0);
            let steps = (cos.acos() / 4f32.to_radians()).ceil().clamp(1.0, 16.0) as u32;
            for i in 0..=steps {
                for j in 0..=steps - i {
                    let (a, b) = (i as f32 / steps as f32, j as f32 / steps as f32);
                    mark(n[0] * a + n[1] * b + n[2] * (1.0 - a - b));
                }
            }
        }
        hit.iter().filter(|&&h| h).count() as f32 * (4.0 * std::f32::consts::PI / (BANDS * SECTORS) as f32)
    }

    /// `count` area-proportional random points.
    pub fn sample(&self, count: usize, rng: &mut Rng) -> Vec<SurfaceSample> {
        let mut cdf = Vec::with_capacity(self.triangles.len());
        let mut acc = 0.0f64;
        for t in &self.triangles {
            acc += 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64;
            cdf.push(acc);
        }
        if acc <= 0.0 {
            return Vec::new();
        }
        (0..count)
            .map(|_| {
                let u = rng.next_f32() as f64 * acc;
                let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
                let t = self.triangles[i];
                let b = glimpse_core::sampling::uniform_triangle(rng.next_2d());
                let b0 = 1.0 - b.x - b.y;
                let position = t[0] * b0 + t[1] * b.x + t[2] * b.y;
                let error_scale = glimpse_core::ray::error_scale(&t, [b0, b.x, b.y]);
                let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Y);
                let ns = self.normals[i];
                let mut shading_normal = (ns[0] * b0 + ns[1] * b.x + ns[2] * b.y).normalize_or(normal);
                if shading_normal.dot(normal) < 0.0 {
                    shading_normal = -shading_normal;
                }
                SurfaceSample { position, error_scale, normal, shading_normal }
            })
            .collect()
    }
}

/// r_max = √(A / (2√3 M)) for M points on area A (Yuksel, 2D).
pub fn r_max(area: f32, m: usize) -> f32 {
    (area / (2.0 * 3f32.sqrt() * m.max(1) as f32)).sqrt()
}

/// Yuksel's weight of a pair at distance d: (1 − min(d, 2 r_max)/(2 r_max))^α.
pub fn weight(d: f32, r_max: f32) -> f32 {
    (1.0 - d.min(2.0 * r_max) / (2.0 * r_max)).powf(ALPHA)
}

#[derive(PartialEq)]
struct HeapItem(f32, u32);
impl Eq for HeapItem {}
impl PartialOrd for HeapItem {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for HeapItem {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

/// Weighted sample elimination of `candidates` down to `m` (indices of the survivors, sorted).
pub fn eliminate(candidates: &[Vec3], m: usize, r_max: f32) -> Vec<u32> {
    let n = candidates.len();
    if m >= n {
        return (0..n as u32).collect();
    }
    let cell = (2.0 * r_max).max(1e-12);
    let key = |p: Vec3| ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64);
    let mut grid: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::new();
    for (i, p) in candidates.iter().enumerate() {
        grid.entry(key(*p)).or_default().push(i as u32);
    }
    let neighbours = |i: usize| {
        let (kx, ky, kz) = key(candidates[i]);
        let mut out = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(v) = grid.get(&(kx + dx, ky + dy, kz + dz)) {
                        for &j in v {
                            let d = candidates[i].distance(candidates[j as usize]);
                            if j as usize != i && d < 2.0 * r_max {
                                out.push((j, d));
                            }
                        }
                    }
                }
            }
        }
        out
    };
    let adjacency: Vec<Vec<(u32, f32)>> = (0..n).map(neighbours).collect();
    let mut w: Vec<f32> = adjacency.iter().map(|a| a.iter().map(|&(_, d)| weight(d, r_max)).sum()).collect();
    let mut alive = vec![true; n];
    let mut heap: BinaryHeap<HeapItem> = w.iter().enumerate().map(|(i, &v)| HeapItem(v, i as u32)).collect();
    let mut count = n;
    while count > m {
        let Some(HeapItem(v, i)) = heap.pop() else {
            break;
        };
        let i = i as usize;
        if !alive[i] || v != w[i] {
            continue; // stale entry
        }
        alive[i] = false;
        count -= 1;
        for &(j, d) in &adjacency[i] {
            let j = j as usize;
            if alive[j] {
                w[j] -= weight(d, r_max);
                heap.push(HeapItem(w[j], j as u32));
            }
        }
    }
    (0..n as u32).filter(|&i| alive[i as usize]).collect()
}

/// M Poisson-disk points on `mesh` from 5M candidates (seeded).
pub fn poisson_points(mesh: &WorldMesh, m: usize, seed: u64) -> Vec<SurfaceSample> {
    let mut rng = Rng::new(seed, 0x5a11);
    let cand = mesh.sample(OVERSAMPLING * m, &mut rng);
    let pos: Vec<Vec3> = cand.iter().map(|c| c.position).collect();
    eliminate(&pos, m, r_max(mesh.area(), m)).into_iter().map(|i| cand[i as usize]).collect()
}

/// An octree node: bounds, normalized mean normal, children (contiguous, non-empty ones only)
/// or points (contiguous in the mesh's point order).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct OctNode {
    pub min: [f32; 3],
    pub max: [f32; 3],
    pub normal: [f32; 3],
    pub first_child: u32,
    pub child_count: u32,
    pub first_point: u32,
    pub point_count: u32,
}

/// Builds the octree over `points` (positions, normals), returning the nodes (root first) and the
/// permutation of the points (leaf order).
pub fn build_octree(positions: &[Vec3], normals: &[Vec3]) -> (Vec<OctNode>, Vec<u32>) {
    let mut nodes = vec![OctNode::default()];
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    let bounds = Aabb::from_points(positions);
    split(&mut nodes, 0, &mut order, 0, positions, bounds, 0);
    finish(&mut nodes, 0, &order, positions, normals);
    (nodes, order)
}

fn split(nodes: &mut Vec<OctNode>, at: usize, order: &mut [u32], offset: u32, pos: &[Vec3], cell: Aabb, depth: u32) {
    nodes[at].first_point = offset;
    nodes[at].point_count = order.len() as u32;
    if order.len() <= LEAF_POINTS || depth >= MAX_DEPTH {
        return;
    }
    let c = (cell.min + cell.max) * 0.5;
    let octant = |i: u32| {
        let p = pos[i as usize];
        (p.x > c.x) as usize | ((p.y > c.y) as usize) << 1 | ((p.z > c.z) as usize) << 2
    };
    order.sort_by_key(|&i| octant(i));
    let mut ranges = Vec::new();
    let mut start = 0;
    for o in 0..8 {
        let end = start + order[start..].iter().take_while(|&&i| octant(i) == o).count();
        if end > start {
            ranges.push((o, start, end));
        }
        start = end;
    }
    let first = nodes.len();
    nodes[at].first_child = first as u32;
    nodes[at].child_count = ranges.len() as u32;
    nodes.resize(first + ranges.len(), OctNode::default());
    for (k, &(o, s, e)) in ranges.iter().enumerate() {
        let pick = |bit: usize, lo: f32, mid: f32, hi: f32| if o & bit != 0 { (mid, hi) } else { (lo, mid) };
        let (x0, x1) = pick(1, cell.min.x, c.x, cell.max.x);
        let (y0, y1) = pick(2, cell.min.y, c.y, cell.max.y);
        let (z0, z1) = pick(4, cell.min.z, c.z, cell.max.z);
        let sub = Aabb { min: Vec3::new(x0, y0, z0), max: Vec3::new(x1, y1, z1) };
        split(nodes, first + k, &mut order[s..e], offset + s as u32, pos, sub, depth + 1);
    }
}

/// Bottom-up: AABB of the points / union of the children, normal sum → normalized.
fn finish(nodes: &mut [OctNode], at: usize, order: &[u32], pos: &[Vec3], normals: &[Vec3]) -> (Aabb, Vec3) {
    let n = nodes[at];
    let (mut b, mut sum) = (Aabb::EMPTY, Vec3::ZERO);
    if n.child_count == 0 {
        for &i in &order[n.first_point as usize..(n.first_point + n.point_count) as usize] {
            b = b.grow(pos[i as usize]);
            sum += normals[i as usize];
        }
    } else {
        for k in 0..n.child_count {
            let (cb, cs) = finish(nodes, (n.first_child + k) as usize, order, pos, normals);
            b = b.union(cb);
            sum += cs;
        }
    }
    nodes[at].min = b.min.to_array();
    nodes[at].max = b.max.to_array();
    nodes[at].normal = sum.normalize_or(Vec3::Z).to_array();
    (b, sum)
}

/// How a query scores points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryParams {
    /// r_max of the mesh's point cloud (distance unit).
    pub r_max: f32,
    /// λ, the normal term's weight.
    pub normal_weight: f32,
    /// cos of the normal cutoff (30°).
    pub normal_cutoff: f32,
    /// Candidates examined at most (0: all that can win).
    pub max_candidates: u32,
    /// Only points within this distance (scene units) rank by the normal cutoff first; farther
    /// ones compete on the plain score (∞: the whole mesh).
    pub search_radius: f32,
}

const PREFERRED: f32 = 1.0e4;

/// The mixed score of a point (with the bonus that ranks points inside the normal cutoff first).
pub fn score(q: &QueryParams, x: Vec3, n: Vec3, p: Vec3, np: Vec3) -> f32 {
    let c = n.dot(np);
    let d = x.distance(p);
    -d / q.r_max + q.normal_weight * c + if c >= q.normal_cutoff && d <= q.search_radius { PREFERRED } else { 0.0 }
}

/// The best score any point in `node`'s box can reach.
fn bound(q: &QueryParams, node: &OctNode, x: Vec3) -> f32 {
    let d = aabb_distance(node, x);
    -d / q.r_max + q.normal_weight.abs() + if d <= q.search_radius { PREFERRED } else { 0.0 }
}

fn aabb_distance(n: &OctNode, x: Vec3) -> f32 {
    let (lo, hi) = (Vec3::from(n.min), Vec3::from(n.max));
    (lo - x).max(x - hi).max(Vec3::ZERO).length()
}

/// Index (into the mesh's points, leaf order) of the best point for (x, n), or `None` when
/// the tree is empty. `positions`/`normals` are in leaf order.
pub fn query(nodes: &[OctNode], positions: &[Vec3], normals: &[Vec3], q: &QueryParams, x: Vec3, n: Vec3) -> Option<u32> {
    if positions.is_empty() {
        return None;
    }
    let mut best = [(f32::NEG_INFINITY, 0u32)];
    let found = best_first(nodes, q, x, &mut best, |i| Some(score(q, x, n, positions[i as usize], normals[i as usize])));
    (found > 0).then_some(best[0].1)
}

thread_local! {
    /// The nodes still to visit, best bound on top: reused by every query of a thread, so a
    /// pixel's lookup allocates nothing.
    static FRONTIER: std::cell::RefCell<BinaryHeap<HeapItem>> = const { std::cell::RefCell::new(BinaryHeap::new()) };
}

/// The octree search under [`query`] and [`query_points_best`]: branch and bound, best first.
/// The node of best [`bound`] is visited next, so the points are examined nearest box first and
/// the cap `max_candidates` keeps the nearest ones. `score(i)` is point i's score, or `None` for
/// a point the query passes over (the other side); the `best.len()` best (score, index) pairs
/// are kept, best first; returns how many were found.
///
/// Best first, not depth first (session 19): a depth-first walk finished the subtree of the
/// child with the best bound before its siblings, and that subtree's far leaves could use up
/// the 32 candidates before the sibling holding the nearest point was opened. On
/// `textured-glossy`'s back wall a pixel whose nearest point lay 0.39 r_max away read one 7
/// r_max away, so `trace_far` traced it at 16 spp: a trail of 2× speckles on a diffuse wall
/// (2.8 % of that image's pixels were traced as far; 0.1 % best first with `query_m` 128).
fn best_first(nodes: &[OctNode], q: &QueryParams, x: Vec3, best: &mut [(f32, u32)], mut score: impl FnMut(u32) -> Option<f32>) -> usize {
    if nodes.is_empty() || best.is_empty() {
        return 0;
    }
    let k = best.len();
    let mut found = 0usize;
    // The score a candidate must beat: the worst kept once the list is full.
    let floor = |best: &[(f32, u32)], found: usize| if found < k { f32::NEG_INFINITY } else { best[k - 1].0 };
    let (mut examined, mut other_side) = (0u32, 0u32);
    FRONTIER.with_borrow_mut(|frontier| {
        frontier.clear();
        frontier.push(HeapItem(bound(q, &nodes[0], x), 0));
        while let Some(HeapItem(b, at)) = frontier.pop() {
            // Every node left is bounded by this one's bound: none can do better.
            if b <= floor(best, found) {
                break;
            }
            if q.max_candidates > 0 && examined >= q.max_candidates && found > 0 {
                break;
            }
            // A surface whose side has no points near (a back face the cache was not made for):
            // give up as the cap would, rather than visit the whole mesh for every such pixel.
            if q.max_candidates > 0 && found == 0 && other_side >= OTHER_SIDE_LIMIT * q.max_candidates {
                break;
            }
            let node = &nodes[at as usize];
            if node.child_count == 0 {
                for i in node.first_point..node.first_point + node.point_count {
                    let Some(s) = score(i) else {
                        other_side += 1;
                        continue;
                    };
                    examined += 1;
                    if s > floor(best, found) {
                        // Insert in descending order, dropping the worst when full.
                        let mut j = found.min(k - 1);
                        while j > 0 && best[j - 1].0 < s {
                            best[j] = best[j - 1];
                            j -= 1;
                        }
                        best[j] = (s, i);
                        found = (found + 1).min(k);
                    }
                }
            } else {
                let f = floor(best, found);
                for c in node.first_child..node.first_child + node.child_count {
                    let bc = bound(q, &nodes[c as usize], x);
                    if bc > f {
                        frontier.push(HeapItem(bc, c));
                    }
                }
            }
        }
    });
    found
}

/// Points of the other side [`query_points`] passes over, × `max_candidates`, before it decides
/// that the query's side has none near.
pub const OTHER_SIDE_LIMIT: u32 = 64;

/// [`query`] over cache points stored in leaf order, among the points on the `side` of their
/// surface (geometric normal · `side` > 0).
///
/// Why the side is a filter inside the search (issue #13): a point on the other side of a thin
/// wall or slab caches the other hemisphere's light. Rejected after the search, such a point —
/// often the nearest when no point of the pixel's own orientation lies within `search_radius` —
/// left the pixel with no cached light at all: 316 of the 362 black-where-lit pixels of
/// `sponza-interior` at 320 × 180. Skipped during the search, the best point of the right side
/// wins.
pub fn query_points(nodes: &[OctNode], pts: &[crate::bake::CachePoint], q: &QueryParams, x: Vec3, n: Vec3, side: Vec3) -> Option<u32> {
    let mut best = [(f32::NEG_INFINITY, 0u32)];
    (query_points_best(nodes, pts, q, x, n, side, &mut best) > 0).then_some(best[0].1)
}

/// [`query_points`]'s search keeping the `best.len()` best (score, index) pairs, best first;
/// returns how many were found. The search prunes against the worst kept score, so more kept
/// points visit more of the tree (the candidate cap `max_candidates` still bounds it).
pub fn query_points_best(
    nodes: &[OctNode],
    pts: &[crate::bake::CachePoint],
    q: &QueryParams,
    x: Vec3,
    n: Vec3,
    side: Vec3,
    best: &mut [(f32, u32)],
) -> usize {
    if pts.is_empty() {
        return 0;
    }
    best_first(nodes, q, x, best, |i| {
        let p = &pts[i as usize];
        (Vec3::from(p.normal).dot(side) > 0.0).then(|| score(q, x, n, Vec3::from(p.position), Vec3::from(p.shading_normal)))
    })
}

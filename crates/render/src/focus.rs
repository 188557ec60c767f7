//! Where a shadow ray can be blocked: the part of the scene a grid-based visibility structure
//! must cover, so its cells are sized by the occluders rather than by the scene's bounds (a
//! 100 km ground under a 600 m sphere made the voxel array's cells 1.1 km wide, and the start
//! offset stepped over the sphere: its shadow vanished).
//!
//! A triangle whose plane has the whole scene on one side (a ground, a room's single-layer wall,
//! the outside of a closed box) cannot block a segment between two points of the scene: the
//! segment meets that plane at most at an end. Nor a ray toward a point light on the same side,
//! or toward a directional light the side faces. Every other triangle may block something; the
//! focus is their box. A structure built in it answers a segment from the part of it inside
//! (the part outside crosses no occluder).
//!
//! Rays in every direction (ambient occlusion, a GI bounce) do meet a supporting triangle (a ray
//! from an object down to the ground): there the focus leaves those few triangles to an exact
//! test beside the structure ([`Focus::for_all_rays`], [`Focus::split`], [`ExactTriangles`]).

use glimpse_core::{Aabb, Ray, Vec3, Vec3A};
use glimpse_scene::{LightKind, SceneFrame, WorldLight};
use glimpse_trace::bvh::{BuildParams, Bvh, BvhNode};
use glimpse_trace::triangle::PreparedRay;
use rayon::prelude::*;

/// A focus is used only when its diagonal is under this share of the scene's (cells at least 4×
/// finer): where the occluders fill much of the scene, the structure is the paper's. At 0.5,
/// `mixed-lights` (share 0.43) built its voxel array 2.4× longer for ε_s 0.8 → 0.6 %.
const WORTHWHILE: f32 = 0.25;
/// Most planes tested as supporting (those of largest area: grounds and walls are).
const CANDIDATES: usize = 64;
/// A plane with less than this share of the largest plane's area is not tested.
const SMALL: f32 = 0.01;

/// The box of the triangles that may block a shadow ray, and the supporting triangles left out.
#[derive(Clone, Debug, PartialEq)]
pub struct Focus {
    pub bounds: Aabb,
    /// Indices (sorted) of the supporting triangles: outside the focus's reckoning.
    pub supporting: Vec<usize>,
}

impl Focus {
    /// The occluders' box of a scene's world-space `triangles` (within `scene`, its bounds) for
    /// shadow rays toward `lights`, or `None` where it is not much smaller than the scene (or
    /// nothing can occlude).
    pub fn occluders(triangles: &[[Vec3; 3]], scene: Aabb, lights: &[WorldLight]) -> Option<Focus> {
        let diagonal = scene.extent().length();
        let tolerance = 1e-4 * diagonal;
        let supporting = supporting_triangles(triangles, lights, tolerance);
        let bounds = triangles
            .iter()
            .enumerate()
            .filter(|(i, _)| supporting.binary_search(i).is_err())
            .fold(Aabb::EMPTY, |b, (_, t)| b.grow(t[0]).grow(t[1]).grow(t[2]));
        (!bounds.is_empty() && bounds.extent().length() < WORTHWHILE * diagonal).then_some(Focus { bounds, supporting })
    }

    /// The focus for rays in every direction from the scene's surfaces: the triangles whose
    /// plane has the whole scene on one side, whatever the lights; a supporting triangle *can*
    /// block such a ray, so a structure built in the focus must be paired with an exact test of
    /// [`Focus::split`]'s second part.
    pub fn for_all_rays(triangles: &[[Vec3; 3]], scene: Aabb) -> Option<Focus> {
        Self::occluders(triangles, scene, &[])
    }

    /// `triangles` (those the focus was computed from) split into the ones inside the focus and
    /// the supporting ones, the latter ready to be tested exactly.
    pub fn split(&self, triangles: &[[Vec3; 3]]) -> (Vec<[Vec3; 3]>, ExactTriangles) {
        (self.inside(triangles), ExactTriangles::new(self.supporting.iter().map(|&i| triangles[i])))
    }

    /// The triangles of `triangles` (those the focus was computed from) inside the focus.
    pub fn inside<T: Copy>(&self, triangles: &[T]) -> Vec<T> {
        triangles.iter().enumerate().filter(|(i, _)| self.supporting.binary_search(i).is_err()).map(|(_, t)| *t).collect()
    }

    /// The focus's diagonal as a share of the scene's: what it did to a grid's cell.
    pub fn share_of(&self, scene: Aabb) -> f32 {
        self.bounds.extent().length() / scene.extent().length()
    }
}

/// [`Focus::for_all_rays`] of a technique's frames: computed once while the scene's geometry
/// does not move (a million triangles take about 90 ms), again every frame where it does. The
/// cached focus is kept only for the same bounds and triangle count (another scene recomputes).
#[derive(Clone, Debug, Default)]
pub struct FocusCache {
    cached: Option<((Aabb, usize), Option<Focus>)>,
}

impl FocusCache {
    /// The focus of `frame`, whose world-space triangles are `triangles`.
    pub fn for_all_rays(&mut self, frame: &SceneFrame, triangles: &[[Vec3; 3]]) -> Option<Focus> {
        if !frame.scene.geometry_is_static() {
            return Focus::for_all_rays(triangles, frame.bounds);
        }
        let key = (frame.bounds, triangles.len());
        match &self.cached {
            Some((k, focus)) if *k == key => focus.clone(),
            _ => {
                let focus = Focus::for_all_rays(triangles, frame.bounds);
                self.cached = Some((key, focus.clone()));
                focus
            }
        }
    }
}

/// The supporting triangles a focused grid leaves out, tested ray by ray with the exact
/// tracer's watertight test (both faces), which two triangles sharing an edge need so no ray
/// slips between them. Empty where no focus is used.
///
/// Most rays leave a ground upward: a plane test first (the plane's `t` against `(0, t_max)`,
/// with a margin for rounding) skips the watertight test. A ground tessellated into many
/// triangles is searched through a BVH (above [`LINEAR_MAX`] triangles).
#[derive(Clone, Debug, Default)]
pub struct ExactTriangles {
    triangles: Vec<[Vec3A; 3]>,
    /// Per triangle: its unit normal and `n · v0`.
    planes: Vec<(Vec3A, f32)>,
    bvh: Option<Bvh>,
}

/// Up to this many triangles are tested one after another.
pub const LINEAR_MAX: usize = 16;

impl ExactTriangles {
    pub fn new(triangles: impl IntoIterator<Item = [Vec3; 3]>) -> Self {
        let triangles: Vec<[Vec3A; 3]> = triangles.into_iter().map(|t| t.map(Vec3A::from)).collect();
        let planes = triangles
            .iter()
            .map(|v| {
                let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                (n, n.dot(v[0]))
            })
            .collect();
        let bvh = (triangles.len() > LINEAR_MAX).then(|| {
            let bounds: Vec<Aabb> = triangles
                .iter()
                .map(|t| {
                    let b = t.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p.into()));
                    // A ground's boxes are flat: a margin keeps the slab test's rounding inside.
                    let pad = Vec3::splat(1e-6 * b.extent().max_element() + 1e-30);
                    Aabb::new(b.min - pad, b.max + pad)
                })
                .collect();
            Bvh::build(&bounds, BuildParams::default())
        });
        Self { triangles, planes, bvh }
    }

    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// World-space vertices, for an upload.
    pub fn triangles(&self) -> &[[Vec3A; 3]] {
        &self.triangles
    }

    /// Does `origin + t·dir` (`dir` unit) meet a triangle for `0 < t < t_max`?
    #[inline]
    pub fn any_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        !self.is_empty() && self.search(origin, dir, t_max, true).is_some()
    }

    /// The nearest `t` in `(0, t_max)` at which `origin + t·dir` meets a triangle.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        if self.is_empty() { None } else { self.search(origin, dir, t_max, false) }
    }

    /// The nearest hit in `(0, t_max)`, or with `any` the first found.
    fn search(&self, origin: Vec3, dir: Vec3, t_max: f32, any: bool) -> Option<f32> {
        let (o, d) = (Vec3A::from(origin), Vec3A::from(dir));
        let mut ray: Option<PreparedRay> = None;
        let mut best: Option<f32> = None;
        let mut test = |i: usize, best: &mut Option<f32>| {
            let limit = best.unwrap_or(t_max);
            let (n, offset) = self.planes[i];
            let t = (offset - n.dot(o)) / n.dot(d); // ±∞ or NaN where parallel: no hit
            let margin = 1e-3 * t.abs() + 1e-6 * o.abs().max_element();
            if t >= -margin && t <= limit + margin {
                let ray = ray.get_or_insert_with(|| PreparedRay::new(&Ray::new(origin, dir)));
                *best = ray.intersect_triangle(&self.triangles[i], limit).map(|h| h.0).or(*best);
            }
        };
        let Some(bvh) = &self.bvh else {
            for i in 0..self.triangles.len() {
                test(i, &mut best);
                if any && best.is_some() {
                    break;
                }
            }
            return best;
        };
        let inv_dir = Vec3::ONE / Vec3::select(dir.abs().cmpgt(Vec3::splat(1e-30)), dir, Vec3::splat(1e-30).copysign(dir));
        // A fixed stack, no allocation per ray: the traversal holds at most one pending node
        // per level, and the build's depth is at most 64 SAH levels plus log2 of the count.
        let (mut stack, mut top) = ([0usize; 128], 1);
        while top > 0 {
            top -= 1;
            let node = stack[top];
            let n = &bvh.nodes[node];
            if n.bounds().intersect(origin, inv_dir, 0.0, best.unwrap_or(t_max)).is_none() {
                continue;
            }
            if n.is_leaf() {
                let first = n.first_or_right as usize;
                for &p in &bvh.prim_order[first..first + n.count as usize] {
                    test(p as usize, &mut best);
                    if any && best.is_some() {
                        return best;
                    }
                }
            } else {
                (stack[top], stack[top + 1]) = (n.first_or_right as usize, node + 1);
                top += 2;
            }
        }
        best
    }

    pub fn memory_bytes(&self) -> usize {
        let bvh = self.bvh.as_ref().map_or(0, |b| b.nodes.len() * std::mem::size_of::<BvhNode>() + b.prim_order.len() * 4);
        self.triangles.len() * std::mem::size_of::<[Vec3A; 3]>() + self.planes.len() * std::mem::size_of::<(Vec3A, f32)>() + bvh
    }
}

impl PartialEq for ExactTriangles {
    fn eq(&self, other: &Self) -> bool {
        self.triangles == other.triangles
    }
}

/// The indices (sorted) of the triangles on large planes that have every vertex of the scene,
/// every point and spot light on one side (within `tolerance`) and face every directional light.
///
/// Triangles are grouped by plane (a ground tessellated into thousands of triangles is one
/// plane) and the planes of largest total area are tested, each once.
fn supporting_triangles(triangles: &[[Vec3; 3]], lights: &[WorldLight], tolerance: f32) -> Vec<usize> {
    let (planes, order) = largest_planes(triangles, tolerance);
    let candidates: Vec<&Plane> = planes.iter().collect();
    // Each supporting candidate reads every vertex: the candidates run in parallel.
    let supporting: Vec<&Plane> = candidates
        .into_par_iter()
        .filter(|plane| {
            let (n, d) = (plane.normal, plane.offset);
            // The side the scene lies on: +1 or −1 (0 while every point seen is on the plane).
            let mut side = 0.0f32;
            let mut one_side = |p: Vec3| {
                let distance = n.dot(p) - d;
                if distance.abs() <= tolerance {
                    return true;
                }
                if side == 0.0 {
                    side = distance.signum();
                }
                distance.signum() == side
            };
            let points = triangles.iter().flatten().all(|&p| one_side(p));
            let point_lights = lights.iter().filter(|l| l.kind != LightKind::Directional).all(|l| one_side(l.position));
            // A directional light's rays leave toward −direction: not through the plane's far side.
            let suns = lights.iter().filter(|l| l.kind == LightKind::Directional).all(|l| side * n.dot(-l.direction) >= 0.0);
            points && point_lights && suns
        })
        .collect();
    let mut out: Vec<usize> = supporting.iter().flat_map(|p| order[p.triangles.clone()].iter().map(|&i| i as usize)).collect();
    out.sort_unstable();
    out
}

/// Coplanar triangles: the plane `normal · p = offset` (the normal's sign made canonical).
struct Plane {
    normal: Vec3,
    offset: f32,
    /// Its triangles' indices: this range of [`largest_planes`]'s second result.
    triangles: std::ops::Range<usize>,
}

/// The [`CANDIDATES`] planes of `triangles` of largest total area (down to [`SMALL`] of the
/// largest's), largest first. Planes are keyed by their normal to 1e-4 and their offset to
/// `tolerance` (exactly, in a 128-bit key, so no two planes merge); a plane split across two keys
/// by rounding is two planes, each tested on its own (the same answer). Keys are made in
/// parallel and sorted.
fn largest_planes(triangles: &[[Vec3; 3]], tolerance: f32) -> (Vec<Plane>, Vec<u32>) {
    let plane_of = |t: &[Vec3; 3]| {
        let cross = (t[1] - t[0]).cross(t[2] - t[0]);
        let mut n = cross.try_normalize()?;
        // One orientation per plane: the first non-zero component positive.
        let first = if n.x != 0.0 {
            n.x
        } else if n.y != 0.0 {
            n.y
        } else {
            n.z
        };
        if first < 0.0 {
            n = -n;
        }
        Some((n, n.dot(t[0]), 0.5 * cross.length()))
    };
    let quantized = |v: f32| (v * 1e4).round() as i64 as u128 & 0xffff;
    let mut keyed: Vec<(u128, u32, f32)> = triangles
        .par_iter()
        .enumerate()
        .filter_map(|(i, t)| {
            let (n, offset, area) = plane_of(t)?;
            let d = (offset / tolerance.max(f32::MIN_POSITIVE)).round() as i64 as u64 as u128;
            Some((quantized(n.x) | quantized(n.y) << 16 | quantized(n.z) << 32 | d << 64, i as u32, area))
        })
        .collect();
    keyed.par_sort_unstable_by_key(|k| (k.0, k.1));
    // Runs of equal keys are planes: (start, end, area).
    let mut start = 0;
    let runs: Vec<(usize, usize, f32)> = keyed
        .chunk_by(|a, b| a.0 == b.0)
        .map(|run| {
            start += run.len();
            (start - run.len(), start, run.iter().map(|k| k.2).sum::<f32>())
        })
        .collect();
    let largest = runs.iter().map(|r| r.2).fold(0.0f32, f32::max);
    let mut large: Vec<&(usize, usize, f32)> = runs.iter().filter(|r| r.2 >= SMALL * largest).collect();
    large.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)));
    let planes = large
        .into_iter()
        .take(CANDIDATES)
        .map(|&(start, end, _)| {
            let (normal, offset, _) = plane_of(&triangles[keyed[start].1 as usize]).unwrap_or_default();
            Plane { normal, offset, triangles: start..end }
        })
        .collect();
    (planes, keyed.into_iter().map(|k| k.1).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(y: f32, half: f32) -> [[Vec3; 3]; 2] {
        let (a, b, c, d) = (Vec3::new(-half, y, -half), Vec3::new(half, y, -half), Vec3::new(half, y, half), Vec3::new(-half, y, half));
        [[a, c, b], [a, d, c]]
    }

    #[test]
    fn a_ground_under_everything_supports_and_a_shelf_between_does_not() {
        let mut tris: Vec<[Vec3; 3]> = quad(0.0, 100.0).to_vec();
        tris.extend(quad(2.0, 1.0)); // a shelf: points above and below it
        tris.push([Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.5, 3.0, 0.0), Vec3::new(0.0, 3.5, 0.0)]);
        let sun = |dir: Vec3| WorldLight { kind: LightKind::Directional, intensity: Vec3::ONE, position: Vec3::ZERO, direction: dir };
        assert_eq!(supporting_triangles(&tris, &[sun(Vec3::new(0.3, -1.0, 0.0).normalize())], 1e-3), [0, 1]);
        // A sun under the horizon: the ground blocks it.
        assert!(supporting_triangles(&tris, &[sun(Vec3::new(0.3, 1.0, 0.0).normalize())], 1e-3).is_empty());
        // A point light under the ground: likewise.
        let under = WorldLight { kind: LightKind::Point, intensity: Vec3::ONE, position: Vec3::new(0.0, -1.0, 0.0), direction: Vec3::Y };
        assert!(supporting_triangles(&tris, &[under], 1e-3).is_empty());
    }

    #[test]
    fn for_every_ray_the_ground_is_split_off_and_hit_exactly() {
        let mut tris: Vec<[Vec3; 3]> = quad(0.0, 100.0).to_vec();
        tris.extend(quad(1.0, 1.0)); // a small table top: the focus
        tris.push([Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.0, 0.5, 0.5)]);
        let scene = tris.iter().flatten().fold(Aabb::EMPTY, |b, &p| b.grow(p));
        let focus = Focus::for_all_rays(&tris, scene).expect("the table is far smaller than the ground");
        assert_eq!(focus.supporting, [0, 1]);
        let (inside, exact) = focus.split(&tris);
        assert_eq!((inside.len(), exact.len()), (3, 2));
        assert!(focus.share_of(scene) < 0.02);
        // Straight down from 2 m at x = 50: the ground at t = 2, both faces, not beyond t_max.
        let p = Vec3::new(50.0, 2.0, 3.0);
        assert_eq!(exact.closest_hit(p, -Vec3::Y, f32::INFINITY), Some(2.0));
        assert!(exact.any_hit(p, -Vec3::Y, 2.5) && !exact.any_hit(p, -Vec3::Y, 1.5));
        assert!(exact.any_hit(Vec3::new(50.0, -2.0, 3.0), Vec3::Y, 3.0), "from below: two-sided");
        assert!(!exact.any_hit(p, Vec3::Y, f32::INFINITY) && ExactTriangles::default().closest_hit(p, -Vec3::Y, 9.0).is_none());
    }

    #[test]
    fn the_cache_keeps_a_focus_for_its_own_scene_only() {
        use glimpse_scene::{Material, Mesh, Scene};
        let mut ground = Scene { name: "ground".into(), ..Default::default() };
        let m = ground.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
        let q = |y: f32, h: f32| [Vec3::new(-h, y, -h), Vec3::new(h, y, -h), Vec3::new(h, y, h), Vec3::new(-h, y, h)];
        ground.add_mesh(Mesh::quad("floor", m, q(0.0, 100.0)), glimpse_core::Mat4::IDENTITY);
        ground.add_mesh(Mesh::quad("shelf", m, q(1.0, 0.5)), glimpse_core::Mat4::IDENTITY);
        let room = glimpse_scene::load("cornell").unwrap();
        let mut cache = FocusCache::default();
        let (a, b) = (ground.at(0.0), room.at(0.0));
        assert!(cache.for_all_rays(&a, &a.world_triangles()).is_some(), "the shelf over a large floor is a focus");
        assert!(cache.for_all_rays(&a, &a.world_triangles()).is_some(), "kept");
        assert!(cache.for_all_rays(&b, &b.world_triangles()).is_none(), "another scene is not handed the first one's focus");
    }

    #[test]
    fn a_tessellated_ground_is_one_plane_and_its_bvh_answers_as_every_triangle() {
        // A 100 m ground of 40 × 40 quads (3,200 triangles, each under 0.1 % of the ground) and
        // a small box's top: the ground is one plane, found although no triangle of it is large.
        let mut tris: Vec<[Vec3; 3]> = Vec::new();
        let cell = 100.0 / 40.0;
        for i in 0..40 {
            for j in 0..40 {
                let (x, z) = (-50.0 + i as f32 * cell, -50.0 + j as f32 * cell);
                let (a, b, c, d) =
                    (Vec3::new(x, 0.0, z), Vec3::new(x + cell, 0.0, z), Vec3::new(x + cell, 0.0, z + cell), Vec3::new(x, 0.0, z + cell));
                tris.extend([[a, c, b], [a, d, c]]);
            }
        }
        tris.extend(quad(1.0, 1.0));
        let scene = tris.iter().flatten().fold(Aabb::EMPTY, |b, &p| b.grow(p));
        let focus = Focus::for_all_rays(&tris, scene).expect("the box top is far smaller than the ground");
        assert_eq!(focus.supporting.len(), 3200);
        let (_, exact) = focus.split(&tris);
        let brute = |o: Vec3, d: Vec3| {
            let r = PreparedRay::new(&Ray::new(o, d));
            tris[..3200].iter().filter_map(|t| r.intersect_triangle(&t.map(Vec3A::from), f32::INFINITY)).map(|h| h.0).reduce(f32::min)
        };
        let mut rng = glimpse_core::Rng::new(5, 0);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.next_f32() * 120.0 - 60.0, rng.next_f32() * 4.0 - 0.5, rng.next_f32() * 120.0 - 60.0);
            let d = glimpse_core::sampling::uniform_sphere(rng.next_2d());
            let (want, got) = (brute(o, d), exact.closest_hit(o, d, f32::INFINITY));
            assert_eq!(want, got, "{o:?} {d:?}");
            assert_eq!(want.is_some(), exact.any_hit(o, d, f32::INFINITY));
            hits += usize::from(want.is_some());
        }
        assert!(hits > 500, "{hits} of 2000 rays meet the ground");
    }
}

//! The exact tracer: a two-level BVH over the scene at time t.
//!
//! Static geometry (instances that never move, meshes that never deform) is flattened into one
//! world-space BLAS, which traces fastest. Each moving instance references its mesh's
//! object-space BLAS through its own transform; deforming meshes get a BLAS refitted every frame.
//! The TLAS over these entries is rebuilt per frame (it has one leaf per moving instance plus one
//! for the static world, so that costs microseconds).

use crate::bvh::{BuildParams, Bvh, Bvh4, Bvh4Node, WIDTH};
use crate::packet::PacketRays;
use crate::triangle::PreparedRay;
use glimpse_core::glam::Affine3A;
use glimpse_core::{Aabb, Ray, Vec3, Vec3A, Vec4};
use glimpse_scene::{Cutouts, SceneFrame};
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::sync::Arc;

/// A ray's closest intersection: the parameter `t` along the ray, barycentrics of vertices 1
/// and 2, and which instance and triangle (index into the mesh's `indices`) were hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub instance: u32,
    pub triangle: u32,
}

/// Marks a primitive of a per-mesh BLAS, whose instance comes from the TLAS entry.
const FROM_ENTRY: u32 = u32::MAX;

#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct PrimId {
    pub instance: u32,
    pub triangle: u32,
}

/// Triangles in BVH leaf order, so a leaf's range indexes `triangles` directly. `bvh` is the
/// binary tree (built, refitted, GPU layout); `wide` is its 4-wide form that the CPU traverses.
#[derive(Clone, Debug, Default)]
pub struct Blas {
    pub bvh: Bvh,
    pub wide: Bvh4,
    pub triangles: Vec<[Vec3A; 3]>,
    pub ids: Vec<PrimId>,
}

impl Blas {
    pub fn build(triangles: Vec<[Vec3A; 3]>, ids: Vec<PrimId>) -> Blas {
        let bounds: Vec<Aabb> = triangles.iter().map(triangle_bounds).collect();
        let bvh = Bvh::build(&bounds, BuildParams::default());
        let triangles = bvh.prim_order.iter().map(|&i| triangles[i as usize]).collect();
        let ids = bvh.prim_order.iter().map(|&i| ids[i as usize]).collect();
        Blas { wide: Bvh4::from_bvh2(&bvh), bvh, triangles, ids }
    }

    /// New vertex positions for the same triangles (given in the original order): refit.
    pub fn refit(&mut self, triangles: &[[Vec3A; 3]]) {
        let bounds: Vec<Aabb> = triangles.iter().map(triangle_bounds).collect();
        self.bvh.refit(&bounds);
        self.wide = Bvh4::from_bvh2(&self.bvh);
        for (slot, &i) in self.bvh.prim_order.iter().enumerate() {
            self.triangles[slot] = triangles[i as usize];
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.bvh.nodes.len() * 32
            + self.wide.nodes.len() * size_of::<Bvh4Node>()
            + self.bvh.prim_order.len() * 4
            + self.triangles.len() * 48
            + self.ids.len() * 8
    }
}

fn triangle_bounds(t: &[Vec3A; 3]) -> Aabb {
    let [a, b, c] = t.map(Vec3::from);
    Aabb::new(a.min(b).min(c), a.max(b).max(c))
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    blas: u32,
    instance: u32,
    world_to_object: Affine3A,
    identity: bool,
}

/// The exact BVH for one frame of a scene.
#[derive(Clone, Debug, Default)]
pub struct ExactTracer {
    blases: Vec<Blas>,
    entries: Vec<Entry>,
    tlas: Bvh,
    tlas_wide: Bvh4,
    /// Per mesh: its object-space BLAS, when some instance of it moves or it deforms.
    mesh_blas: Vec<Option<u32>>,
    /// The alpha-masked instances' coverage; `None` in a scene without masks (no cost there).
    /// A triangle hit in a hole is not a hit, for closest and any-hit queries alike (pbrt's and
    /// Mitsuba's alpha test), so every reference sees through a leaf's cut-out texels.
    cutouts: Option<Arc<Cutouts>>,
}

impl ExactTracer {
    pub fn build(frame: &SceneFrame) -> ExactTracer {
        let scene = frame.scene;
        let dynamic_instance = |i: usize| {
            let inst = &scene.instances[i];
            !inst.motion.is_static() || scene.meshes[inst.mesh as usize].deformation.is_some()
        };
        // The static world, in world space.
        let (mut tris, mut ids) = (Vec::new(), Vec::new());
        for (ii, inst) in scene.instances.iter().enumerate() {
            if dynamic_instance(ii) {
                continue;
            }
            let m = frame.transforms[ii];
            let pos = &frame.positions[inst.mesh as usize];
            for (ti, t) in scene.meshes[inst.mesh as usize].indices.iter().enumerate() {
                tris.push(t.map(|i| Vec3A::from(m.transform_point3(pos[i as usize]))));
                ids.push(PrimId { instance: ii as u32, triangle: ti as u32 });
            }
        }
        let mut blases = Vec::new();
        if !tris.is_empty() {
            blases.push(Blas::build(tris, ids));
        }
        // One object-space BLAS per mesh used by a moving instance or deforming.
        let mut mesh_blas = vec![None; scene.meshes.len()];
        for ii in (0..scene.instances.len()).filter(|&i| dynamic_instance(i)) {
            let mesh = scene.instances[ii].mesh as usize;
            if mesh_blas[mesh].is_none() {
                mesh_blas[mesh] = Some(blases.len() as u32);
                let (tris, ids) = object_triangles(frame, mesh);
                blases.push(Blas::build(tris, ids));
            }
        }
        let cutouts = Cutouts::new(scene).map(Arc::new);
        let mut tracer = ExactTracer { blases, entries: Vec::new(), tlas: Bvh::default(), tlas_wide: Bvh4::default(), mesh_blas, cutouts };
        tracer.rebuild_tlas(frame);
        tracer
    }

    /// Moves to another time of the same scene: refits deforming meshes and rebuilds the TLAS.
    pub fn update(&mut self, frame: &SceneFrame) {
        for (mesh, blas) in self.mesh_blas.iter().enumerate() {
            if let (Some(b), Some(_)) = (blas, &frame.scene.meshes[mesh].deformation) {
                let (tris, _) = object_triangles(frame, mesh);
                self.blases[*b as usize].refit(&tris);
            }
        }
        self.rebuild_tlas(frame);
    }

    fn rebuild_tlas(&mut self, frame: &SceneFrame) {
        let scene = frame.scene;
        self.entries.clear();
        let has_static = self.blases.first().is_some_and(|b| b.ids.first().is_some_and(|id| id.instance != FROM_ENTRY));
        if has_static {
            self.entries.push(Entry { blas: 0, instance: FROM_ENTRY, world_to_object: Affine3A::IDENTITY, identity: true });
        }
        for (ii, inst) in scene.instances.iter().enumerate() {
            if let Some(b) = self.mesh_blas[inst.mesh as usize] {
                let is_dynamic = !inst.motion.is_static() || scene.meshes[inst.mesh as usize].deformation.is_some();
                if is_dynamic {
                    let m = Affine3A::from_mat4(frame.transforms[ii]);
                    self.entries.push(Entry { blas: b, instance: ii as u32, world_to_object: m.inverse(), identity: false });
                }
            }
        }
        let bounds: Vec<Aabb> = self
            .entries
            .iter()
            .map(|e| {
                let b = self.blases[e.blas as usize].bvh.bounds();
                if e.identity { b } else { b.transform(&glimpse_core::Mat4::from(e.world_to_object.inverse())) }
            })
            .collect();
        self.tlas = Bvh::build(&bounds, BuildParams { max_leaf_size: 1, ..Default::default() });
        self.tlas_wide = Bvh4::from_bvh2(&self.tlas);
        // Leaf ranges index entries directly, as they index triangles in a BLAS.
        self.entries = self.tlas.prim_order.iter().map(|&i| self.entries[i as usize]).collect();
    }

    pub fn bounds(&self) -> Aabb {
        self.tlas.bounds()
    }

    pub fn triangle_count(&self) -> usize {
        self.blases.iter().map(|b| b.triangles.len()).sum()
    }

    pub fn memory_bytes(&self) -> usize {
        self.blases.iter().map(Blas::memory_bytes).sum::<usize>()
            + self.tlas.nodes.len() * 32
            + self.tlas_wide.nodes.len() * size_of::<Bvh4Node>()
            + self.entries.len() * 64
    }

    /// Is anything hit at `0 < t < t_max`?
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.trace::<true>(ray, t_max).is_some()
    }

    /// [`occluded`](Self::occluded), testing first the triangle that blocked the previous ray
    /// given the same `cache` (a shadow cache, Haines & Greenberg 1986): rays from one point
    /// to a cluster of lights are often blocked by one triangle. The answer is `occluded`'s:
    /// a remembered triangle counts only where the ray hits it inside `(0, t_max)`, and the
    /// traversal's conservative boxes would have reached it too.
    pub fn occluded_cached(&self, ray: &Ray, t_max: f32, cache: &mut ShadowCache) -> bool {
        let world = PreparedRay::new(ray);
        if let Some(blocker) = cache.0
            && self.blocks(blocker, ray, &world, t_max)
        {
            return true;
        }
        let found = self.trace_prepared::<true>(ray, &world, t_max);
        cache.0 = found.map(|f| f.blocker);
        found.is_some()
    }

    /// [`occluded`](Self::occluded) for a batch of rays, `out[i]` for `rays[i]`. Rays that share
    /// an origin and point nearly the same way (one point's rays to neighbouring lights) enter
    /// mostly the same nodes: in a static scene (one world-space BLAS) they go down the tree
    /// together, [`PACKET`] at a time, each node fetched once for all the rays that enter it.
    /// Each ray's box tests and triangle tests are its own traversal's, so each answer is
    /// `occluded`'s.
    pub fn occluded_many(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "one answer per ray");
        let Some((blas, _)) = self.static_world() else {
            for ((ray, t_max), o) in rays.iter().zip(out) {
                *o = self.occluded(ray, *t_max);
            }
            return;
        };
        // The triangle that blocked a ray of the previous packet is tried first (the shadow
        // cache of `occluded_cached`: neighbouring lights are often hidden by one triangle).
        let mut blocker = None;
        for (rays, out) in rays.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            // A few rays: a small packet, whose set-up costs no more than the rays.
            blocker = match rays.len() {
                1 => {
                    out[0] = self.occluded(&rays[0].0, rays[0].1);
                    blocker
                }
                2..=8 => occluded_packet::<8>(blas, self.cutouts.as_deref(), rays, out, blocker),
                _ => occluded_packet::<PACKET>(blas, self.cutouts.as_deref(), rays, out, blocker),
            };
        }
    }

    /// A static scene's one world-space BLAS and the instance its [`FROM_ENTRY`] ids belong to:
    /// what the packets traverse (rays through a TLAS of moving instances go one by one).
    fn static_world(&self) -> Option<(&Blas, u32)> {
        match &self.entries[..] {
            [e] if e.identity => Some((&self.blases[e.blas as usize], e.instance)),
            _ => None,
        }
    }

    /// [`closest_hit`](Self::closest_hit) for a batch of rays, `out[i]` for `rays[i]`: in a
    /// static scene, [`PACKET`] at a time down the tree together, as [`Self::occluded_many`]
    /// traces shadow rays. Meant for coherent rays (a light's shadow-map texels, a tile of
    /// pixels). Each ray finds the hit `closest_hit` finds, at the same `t` with the same
    /// barycentrics, except at ties: two triangles hit at the same `t`, or within one rounding
    /// of it (at a shared vertex: the triangle test compares t·det with t_max·det, so the first
    /// hit found can hide the other), where the first visited wins in both and the packet
    /// visits the tree in another order (on `scenes/extra/sponza-night`, 1 of 786,432 RSM-like
    /// rays: t 6.9 against 6.8999996, a ray straight down through a vertex).
    pub fn closest_hits(&self, rays: &[(Ray, f32)], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "one answer per ray");
        let Some((blas, instance)) = self.static_world() else {
            for ((ray, t_max), o) in rays.iter().zip(out) {
                *o = self.closest_hit(ray, *t_max);
            }
            return;
        };
        for (rays, out) in rays.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            match rays.len() {
                1 => out[0] = self.closest_hit(&rays[0].0, rays[0].1),
                2..=8 => closest_packet::<8>(blas, instance, self.cutouts.as_deref(), rays, out),
                _ => closest_packet::<PACKET>(blas, instance, self.cutouts.as_deref(), rays, out),
            }
        }
    }

    /// Per pixel of a `width` × `height` image, its ray (`ray(i)` for pixel `i` in row-major
    /// order, if it has one) and the ray's closest hit, traced [`TILE`] × [`TILE`] pixels at a
    /// time with [`Self::closest_hits`] (a tile's camera or shadow-map rays leave one point
    /// nearly together), the tiles in parallel.
    pub fn closest_hits_tiled(
        &self,
        width: u32,
        height: u32,
        ray: impl Fn(usize) -> Option<Ray> + Sync,
    ) -> Vec<Option<(Ray, Option<Hit>)>> {
        let mut out = vec![None; (width * height) as usize];
        // Bands of TILE rows are contiguous in `out`: each is written in place by its thread.
        out.par_chunks_mut((width * TILE) as usize).enumerate().for_each(|(band, rows)| {
            let y0 = band as u32 * TILE;
            let (mut index, mut rays, mut hits) = (Vec::new(), Vec::new(), Vec::new());
            for x0 in (0..width).step_by(TILE as usize) {
                index.clear();
                rays.clear();
                for y in y0..(y0 + TILE).min(height) {
                    for x in x0..(x0 + TILE).min(width) {
                        let i = (y * width + x) as usize;
                        if let Some(r) = ray(i) {
                            index.push(i - (y0 * width) as usize);
                            rays.push((r, f32::INFINITY));
                        }
                    }
                }
                hits.clear();
                hits.resize(rays.len(), None);
                self.closest_hits(&rays, &mut hits);
                for ((&k, &(r, _)), &h) in index.iter().zip(&rays).zip(&hits) {
                    rows[k] = Some((r, h));
                }
            }
        });
        out
    }

    /// The closest hit at `0 < t < t_max`.
    pub fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.trace::<false>(ray, t_max).map(|f| f.hit)
    }

    /// Does the remembered triangle intersect `ray` at `0 < t < t_max`?
    fn blocks(&self, b: Blocker, ray: &Ray, world: &PreparedRay, t_max: f32) -> bool {
        let Some(e) = self.entries.get(b.entry as usize) else { return false };
        let blas = &self.blases[e.blas as usize];
        let Some(triangle) = blas.triangles.get(b.slot as usize) else { return false };
        let local = self.local_ray(e, ray, world);
        let hit = match local.major_axis() {
            0 => local.intersect_along::<0>(triangle, t_max),
            1 => local.intersect_along::<1>(triangle, t_max),
            _ => local.intersect_along::<2>(triangle, t_max),
        };
        let Some((_, b1, b2)) = hit else { return false };
        let id = blas.ids[b.slot as usize];
        let instance = if id.instance == FROM_ENTRY { e.instance } else { id.instance };
        !self.cutouts.as_ref().is_some_and(|c| c.hole(instance, id.triangle, b1, b2))
    }

    fn trace<const ANY: bool>(&self, ray: &Ray, t_max: f32) -> Option<Found> {
        self.trace_prepared::<ANY>(ray, &PreparedRay::new(ray), t_max)
    }

    /// [`trace`](Self::trace) with the ray already prepared (`world`).
    fn trace_prepared<const ANY: bool>(&self, ray: &Ray, world: &PreparedRay, t_max: f32) -> Option<Found> {
        let mut best: Option<Found> = None;
        let mut t_max = t_max;
        if let [entry] = &self.entries[..] {
            // One entry (a static scene): its BLAS's own boxes cull as well as the TLAS's would.
            self.trace_entry::<ANY>(0, entry, ray, world, &mut t_max, &mut best);
            return best;
        }
        if self.tlas_wide.nodes.is_empty() {
            return None;
        }
        traverse::<ANY>(&self.tlas_wide, world, t_max, |first, count| {
            for (k, e) in self.entries[first..first + count].iter().enumerate() {
                if self.trace_entry::<ANY>((first + k) as u32, e, ray, world, &mut t_max, &mut best) {
                    return Step::Stop;
                }
            }
            best.map_or(Step::Continue, |f| Step::Shrink(f.hit.t))
        });
        best
    }

    /// The ray in an entry's object space.
    #[inline(always)]
    fn local_ray(&self, e: &Entry, ray: &Ray, world: &PreparedRay) -> PreparedRay {
        if e.identity {
            *world
        } else {
            let o = e.world_to_object.transform_point3(ray.origin);
            let d = e.world_to_object.transform_vector3(ray.dir);
            PreparedRay::new(&Ray::new(o, d))
        }
    }

    /// Traces one TLAS entry's BLAS (entry number `index`), updating `best` and `t_max`; true
    /// when an any-hit query is answered.
    #[inline(always)]
    fn trace_entry<const ANY: bool>(
        &self,
        index: u32,
        e: &Entry,
        ray: &Ray,
        world: &PreparedRay,
        t_max: &mut f32,
        best: &mut Option<Found>,
    ) -> bool {
        let blas = &self.blases[e.blas as usize];
        let local = self.local_ray(e, ray, world);
        let ids = (index, e.instance);
        let cut = self.cutouts.as_deref();
        // The triangle test's copy for the ray's major axis, chosen once per ray.
        match local.major_axis() {
            0 => trace_blas::<ANY, 0>(blas, ids, cut, &local, t_max, best),
            1 => trace_blas::<ANY, 1>(blas, ids, cut, &local, t_max, best),
            _ => trace_blas::<ANY, 2>(blas, ids, cut, &local, t_max, best),
        }
    }
}

/// Rays traced together by [`ExactTracer::occluded_many`].
pub const PACKET: usize = 64;

/// Side of the pixel tiles of [`ExactTracer::closest_hits_tiled`]: one packet.
pub const TILE: u32 = 8;

/// Any-hit for up to `N` ≤ 64 rays through one world-space BLAS: a stack of (node or leaf,
/// the rays that entered it); a ray leaves every entry once it is found occluded. Triangle slot
/// `first_try` is tested first; returns the slot of a triangle that blocked a ray.
fn occluded_packet<const N: usize>(
    blas: &Blas,
    cut: Option<&Cutouts>,
    rays: &[(Ray, f32)],
    out: &mut [bool],
    first_try: Option<usize>,
) -> Option<usize> {
    let n = rays.len();
    debug_assert!(n <= N && N <= 64);
    let nodes = &blas.wide.nodes;
    // Lanes past the rays repeat the last one (never read: they are not in any mask).
    let prepared: [PreparedRay; N] = std::array::from_fn(|i| PreparedRay::new(&rays[i.min(n - 1)].0));
    let t_max = |r: usize| rays[r].1;
    let packet = PacketRays::<N>::new(&prepared[..n], t_max);
    // Rays not yet found occluded.
    let mut open: u64 = if n == 64 { u64::MAX } else { (1 << n) - 1 };
    let mut blocker = None;
    // Whether triangle `i` blocks ray `r`.
    let blocks = |i: usize, r: usize| {
        prepared[r].intersect_triangle(&blas.triangles[i], t_max(r)).is_some_and(|(_, b1, b2)| {
            let id = blas.ids[i];
            !cut.is_some_and(|c| c.hole(id.instance, id.triangle, b1, b2))
        })
    };
    if let Some(i) = first_try.filter(|&i| i < blas.triangles.len()) {
        for r in 0..n {
            if blocks(i, r) {
                open &= !(1 << r);
                blocker = Some(i);
            }
        }
    }
    let mut stack: Vec<(u32, u32, u64)> = Vec::with_capacity(64);
    if !nodes.is_empty() && open != 0 {
        stack.push((0, 0, open));
    }
    while let Some((child, count, mask)) = stack.pop() {
        let mask = mask & open;
        if mask == 0 {
            continue;
        }
        if count == 0 {
            let node = &nodes[child as usize];
            let entered = packet.enter(node, mask);
            for slot in (0..WIDTH).rev() {
                if entered[slot] != 0 {
                    stack.push((node.child[slot], node.count[slot], entered[slot]));
                }
            }
            continue;
        }
        for i in child as usize..(child + count) as usize {
            let mut bits = mask & open;
            while bits != 0 {
                let r = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if blocks(i, r) {
                    open &= !(1 << r);
                    blocker = Some(i);
                }
            }
        }
        if open == 0 {
            break;
        }
    }
    for (r, o) in out.iter_mut().enumerate() {
        *o = open & (1 << r) == 0;
    }
    blocker
}

/// Closest hits for up to `N` ≤ 64 rays through one world-space BLAS (the static world, whose
/// ids marked [`FROM_ENTRY`] belong to `instance`): a stack of (node or leaf, the rays that
/// entered it), children pushed far to near along the first ray's direction; each ray's `t_max`
/// shrinks at its hits, so its later box tests cull as its own traversal's would.
fn closest_packet<const N: usize>(blas: &Blas, instance: u32, cut: Option<&Cutouts>, rays: &[(Ray, f32)], out: &mut [Option<Hit>]) {
    let n = rays.len();
    debug_assert!(n <= N && N <= 64);
    let nodes = &blas.wide.nodes;
    let prepared: [PreparedRay; N] = std::array::from_fn(|i| PreparedRay::new(&rays[i.min(n - 1)].0));
    let mut packet = PacketRays::<N>::new(&prepared[..n], |r| rays[r].1);
    out.fill(None);
    let all: u64 = if n == 64 { u64::MAX } else { (1 << n) - 1 };
    let mut stack: Vec<(u32, u32, u64)> = Vec::with_capacity(64);
    if !nodes.is_empty() {
        stack.push((0, 0, all));
    }
    let toward = prepared[0].dir;
    while let Some((child, count, mask)) = stack.pop() {
        if count == 0 {
            let node = &nodes[child as usize];
            let entered = packet.enter(node, mask);
            // Far to near along the first ray: the nearest child comes off the stack first.
            let depth = |slot: usize| {
                let p = &node.planes;
                let centre = Vec3A::new(p[0][0][slot] + p[0][1][slot], p[1][0][slot] + p[1][1][slot], p[2][0][slot] + p[2][1][slot]);
                centre.dot(toward)
            };
            let mut order: [usize; WIDTH] = std::array::from_fn(|slot| slot);
            order.sort_unstable_by(|&a, &b| depth(b).total_cmp(&depth(a)));
            for slot in order {
                if entered[slot] != 0 {
                    stack.push((node.child[slot], node.count[slot], entered[slot]));
                }
            }
            continue;
        }
        for i in child as usize..(child + count) as usize {
            let mut bits = mask;
            while bits != 0 {
                let r = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let Some((t, b1, b2)) = prepared[r].intersect_triangle(&blas.triangles[i], packet.t_max(r)) else { continue };
                let id = blas.ids[i];
                let instance = if id.instance == FROM_ENTRY { instance } else { id.instance };
                if cut.is_some_and(|c| c.hole(instance, id.triangle, b1, b2)) {
                    continue;
                }
                packet.set_t_max(r, t);
                out[r] = Some(Hit { t, b1, b2, instance, triangle: id.triangle });
            }
        }
    }
}

/// A triangle of the tracer: its TLAS entry and its slot in that entry's BLAS.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Blocker {
    entry: u32,
    slot: u32,
}

/// A hit and the triangle it is on.
#[derive(Clone, Copy, Debug)]
struct Found {
    hit: Hit,
    blocker: Blocker,
}

/// The triangle that blocked a caller's previous shadow ray ([`ExactTracer::occluded_cached`]):
/// one per sequence of related rays (one shading point's rays to a cluster of lights), used
/// with one tracer only.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadowCache(Option<Blocker>);

/// Traces `ray` (whose major axis is `KZ`) through one BLAS, updating `best` and `t_max`; true
/// when an any-hit query is answered. `(entry, instance)`: the TLAS entry's number, and the
/// instance that stands in for ids marked [`FROM_ENTRY`]; a hit in one of `cut`'s holes is
/// passed through.
#[inline(always)]
fn trace_blas<const ANY: bool, const KZ: usize>(
    blas: &Blas,
    (entry, instance): (u32, u32),
    cut: Option<&Cutouts>,
    ray: &PreparedRay,
    t_max: &mut f32,
    best: &mut Option<Found>,
) -> bool {
    let mut stop = false;
    traverse::<ANY>(&blas.wide, ray, *t_max, |first, count| {
        let mut step = Step::Continue;
        for i in first..first + count {
            if let Some((t, b1, b2)) = ray.intersect_along::<KZ>(&blas.triangles[i], *t_max) {
                let id = blas.ids[i];
                let instance = if id.instance == FROM_ENTRY { instance } else { id.instance };
                if cut.is_some_and(|c| c.hole(instance, id.triangle, b1, b2)) {
                    continue;
                }
                *t_max = t;
                let hit = Hit { t, b1, b2, instance, triangle: id.triangle };
                *best = Some(Found { hit, blocker: Blocker { entry, slot: i as u32 } });
                if ANY {
                    stop = true;
                    return Step::Stop;
                }
                step = Step::Shrink(t);
            }
        }
        step
    });
    stop
}

/// Object-space triangles of a mesh at the frame's time, and their ids.
fn object_triangles(frame: &SceneFrame, mesh: usize) -> (Vec<[Vec3A; 3]>, Vec<PrimId>) {
    let pos = &frame.positions[mesh];
    let indices = &frame.scene.meshes[mesh].indices;
    let tris = indices.iter().map(|t| t.map(|i| Vec3A::from(pos[i as usize]))).collect();
    let ids = (0..indices.len() as u32).map(|triangle| PrimId { instance: FROM_ENTRY, triangle }).collect();
    (tris, ids)
}

/// What a leaf test tells the traversal.
enum Step {
    /// Nothing closer found.
    Continue,
    /// A hit at this distance: only closer boxes matter now.
    Shrink(f32),
    /// Any-hit query answered.
    Stop,
}

/// Traversal of a 4-wide tree; `leaf(first, count)` tests a leaf's primitive range.
///
/// Closest hit (`ANY == false`): front to back. Of the children a ray enters, the nearest is
/// visited next and the others wait on the stack, farthest deepest; what was entered beyond the
/// current `t_max` is dropped when it comes off the stack. Any hit (`t_max` never shrinks and the
/// first hit ends the query): children in slot order, without sorting.
#[inline]
fn traverse<const ANY: bool>(bvh: &Bvh4, ray: &PreparedRay, mut t_max: f32, mut leaf: impl FnMut(usize, usize) -> Step) {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return;
    }
    let ray4 = Ray4::new(ray);
    let mut stack = Stack::new();
    let mut cur = Pending { child: 0, count: 0, near: 0.0 };
    loop {
        // Down through interior nodes to a leaf.
        while cur.count == 0 {
            let n = &nodes[cur.child as usize];
            let (mask, near) = ray4.enter(n, t_max);
            let near = near.to_array();
            let pending = |slot: u32| {
                let slot = slot as usize % WIDTH;
                Pending { child: n.child[slot], count: n.count[slot], near: near[slot] }
            };
            // Zero, one, two, or more children entered (`rest`: all but the first).
            let first = mask.trailing_zeros();
            let rest = mask & mask.wrapping_sub(1);
            match (mask, rest, rest & rest.wrapping_sub(1)) {
                (0, _, _) => match stack.pop::<ANY>(t_max) {
                    Some(p) => cur = p,
                    None => return,
                },
                (_, 0, _) => cur = pending(first),
                (_, _, 0) if !ANY => {
                    let (a, b) = (pending(first), pending(rest.trailing_zeros()));
                    let (near, far) = if a.near <= b.near { (a, b) } else { (b, a) };
                    stack.push(far);
                    cur = near;
                }
                _ if !ANY => {
                    // Three or four: sort by entry distance, farthest first, keep the nearest.
                    let mut sorted = [cur; WIDTH];
                    let mut k = 0;
                    let mut bits = mask;
                    while bits != 0 {
                        let p = pending(bits.trailing_zeros());
                        bits &= bits - 1;
                        let mut j = k;
                        while j > 0 && sorted[j - 1].near < p.near {
                            sorted[j] = sorted[j - 1];
                            j -= 1;
                        }
                        sorted[j] = p;
                        k += 1;
                    }
                    for &p in &sorted[..k - 1] {
                        stack.push(p);
                    }
                    cur = sorted[k - 1];
                }
                _ => {
                    let mut bits = rest;
                    while bits != 0 {
                        stack.push(pending(bits.trailing_zeros()));
                        bits &= bits - 1;
                    }
                    cur = pending(first);
                }
            }
        }
        match leaf(cur.child as usize, cur.count as usize) {
            Step::Continue => {}
            Step::Shrink(t) => t_max = t,
            Step::Stop => return,
        }
        match stack.pop::<ANY>(t_max) {
            Some(p) => cur = p,
            None => return,
        }
    }
}

/// A child to visit: a node (`count == 0`) or a leaf's primitive range, and the distance at
/// which the ray enters its box.
#[derive(Clone, Copy)]
struct Pending {
    child: u32,
    count: u32,
    near: f32,
}

/// The traversal stack. Each level of a 4-wide tree leaves at most three siblings behind, and
/// trees are at most 64 levels deep (a deeper one panics on overflow, never reads garbage).
/// Left uninitialized: zeroing 2 KiB per ray would cost as much as tracing a small scene.
struct Stack {
    entries: [MaybeUninit<Pending>; 3 * 64],
    len: usize,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self { entries: [const { MaybeUninit::uninit() }; 3 * 64], len: 0 }
    }

    #[inline(always)]
    fn push(&mut self, p: Pending) {
        self.entries[self.len].write(p);
        self.len += 1;
    }

    /// The most recently pushed entry that the ray enters before `t_max`, dropping the ones above
    /// it; for any-hit traversal (`t_max` fixed, so all qualify), just the most recent.
    #[inline(always)]
    fn pop<const ANY: bool>(&mut self, t_max: f32) -> Option<Pending> {
        while self.len > 0 {
            self.len -= 1;
            // SAFETY: `push` wrote every entry below `len`, and `len` only shrinks past read ones.
            let p = unsafe { self.entries[self.len].assume_init() };
            if ANY || p.near < t_max {
                return Some(p);
            }
        }
        None
    }
}

/// A ray splatted across four lanes for [`Ray4::enter`], with, per axis, whether it crosses a
/// box's maximum plane before its minimum (a negative direction).
pub(crate) struct Ray4 {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    negative: [bool; 3],
}

impl Ray4 {
    #[inline(always)]
    pub(crate) fn new(ray: &PreparedRay) -> Self {
        let (o, i) = (ray.origin, ray.inv_dir);
        Self {
            origin: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv_dir: [Vec4::splat(i.x), Vec4::splat(i.y), Vec4::splat(i.z)],
            negative: [i.x < 0.0, i.y < 0.0, i.z < 0.0],
        }
    }

    /// Which of the node's four child boxes the ray enters before `t_max` (bit mask), and where.
    /// Slab test; the exit distance is scaled up by 1 + 2γ₃ (pbrt-v4 §6.8.2) so rounding never
    /// culls a box the ray really touches. Empty slots (inverted boxes) are never entered: their
    /// near plane is at +∞ and their far plane at −∞ whichever way the ray goes.
    #[inline(always)]
    pub(crate) fn enter(&self, n: &Bvh4Node, t_max: f32) -> (u32, Vec4) {
        let mut near = Vec4::ZERO;
        let mut far = Vec4::splat(t_max);
        for axis in 0..3 {
            let planes = &n.planes[axis];
            let neg = self.negative[axis];
            let t_near = (Vec4::from_array(planes[neg as usize]) - self.origin[axis]) * self.inv_dir[axis];
            let t_far = (Vec4::from_array(planes[!neg as usize]) - self.origin[axis]) * self.inv_dir[axis];
            near = near.max(t_near);
            far = far.min(t_far);
        }
        (near.cmple(far * (1.0 + 2.0 * GAMMA3)).bitmask(), near)
    }
}

pub(crate) const GAMMA3: f32 = 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

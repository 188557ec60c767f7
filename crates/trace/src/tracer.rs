//! The exact tracer: a two-level BVH over the scene at time t.
//!
//! Static geometry (instances that never move, meshes that never deform) is flattened into one
//! world-space BLAS, which traces fastest. Each moving instance references its mesh's
//! object-space BLAS through its own transform; deforming meshes get a BLAS refitted every frame.
//! The TLAS over these entries is rebuilt per frame (it has one leaf per moving instance plus one
//! for the static world, so that costs microseconds).

use crate::bvh::{BuildParams, Bvh};
use crate::triangle::PreparedRay;
use glimpse_core::glam::Affine3A;
use glimpse_core::{Aabb, Ray, Vec3, Vec3A};
use glimpse_scene::SceneFrame;

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

/// Triangles in BVH leaf order, so a leaf's range indexes `triangles` directly.
#[derive(Clone, Debug, Default)]
pub struct Blas {
    pub bvh: Bvh,
    pub triangles: Vec<[Vec3A; 3]>,
    pub ids: Vec<PrimId>,
}

impl Blas {
    pub fn build(triangles: Vec<[Vec3A; 3]>, ids: Vec<PrimId>) -> Blas {
        let bounds: Vec<Aabb> = triangles.iter().map(triangle_bounds).collect();
        let bvh = Bvh::build(&bounds, BuildParams::default());
        let triangles = bvh.prim_order.iter().map(|&i| triangles[i as usize]).collect();
        let ids = bvh.prim_order.iter().map(|&i| ids[i as usize]).collect();
        Blas { bvh, triangles, ids }
    }

    /// New vertex positions for the same triangles (given in the original order): refit.
    pub fn refit(&mut self, triangles: &[[Vec3A; 3]]) {
        let bounds: Vec<Aabb> = triangles.iter().map(triangle_bounds).collect();
        self.bvh.refit(&bounds);
        for (slot, &i) in self.bvh.prim_order.iter().enumerate() {
            self.triangles[slot] = triangles[i as usize];
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.bvh.nodes.len() * 32 + self.bvh.prim_order.len() * 4 + self.triangles.len() * 48 + self.ids.len() * 8
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
    /// Per mesh: its object-space BLAS, when some instance of it moves or it deforms.
    mesh_blas: Vec<Option<u32>>,
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
        let mut tracer = ExactTracer { blases, entries: Vec::new(), tlas: Bvh::default(), mesh_blas };
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
        self.blases.iter().map(Blas::memory_bytes).sum::<usize>() + self.tlas.nodes.len() * 32 + self.entries.len() * 64
    }

    /// Is anything hit at `0 < t < t_max`?
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.trace::<true>(ray, t_max).is_some()
    }

    /// The closest hit at `0 < t < t_max`.
    pub fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.trace::<false>(ray, t_max)
    }

    fn trace<const ANY: bool>(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if self.tlas.nodes.is_empty() {
            return None;
        }
        let world = PreparedRay::new(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = t_max;
        traverse(&self.tlas, &world, t_max, |first, count| {
            for e in &self.entries[first..first + count] {
                let blas = &self.blases[e.blas as usize];
                let local = if e.identity {
                    world
                } else {
                    let o = e.world_to_object.transform_point3(ray.origin);
                    let d = e.world_to_object.transform_vector3(ray.dir);
                    PreparedRay::new(&Ray::new(o, d))
                };
                let mut stop = false;
                traverse(&blas.bvh, &local, t_max, |first, count| {
                    let mut step = Step::Continue;
                    for i in first..first + count {
                        if let Some((t, b1, b2)) = local.intersect_triangle(&blas.triangles[i], t_max) {
                            let id = blas.ids[i];
                            let instance = if id.instance == FROM_ENTRY { e.instance } else { id.instance };
                            t_max = t;
                            best = Some(Hit { t, b1, b2, instance, triangle: id.triangle });
                            if ANY {
                                stop = true;
                                return Step::Stop;
                            }
                            step = Step::Shrink(t);
                        }
                    }
                    step
                });
                if stop {
                    return Step::Stop;
                }
            }
            best.map_or(Step::Continue, |h| Step::Shrink(h.t))
        });
        best
    }
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

/// Front-to-back traversal; `leaf(first, count)` tests a leaf's primitive range.
#[inline]
fn traverse(bvh: &Bvh, ray: &PreparedRay, mut t_max: f32, mut leaf: impl FnMut(usize, usize) -> Step) {
    let nodes = &bvh.nodes;
    let mut stack = [0u32; 64];
    let mut sp = 0usize;
    if box_hit(&nodes[0], ray, t_max).is_none() {
        return;
    }
    let mut node = 0usize;
    loop {
        let n = &nodes[node];
        if n.count > 0 {
            match leaf(n.first_or_right as usize, n.count as usize) {
                Step::Continue => {}
                Step::Shrink(t) => t_max = t,
                Step::Stop => return,
            }
        } else {
            let (l, r) = (node + 1, n.first_or_right as usize);
            let tl = box_hit(&nodes[l], ray, t_max);
            let tr = box_hit(&nodes[r], ray, t_max);
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    let (near, far) = if a <= b { (l, r) } else { (r, l) };
                    stack[sp] = far as u32;
                    sp += 1;
                    node = near;
                    continue;
                }
                (Some(_), None) => {
                    node = l;
                    continue;
                }
                (None, Some(_)) => {
                    node = r;
                    continue;
                }
                (None, None) => {}
            }
        }
        if sp == 0 {
            return;
        }
        sp -= 1;
        node = stack[sp] as usize;
    }
}

/// Entry distance into a node's box, or `None`. The exit distance is scaled up by 1 + 2γ₃
/// (pbrt-v4 §6.8.2) so rounding never culls a box the ray really touches.
#[inline(always)]
fn box_hit(n: &crate::bvh::BvhNode, ray: &PreparedRay, t_max: f32) -> Option<f32> {
    let t0 = (Vec3A::from(n.min) - ray.origin) * ray.inv_dir;
    let t1 = (Vec3A::from(n.max) - ray.origin) * ray.inv_dir;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element() * (1.0 + 2.0 * GAMMA3);
    (near <= far && near < t_max).then_some(near)
}

const GAMMA3: f32 = 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);

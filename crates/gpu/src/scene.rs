//! [`GpuScene`]: one frame of a scene in GPU buffers — world-space triangles and the 4-wide BVH
//! over them.
//!
//! Geometry: every instance is flattened into world space with the same expression the CPU
//! tracer uses for its static BLAS (`transform.transform_point3(position)`), and the BLAS is
//! built by the CPU tracer's own `Blas::build`. For a static scene this is the CPU tracer's tree
//! and triangles bit for bit. Moving or deforming instances, which the CPU traces in object
//! space under a two-level BVH, are flattened too (one level on the GPU): their answers differ
//! from the CPU's only by the rounding of the transform, at triangle edges.
//!
//! Why the 4-wide tree (`Bvh4`) rather than the binary one: a GPU thread pays for every node
//! fetch and every loop iteration, and a 4-wide node tests four boxes with `vec4` arithmetic from
//! one 128-byte fetch while visiting about half as many nodes; the stack holds fewer entries; and
//! it is the tree the CPU traverses, in the same order, so closest-hit ties resolve alike.
//!
//! Buffers are kept across frames: [`GpuScene::update`] rewrites them in place when the new
//! frame's data fits and only reallocates (bumping [`GpuScene::generation`]) when it grows.

use crate::compute::ReusableBuffer;
use crate::layout::{GpuNode, GpuTriangle};
use crate::{GpuContext, GpuError, GpuTimer};
use glimpse_core::Vec3A;
use glimpse_trace::SceneFrame;
use glimpse_trace::bvh::Bvh4;
use glimpse_trace::tracer::{Blas, PrimId};
use wgpu::util::DeviceExt;

/// Levels of the 4-wide tree the WGSL stack can hold (three pending siblings per level), the
/// CPU traversal's bound too.
pub const MAX_TREE_DEPTH: usize = 64;

pub struct GpuScene {
    pub nodes: ReusableBuffer,
    pub triangles: ReusableBuffer,
    pub node_count: u32,
    pub triangle_count: u32,
    /// `(instance, triangle)` of each GPU triangle (BVH order): maps a GPU hit to the scene.
    pub ids: Vec<PrimId>,
    /// Bumped whenever a buffer is reallocated, so users rebuild their bind groups.
    pub generation: u64,
}

impl GpuScene {
    /// Flattens, builds and uploads `frame`; the copy is timed as "upload" on `timer`.
    /// A scene with alpha-masked materials is refused: the GPU traversal has no alpha test, and
    /// its exact answers would disagree with the CPU tracer's, which cuts the masks out.
    pub fn new(ctx: &GpuContext, frame: &SceneFrame, timer: &mut GpuTimer) -> Result<Self, GpuError> {
        if let Some(m) = frame.scene.materials.iter().find(|m| m.alpha_mask.is_some()) {
            return Err(GpuError::AlphaMask(m.name.clone()));
        }
        let (tris, ids) = gather(frame);
        Self::from_flat(ctx, build(tris, ids)?, timer)
    }

    /// A scene of bare world-space triangles (ids: instance 0, the triangle's index), under the
    /// CPU tracer's BLAS: what a focused ROMA grid leaves out is traced this way.
    pub fn from_triangles(ctx: &GpuContext, triangles: &[[Vec3A; 3]], timer: &mut GpuTimer) -> Result<Self, GpuError> {
        let ids = (0..triangles.len() as u32).map(|triangle| PrimId { instance: 0, triangle }).collect();
        Self::from_flat(ctx, build(triangles.to_vec(), ids)?, timer)
    }

    fn from_flat(ctx: &GpuContext, (nodes, triangles, ids): Flat, timer: &mut GpuTimer) -> Result<Self, GpuError> {
        check_sizes(ctx, &nodes, &triangles)?;
        let mut scene = Self {
            nodes: ReusableBuffer::new(ctx, "bvh nodes", size_of_val(&nodes[..]) as u64)?,
            triangles: ReusableBuffer::new(ctx, "triangles", size_of_val(&triangles[..]) as u64)?,
            node_count: 0,
            triangle_count: 0,
            ids: Vec::new(),
            generation: 0,
        };
        scene.upload(ctx, &nodes, &triangles, ids, timer)?;
        Ok(scene)
    }

    /// Moves to another frame: rebuilds the tree on the CPU and rewrites the buffers, in place
    /// when they are large enough.
    pub fn update(&mut self, ctx: &GpuContext, frame: &SceneFrame, timer: &mut GpuTimer) -> Result<(), GpuError> {
        let (tris, ids) = gather(frame);
        let (nodes, triangles, ids) = build(tris, ids)?;
        check_sizes(ctx, &nodes, &triangles)?;
        let grew =
            self.nodes.reserve(ctx, size_of_val(&nodes[..]) as u64)? | self.triangles.reserve(ctx, size_of_val(&triangles[..]) as u64)?;
        self.generation += grew as u64;
        self.upload(ctx, &nodes, &triangles, ids, timer)
    }

    /// Copies through one staging buffer, so the GPU-side copy can be timed.
    fn upload(
        &mut self,
        ctx: &GpuContext,
        nodes: &[GpuNode],
        triangles: &[GpuTriangle],
        ids: Vec<PrimId>,
        timer: &mut GpuTimer,
    ) -> Result<(), GpuError> {
        let (node_bytes, tri_bytes) = (size_of_val(nodes) as u64, size_of_val(triangles) as u64);
        let mut staging_data: Vec<u8> = Vec::with_capacity((node_bytes + tri_bytes) as usize);
        staging_data.extend_from_slice(bytemuck::cast_slice(nodes));
        staging_data.extend_from_slice(bytemuck::cast_slice(triangles));
        if !staging_data.is_empty() {
            let staging = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("scene staging"),
                contents: &staging_data,
                usage: wgpu::BufferUsages::COPY_SRC,
            });
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            let span = timer.begin(&mut encoder, "upload");
            if node_bytes > 0 {
                encoder.copy_buffer_to_buffer(&staging, 0, &self.nodes.buffer, 0, node_bytes);
            }
            if tri_bytes > 0 {
                encoder.copy_buffer_to_buffer(&staging, node_bytes, &self.triangles.buffer, 0, tri_bytes);
            }
            timer.end(&mut encoder, span);
            ctx.queue.submit([encoder.finish()]);
        }
        ctx.check()?;
        self.node_count = nodes.len() as u32;
        self.triangle_count = triangles.len() as u32;
        self.ids = ids;
        Ok(())
    }

    /// Bytes held on the GPU.
    pub fn memory_bytes(&self) -> u64 {
        self.nodes.buffer.size() + self.triangles.buffer.size()
    }
}

fn check_sizes(ctx: &GpuContext, nodes: &[GpuNode], triangles: &[GpuTriangle]) -> Result<(), GpuError> {
    ctx.check_storage_size("the BVH node buffer", size_of_val(nodes) as u64)?;
    ctx.check_storage_size("the triangles", size_of_val(triangles) as u64)
}

/// The GPU forms of a frame: nodes, triangles, and the triangles' scene ids.
type Flat = (Vec<GpuNode>, Vec<GpuTriangle>, Vec<PrimId>);

/// World-space triangles of every instance and their scene ids.
fn gather(frame: &SceneFrame) -> (Vec<[Vec3A; 3]>, Vec<PrimId>) {
    let scene = frame.scene;
    let (mut tris, mut ids) = (Vec::new(), Vec::new());
    for (ii, inst) in scene.instances.iter().enumerate() {
        let m = frame.transforms[ii];
        let pos = &frame.positions[inst.mesh as usize];
        for (ti, t) in scene.meshes[inst.mesh as usize].indices.iter().enumerate() {
            tris.push(t.map(|i| Vec3A::from(m.transform_point3(pos[i as usize]))));
            ids.push(PrimId { instance: ii as u32, triangle: ti as u32 });
        }
    }
    (tris, ids)
}

/// The CPU tracer's BLAS over world-space triangles, and the GPU forms.
fn build(tris: Vec<[Vec3A; 3]>, ids: Vec<PrimId>) -> Result<Flat, GpuError> {
    // The hit record's NO_HIT (u32::MAX) must never be a triangle index.
    if tris.len() >= u32::MAX as usize {
        return Err(GpuError::TooManyTriangles(tris.len()));
    }
    if tris.is_empty() {
        return Ok((Vec::new(), Vec::new(), Vec::new()));
    }
    let blas = Blas::build(tris, ids);
    let depth = depth(&blas.wide);
    if depth > MAX_TREE_DEPTH {
        return Err(GpuError::TreeTooDeep { depth, max: MAX_TREE_DEPTH });
    }
    let nodes = blas.wide.nodes.iter().map(GpuNode::from).collect();
    let triangles = blas.triangles.iter().map(GpuTriangle::from).collect();
    Ok((nodes, triangles, blas.ids))
}

/// Levels of interior nodes on the longest root-to-leaf path.
pub fn depth(tree: &Bvh4) -> usize {
    if tree.nodes.is_empty() {
        return 0;
    }
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        deepest = deepest.max(d);
        let n = &tree.nodes[i];
        for slot in 0..glimpse_trace::bvh::WIDTH {
            if n.child[slot] != glimpse_trace::bvh::EMPTY_SLOT && n.count[slot] == 0 {
                stack.push((n.child[slot] as usize, d + 1));
            }
        }
    }
    deepest
}

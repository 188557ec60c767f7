//! The plain-data structs that cross to the GPU, field for field the structs of `trace.wgsl`
//! (WGSL storage layout: `vec3<f32>` aligned to 16 bytes, so each is followed by a 4-byte field).

use glimpse_core::{Ray, Vec3A};
use glimpse_trace::bvh::{Bvh4Node, EMPTY_SLOT, WIDTH};
use glimpse_trace::triangle::PreparedRay;

/// A 4-wide BVH node, [`Bvh4Node`] as the GPU reads it: `planes[2·axis + side]` holds the four
/// children's minima (`side` 0) or maxima (`side` 1) along `axis`; `count > 0` marks a leaf
/// over triangles `child .. child + count`, `count == 0` an interior child, `child == EMPTY_SLOT`
/// an unused slot. 128 bytes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuNode {
    pub planes: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
    pub count: [u32; WIDTH],
}

impl From<&Bvh4Node> for GpuNode {
    fn from(n: &Bvh4Node) -> Self {
        let p = &n.planes;
        Self { planes: [p[0][0], p[0][1], p[1][0], p[1][1], p[2][0], p[2][1]], child: n.child, count: n.count }
    }
}

pub const GPU_EMPTY_SLOT: u32 = EMPTY_SLOT;

/// A triangle's three vertices, each padded to a `vec4<f32>` (48 bytes, as the CPU's `[Vec3A; 3]`).
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuTriangle {
    pub v: [[f32; 4]; 3],
}

impl From<&[Vec3A; 3]> for GpuTriangle {
    fn from(t: &[Vec3A; 3]) -> Self {
        Self { v: t.map(|p| [p.x, p.y, p.z, 0.0]) }
    }
}

/// A ray prepared on the CPU exactly as the CPU tracer's `PreparedRay` is (same operations, so
/// the same bits): the GPU then needs no division to set up the watertight test, and Vulkan's
/// division (2.5 ulp) cannot make the shear differ from the CPU's. 48 bytes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuRay {
    pub origin: [f32; 3],
    /// The axis of the direction's largest magnitude (the paper's `kz`).
    pub kz: u32,
    /// 1/dir, with zero components replaced by ±1e-30 first.
    pub inv_dir: [f32; 3],
    pub t_max: f32,
    /// `dir[kx]/dir[kz]`, `dir[ky]/dir[kz]`, `1/dir[kz]` with kx, ky following kz cyclically.
    pub shear: [f32; 3],
    pub _pad: u32,
}

impl GpuRay {
    /// The CPU tracer's own `PreparedRay` (so the same bits), laid out for the GPU.
    pub fn new(ray: &Ray, t_max: f32) -> Self {
        let p = PreparedRay::new(ray);
        Self { origin: p.origin.to_array(), kz: p.kz() as u32, inv_dir: p.inv_dir.to_array(), t_max, shear: p.shear().to_array(), _pad: 0 }
    }
}

/// A closest-hit answer: `t` and the barycentrics of vertices 1 and 2 of triangle `prim` (in
/// the GPU scene's BVH order), or `prim == NO_HIT`.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuHitRecord {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
    pub prim: u32,
}

pub const NO_HIT: u32 = u32::MAX;

/// The kernels' uniform parameters.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct TraceParams {
    /// Rays in this batch.
    pub ray_count: u32,
    /// Nodes in the BVH (0: an empty scene, every ray misses).
    pub node_count: u32,
    /// Always 0: the kernels OR it into products so the compiler cannot fuse them into the add
    /// that follows (`unfused` in trace.wgsl) and into `t_max = ∞` (DVF's rays).
    pub zero: u32,
    /// `1 + 2γ₃`, the slab test's conservative exit scale, computed in f32 as the CPU does.
    pub box_exit_scale: f32,
}

/// γ₃ of pbrt-v4 §6.8.2, as `tracer.rs` defines it.
const GAMMA3: f32 = 3.0 * f32::EPSILON * 0.5 / (1.0 - 3.0 * f32::EPSILON * 0.5);
pub const BOX_EXIT_SCALE: f32 = 1.0 + 2.0 * GAMMA3;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_match_the_wgsl_structs() {
        assert_eq!(size_of::<GpuNode>(), 128);
        assert_eq!(size_of::<GpuTriangle>(), 48);
        assert_eq!(size_of::<GpuRay>(), 48);
        assert_eq!(size_of::<GpuHitRecord>(), 16);
        assert_eq!(size_of::<TraceParams>(), 16);
    }
}

//! [`GpuTracer`]: batches of rays traced on the GPU against a [`GpuScene`] — any-hit
//! (`occluded`) and closest-hit — with the CPU tracer's watertight test (`trace.wgsl`).
//!
//! Batches of any size are split into chunks that fit the device's storage-binding and
//! dispatch limits; ray and result buffers are kept and reused between calls. Each call's
//! kernel times (from timestamp queries, when the adapter has them) are in
//! [`GpuTracer::last_times`].

use crate::compute::{Kernel, ReusableBuffer, read_back, uniform_buffer, workgroups, write};
use crate::layout::{BOX_EXIT_SCALE, GpuHitRecord, GpuRay, NO_HIT, TraceParams};
use crate::{GpuContext, GpuError, GpuScene, GpuTimer, KernelTime};
use glimpse_core::Ray;
use wgpu::Buffer;

/// A closest hit, in the CPU tracer's terms (`t`, barycentrics of vertices 1 and 2, instance
/// and triangle index within the mesh), so CPU surface code (`SurfacePoint`) applies as is.
pub type GpuHit = glimpse_trace::Hit;

const WORKGROUP: u32 = 64;
/// Rays per chunk at most, whatever the limits allow (bounds the reused buffers' size).
const MAX_CHUNK: usize = 1 << 20;

pub struct GpuTracer {
    any_hit: Kernel,
    closest: Kernel,
    rays: ReusableBuffer,
    occluded_out: ReusableBuffer,
    hits_out: ReusableBuffer,
    params: Buffer,
    /// Rays per dispatch, from the device limits.
    chunk: usize,
    /// Kernel times of the last call (empty without timestamp queries).
    pub last_times: Vec<KernelTime>,
}

impl GpuTracer {
    /// Compiles the kernels and sizes the chunks for this device. Edges exactly zero in f32 are
    /// decided in f64 where the device has `SHADER_F64`, as on the CPU; otherwise with fma.
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        Self::with_f64_edges(ctx, ctx.features.contains(wgpu::Features::SHADER_F64))
    }

    /// [`GpuTracer::new`] with the choice of the edge fallback made by the caller (`f64`
    /// needs `SHADER_F64`; tests measure the fma fallback with `false`).
    pub fn with_f64_edges(ctx: &GpuContext, f64_edges: bool) -> Result<Self, GpuError> {
        let exact = if f64_edges { include_str!("exact_f64.wgsl") } else { include_str!("exact_fma.wgsl") };
        let source = format!("{}\n{exact}", include_str!("trace.wgsl"));
        let source = source.as_str();
        let per_ray = size_of::<GpuRay>().max(size_of::<GpuHitRecord>()) as u64;
        let by_binding = (ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size) / per_ray) as usize;
        let by_dispatch = ctx.limits.max_compute_workgroups_per_dimension as usize * WORKGROUP as usize;
        let chunk = by_binding.min(by_dispatch).min(MAX_CHUNK);
        if chunk == 0 {
            return Err(GpuError::BindingTooLarge {
                what: "one ray".into(),
                needed: per_ray,
                limit: ctx.limits.max_storage_buffer_binding_size,
            });
        }
        Ok(Self {
            any_hit: Kernel::new(ctx, "occluded", source, "occluded")?,
            closest: Kernel::new(ctx, "closest", source, "closest")?,
            rays: ReusableBuffer::new(ctx, "rays", size_of::<GpuRay>() as u64)?,
            occluded_out: ReusableBuffer::new(ctx, "occluded", 4)?,
            hits_out: ReusableBuffer::new(ctx, "hits", size_of::<GpuHitRecord>() as u64)?,
            params: uniform_buffer(ctx, "trace params", &TraceParams::zeroed_with_scale()),
            chunk,
            last_times: Vec::new(),
        })
    }

    /// Rays per dispatch on this device.
    pub fn chunk_size(&self) -> usize {
        self.chunk
    }

    /// `out[i]`: is anything hit at `0 < t < t_max` along `rays[i] = (ray, t_max)`?
    pub fn occluded(&mut self, ctx: &GpuContext, scene: &GpuScene, rays: &[(Ray, f32)]) -> Result<Vec<bool>, GpuError> {
        let words: Vec<u32> = self.run(ctx, scene, rays, true)?;
        Ok(words.into_iter().map(|w| w != 0).collect())
    }

    /// The closest hit at `0 < t < t_max` of each ray, as the CPU tracer's `Hit`.
    pub fn closest_hit(&mut self, ctx: &GpuContext, scene: &GpuScene, rays: &[(Ray, f32)]) -> Result<Vec<Option<GpuHit>>, GpuError> {
        let records: Vec<GpuHitRecord> = self.run(ctx, scene, rays, false)?;
        records
            .into_iter()
            .map(|r| {
                if r.prim == NO_HIT {
                    return Ok(None);
                }
                let id = scene
                    .ids
                    .get(r.prim as usize)
                    .ok_or_else(|| GpuError::ReadBack(format!("hit on triangle {} of {}", r.prim, scene.ids.len())))?;
                Ok(Some(GpuHit { t: r.t, b1: r.b1, b2: r.b2, instance: id.instance, triangle: id.triangle }))
            })
            .collect()
    }

    /// Traces `rays` chunk by chunk; returns the raw result words (u32 or `GpuHitRecord`).
    fn run<T: bytemuck::Pod>(
        &mut self,
        ctx: &GpuContext,
        scene: &GpuScene,
        rays: &[(Ray, f32)],
        any_hit: bool,
    ) -> Result<Vec<T>, GpuError> {
        let name = if any_hit { "any-hit" } else { "closest-hit" };
        let mut timer = GpuTimer::new(ctx, rays.len().div_ceil(self.chunk).max(1) as u32);
        let mut out = Vec::with_capacity(rays.len());
        for batch in rays.chunks(self.chunk) {
            let prepared: Vec<GpuRay> = batch.iter().map(|(r, t)| GpuRay::new(r, *t)).collect();
            self.rays.upload(ctx, &prepared)?;
            let result = if any_hit { &mut self.occluded_out } else { &mut self.hits_out };
            result.reserve(ctx, (batch.len() * size_of::<T>()) as u64)?;
            let params =
                TraceParams { ray_count: batch.len() as u32, node_count: scene.node_count, zero: 0, box_exit_scale: BOX_EXIT_SCALE };
            write(ctx, &self.params, &[params])?;
            let (kernel, binding) = if any_hit { (&self.any_hit, 4) } else { (&self.closest, 5) };
            // Bind groups are cheap next to a chunk of rays; making one per chunk keeps them in
            // step with reallocated buffers.
            let bind = kernel.bind(
                ctx,
                &[
                    (0, &scene.nodes.buffer),
                    (1, &scene.triangles.buffer),
                    (2, &self.rays.buffer),
                    (3, &self.params),
                    (binding, &result.buffer),
                ],
            );
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            kernel.dispatch(&mut encoder, &bind, workgroups(batch.len(), WORKGROUP), timer.pass(name));
            ctx.queue.submit([encoder.finish()]);
            out.extend(read_back::<T>(ctx, &result.buffer, batch.len())?);
        }
        self.last_times = timer.finish(ctx)?;
        Ok(out)
    }
}

impl TraceParams {
    fn zeroed_with_scale() -> Self {
        Self { ray_count: 0, node_count: 0, zero: 0, box_exit_scale: BOX_EXIT_SCALE }
    }
}

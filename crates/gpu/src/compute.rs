//! The small helper API that GPU kernels are built on (here and in the technique crates):
//!
//! ```ignore
//! let ctx = GpuContext::new()?;
//! let input = storage_buffer(&ctx, "input", &values)?;             // from a bytemuck slice
//! let output = storage_buffer_zeroed(&ctx, "output", 4 * n as u64)?;
//! let kernel = Kernel::new(&ctx, "double", include_str!("double.wgsl"), "main")?;
//! let bind = kernel.bind(&ctx, &[(0, &input), (1, &output)]);
//! let mut encoder = ctx.device.create_command_encoder(&Default::default());
//! kernel.dispatch(&mut encoder, &bind, workgroups(n, 64), timer.pass("double"));
//! ctx.queue.submit([encoder.finish()]);
//! let result: Vec<u32> = read_back(&ctx, &output, n)?;
//! ```
//!
//! Every buffer size is checked against the device's limits before the buffer is created, and
//! shader or pipeline errors come back as [`GpuError::Shader`], so a kernel never panics on an
//! oversized input or a WGSL typo. Bindings all live in group 0.

use crate::{GpuContext, GpuError};
use bytemuck::Pod;
use wgpu::util::DeviceExt;
use wgpu::{BindGroup, Buffer, BufferUsages, CommandEncoder, ComputePassTimestampWrites, ComputePipeline};

/// Usages of every storage buffer made here: bindable, writable by the queue, copyable out.
const STORAGE: BufferUsages = BufferUsages::STORAGE.union(BufferUsages::COPY_DST).union(BufferUsages::COPY_SRC);

/// A storage buffer holding `data` (at least 4 bytes, as wgpu requires non-empty bindings).
pub fn storage_buffer<T: Pod>(ctx: &GpuContext, label: &str, data: &[T]) -> Result<Buffer, GpuError> {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    if bytes.len() < 4 {
        return storage_buffer_zeroed(ctx, label, 4);
    }
    ctx.check_storage_size(label, bytes.len() as u64)?;
    Ok(ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage: STORAGE }))
}

/// A zero-filled storage buffer of `bytes` bytes (rounded up to a multiple of 4, at least 4).
pub fn storage_buffer_zeroed(ctx: &GpuContext, label: &str, bytes: u64) -> Result<Buffer, GpuError> {
    let size = bytes.max(4).next_multiple_of(4);
    ctx.check_storage_size(label, size)?;
    Ok(ctx.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage: STORAGE, mapped_at_creation: false }))
}

/// A uniform buffer holding `value` (writable later with [`write`]).
pub fn uniform_buffer<T: Pod>(ctx: &GpuContext, label: &str, value: &T) -> Buffer {
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::bytes_of(value),
        usage: BufferUsages::UNIFORM | BufferUsages::COPY_DST,
    })
}

/// Writes `data` at the start of `buffer`, which must be large enough (checked).
pub fn write<T: Pod>(ctx: &GpuContext, buffer: &Buffer, data: &[T]) -> Result<(), GpuError> {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    if bytes.len() as u64 > buffer.size() {
        return Err(GpuError::Validation(format!("{} bytes written into a {}-byte buffer", bytes.len(), buffer.size())));
    }
    if !bytes.is_empty() {
        ctx.queue.write_buffer(buffer, 0, bytes);
    }
    Ok(())
}

/// A storage buffer that is reused while its contents fit and replaced by a larger one when
/// they do not (per-frame uploads, ray batches).
pub struct ReusableBuffer {
    label: String,
    pub buffer: Buffer,
}

impl ReusableBuffer {
    pub fn new(ctx: &GpuContext, label: &str, bytes: u64) -> Result<Self, GpuError> {
        Ok(Self { label: label.to_owned(), buffer: storage_buffer_zeroed(ctx, label, bytes)? })
    }

    /// Makes room for `bytes`; true when the buffer was replaced (bind groups must be remade).
    pub fn reserve(&mut self, ctx: &GpuContext, bytes: u64) -> Result<bool, GpuError> {
        if bytes <= self.buffer.size() {
            return Ok(false);
        }
        self.buffer = storage_buffer_zeroed(ctx, &self.label, bytes)?;
        Ok(true)
    }

    /// Writes `data`, growing the buffer first if needed; true when it was replaced.
    pub fn upload<T: Pod>(&mut self, ctx: &GpuContext, data: &[T]) -> Result<bool, GpuError> {
        let replaced = self.reserve(ctx, size_of_val(data) as u64)?;
        write(ctx, &self.buffer, data)?;
        Ok(replaced)
    }
}

/// A compiled compute pipeline (one WGSL entry point) and its group-0 bind group layout.
pub struct Kernel {
    pub label: String,
    pub pipeline: ComputePipeline,
}

impl Kernel {
    /// Compiles `entry` of the WGSL `source`; errors carry the compiler's message.
    pub fn new(ctx: &GpuContext, label: &str, source: &str, entry: &str) -> Result<Self, GpuError> {
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(label), source: wgpu::ShaderSource::Wgsl(source.into()) });
        let pipeline = ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader { label: label.to_owned(), message: e.to_string() });
        }
        Ok(Self { label: label.to_owned(), pipeline })
    }

    /// A bind group for group 0 from `(binding, buffer)` pairs; the pairs must be exactly the
    /// bindings the entry point uses (the layout is derived from the shader).
    pub fn bind(&self, ctx: &GpuContext, buffers: &[(u32, &Buffer)]) -> BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> =
            buffers.iter().map(|&(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }).collect();
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&self.label),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// Records one compute pass running `groups` workgroups (x only), timed when `timestamps`.
    pub fn dispatch(&self, encoder: &mut CommandEncoder, bind: &BindGroup, groups: u32, timestamps: Option<ComputePassTimestampWrites>) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&self.label), timestamp_writes: timestamps });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(groups, 1, 1);
    }
}

/// Workgroups needed for `items` invocations at `size` per group.
pub fn workgroups(items: usize, size: u32) -> u32 {
    items.div_ceil(size as usize) as u32
}

/// Copies the first `count` elements of `buffer` (which needs `COPY_SRC`) to the host; waits
/// for the queue.
pub fn read_back<T: Pod>(ctx: &GpuContext, buffer: &Buffer, count: usize) -> Result<Vec<T>, GpuError> {
    let bytes = (count * size_of::<T>()) as u64;
    if bytes == 0 {
        return Ok(Vec::new());
    }
    if bytes > buffer.size() {
        return Err(GpuError::ReadBack(format!("{bytes} bytes asked of a {}-byte buffer", buffer.size())));
    }
    let size = bytes.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read back"),
        size,
        usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size.min(buffer.size()));
    ctx.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv().map_err(|e| GpuError::ReadBack(e.to_string()))?.map_err(|e| GpuError::ReadBack(e.to_string()))?;
    let view = staging.get_mapped_range(..).map_err(|e| GpuError::ReadBack(e.to_string()))?;
    // Copy out through bytes: the mapping's alignment is not promised to suit `T`.
    let out = bytemuck::pod_collect_to_vec(&view[..bytes as usize]);
    drop(view);
    staging.unmap();
    Ok(out)
}

/// An f32 as an exact WGSL hex-float literal: a decimal literal would be rounded twice by naga
/// (through f64), so kernels that must equal the CPU bit for bit get their constants this way.
pub fn hexf(x: f32) -> String {
    if x == 0.0 {
        return if x.is_sign_negative() { "-0.0f".into() } else { "0.0f".into() };
    }
    let b = x.to_bits();
    let (sign, e, m) = (if b >> 31 == 1 { "-" } else { "" }, ((b >> 23) & 0xff) as i32, b & 0x7f_ffff);
    if e == 0 {
        // Subnormal: 0.m · 2^-126.
        return format!("{sign}0x0.{:06x}p-126f", m << 1);
    }
    format!("{sign}0x1.{:06x}p{}f", m << 1, e - 127)
}

/// An f64 (normal) as an exact WGSL hex-float literal (`SHADER_F64` kernels).
pub fn hexd(x: f64) -> String {
    let b = x.to_bits();
    let (sign, e, m) = (if b >> 63 == 1 { "-" } else { "" }, ((b >> 52) & 0x7ff) as i64, b & 0xf_ffff_ffff_ffff);
    format!("{sign}0x1.{m:013x}p{}lf", e - 1023)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(hexf(1.0), "0x1.000000p0f");
        assert_eq!(hexf(-0.5), "-0x1.000000p-1f");
        assert_eq!(hexd(1.0), "0x1.0000000000000p0lf");
        assert_eq!(hexd(-1.5), "-0x1.8000000000000p0lf");
        assert_eq!(hexd(f64::from_bits(0x3ff9_21fb_5444_2d18)), "0x1.921fb54442d18p0lf");
    }
}

//! Alg. 3 on the GPU (issue #18 item 4): a built [`VoxArray`] uploaded once (or, rebuilt every
//! frame, re-uploaded by [`GpuVoxArray::reload`]), then batches of segments answered by
//! `query.wgsl`, one invocation per segment, with the decisions of [`Array::occluded_segment`] /
//! [`Array::occluded_segments`] (the CPU arithmetic ported operation for operation; see the
//! kernel's header comment).
//!
//! Data on the GPU (all read-only storage, group 0):
//! - binding 0, `Params` (uniform): grid centre and scale, N, n, the biases, `nf − 1e-3`, π/n,
//!   the chunk shifts — every constant computed on the CPU by the CPU's own expression;
//! - binding 1, the `Directions::cos_sin` table as `vec2<f32>` (the CPU rotates with it);
//! - bindings 2, 3: segments (`vec4<f32>` start, end) and answers (`u32`);
//! - bindings 4 ..: the rows (plain array) or the dictionary rows (compressed), as the CPU stores
//!   them: 128-bit rows `vec4<u32>`, 64-bit `vec2<u32>`, 32-bit `u32`, LSB first; then, when
//!   compressed, the packed indices as the CPU's u64 words seen as pairs of u32 words. Each
//!   array is split into chunks of a power of two of elements that fit one storage binding
//!   (`max_storage_buffer_binding_size`, 128 MiB on lavapipe): the default 128³ compressed
//!   array of many-lights (~333 MiB of indices) takes 3 index chunks.
//!
//! Divisions and square roots are correctly rounded through f64 where the device has
//! `SHADER_F64` (WGSL's own `/` is allowed 2.5 ulp on Vulkan, `sqrt` is derived from
//! `inverseSqrt`); the CPU's sin/cos table and polynomial coefficients go up as bits.

use crate::row::Row;
use crate::{Array, Rows, VoxArray};
use bytemuck::{Pod, Zeroable};
use glimpse_core::{Ray, Vec3};
use glimpse_gpu::compute::{Kernel, ReusableBuffer, read_back, storage_buffer, uniform_buffer, workgroups, write};
use glimpse_gpu::wgpu::{self, Buffer};
use glimpse_gpu::{GpuContext, GpuError, GpuTimer, KernelTime};
use glimpse_render::direct::{self, PunctualSample, Shading};
use glimpse_scene::{SceneFrame, WorldLight};
use glimpse_trace::GBuffer;
use thiserror::Error;

/// The technique's structure (static array, Alg. 5's instances, Alg. 6's rebuilt array) on the GPU.
#[path = "gpu_structure.rs"]
pub mod structure;
/// `lights-voxarray` as a `Technique` on the GPU (`--device gpu`).
#[path = "gpu_technique.rs"]
pub mod technique;

const WORKGROUP: u32 = 64;
/// Segments per dispatch at most (bounds the reused buffers: 32 MiB of segments).
const MAX_CHUNK: usize = 1 << 20;
/// Bindings before the row chunks.
const FIRST_DATA_BINDING: u32 = 4;

#[derive(Debug, Error)]
pub enum GpuVoxArrayError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(
        "the voxel array needs {needed} storage buffers in one shader stage ({what}), but the adapter allows {limit} (max_storage_buffers_per_shader_stage)"
    )]
    TooManyBindings { what: String, needed: u32, limit: u32 },
    #[error("the voxel array is too large for the GPU query's 32-bit indexing: {0}")]
    TooLarge(String),
}

/// The uniform block of `query.wgsl` (field for field).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Params {
    count: u32,
    n_dirs: u32,
    resolution: u32,
    index_bits: u32,
    center: [f32; 3],
    scale: f32,
    nf: f32,
    half_n: f32,
    bias_start: f32,
    bias_end: f32,
    hi_cap: f32,
    step: f32,
    row_shift: u32,
    word_shift: u32,
    /// 0 (the kernel's guard against contracted multiply-adds, `mul` in `query.wgsl`).
    zero: u32,
    _pad: [u32; 3],
}

/// A [`VoxArray`] in GPU buffers and the compiled query.
pub struct GpuVoxArray {
    kernel: Kernel,
    data: Uploaded,
    params_buffer: Buffer,
    segments: ReusableBuffer,
    out: ReusableBuffer,
    chunk: usize,
    /// Whether divisions and square roots are corrected through f64 (`SHADER_F64`).
    pub exact_f64: bool,
    /// Bytes uploaded (rows or dictionary + indices, and the cos/sin table).
    pub bytes: u64,
    /// Kernel times of the last call (empty without timestamp queries).
    pub last_times: Vec<KernelTime>,
}

/// One array's buffers, the kernel's constants for it, and the kernel source its layout needs.
struct Uploaded {
    params: Params,
    cos_sin: Buffer,
    /// Plain rows or dictionary rows, in chunks of `1 << params.row_shift` rows.
    rows: Vec<Buffer>,
    /// Packed index words (u32), in chunks of `1 << params.word_shift` words; empty when plain.
    indices: Vec<Buffer>,
    /// `query.wgsl` with its header: depends on the layout only (row width, compression, chunk
    /// counts, f64 division), not on the array's contents or grid.
    source: String,
    bytes: u64,
}

/// Elements of `elem_bytes` bytes per chunk: the largest power of two that fits one binding,
/// and no more than `total` needs.
fn chunk_elems(ctx: &GpuContext, elem_bytes: u64, total: u64) -> u64 {
    let limit = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
    let fit = (limit / elem_bytes).max(1);
    let pow = 1u64 << (63 - fit.leading_zeros());
    pow.min(total.max(1).next_power_of_two()).min(1 << 31)
}

/// `data` in storage buffers of `per_chunk` elements each (one 4-byte buffer when empty).
fn upload_chunks<T: Pod>(ctx: &GpuContext, label: &str, data: &[T], per_chunk: u64) -> Result<Vec<Buffer>, GpuError> {
    if data.is_empty() {
        return Ok(vec![storage_buffer::<u32>(ctx, label, &[0])?]);
    }
    data.chunks(per_chunk as usize).enumerate().map(|(k, c)| storage_buffer(ctx, &format!("{label} {k}"), c)).collect()
}

/// `glimpse_core::fast_math::atan_unit`'s coefficients (the unit test checks they give its bits).
const ATAN_COEFFICIENTS: [f32; 6] = [0.999_977_26, -0.332_623_47, 0.193_543_46, -0.116_432_87, 0.052_653_32, -0.011_721_2];

impl GpuVoxArray {
    /// Uploads `array` (plain or compressed, any resolution) and compiles the query; errors if
    /// the device's limits cannot hold it.
    pub fn new(ctx: &GpuContext, array: &VoxArray) -> Result<Self, GpuVoxArrayError> {
        Self::with_f64(ctx, array, ctx.features.contains(wgpu::Features::SHADER_F64))
    }

    /// [`GpuVoxArray::new`] with the division/square-root choice made by the caller (`exact_f64`
    /// needs `SHADER_F64`; `false` uses WGSL's `/` and `sqrt`).
    pub fn with_f64(ctx: &GpuContext, array: &VoxArray, exact_f64: bool) -> Result<Self, GpuVoxArrayError> {
        let data = Uploaded::new(ctx, array, exact_f64)?;
        let kernel = Kernel::new(ctx, "voxarray query", &data.source, "query")?;
        let by_binding = (ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size) / 32) as usize;
        let by_dispatch = ctx.limits.max_compute_workgroups_per_dimension as usize * WORKGROUP as usize;
        let chunk = by_binding.min(by_dispatch).clamp(1, MAX_CHUNK);
        Ok(Self {
            kernel,
            params_buffer: uniform_buffer(ctx, "voxarray params", &data.params),
            bytes: data.bytes,
            data,
            segments: ReusableBuffer::new(ctx, "voxarray segments", 32)?,
            out: ReusableBuffer::new(ctx, "voxarray occluded", 4)?,
            chunk,
            exact_f64,
            last_times: Vec::new(),
        })
    }

    /// Replaces the array by `array` (a deforming scene's per-frame rebuild, Alg. 6): fresh data
    /// buffers, the compiled kernel kept when the layout is the same (it is for a rebuild at the
    /// same resolution and directions: only the contents and the grid move).
    pub fn reload(&mut self, ctx: &GpuContext, array: &VoxArray) -> Result<(), GpuVoxArrayError> {
        let data = Uploaded::new(ctx, array, self.exact_f64)?;
        if data.source != self.data.source {
            self.kernel = Kernel::new(ctx, "voxarray query", &data.source, "query")?;
        }
        self.bytes = data.bytes;
        self.data = data;
        Ok(())
    }

    /// The row (or dictionary) chunks, then the index chunks, for read-back checks.
    pub fn data_buffers(&self) -> (&[Buffer], &[Buffer]) {
        (&self.data.rows, &self.data.indices)
    }

    /// The cos/sin table's buffer.
    pub fn cos_sin_buffer(&self) -> &Buffer {
        &self.data.cos_sin
    }

    /// Segments per dispatch on this device.
    pub fn chunk_size(&self) -> usize {
        self.chunk
    }

    /// Uploads one chunk of segments (at most [`Self::chunk_size`]) and its count, and binds
    /// them with the array for the query kernel.
    fn bind_batch(&mut self, ctx: &GpuContext, batch: &[(Vec3, Vec3)]) -> Result<wgpu::BindGroup, GpuVoxArrayError> {
        let packed: Vec<[f32; 4]> = batch.iter().flat_map(|(a, b)| [a.extend(0.0).to_array(), b.extend(0.0).to_array()]).collect();
        self.segments.upload(ctx, &packed)?;
        self.out.reserve(ctx, batch.len() as u64 * 4)?;
        write(ctx, &self.params_buffer, &[Params { count: batch.len() as u32, ..self.data.params }])?;
        let mut entries = vec![(0, &self.params_buffer), (1, &self.data.cos_sin), (2, &self.segments.buffer), (3, &self.out.buffer)];
        for (k, b) in self.data.rows.iter().chain(&self.data.indices).enumerate() {
            entries.push((FIRST_DATA_BINDING + k as u32, b));
        }
        Ok(self.kernel.bind(ctx, &entries))
    }

    /// Keeps the GPU busy with the query kernel: the first chunk of `segments` uploaded once,
    /// then `dispatches` dispatches of it in one submission, waited for; no answers read back.
    /// A warm-up for timing: one [`Self::occluded_segments`] pass is a fraction of a millisecond
    /// of kernel among ~10 ms of copies, too light a load to raise a GPU's clocks.
    pub fn keep_busy(&mut self, ctx: &GpuContext, segments: &[(Vec3, Vec3)], dispatches: u32) -> Result<(), GpuVoxArrayError> {
        let batch = &segments[..segments.len().min(self.chunk)];
        if batch.is_empty() {
            return Ok(());
        }
        let bind = self.bind_batch(ctx, batch)?;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        for _ in 0..dispatches {
            self.kernel.dispatch(&mut encoder, &bind, workgroups(batch.len(), WORKGROUP), None);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        Ok(())
    }

    /// `out[k] = array.occluded_segment(segments[k].0, segments[k].1)` on the GPU, for finite
    /// segments; kernel times in [`GpuVoxArray::last_times`].
    pub fn occluded_segments(&mut self, ctx: &GpuContext, segments: &[(Vec3, Vec3)]) -> Result<Vec<bool>, GpuVoxArrayError> {
        let mut timer = GpuTimer::new(ctx, segments.len().div_ceil(self.chunk).max(1) as u32);
        let mut out = Vec::with_capacity(segments.len());
        for batch in segments.chunks(self.chunk) {
            let bind = self.bind_batch(ctx, batch)?;
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            self.kernel.dispatch(&mut encoder, &bind, workgroups(batch.len(), WORKGROUP), timer.pass("voxarray query"));
            ctx.queue.submit([encoder.finish()]);
            let words: Vec<u32> = read_back(ctx, &self.out.buffer, batch.len())?;
            out.extend(words.into_iter().map(|w| w != 0));
        }
        self.last_times = timer.finish(ctx)?;
        Ok(out)
    }
}

impl Uploaded {
    fn new(ctx: &GpuContext, array: &VoxArray, exact_f64: bool) -> Result<Self, GpuVoxArrayError> {
        match array {
            VoxArray::R32(a) => Self::upload(ctx, a, "u32", "vec4<u32>(r, 0u, 0u, 0u)", exact_f64),
            VoxArray::R64(a) => Self::upload(ctx, a, "vec2<u32>", "vec4<u32>(r, 0u, 0u)", exact_f64),
            VoxArray::R128(a) => Self::upload(ctx, a, "vec4<u32>", "r", exact_f64),
        }
    }

    fn upload<R: Row + Pod>(
        ctx: &GpuContext,
        a: &Array<R>,
        row_type: &str,
        words: &str,
        exact_f64: bool,
    ) -> Result<Self, GpuVoxArrayError> {
        let row_bytes = size_of::<R>() as u64;
        let total_rows = a.row_count() as u64;
        if total_rows >= 1 << 32 {
            return Err(GpuVoxArrayError::TooLarge(format!("{total_rows} rows")));
        }
        let (row_data, index_words, index_bits): (&[R], &[u32], u32) = match &a.rows {
            Rows::Plain(v) => (v, &[], 0),
            Rows::Compressed(c) => {
                // The last row's index ends below bit 2^32 (positions are u32 in the kernel).
                if (c.rows as u64 + 2) * c.index_bits as u64 >= 1 << 32 {
                    return Err(GpuVoxArrayError::TooLarge(format!("{} rows × {} index bits", c.rows, c.index_bits)));
                }
                (&c.dictionary, bytemuck::cast_slice(&c.indices), c.index_bits)
            }
        };
        let compressed = matches!(a.rows, Rows::Compressed(_));
        let per_row_chunk = chunk_elems(ctx, row_bytes, row_data.len() as u64);
        let per_word_chunk = chunk_elems(ctx, 4, index_words.len() as u64);
        let row_chunks = (row_data.len() as u64).div_ceil(per_row_chunk).max(1) as u32;
        let word_chunks = if compressed { (index_words.len() as u64).div_ceil(per_word_chunk).max(1) as u32 } else { 0 };
        let needed = FIRST_DATA_BINDING - 1 + row_chunks + word_chunks;
        let limit = ctx.limits.max_storage_buffers_per_shader_stage;
        if needed > limit {
            let what = format!("{row_chunks} row chunks, {word_chunks} index chunks");
            return Err(GpuVoxArrayError::TooManyBindings { what, needed, limit });
        }
        let rows = upload_chunks(ctx, "voxarray rows", row_data, per_row_chunk)?;
        let indices = if compressed { upload_chunks(ctx, "voxarray indices", index_words, per_word_chunk)? } else { Vec::new() };
        let table: Vec<[f32; 2]> = a.dirs.cos_sin.iter().map(|&(c, s)| [c, s]).collect();
        let cos_sin = storage_buffer(ctx, "voxarray cos/sin", &table)?;
        let nf = a.grid.resolution as f32;
        let pi = std::f32::consts::PI;
        let params = Params {
            count: 0,
            n_dirs: a.dirs.n,
            resolution: a.grid.resolution,
            index_bits,
            center: a.grid.center.to_array(),
            scale: a.grid.scale,
            nf,
            // `Grid::to_cells_ij`'s `resolution as f32 * 0.5`.
            half_n: a.grid.resolution as f32 * 0.5,
            bias_start: a.bias_start_cells,
            bias_end: a.bias_end_cells,
            // `query::extent`'s `nf - 1e-3`.
            hi_cap: nf - 1e-3,
            // `directions::discretize`'s `pi / n as f32`.
            step: pi / a.dirs.n as f32,
            row_shift: per_row_chunk.trailing_zeros(),
            word_shift: per_word_chunk.trailing_zeros(),
            zero: 0,
            _pad: [0; 3],
        };
        let source = format!("{}\n{}", header(row_type, words, compressed, row_chunks, word_chunks, exact_f64), include_str!("query.wgsl"));
        let bytes = (row_data.len() as u64 * row_bytes) + index_words.len() as u64 * 4 + table.len() as u64 * 8;
        Ok(Self { params, cos_sin, rows, indices, source, bytes })
    }
}

/// The segment each ray covers in the `Visibility` query (`t_max` cut where the ray leaves the
/// grid): `rays` answered by [`GpuVoxArray::occluded_segments`] on these are the CPU's
/// `occluded_batch` answers when `skip_start_run` is off.
pub fn ray_segments(array: &VoxArray, rays: &[(Ray, f32)]) -> Vec<(Vec3, Vec3)> {
    fn each<R: Row>(a: &Array<R>, rays: &[(Ray, f32)]) -> Vec<(Vec3, Vec3)> {
        rays.iter().map(|(r, t)| a.segment(r, *t)).collect()
    }
    match array {
        VoxArray::R32(a) => each(a, rays),
        VoxArray::R64(a) => each(a, rays),
        VoxArray::R128(a) => each(a, rays),
    }
}

/// The shadow samples `lights-voxarray` makes at one shaded point, in the lights' order: every
/// light that faces the point and reaches it, with its cosine (the CPU technique's test).
pub fn lit_samples(s: Shading, lights: &[WorldLight]) -> impl Iterator<Item = (PunctualSample, f32)> + '_ {
    lights.iter().filter_map(move |light| {
        let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
        let cos = s.cos(ps.wi);
        (cos > 0.0 && ps.irradiance.max_element() > 0.0).then_some((ps, cos))
    })
}

/// Every shadow sample `lights-voxarray` makes for `gbuffer` (pixel by pixel, the first `lights`
/// punctual lights of the frame), with the geometric normal its segment is offset along.
pub fn shadow_samples(frame: &SceneFrame, gbuffer: &GBuffer, lights: usize) -> Vec<(PunctualSample, Vec3)> {
    let lights = &frame.lights[..frame.lights.len().min(lights)];
    (0..gbuffer.len())
        .filter_map(|i| Shading::from_gbuffer(gbuffer, i))
        .flat_map(|s| lit_samples(s, lights).map(move |(ps, _)| (ps, s.normal)))
        .collect()
}

/// The shadow segments `lights-voxarray` queries for `gbuffer`: [`shadow_samples`], each start
/// moved along the normal ([`Array::surface_segment`]), as the technique's per-sample path forms
/// them.
pub fn shadow_segments(array: &VoxArray, frame: &SceneFrame, gbuffer: &GBuffer, lights: usize) -> Vec<(Vec3, Vec3)> {
    shadow_samples(frame, gbuffer, lights).iter().map(|(ps, n)| array.surface_segment(ps, *n)).collect()
}

/// The segment's extent sits on a cell boundary: one of the CPU's clipped ends, or the
/// midpoint's row coordinates, within `tolerance` cells of an integer (where a rounding
/// difference between the CPU and the GPU may flip the decision).
pub fn on_cell_boundary(array: &VoxArray, start: Vec3, end: Vec3, tolerance: f32) -> bool {
    fn each<R: Row>(a: &Array<R>, start: Vec3, end: Vec3, tolerance: f32) -> bool {
        let (i, j) = a.dirs.discretize(end - start);
        let (q0, q1) = (a.grid.to_cells_ij(&a.dirs, i, j, start), a.grid.to_cells_ij(&a.dirs, i, j, end));
        let m = (q0 + q1) * 0.5;
        let (lo, hi) = if q0.z <= q1.z {
            (q0.z + a.bias_start_cells, q1.z - a.bias_end_cells)
        } else {
            (q1.z + a.bias_end_cells, q0.z - a.bias_start_cells)
        };
        let near = |x: f32| (x - x.round()).abs() <= tolerance;
        near(m.x) || near(m.y) || near(lo) || near(hi)
    }
    match array {
        VoxArray::R32(a) => each(a, start, end, tolerance),
        VoxArray::R64(a) => each(a, start, end, tolerance),
        VoxArray::R128(a) => each(a, start, end, tolerance),
    }
}

/// The `query.wgsl` header for one array layout.
fn header(row_type: &str, words: &str, compressed: bool, row_chunks: u32, word_chunks: u32, exact_f64: bool) -> String {
    use std::fmt::Write;
    let mut h = String::new();
    // The coefficients must be fast_math's: checked by the unit test below.
    for (k, v) in ATAN_COEFFICIENTS.iter().enumerate() {
        let _ = writeln!(h, "const C{k}: u32 = {:#010x}u;", v.to_bits());
    }
    let _ = writeln!(h, "const PI: u32 = {:#010x}u;", std::f32::consts::PI.to_bits());
    let _ = writeln!(h, "const FRAC_PI_2: u32 = {:#010x}u;", std::f32::consts::FRAC_PI_2.to_bits());
    let _ = writeln!(h, "const COMPRESSED: bool = {compressed};");
    let _ = writeln!(h, "alias RowT = {row_type};");
    let _ = writeln!(h, "fn row_words(r: RowT) -> vec4<u32> {{ return {words}; }}");
    for k in 0..row_chunks {
        let _ = writeln!(h, "@group(0) @binding({}) var<storage, read> rows_{k}: array<RowT>;", FIRST_DATA_BINDING + k);
    }
    for k in 0..word_chunks {
        let _ = writeln!(h, "@group(0) @binding({}) var<storage, read> words_{k}: array<u32>;", FIRST_DATA_BINDING + row_chunks + k);
    }
    let switch = |name: &str, chunks: u32, shift: &str, index: &str| {
        let mut s = format!("    let o = {index} & ((1u << P.{shift}) - 1u);\n    switch ({index} >> P.{shift}) {{\n");
        for k in 1..chunks {
            s += &format!("        case {k}u: {{ return {name}_{k}[o]; }}\n");
        }
        s += &format!("        default: {{ return {name}_0[o]; }}\n    }}\n");
        s
    };
    let _ = writeln!(h, "fn load_row(r: u32) -> RowT {{\n{}}}", switch("rows", row_chunks, "row_shift", "r"));
    if word_chunks > 0 {
        let _ = writeln!(h, "fn load_index_word(w: u32) -> u32 {{\n{}}}", switch("words", word_chunks, "word_shift", "w"));
    } else {
        let _ = writeln!(h, "fn load_index_word(w: u32) -> u32 {{ return 0u; }}");
    }
    h += if exact_f64 { EXACT_F64 } else { PLAIN };
    h
}

/// `div_rn` and `sqrt_rn` as WGSL's own operations (2.5 ulp division on Vulkan).
const PLAIN: &str = "
fn div_rn(a: f32, b: f32) -> f32 { return a / b; }
fn sqrt_rn(x: f32) -> f32 { return sqrt(x); }
";

/// `div_rn` (a ≥ 0, b > 0) and `sqrt_rn` (x ≥ 0) rounded as IEEE f32: the f64 result rounded to
/// f32, then moved one ulp when the exact value lies beyond a midpoint; each midpoint has 25
/// significant bits, so `midpoint × b` (49 bits) and `midpoint²` (50 bits) are exact in f64,
/// and no exact quotient or root of f32 values is a midpoint (no ties).
const EXACT_F64: &str = "
fn next_up(x: f32) -> f32 { return bitcast<f32>(bitcast<u32>(x) + 1u); }
fn next_down(x: f32) -> f32 { return bitcast<f32>(bitcast<u32>(x) - 1u); }
fn div_rn(a: f32, b: f32) -> f32 {
    let q = f32(f64(a) / f64(b));
    if !(q > 0.0) || (bitcast<u32>(q) & 0x7f800000u) == 0x7f800000u { return q; }
    let up = next_up(q);
    let mu = (f64(q) + f64(up)) * f64(0.5);
    if mu * f64(b) < f64(a) { return up; }
    let dn = next_down(q);
    let md = (f64(q) + f64(dn)) * f64(0.5);
    if md * f64(b) > f64(a) { return dn; }
    return q;
}
fn sqrt_rn(x: f32) -> f32 {
    let s = f32(sqrt(f64(x)));
    if !(s > 0.0) || (bitcast<u32>(s) & 0x7f800000u) == 0x7f800000u { return s; }
    let up = next_up(s);
    let mu = (f64(s) + f64(up)) * f64(0.5);
    if mu * mu < f64(x) { return up; }
    let dn = next_down(s);
    let md = (f64(s) + f64(dn)) * f64(0.5);
    if md * md > f64(x) { return dn; }
    return s;
}
";

/// The CPU's answers for `segments` (the batched query), for comparisons.
pub fn cpu_answers(array: &VoxArray, segments: &[(Vec3, Vec3)]) -> Vec<bool> {
    let mut out = vec![false; segments.len()];
    array.occluded_segments(segments, &mut out);
    out
}

/// One row of `glimpse bench gpu`: the same rays through the voxel array on the GPU.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub segments: usize,
    /// Summed `voxarray query` kernel time (timestamps; 0 without them).
    pub kernel_ms: f64,
    /// Wall time of the GPU call (uploads of segments, dispatches, read-backs).
    pub wall_ms: f64,
    pub upload_ms: f64,
    pub upload_bytes: u64,
    /// Answers that differ from the CPU's batched query.
    pub differ: usize,
    pub exact_f64: bool,
}

/// Timed passes of the `voxarray` bench row; the fastest is reported.
const TIMED_PASSES: usize = 5;

/// Kernel dispatches per submission of the bench's busy warm-up ([`GpuVoxArray::keep_busy`]).
const BUSY_DISPATCHES: u32 = 64;

/// Uploads `array`, runs `rays` (as [`ray_segments`]) through the GPU query untimed (warm-up),
/// then [`TIMED_PASSES`] times timed, keeping the fastest, and compares with the CPU's batched
/// query.
pub fn bench_rays(ctx: &GpuContext, array: &VoxArray, rays: &[(Ray, f32)]) -> Result<BenchRow, GpuVoxArrayError> {
    let t = std::time::Instant::now();
    let mut gpu = GpuVoxArray::new(ctx, array)?;
    ctx.wait()?;
    let upload_ms = t.elapsed().as_secs_f64() * 1e3;
    let segments = ray_segments(array, rays);
    // Untimed passes over the whole batch (caches), then the kernel alone back to back for the
    // same time (clocks): a pass is well under a millisecond of kernel beside ~10 ms of copies,
    // so passes alone leave the GPU mostly idle. On an H200, after the 1.3–7 s CPU build of the
    // array with the GPU idle, 4 of 7 processes timed every pass at a quarter of the speed of a
    // process that loaded the array from the disk cache; the best of 5 timed passes did not
    // change that, this busy warm-up took Sponza's 3.7× to 5.5–5.7× (loaded: 15×; docs/gpu.md).
    glimpse_gpu::timer::warm_up(|| gpu.occluded_segments(ctx, &segments).map(drop))?;
    glimpse_gpu::timer::warm_up(|| gpu.keep_busy(ctx, &segments, BUSY_DISPATCHES))?;
    let (mut kernel_ms, mut wall_ms, mut answers) = (f64::INFINITY, f64::INFINITY, Vec::new());
    for _ in 0..TIMED_PASSES {
        let t = std::time::Instant::now();
        answers = gpu.occluded_segments(ctx, &segments)?;
        wall_ms = wall_ms.min(t.elapsed().as_secs_f64() * 1e3);
        kernel_ms = kernel_ms.min(gpu.last_times.iter().map(|k| k.ms).sum());
    }
    let cpu = cpu_answers(array, &segments);
    let differ = answers.iter().zip(&cpu).filter(|(g, c)| g != c).count();
    Ok(BenchRow { segments: segments.len(), kernel_ms, wall_ms, upload_ms, upload_bytes: gpu.bytes, differ, exact_f64: gpu.exact_f64 })
}

/// The `voxarray` row of `glimpse bench gpu`: the default `lights-voxarray` array of `frame`
/// (128³ × 90², compressed; from the disk cache when there, as the technique does), the same
/// `rays` the exact GPU tracer traced, the kernel time against `exact_kernel_ms` (the exact
/// any-hit kernel on the same device) and agreement with the CPU voxel array. Prints its lines.
pub fn print_bench_row(ctx: &GpuContext, frame: &SceneFrame, rays: &[(Ray, f32)], exact_kernel_ms: f64) -> Result<(), GpuVoxArrayError> {
    let p = crate::VoxArrayParams::default();
    let triangles = frame.world_triangles();
    let path = glimpse_render::structure_cache_dir().map(|dir| crate::disk_cache::path_for(&dir, &triangles, None, &p));
    let t = std::time::Instant::now();
    let (array, how) = match path.as_ref().and_then(|path| crate::disk_cache::load(path, &p)) {
        Some(a) => (a, "loaded from the disk cache"),
        None => {
            let a = VoxArray::from_triangles(&triangles, &p);
            if let Some(path) = &path
                && let Err(e) = crate::disk_cache::store(path, &a)
            {
                eprintln!("warning: cannot cache the voxel array: {e}");
            }
            (a, "built")
        }
    };
    let ready_ms = t.elapsed().as_secs_f64() * 1e3;
    let row = bench_rays(ctx, &array, rays)?;
    println!(
        "voxarray: 128³ × 90² compressed array {how} in {ready_ms:.0} ms; {:.1} MiB uploaded in {:.0} ms; divisions {}",
        row.upload_bytes as f64 / (1 << 20) as f64,
        row.upload_ms,
        if row.exact_f64 { "correctly rounded (f64)" } else { "WGSL (2.5 ulp)" }
    );
    let n = row.segments as f64;
    let kernel =
        if row.kernel_ms > 0.0 { format!("{:.2} Mrays/s ({:.3} ms)", n / row.kernel_ms * 1e-3, row.kernel_ms) } else { "-".into() };
    let ratio = if row.kernel_ms > 0.0 && exact_kernel_ms > 0.0 {
        format!("{:.2}x the exact any-hit kernel", exact_kernel_ms / row.kernel_ms)
    } else {
        "-".into()
    };
    println!("{:<12} {kernel:>22} {:>22} {ratio}", "voxarray", format!("{:.2} Mrays/s", n / row.wall_ms * 1e-3));
    println!(
        "agreement of the GPU voxel array with the CPU voxel array: {:.4} % ({} differ)",
        100.0 - 100.0 * row.differ as f64 / n.max(1.0),
        row.differ
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_header_coefficients_are_fast_maths() {
        // atan_unit(1) = sum of the coefficients in the CPU's order: same bits iff same constants.
        let c = super::ATAN_COEFFICIENTS;
        for k in 0..=1000 {
            let x = k as f32 / 1000.0;
            let x2 = x * x;
            let poly = x * (c[0] + x2 * (c[1] + x2 * (c[2] + x2 * (c[3] + x2 * (c[4] + x2 * c[5])))));
            assert_eq!(poly.to_bits(), glimpse_core::fast_math::atan_unit(x).to_bits(), "x = {x}");
        }
    }
}

//! The DVF on the GPU (feature `gpu`; docs/gpu.md, "DVF"): the paper's compute passes rebuilt
//! every frame in WGSL (`gpu/*.wgsl`, beside this file) on the [`glimpse_gpu`] helper API, and
//! env-dvf's shading ([`GpuEnvDvf`]); [`bench()`] times a frame of it against the GPU `env-exact`
//! (`glimpse bench gpu`).
//!
//! Passes of one frame ([`GpuDvf::build`], timed by name):
//! 1. `areas` (CS1): per triangle, area and normal from the world-space vertices the CPU uploads
//!    (the paper's "CPU animation update", [`WorldMesh::gather`]).
//! 2. `upsweep`, `downsweep` (CS2, CS3): the Blelloch scan of the areas in blocks of
//!    2·`workgroup`, level by level ([`crate::scan::schedule`]).
//! 3. `counts`: Eq. (1) and each triangle's first global sample id, then `sample scan` (the same
//!    kernels over the integer counts: where each triangle's samples start) and `dispatch` (the
//!    indirect arguments of CS4, so the sample total never comes back to the CPU).
//! 4. `field` (CS4): one invocation per point sample: Eq. (2), the sample's rotation from its PCG
//!    stream, its N_r rays (both hemispheres with `sides=both`), each traced by glimpse-gpu's exact
//!    traversal (`trace.wgsl`) and OR-ed atomically into the cell's octahedral maps.
//! 5. `labels` (CS5): per cell, l_occ = N_occ > N_vis.
//!
//! The masks and labels are the CPU's bit for bit for the same parameters, seed and frame: every
//! float operation of the kernels is the CPU's in its operand order (`exact.wgsl`: products kept
//! from being fused, division and square root correctly rounded with integer arithmetic, sin/cos
//! as glibc's `__sincosf_fma` in f64), the random numbers are the CPU's PCG32 streams computed on
//! the GPU (64-bit integers as u32 pairs), the scan adds the same pairs as the CPU's, and Eq. (1)
//! is evaluated in f64 as on the CPU. This needs `SHADER_F64`; without it [`GpuDvf::new`] fails
//! with [`DvfGpuError::NoF64`]. Deviations from the paper's shaders: CS4 is one invocation per
//! sample looping over its N_r rays (the paper spreads a sample's rays over N_inv invocations), and
//! the masks are packed bits (u32 halves of the CPU's u64 words), not one R32 texel per pixel.

use crate::areas::WorldMesh;
use crate::bright::BrightDirections;
use crate::grid::{Grid, MAX_RESOLUTION};
use crate::{AutoBudget, DvfParams, Footprint, PointSampling, Rounding, Unshadowed};
use glimpse_core::sh::Sh9;
use glimpse_core::{Image, Vec2, Vec3};
use glimpse_gpu::compute::{Kernel, ReusableBuffer, hexd, hexf, read_back, storage_buffer, uniform_buffer, write};
use glimpse_gpu::layout::{BOX_EXIT_SCALE, TraceParams};
use glimpse_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, KernelTime, wgpu};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::SceneFrame;
use glimpse_trace::GBuffer;
use std::sync::Arc;
use thiserror::Error;

pub mod bench;
pub use bench::{DvfBench, bench};

const TRACE: &str = include_str!("../../gpu/src/trace.wgsl");
const EXACT_F64: &str = include_str!("../../gpu/src/exact_f64.wgsl");
const EXACT: &str = include_str!("gpu/exact.wgsl");
const BUILD: &str = include_str!("gpu/build.wgsl");
const SCAN: &str = include_str!("gpu/scan.wgsl");
const SHADE: &str = include_str!("gpu/shade.wgsl");

/// Invocations per workgroup of the one-dimensional kernels (`WG_1D` in build.wgsl).
const WORKGROUP: u32 = 64;

/// What the GPU DVF can fail with; nothing panics.
#[derive(Debug, Error)]
pub enum DvfGpuError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(
        "the GPU DVF needs 64-bit floats in shaders (SHADER_F64: Eq. (1) and glibc's sin/cos are evaluated in f64 as on the CPU); {0} has none"
    )]
    NoF64(String),
    #[error(
        "workgroup={asked}: the prefix-sum kernels need {asked} invocations and {bytes} bytes of workgroup memory per workgroup; the device allows {max_invocations} and {max_bytes}"
    )]
    Workgroup { asked: u32, bytes: u32, max_invocations: u32, max_bytes: u32 },
    #[error("octahedral={0}: the GPU DVF supports 1 to {MAX_RESOLUTION}")]
    Resolution(u32),
    #[error("{what} = {value}: more than the GPU build allows ({limit})")]
    TooLarge { what: &'static str, value: u64, limit: u64 },
    #[error("the DVF parameters still have automatic keys ({0:?}); choose them with DvfParams::for_frame first")]
    Automatic(AutoBudget),
    #[error("the GPU DVF was read before it was built")]
    NotBuilt,
}

impl From<DvfGpuError> for RenderError {
    fn from(e: DvfGpuError) -> Self {
        RenderError::Unsupported { technique: "env-dvf (GPU)".into(), message: e.to_string() }
    }
}

fn vec3_literal(v: [f32; 3]) -> String {
    format!("vec3<f32>({}, {}, {})", hexf(v[0]), hexf(v[1]), hexf(v[2]))
}

/// The CPU's constants, exactly: glibc's `__sincosf_table` entries (as `raybatch.rs` has them),
/// the f32 constants of the sampling code, and the hash's.
fn prelude() -> String {
    let d = |bits: u64| hexd(f64::from_bits(bits));
    let mut s = String::new();
    s += &format!("const HPI_INV: f64 = {};\nconst HPI: f64 = {};\n", d(0x4164_5f30_6dc9_c883), d(0x3ff9_21fb_5444_2d18));
    s += &format!("const C0: f64 = {};\n", hexd(1.0));
    for (name, bits) in [
        ("C1", 0xbfdf_ffff_fd0c_621c),
        ("S1", 0xbfc5_5554_5995_a603),
        ("C2", 0x3fa5_5553_e106_8f19),
        ("S2", 0x3f81_1076_0523_0bc4),
        ("C3", 0xbf56_c087_e89a_359d),
        ("S3", 0xbf29_94eb_3774_cf24),
        ("C4", 0x3ef9_9343_027b_f8c3),
    ] {
        s += &format!("const {name}: f64 = {};\n", d(bits));
    }
    for (name, v) in [
        ("HALF_PI", std::f32::consts::PI / 2.0),
        ("FRAC_PI_4", std::f32::consts::FRAC_PI_4),
        ("TAU", std::f32::consts::TAU),
        ("OFFSET", glimpse_core::ray::RAY_OFFSET),
        ("TINY", 1e-30),
        ("HASH_ADD", 33.33),
        ("BELOW_ONE", 1.0 - f32::EPSILON / 2.0),
    ] {
        s += &format!("const {name}: f32 = {};\n", hexf(v));
    }
    s += &format!("const HASH_SCALE: vec3<f32> = {};\n", vec3_literal([0.1031, 0.1030, 0.0973]));
    s += &format!("const HASH_STEP: vec3<f32> = {};\n", vec3_literal([7.31, 3.17, 5.13]));
    s
}

/// A kernel module over the exact traversal: trace.wgsl, its f64 edge fallback, the constants,
/// exact.wgsl, then `body`.
fn traced_source(body: &str) -> String {
    format!("{TRACE}\n{EXACT_F64}\n{}\n{EXACT}\n{body}", prelude())
}

fn scan_source(element: &str, workgroup: u32) -> String {
    format!("alias T = {element};\nconst WG: u32 = {workgroup}u;\n{SCAN}")
}

/// The build kernels' uniform (`Build` in build.wgsl).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct BuildUniform {
    counts: [u32; 4],
    rays: [u32; 4],
    cells: [u32; 4],
    misc: [u32; 4],
    rng: [u32; 4],
    grid: [f32; 4],
}

/// One level of a scan pass (`Level` in scan.wgsl).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct LevelUniform {
    src: u32,
    dst: u32,
    top: u32,
    pad: u32,
}

/// The shading kernel's uniform (`Shade` in shade.wgsl).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct ShadeUniform {
    size: [u32; 4],
    flags: [u32; 4],
    cells: [u32; 4],
    rng: [u32; 4],
    grid: [f32; 4],
    env: [f32; 4],
    /// `bright`'s luminance threshold (x; the rest 0).
    bright: [f32; 4],
    /// `footprint=around` (x = 1): the masks of the 2×2×2 cells around the fragment.
    lookup: [u32; 4],
    /// `bright`'s octahedral pixels at `bright::RESOLUTION` (32² bits), 32 to a word (all 0
    /// when off).
    bright_pixels: [[u32; 4]; crate::bright::WORDS / 2],
}

fn lo_hi(v: u64) -> [u32; 2] {
    [v as u32, (v >> 32) as u32]
}

/// The PCG state `Rng::new(seed, ·)` starts every stream from.
fn rng_state(seed: u64) -> [u32; 2] {
    lo_hi(glimpse_core::sampling::mix64(seed ^ 0x853c_49e6_748f_ea9b))
}

/// Workgroups `(x, y)` for `threads` invocations of 64, rows within the device's limit.
fn grid_2d(ctx: &GpuContext, threads: u64) -> Result<(u32, u32), DvfGpuError> {
    let max = ctx.limits.max_compute_workgroups_per_dimension.max(1) as u64;
    let groups = threads.div_ceil(WORKGROUP as u64);
    if groups == 0 {
        return Ok((0, 1));
    }
    let gx = groups.min(max);
    let gy = groups.div_ceil(gx);
    if gy > max {
        return Err(DvfGpuError::TooLarge { what: "invocations", value: threads, limit: max * max * WORKGROUP as u64 });
    }
    Ok((gx as u32, gy as u32))
}

fn pass<'e>(encoder: &'e mut wgpu::CommandEncoder, kernel: &Kernel, ts: Option<wgpu::ComputePassTimestampWrites>) -> wgpu::ComputePass<'e> {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&kernel.label), timestamp_writes: ts });
    pass.set_pipeline(&kernel.pipeline);
    pass
}

fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    kernel: &Kernel,
    bind: &wgpu::BindGroup,
    (gx, gy): (u32, u32),
    ts: Option<wgpu::ComputePassTimestampWrites>,
) {
    let mut p = pass(encoder, kernel, ts);
    p.set_bind_group(0, bind, &[]);
    p.dispatch_workgroups(gx, gy, 1);
}

/// The scan kernels for one workgroup size.
struct ScanKernels {
    workgroup: u32,
    up_f32: Kernel,
    down_f32: Kernel,
    up_u32: Kernel,
    down_u32: Kernel,
}

impl ScanKernels {
    fn new(ctx: &GpuContext, workgroup: u32) -> Result<Self, DvfGpuError> {
        let bytes = 2 * workgroup * 4;
        let l = &ctx.limits;
        if workgroup == 0
            || workgroup > l.max_compute_invocations_per_workgroup
            || workgroup > l.max_compute_workgroup_size_x
            || bytes > l.max_compute_workgroup_storage_size
        {
            return Err(DvfGpuError::Workgroup {
                asked: workgroup,
                bytes,
                max_invocations: l.max_compute_invocations_per_workgroup.min(l.max_compute_workgroup_size_x),
                max_bytes: l.max_compute_workgroup_storage_size,
            });
        }
        let (f, u) = (scan_source("f32", workgroup), scan_source("u32", workgroup));
        Ok(Self {
            workgroup,
            up_f32: Kernel::new(ctx, "upsweep", &f, "up_sweep")?,
            down_f32: Kernel::new(ctx, "downsweep", &f, "down_sweep")?,
            up_u32: Kernel::new(ctx, "sample scan up", &u, "up_sweep")?,
            down_u32: Kernel::new(ctx, "sample scan down", &u, "down_sweep")?,
        })
    }
}

/// The buffers of a frame, kept across frames (grown, never shrunk).
struct Buffers {
    vertices: ReusableBuffer,
    indices: ReusableBuffer,
    normals: ReusableBuffer,
    areas: ReusableBuffer,
    area_scan: ReusableBuffer,
    area_total: ReusableBuffer,
    count_scan: ReusableBuffer,
    count_total: ReusableBuffer,
    tri_info: ReusableBuffer,
    masks: ReusableBuffer,
    labels: ReusableBuffer,
    samples: ReusableBuffer,
    /// CS4's indirect dispatch arguments (storage, written by `dispatch_args`; indirect).
    indirect: wgpu::Buffer,
    build: wgpu::Buffer,
    trace: wgpu::Buffer,
}

impl Buffers {
    fn new(ctx: &GpuContext) -> Result<Self, DvfGpuError> {
        let b = |label: &str| ReusableBuffer::new(ctx, label, 16);
        Ok(Self {
            vertices: b("dvf vertices")?,
            indices: b("dvf indices")?,
            normals: b("dvf normals")?,
            areas: b("dvf areas")?,
            area_scan: b("dvf area scan")?,
            area_total: b("dvf area total")?,
            count_scan: b("dvf count scan")?,
            count_total: b("dvf sample total")?,
            tri_info: b("dvf triangle info")?,
            masks: b("dvf masks")?,
            labels: b("dvf labels")?,
            samples: b("dvf samples")?,
            indirect: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("dvf dispatch"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            build: uniform_buffer(ctx, "dvf build", &BuildUniform::zeroed()),
            trace: uniform_buffer(
                ctx,
                "dvf trace params",
                &TraceParams { ray_count: 0, node_count: 0, zero: 0, box_exit_scale: BOX_EXIT_SCALE },
            ),
        })
    }

    /// Every reusable buffer (for the reallocation count and the memory total).
    fn all(&self) -> [&ReusableBuffer; 12] {
        [
            &self.vertices,
            &self.indices,
            &self.normals,
            &self.areas,
            &self.area_scan,
            &self.area_total,
            &self.count_scan,
            &self.count_total,
            &self.tri_info,
            &self.masks,
            &self.labels,
            &self.samples,
        ]
    }
}

impl BuildUniform {
    fn zeroed() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

/// What the last build was made with.
#[derive(Clone, Debug)]
pub struct BuiltField {
    pub grid: Grid,
    pub params: DvfParams,
    pub triangles: usize,
    /// u64 words per mask, as `Masks::words_per_mask`.
    pub words_per_mask: usize,
}

impl BuiltField {
    pub fn cells(&self) -> usize {
        self.grid.cell_count()
    }

    fn words32(&self) -> usize {
        2 * self.words_per_mask
    }
}

/// One point sample as the GPU placed it (the debug read-back of [`GpuDvf::samples`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuSample {
    pub position: Vec3,
    pub cell: u32,
    /// The sample's random 2-D shift (its ray set's rotation).
    pub shift: Vec2,
    pub triangle: u32,
    /// Its index among the triangle's N(T_k) samples.
    pub index: u32,
}

/// The field's kernels and one frame's buffers.
pub struct GpuDvf {
    areas: Kernel,
    counts: Kernel,
    args: Kernel,
    samples: Kernel,
    field: Kernel,
    labels: Kernel,
    scans: Option<ScanKernels>,
    /// Per level of the current schedule: its uniform (shared by both scans).
    levels: Vec<wgpu::Buffer>,
    schedule: Vec<usize>,
    scene: Option<GpuScene>,
    buffers: Buffers,
    built: Option<BuiltField>,
    /// Buffer reallocations so far (0 after the first frame while sizes do not grow).
    reallocations: u64,
}

impl GpuDvf {
    /// Compiles the build kernels (the scan kernels are compiled for the workgroup size of the
    /// first build). Fails without `SHADER_F64`.
    pub fn new(ctx: &GpuContext) -> Result<Self, DvfGpuError> {
        if !ctx.features.contains(wgpu::Features::SHADER_F64) {
            return Err(DvfGpuError::NoF64(ctx.describe()));
        }
        let source = traced_source(BUILD);
        Ok(Self {
            areas: Kernel::new(ctx, "areas", &source, "areas_and_normals")?,
            counts: Kernel::new(ctx, "counts", &source, "counts")?,
            args: Kernel::new(ctx, "dispatch", &source, "dispatch_args")?,
            samples: Kernel::new(ctx, "samples", &source, "samples")?,
            field: Kernel::new(ctx, "field", &source, "field")?,
            labels: Kernel::new(ctx, "labels", &source, "occlusion_labels")?,
            scans: None,
            levels: Vec::new(),
            schedule: Vec::new(),
            scene: None,
            buffers: Buffers::new(ctx)?,
            built: None,
            reallocations: 0,
        })
    }

    /// The last build's settings, or an error before the first.
    pub fn built(&self) -> Result<&BuiltField, DvfGpuError> {
        self.built.as_ref().ok_or(DvfGpuError::NotBuilt)
    }

    /// Buffer reallocations since [`GpuDvf::new`] (the scene's included): unchanged by a frame
    /// whose sizes fit the previous one's.
    pub fn reallocations(&self) -> u64 {
        self.reallocations + self.scene.as_ref().map_or(0, |s| s.generation)
    }

    /// Bytes held on the GPU by the field and the scene.
    pub fn memory_bytes(&self) -> u64 {
        self.buffers.all().iter().map(|b| b.buffer.size()).sum::<u64>() + self.scene.as_ref().map_or(0, |s| s.memory_bytes())
    }

    /// Builds the field of `frame` as [`crate::Dvf::build`] does on the CPU (`p` with its
    /// automatic keys chosen, [`DvfParams::for_frame`]), the passes timed on `timer`. Returns
    /// once the work is submitted.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        ctx: &GpuContext,
        frame: &SceneFrame,
        back_instances: &[u32],
        p: &DvfParams,
        seed: u64,
        frame_index: u32,
        timer: &mut GpuTimer,
    ) -> Result<(), DvfGpuError> {
        if p.auto != AutoBudget::default() {
            return Err(DvfGpuError::Automatic(p.auto));
        }
        if p.octahedral == 0 || p.octahedral > MAX_RESOLUTION {
            return Err(DvfGpuError::Resolution(p.octahedral));
        }
        if self.scans.as_ref().is_none_or(|s| s.workgroup != p.workgroup) {
            self.scans = Some(ScanKernels::new(ctx, p.workgroup)?);
        }
        self.built = None;
        let mesh = WorldMesh::gather(frame, back_instances);
        let k = mesh.indices.len();
        let limit = u32::MAX as u64;
        if k as u64 + p.points as u64 >= limit {
            return Err(DvfGpuError::TooLarge {
                what: "triangles + points (the sample total's bound)",
                value: k as u64 + p.points as u64,
                limit,
            });
        }
        match &mut self.scene {
            Some(s) => s.update(ctx, frame, timer)?,
            None => self.scene = Some(GpuScene::new(ctx, frame, timer)?),
        }
        let grid = Grid::from_bounds(frame.bounds, p.grid);
        let cells = grid.cell_count();
        let words_per_mask = ((p.octahedral * p.octahedral) as usize).div_ceil(64);
        let words32 = 2 * words_per_mask;
        if (2 * cells * words32) as u64 >= limit {
            return Err(DvfGpuError::TooLarge { what: "mask words", value: (2 * cells * words32) as u64, limit });
        }

        // The scan's levels, one after another, each padded to whole blocks.
        let block = 2 * p.workgroup as usize;
        let schedule = crate::scan::schedule(k, p.workgroup as usize);
        let max_groups = ctx.limits.max_compute_workgroups_per_dimension as usize;
        if let Some(&g) = schedule.iter().find(|&&g| g > max_groups) {
            return Err(DvfGpuError::TooLarge { what: "prefix-sum workgroups in one pass", value: g as u64, limit: max_groups as u64 });
        }
        let offsets: Vec<usize> = schedule.iter().scan(0, |o, &g| Some(std::mem::replace(o, *o + g * block))).collect();
        let scan_len = offsets.last().map_or(0, |&o| o) + schedule.last().map_or(0, |&g| g * block);
        if schedule != self.schedule {
            self.levels = (0..schedule.len())
                .map(|l| {
                    let top = l + 1 == schedule.len();
                    let level =
                        LevelUniform { src: offsets[l] as u32, dst: if top { 0 } else { offsets[l + 1] as u32 }, top: top as u32, pad: 0 };
                    uniform_buffer(ctx, "dvf scan level", &level)
                })
                .collect();
            self.schedule = schedule.clone();
        }

        // Per-frame uploads and sizes (buffers grow only).
        let b = &mut self.buffers;
        let vertices: Vec<[f32; 4]> = mesh.vertices.iter().map(|v| v.extend(0.0).to_array()).collect();
        let indices: Vec<[u32; 4]> = mesh.indices.iter().zip(&mesh.back).map(|(t, &b)| [t[0], t[1], t[2], b as u32]).collect();
        let mut grew = b.vertices.upload(ctx, &vertices)? as u64;
        grew += b.indices.upload(ctx, &indices)? as u64;
        grew += b.normals.reserve(ctx, 16 * k as u64)? as u64;
        grew += b.areas.reserve(ctx, 4 * k as u64)? as u64;
        grew += b.area_scan.reserve(ctx, 4 * scan_len as u64)? as u64;
        grew += b.count_scan.reserve(ctx, 4 * scan_len as u64)? as u64;
        grew += b.tri_info.reserve(ctx, 16 * k as u64)? as u64;
        grew += b.masks.reserve(ctx, 4 * (2 * cells * words32) as u64)? as u64;
        grew += b.labels.reserve(ctx, 4 * cells as u64)? as u64;
        self.reallocations += grew;
        let scene = self.scene.as_ref().ok_or(DvfGpuError::NotBuilt)?;
        write(ctx, &b.trace, &[TraceParams { ray_count: 0, node_count: scene.node_count, zero: 0, box_exit_scale: BOX_EXIT_SCALE }])?;
        let uniform = BuildUniform {
            counts: [
                k as u32,
                p.points,
                match p.rounding {
                    Rounding::Ceil => 0,
                    Rounding::Round => 1,
                    Rounding::Cumulative => 2,
                },
                (p.sampling == PointSampling::Hammersley) as u32,
            ],
            rays: [if p.build_rays == 0 { p.rays } else { p.build_rays }, 0, p.rotate_about_normal as u32, p.octahedral],
            cells: [grid.dims[0], grid.dims[1], grid.dims[2], words32 as u32],
            misc: [cells as u32, frame_index, ctx.limits.max_compute_workgroups_per_dimension, 0],
            rng: {
                let [lo, hi] = rng_state(seed ^ 0xd1f_5eed);
                [lo, hi, 0, 0]
            },
            grid: [grid.origin.x, grid.origin.y, grid.origin.z, grid.cell_size_world],
        };
        write(ctx, &b.build, &[uniform])?;

        let scans = self.scans.as_ref().ok_or(DvfGpuError::NotBuilt)?;
        let bind = |kernel: &Kernel, entries: &[(u32, &wgpu::Buffer)]| kernel.bind(ctx, entries);
        let areas_bind = bind(
            &self.areas,
            &[
                (6, &b.build),
                (7, &b.vertices.buffer),
                (8, &b.indices.buffer),
                (9, &b.normals.buffer),
                (10, &b.areas.buffer),
                (11, &b.area_scan.buffer),
            ],
        );
        let counts_bind = bind(
            &self.counts,
            &[
                (6, &b.build),
                (10, &b.areas.buffer),
                (11, &b.area_scan.buffer),
                (12, &b.area_total.buffer),
                (13, &b.count_scan.buffer),
                (15, &b.tri_info.buffer),
            ],
        );
        let args_bind = bind(&self.args, &[(6, &b.build), (14, &b.count_total.buffer), (16, &b.indirect)]);
        let field_bind = bind(
            &self.field,
            &[
                (0, &scene.nodes.buffer),
                (1, &scene.triangles.buffer),
                (3, &b.trace),
                (6, &b.build),
                (7, &b.vertices.buffer),
                (8, &b.indices.buffer),
                (9, &b.normals.buffer),
                (13, &b.count_scan.buffer),
                (14, &b.count_total.buffer),
                (15, &b.tri_info.buffer),
                (17, &b.masks.buffer),
            ],
        );
        let labels_bind = bind(&self.labels, &[(6, &b.build), (17, &b.masks.buffer), (18, &b.labels.buffer)]);
        let scan_binds = |up: &Kernel, down: &Kernel, data: &wgpu::Buffer, total: &wgpu::Buffer| {
            // The down-sweep does not read the total, so its layout has no binding 2.
            let ups = self.levels.iter().map(|u| up.bind(ctx, &[(0, u), (1, data), (2, total)])).collect::<Vec<_>>();
            let downs = self.levels.iter().map(|u| down.bind(ctx, &[(0, u), (1, data)])).collect::<Vec<_>>();
            (ups, downs)
        };
        let (area_up, area_down) = scan_binds(&scans.up_f32, &scans.down_f32, &b.area_scan.buffer, &b.area_total.buffer);
        let (count_up, count_down) = scan_binds(&scans.up_u32, &scans.down_u32, &b.count_scan.buffer, &b.count_total.buffer);

        let tri_groups = grid_2d(ctx, k as u64)?;
        let cell_groups = grid_2d(ctx, cells as u64)?;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        // The paper's per-frame clears: the scans' padding, the totals, the masks.
        for buffer in [&b.area_scan, &b.count_scan, &b.area_total, &b.count_total, &b.masks] {
            encoder.clear_buffer(&buffer.buffer, 0, None);
        }
        dispatch(&mut encoder, &self.areas, &areas_bind, tri_groups, timer.pass("areas"));
        let sweep = |encoder: &mut wgpu::CommandEncoder,
                     up: &Kernel,
                     down: &Kernel,
                     ups: &[wgpu::BindGroup],
                     downs: &[wgpu::BindGroup],
                     timer: &mut GpuTimer| {
            for (l, &g) in schedule.iter().enumerate() {
                dispatch(encoder, up, &ups[l], (g as u32, 1), timer.pass(&up.label));
            }
            for (l, &g) in schedule.iter().enumerate().rev() {
                dispatch(encoder, down, &downs[l], (g as u32, 1), timer.pass(&down.label));
            }
        };
        sweep(&mut encoder, &scans.up_f32, &scans.down_f32, &area_up, &area_down, timer);
        dispatch(&mut encoder, &self.counts, &counts_bind, tri_groups, timer.pass("counts"));
        sweep(&mut encoder, &scans.up_u32, &scans.down_u32, &count_up, &count_down, timer);
        dispatch(&mut encoder, &self.args, &args_bind, (1, 1), timer.pass("dispatch"));
        {
            let mut p = pass(&mut encoder, &self.field, timer.pass("field"));
            p.set_bind_group(0, &field_bind, &[]);
            p.dispatch_workgroups_indirect(&b.indirect, 0);
        }
        dispatch(&mut encoder, &self.labels, &labels_bind, cell_groups, timer.pass("labels"));
        ctx.queue.submit([encoder.finish()]);
        ctx.check()?;
        self.built = Some(BuiltField { grid, params: *p, triangles: k, words_per_mask });
        Ok(())
    }

    /// The visible and occluded mask words, as the CPU's `Masks::snapshot` (u64 words).
    pub fn masks(&self, ctx: &GpuContext) -> Result<(Vec<u64>, Vec<u64>), DvfGpuError> {
        let f = self.built()?;
        let n = f.cells() * f.words32();
        let words: Vec<[u32; 2]> = read_back(ctx, &self.buffers.masks.buffer, n)?;
        let as_u64 = |w: &[[u32; 2]]| w.iter().map(|&[lo, hi]| lo as u64 | (hi as u64) << 32).collect();
        Ok((as_u64(&words[..n / 2]), as_u64(&words[n / 2..])))
    }

    /// l_occ per cell.
    pub fn labels(&self, ctx: &GpuContext) -> Result<Vec<u8>, DvfGpuError> {
        let f = self.built()?;
        Ok(read_back::<u32>(ctx, &self.buffers.labels.buffer, f.cells())?.into_iter().map(|l| l as u8).collect())
    }

    /// The per-triangle areas, their exclusive prefix sums and the total (CS1–CS3's results).
    pub fn areas(&self, ctx: &GpuContext) -> Result<(Vec<f32>, Vec<f32>, f32), DvfGpuError> {
        let f = self.built()?;
        let areas = read_back(ctx, &self.buffers.areas.buffer, f.triangles)?;
        let prefix = read_back(ctx, &self.buffers.area_scan.buffer, f.triangles)?;
        let total: Vec<f32> = read_back(ctx, &self.buffers.area_total.buffer, 1)?;
        Ok((areas, prefix, total[0]))
    }

    /// The per-triangle normals (CS1).
    pub fn normals(&self, ctx: &GpuContext) -> Result<Vec<Vec3>, DvfGpuError> {
        let f = self.built()?;
        let n: Vec<[f32; 4]> = read_back(ctx, &self.buffers.normals.buffer, f.triangles)?;
        Ok(n.into_iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect())
    }

    /// Per triangle: N(T_k) and the first global sample id (Eq. 1, `first_sample_id`).
    pub fn counts(&self, ctx: &GpuContext) -> Result<Vec<(u32, u64)>, DvfGpuError> {
        let f = self.built()?;
        let info: Vec<[u32; 4]> = read_back(ctx, &self.buffers.tri_info.buffer, f.triangles)?;
        Ok(info.into_iter().map(|[c, lo, hi, _]| (c, lo as u64 | (hi as u64) << 32)).collect())
    }

    /// Point samples placed this frame (Σ N(T_k)).
    pub fn sample_total(&self, ctx: &GpuContext) -> Result<u32, DvfGpuError> {
        self.built()?;
        Ok(read_back::<u32>(ctx, &self.buffers.count_total.buffer, 1)?[0])
    }

    /// Every point sample of the last build, in triangle order (runs the `samples` kernel, a
    /// debug pass that is not part of the build).
    pub fn samples(&mut self, ctx: &GpuContext) -> Result<Vec<GpuSample>, DvfGpuError> {
        let total = self.sample_total(ctx)? as usize;
        let b = &mut self.buffers;
        b.samples.reserve(ctx, 32 * total as u64)?;
        let bind = self.samples.bind(
            ctx,
            &[
                (6, &b.build),
                (7, &b.vertices.buffer),
                (8, &b.indices.buffer),
                (9, &b.normals.buffer),
                (13, &b.count_scan.buffer),
                (14, &b.count_total.buffer),
                (15, &b.tri_info.buffer),
                (19, &b.samples.buffer),
            ],
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        dispatch(&mut encoder, &self.samples, &bind, grid_2d(ctx, total as u64)?, None);
        ctx.queue.submit([encoder.finish()]);
        let raw: Vec<[u32; 8]> = read_back(ctx, &b.samples.buffer, total)?;
        Ok(raw
            .into_iter()
            .map(|r| GpuSample {
                position: Vec3::new(f32::from_bits(r[0]), f32::from_bits(r[1]), f32::from_bits(r[2])),
                cell: r[3],
                shift: Vec2::new(f32::from_bits(r[4]), f32::from_bits(r[5])),
                triangle: r[6],
                index: r[7],
            })
            .collect())
    }
}

/// `env-dvf` on the GPU: [`GpuDvf`] rebuilt in `prepare`, the masked shading in `render`, as the
/// CPU technique ([`crate::technique::EnvDvf`]) computes them for the same parameters and seed.
pub struct GpuEnvDvf {
    ctx: Arc<GpuContext>,
    pub params: DvfParams,
    pub settings: Settings,
    pub dvf: GpuDvf,
    shade: Kernel,
    /// The environment's SH (projected on the first `prepare`, as the CPU's).
    pub sh: Option<Sh9>,
    pub map_noise: Option<f32>,
    /// The map's brightest directions (with the SH, as the CPU's).
    pub bright: Option<BrightDirections>,
    env: Option<EnvBuffers>,
    gbuffer: ReusableBuffer,
    image: ReusableBuffer,
    uniform: wgpu::Buffer,
    frame_index: u32,
    times: Vec<KernelTime>,
}

/// The environment map's texels and its SH coefficients on the GPU.
struct EnvBuffers {
    texels: wgpu::Buffer,
    sh: wgpu::Buffer,
    size: [f32; 4],
}

impl GpuEnvDvf {
    /// Reads the same keys as the CPU `env-dvf` ([`DvfParams::read`]) and compiles the kernels.
    pub fn new(ctx: Arc<GpuContext>, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let params = DvfParams::default().read(params)?;
        Self::with_params(ctx, settings, params).map_err(RenderError::from)
    }

    pub fn with_params(ctx: Arc<GpuContext>, settings: &Settings, params: DvfParams) -> Result<Self, DvfGpuError> {
        let dvf = GpuDvf::new(&ctx)?;
        let shade = Kernel::new(&ctx, "shade", &traced_source(SHADE), "shade_pixels")?;
        let gbuffer = ReusableBuffer::new(&ctx, "dvf gbuffer", 16)?;
        let image = ReusableBuffer::new(&ctx, "dvf image", 16)?;
        let uniform = uniform_buffer(&ctx, "dvf shade", &ShadeUniform::zeroed());
        Ok(Self {
            ctx,
            params,
            settings: *settings,
            dvf,
            shade,
            sh: None,
            map_noise: None,
            bright: None,
            env: None,
            gbuffer,
            image,
            uniform,
            frame_index: 0,
            times: Vec::new(),
        })
    }

    /// Reads the keys anew (as [`GpuEnvDvf::new`]) without recompiling the kernels; the
    /// environment's SH and `unshadowed=auto`'s choice are made again on the next `prepare`.
    pub fn set_params(&mut self, params: &Params) -> Result<(), RenderError> {
        self.params = DvfParams::default().read(params)?;
        (self.sh, self.map_noise, self.bright, self.env) = (None, None, None, None);
        Ok(())
    }

    /// Per-kernel GPU times of the last `prepare` and `render` (timestamps; empty without them).
    pub fn last_times(&self) -> &[KernelTime] {
        &self.times
    }

    /// Builds the field for a `width × height` frame (the automatic keys chosen as the CPU
    /// technique chooses them), and waits for it.
    /// `back_instances` as [`crate::Dvf::build`]'s ([`DvfParams::back_instances`]).
    pub fn prepare_frame(
        &mut self,
        frame: &SceneFrame,
        back_instances: &[u32],
        width: u32,
        height: u32,
        frame_index: u32,
    ) -> Result<Stats, DvfGpuError> {
        let ctx = self.ctx.clone();
        let mut stats = Stats::default();
        if let (None, Some(env)) = (&self.sh, frame.scene.environment.as_ref()) {
            let sh = stats.time("sh", || crate::technique::project_environment(env));
            if self.params.wants_map_noise() {
                // Chosen after the build, with the field's occlusion (as the CPU technique).
                self.map_noise = Some(stats.time("map noise", || crate::cosine_estimator_noise(env, self.params.rays)));
            }
            self.bright = stats.time("bright", || self.params.bright_directions(env));
            let texels: Vec<[f32; 4]> = env.image.pixels.iter().map(|p| p.extend(0.0).to_array()).collect();
            let coeffs: Vec<[f32; 4]> = sh.coeffs.iter().map(|c| c.extend(0.0).to_array()).collect();
            self.env = Some(EnvBuffers {
                texels: storage_buffer(&ctx, "dvf environment", &texels)?,
                sh: storage_buffer(&ctx, "dvf sh", &coeffs)?,
                size: [env.image.width as f32, env.image.height as f32, env.scale, 1.0],
            });
            self.sh = Some(sh);
        }
        let p = self.params.for_frame(width as u64 * height as u64, frame.scene.triangle_count());
        let mut timer = GpuTimer::new(&ctx, 64);
        let t = std::time::Instant::now();
        self.dvf.build(&ctx, frame, back_instances, &p, self.settings.seed, frame_index, &mut timer)?;
        stats.metrics.push(("back_side_instances".to_owned(), back_instances.len() as f64));
        ctx.wait()?;
        stats.stage("gpu build", t.elapsed().as_secs_f64() * 1e3);
        self.times = timer.finish(&ctx)?;
        self.frame_index = frame_index;
        stats.metrics.push(("points".to_owned(), p.points as f64));
        stats.metrics.push(("grid".to_owned(), p.grid as f64));
        if let (Some(noise), true) = (self.map_noise, self.params.auto.unshadowed) {
            let (visible, occluded) = self.dvf.masks(&ctx)?;
            let words = visible.len() / self.dvf.built()?.cells().max(1);
            let seen = |c: usize| visible[c * words..(c + 1) * words].iter().chain(&occluded[c * words..(c + 1) * words]).any(|&w| w != 0);
            let fraction = crate::occluded_cell_fraction(&self.dvf.labels(&ctx)?, seen);
            self.params.unshadowed = crate::choose_unshadowed(noise, fraction);
            stats.metrics.push(("occluded_cells".to_owned(), fraction as f64));
        }
        if let (Some(noise), true) = (self.map_noise, self.params.auto.bright) {
            self.params.bright = crate::choose_bright(noise);
        }
        stats.memory_bytes = self.dvf.memory_bytes() as usize;
        Ok(stats)
    }

    /// Shades every pixel of `gbuffer` with the field built last.
    pub fn render_gbuffer(&mut self, gbuffer: &GBuffer) -> Result<Image, DvfGpuError> {
        let ctx = self.ctx.clone();
        let f = self.dvf.built()?.clone();
        let scene = self.dvf.scene.as_ref().ok_or(DvfGpuError::NotBuilt)?;
        let n = gbuffer.len();
        if n as u64 >= u32::MAX as u64 / 5 {
            return Err(DvfGpuError::TooLarge { what: "pixels", value: n as u64, limit: u32::MAX as u64 / 5 });
        }
        let mut packed: Vec<[f32; 4]> = Vec::with_capacity(5 * n);
        for i in 0..n {
            let hit = gbuffer.is_hit(i);
            let v = |v: Vec3| v.extend(0.0).to_array();
            packed.push(gbuffer.position[i].extend(f32::from_bits(hit as u32)).to_array());
            // The normal's w: the position's error scale (the ray offset's scale).
            packed.push(if hit { gbuffer.normal[i].extend(gbuffer.error_scale[i]).to_array() } else { v(gbuffer.view_dir[i]) });
            packed.push(v(gbuffer.shading_normal[i]));
            packed.push(v(gbuffer.albedo[i]));
            packed.push(v(gbuffer.emission[i]));
        }
        self.gbuffer.upload(&ctx, &packed)?;
        self.image.reserve(&ctx, 16 * n as u64)?;
        // Without an environment the masks still select rays, but every radiance is 0.
        let empty = [[0.0f32; 4]; 9];
        let fallback;
        let env = match &self.env {
            Some(e) => e,
            None => {
                fallback = EnvBuffers {
                    texels: storage_buffer(&ctx, "dvf environment", &empty[..1])?,
                    sh: storage_buffer(&ctx, "dvf sh", &empty)?,
                    size: [1.0, 1.0, 0.0, 0.0],
                };
                &fallback
            }
        };
        let p = &f.params;
        let bright = self.bright.as_ref().filter(|_| self.params.bright);
        let mut bright_pixels = [[0u32; 4]; crate::bright::WORDS / 2];
        for (w, &word) in bright.map_or(&[0u64; crate::bright::WORDS], |b| &b.pixels).iter().enumerate() {
            bright_pixels[w / 2][2 * (w % 2)..2 * (w % 2) + 2].copy_from_slice(&lo_hi(word));
        }
        let [lo, hi] = rng_state(self.settings.seed);
        let [pass_lo, pass_hi] = lo_hi(self.frame_index as u64);
        let uniform = ShadeUniform {
            size: [n as u32, p.rays, p.rotate_about_normal as u32, p.octahedral],
            // E_unshad's source is chosen after the build (`unshadowed=auto`), so it is read from
            // the technique's parameters, not the field's.
            flags: [(self.params.unshadowed == Unshadowed::Rays) as u32, p.trace_unknown as u32, f.words32() as u32, 0],
            cells: [f.grid.dims[0], f.grid.dims[1], f.grid.dims[2], f.cells() as u32],
            rng: [lo, hi, pass_lo, pass_hi],
            grid: [f.grid.origin.x, f.grid.origin.y, f.grid.origin.z, f.grid.cell_size_world],
            env: env.size,
            bright: [bright.map_or(f32::INFINITY, |b| b.threshold), 0.0, 0.0, 0.0],
            lookup: [(p.footprint == Footprint::Around) as u32, 0, 0, 0],
            bright_pixels,
        };
        write(&ctx, &self.uniform, &[uniform])?;
        let b = &self.dvf.buffers;
        let bind = self.shade.bind(
            &ctx,
            &[
                (0, &scene.nodes.buffer),
                (1, &scene.triangles.buffer),
                (3, &b.trace),
                (6, &self.uniform),
                (7, &self.gbuffer.buffer),
                (8, &env.texels),
                (9, &env.sh),
                (10, &b.masks.buffer),
                (11, &b.labels.buffer),
                (12, &self.image.buffer),
            ],
        );
        let mut timer = GpuTimer::new(&ctx, 1);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        dispatch(&mut encoder, &self.shade, &bind, grid_2d(&ctx, n as u64)?, timer.pass("shade"));
        ctx.queue.submit([encoder.finish()]);
        let pixels: Vec<[f32; 4]> = read_back(&ctx, &self.image.buffer, n)?;
        self.times.retain(|t| t.name != "shade");
        self.times.extend(timer.finish(&ctx)?);
        let mut image = Image::new(gbuffer.width, gbuffer.height);
        for (out, p) in image.pixels.iter_mut().zip(pixels) {
            *out = Vec3::new(p[0], p[1], p[2]);
        }
        Ok(image)
    }
}

impl ShadeUniform {
    fn zeroed() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

/// The CLI's entry point: `env-dvf` with the field and the shading on the GPU.
impl Technique for GpuEnvDvf {
    fn id(&self) -> &'static str {
        "env-dvf"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        glimpse_render::technique::require(ctx.frame.scene, "env-dvf", glimpse_render::technique::Need::Environment)?;
        Ok(self.prepare_frame(&ctx.frame, &self.params.back_instances_in(ctx), ctx.width, ctx.height, ctx.frame_index)?)
    }

    fn render(&mut self, _ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported {
                technique: "env-dvf".into(),
                message: format!("image is {}x{} but the GBuffer is {}x{}", out.width, out.height, gbuffer.width, gbuffer.height),
            });
        }
        let mut stats = Stats::default();
        let image = stats.time("shade", || self.render_gbuffer(gbuffer))?;
        out.pixels.copy_from_slice(&image.pixels);
        stats.memory_bytes = self.dvf.memory_bytes() as usize;
        Ok(stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rng_state_is_rngs() {
        // Rng::new(seed, stream) starts from mix64(seed ^ 0x853c…): the state the kernels get.
        let [lo, hi] = rng_state(42);
        assert_eq!(lo as u64 | (hi as u64) << 32, glimpse_core::sampling::mix64(42 ^ 0x853c_49e6_748f_ea9b));
    }
}

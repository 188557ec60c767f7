//! ROMA on the GPU (feature `gpu`; docs/gpu.md, "ROMA"): the BOM (§3.1), Generate (Alg. 1) and
//! the snapped any-hit and closest-hit of Alg. 2 and the un-snapped DDA any-hit as WGSL compute
//! kernels (`gpu/*.wgsl`, beside
//! this file), on the [`glimpse_gpu`] helper API.
//!
//! The GPU build is the CPU build, bit for bit: the grid, the jitter and the candidates come from
//! the same CPU code ([`crate::frame_grid_and_candidates`]), the OM axes and world → map
//! transforms are computed on the CPU and uploaded, and every float operation of the kernels is
//! the CPU's, one for one, in the same operand order. Where the CPU divides or takes a square
//! root, the kernels call `div_exact` / `sqrt_exact` (`gpu/common.wgsl`), which compute the
//! correctly rounded result with integer arithmetic: Vulkan allows 2.5 ulp of error in division.
//! The CPU's f32 constants are handed to WGSL as exact hex-float literals ([`wgsl_prelude`]).
//! Two things the WGSL cannot promise and the tests measure instead: a driver may fuse `a·b + c`
//! into an fma (lavapipe does not), and may flush subnormals (no value here is near one).
//!
//! Layout: 128-bit words as `vec4<u32>` (`.x` = bits 0–31, as a little-endian `u128`; slice `s`
//! at bit `127 − s`), BOM word `y·R + x`, OMs layer-major (word `k·R² + y·R + x`), exactly the
//! CPU's `Vec<u128>`s, so a read-back is compared word for word. Only resolution 128 (the
//! paper's) is supported on the GPU; other resolutions are an error.
//!
//! Kernels: `voxelize` (one invocation per triangle, axis pass and texel row; atomic OR into the
//! BOM's u32s), `generate` (one per texel of every OM), `query` (one per ray: stratum selection,
//! transform, slice range, bit test; modes any-hit, `occluded_ray`, closest hit), `dda` (one per
//! segment: `RomaMaps::any_hit_unsnapped`, the clip and the texel walk).
//!
//! `focus=auto` ([`GpuRoma::build_frame`], as [`crate::Roma::build`]): the kernels build the
//! grid around all but the scene's supporting planes, and those planes are traced by the exact
//! GPU tracer ([`glimpse_gpu::GpuTracer`], the CPU's watertight test bit for bit) in a second
//! pass over each batch's queries: the snapped rays are made on the CPU from the same
//! candidates, and the answers combined as the CPU's queries combine them.

use crate::directions::CandidateSet;
use crate::grid::om_axes;
use crate::weighting::SnappedSample;
use crate::{Grid, MapTransform, RomaParams, frame_grid_and_candidates, occluded_exact_ray};
use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Aabb, Frame, Image, Ray, Rng, Vec3};
use glimpse_gpu::compute::{Kernel, ReusableBuffer, hexf, read_back, storage_buffer, storage_buffer_zeroed, uniform_buffer};
use glimpse_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, GpuTracer, KernelTime, wgpu};
use glimpse_render::focus::FocusCache;
use glimpse_scene::SceneFrame;
use glimpse_trace::GBuffer;

/// `ao-roma`, `soft-roma` and `gi-roma` as `Technique`s on the GPU (`--device gpu`).
#[path = "gpu_technique.rs"]
pub mod technique;

/// The one positional resolution the GPU kernels support (words of 128 bits).
pub const GPU_RESOLUTION: u32 = 128;
const WORKGROUP: u32 = 64;

const COMMON: &str = include_str!("gpu/common.wgsl");
const BOM: &str = include_str!("gpu/bom.wgsl");
const GENERATE: &str = include_str!("gpu/generate.wgsl");
const QUERY: &str = include_str!("gpu/query.wgsl");
const DDA: &str = include_str!("gpu/dda.wgsl");

/// `fast_math::atan_unit`'s coefficients (checked against it by a unit test).
const ATAN: [f32; 6] = [0.999_977_26, -0.332_623_47, 0.193_543_46, -0.116_432_87, 0.052_653_32, -0.011_721_2];

/// The constants every kernel reads: the resolution and the CPU's f32 constants, exactly.
pub fn wgsl_prelude() -> String {
    let r = GPU_RESOLUTION;
    let mut s = format!("const RESOLUTION: u32 = {r}u;\nconst HALF: f32 = {};\n", hexf(r as f32 * 0.5));
    s += &format!("const AREA_EPS: f32 = {};\nconst STEP_EPS: f32 = {};\n", hexf(1e-12), hexf(1e-9));
    for (i, c) in ATAN.iter().enumerate() {
        s += &format!("const ATAN_C{i}: f32 = {};\n", hexf(*c));
    }
    s += &format!("const INV_FRAC_PI_4: f32 = {};\n", hexf(1.0 / std::f32::consts::FRAC_PI_4));
    s
}

/// The prelude and the shared functions (`div_exact`, `sqrt_exact`, the word helpers), for
/// kernels built on them (the parity tests check the exact arithmetic with one).
pub fn wgsl_library() -> String {
    format!("{}\n{COMMON}\n", wgsl_prelude())
}

fn source(kernel: &str) -> String {
    format!("{}{kernel}", wgsl_library())
}

#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct BomParams {
    center_cell: [f32; 4],
    counts: [u32; 4],
}

#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct GenerateParams {
    counts: [u32; 4],
}

#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct QueryParams {
    counts: [u32; 4],
    scales: [f32; 4],
}

/// One ray as the query kernel reads it (`Query` in `query.wgsl`), 32 bytes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuQuery {
    pub origin: [f32; 3],
    pub t_max: f32,
    pub dir: [f32; 3],
    pub pad: f32,
}

impl GpuQuery {
    pub fn new(origin: Vec3, dir: Vec3, t_max: f32) -> Self {
        Self { origin: origin.to_array(), t_max, dir: dir.to_array(), pad: 0.0 }
    }

    /// The segment `from → to` as the `dda` kernel reads it (`origin` = from, `dir` = to).
    pub fn segment(from: Vec3, to: Vec3) -> Self {
        Self::new(from, to, 0.0)
    }
}

/// What the query kernel computes per ray (`counts.w` in `query.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// `select(dir)`, then [`crate::RomaMaps::any_hit_snapped`] from the origin as given.
    AnyHit = 0,
    /// [`crate::RomaMaps::occluded_ray`]: origin offset along the snapped direction, `t_max`
    /// shortened at both ends.
    Occluded = 1,
    /// `select(dir)`, then [`crate::RomaMaps::closest_hit_snapped`].
    ClosestHit = 2,
}

/// Which kernel a batch runs, and the `counts.w` it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pass {
    Query(Mode),
    /// The `dda` kernel with at most this many texel fetches.
    Dda(u32),
}

/// One frame's ROMA in GPU buffers, and what the CPU made for it.
pub struct GpuRomaFrame {
    pub grid: Grid,
    pub candidates: CandidateSet,
    pub to_map: Vec<MapTransform>,
    pub origin_offset_cells: f32,
    /// R² words of 16 bytes.
    pub bom: wgpu::Buffer,
    /// n²·R² words of 16 bytes, layer-major.
    pub maps: wgpu::Buffer,
    to_map_rows: wgpu::Buffer,
}

/// The kernels, the current frame's buffers, and the query buffers (reused across batches).
pub struct GpuRoma {
    voxelize: Kernel,
    generate: Kernel,
    query: Kernel,
    dda: Kernel,
    frame: Option<GpuRomaFrame>,
    queries: Option<ReusableBuffer>,
    results: Option<ReusableBuffer>,
    /// The supporting planes a focused grid leaves out, and the exact tracer for them (compiled
    /// at the first focused frame).
    exact: Option<GpuScene>,
    exact_tracer: Option<GpuTracer>,
    /// The focus's share of the scene's diagonal, where the last frame was focused.
    pub focus_share: Option<f32>,
    focus: FocusCache,
    /// Kernel times of the last query batch (empty without timestamp queries).
    pub last_times: Vec<KernelTime>,
}

/// Workgroups `(x, y)` covering `threads` invocations, and the invocations per row of `x`.
fn grid_2d(ctx: &GpuContext, threads: u64) -> Result<(u32, u32, u32), GpuError> {
    let max = ctx.limits.max_compute_workgroups_per_dimension.max(1) as u64;
    let groups = threads.div_ceil(WORKGROUP as u64).max(1);
    let gx = groups.min(max);
    let gy = groups.div_ceil(gx);
    if gy > max {
        return Err(GpuError::Validation(format!("{threads} invocations exceed the device's {max}×{max} workgroups")));
    }
    Ok((gx as u32, gy as u32, (gx * WORKGROUP as u64) as u32))
}

fn dispatch_2d(
    encoder: &mut wgpu::CommandEncoder,
    kernel: &Kernel,
    bind: &wgpu::BindGroup,
    (gx, gy): (u32, u32),
    timestamps: Option<wgpu::ComputePassTimestampWrites>,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&kernel.label), timestamp_writes: timestamps });
    pass.set_pipeline(&kernel.pipeline);
    pass.set_bind_group(0, bind, &[]);
    pass.dispatch_workgroups(gx, gy, 1);
}

impl GpuRoma {
    /// Compiles the kernels (errors carry the WGSL compiler's message).
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        Ok(Self {
            voxelize: Kernel::new(ctx, "roma bom", &source(BOM), "voxelize")?,
            generate: Kernel::new(ctx, "roma generate", &source(GENERATE), "generate")?,
            query: Kernel::new(ctx, "roma query", &source(QUERY), "query")?,
            dda: Kernel::new(ctx, "roma dda", &format!("{}{DDA}", source(QUERY)), "dda")?,
            frame: None,
            queries: None,
            results: None,
            exact: None,
            exact_tracer: None,
            focus_share: None,
            focus: FocusCache::default(),
            last_times: Vec::new(),
        })
    }

    /// One frame of `frame`, as [`crate::Roma::build`]: with `params.focus`, the grid around all
    /// but the supporting planes (where that pays), which are uploaded for the exact pass.
    pub fn build_frame(
        &mut self,
        ctx: &GpuContext,
        frame: &SceneFrame,
        params: &RomaParams,
        seed: u64,
        frame_index: u32,
        timer: &mut GpuTimer,
    ) -> Result<(), GpuError> {
        let triangles = frame.occluding_triangles();
        let focus = if params.focus { self.focus.for_all_rays(frame, &triangles) } else { None };
        let Some(focus) = focus else {
            return self.build(ctx, &triangles, frame.bounds, params, seed, frame_index, timer);
        };
        let (inside, exact) = focus.split(&triangles);
        self.build(ctx, &inside, focus.bounds, params, seed, frame_index, timer)?;
        if self.exact_tracer.is_none() {
            self.exact_tracer = Some(GpuTracer::new(ctx)?);
        }
        self.exact = Some(GpuScene::from_triangles(ctx, exact.triangles(), timer)?);
        self.focus_share = Some(focus.share_of(frame.bounds));
        Ok(())
    }

    /// Bytes of the current frame's buffers (the maps, the BOM, the exact planes).
    pub fn memory_bytes(&self) -> Result<u64, GpuError> {
        let f = self.frame()?;
        Ok(f.bom.size() + f.maps.size() + self.exact.as_ref().map_or(0, GpuScene::memory_bytes))
    }

    /// The exact pass of a focused frame over the queries the grid left unblocked: `ray` makes
    /// each query's exact ray from the frame's candidates (`None`: nothing to test).
    fn exact_any(
        &mut self,
        ctx: &GpuContext,
        queries: &[GpuQuery],
        blocked: &mut [bool],
        ray: impl Fn(&GpuRomaFrame, &GpuQuery) -> Option<(Ray, f32)>,
    ) -> Result<(), GpuError> {
        let (Some(scene), Some(tracer), Some(f)) = (&self.exact, &mut self.exact_tracer, &self.frame) else {
            return Ok(());
        };
        let (which, rays): (Vec<usize>, Vec<(Ray, f32)>) =
            queries.iter().enumerate().filter(|(i, _)| !blocked[*i]).filter_map(|(i, q)| Some((i, ray(f, q)?))).unzip();
        for (i, b) in which.into_iter().zip(tracer.occluded(ctx, scene, &rays)?) {
            blocked[i] |= b;
        }
        Ok(())
    }

    /// The frame built last, or an error before the first [`GpuRoma::build`].
    pub fn frame(&self) -> Result<&GpuRomaFrame, GpuError> {
        self.frame.as_ref().ok_or_else(|| GpuError::Validation("GPU ROMA queried before it was built".into()))
    }

    /// Builds one frame from world-space triangles within `bounds`, as
    /// [`crate::Roma::build_from_triangles`] does on the CPU: the BOM (`Voxelization::PAPER`),
    /// then the n² OMs. The kernels are timed as "roma bom" and "roma generate" on `timer`.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        ctx: &GpuContext,
        triangles: &[[Vec3; 3]],
        bounds: Aabb,
        params: &RomaParams,
        seed: u64,
        frame_index: u32,
        timer: &mut GpuTimer,
    ) -> Result<(), GpuError> {
        if params.resolution != GPU_RESOLUTION {
            return Err(GpuError::Validation(format!("GPU ROMA supports resolution {GPU_RESOLUTION} only (asked: {})", params.resolution)));
        }
        if params.voxelization != crate::Voxelization::PAPER {
            return Err(GpuError::Validation("GPU ROMA supports the paper's voxelization only (voxelization=sampled)".into()));
        }
        if params.n == 0 || params.n > 32 {
            return Err(GpuError::Validation(format!("n = {}: must be 1 to 32", params.n)));
        }
        (self.frame, self.exact, self.focus_share) = (None, None, None);
        let (grid, candidates) = frame_grid_and_candidates(bounds, params, seed, frame_index);
        let axes: Vec<Frame> = candidates.dirs.iter().map(|&d| om_axes(d)).collect();
        let to_map: Vec<MapTransform> = axes.iter().map(|a| MapTransform::new(&grid, a)).collect();
        let r2 = (GPU_RESOLUTION * GPU_RESOLUTION) as u64;
        let maps_count = axes.len() as u64;

        let tri_data: Vec<[f32; 4]> = triangles.iter().flat_map(|t| t.map(|p| p.extend(0.0).to_array())).collect();
        let tri_buffer = storage_buffer(ctx, "roma triangles", &tri_data)?;
        let bom = storage_buffer_zeroed(ctx, "roma bom", r2 * 16)?;
        let maps = storage_buffer_zeroed(ctx, "roma maps", maps_count * r2 * 16)?;
        let axes_data: Vec<[f32; 4]> = axes.iter().flat_map(|a| [a.x, a.y, a.z].map(|v| v.extend(0.0).to_array())).collect();
        let axes_buffer = storage_buffer(ctx, "roma axes", &axes_data)?;
        let rows: Vec<[f32; 4]> = to_map.iter().flat_map(|t| t.rows.map(|r| r.to_array())).collect();
        let to_map_rows = storage_buffer(ctx, "roma to_map", &rows)?;

        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if !triangles.is_empty() {
            let threads = triangles.len() as u64 * 3 * GPU_RESOLUTION as u64;
            if triangles.len() as u64 >= u32::MAX as u64 / (3 * GPU_RESOLUTION as u64) {
                return Err(GpuError::Validation(format!(
                    "{} triangles: too many for the BOM kernel's 32-bit invocation index",
                    triangles.len()
                )));
            }
            let (gx, gy, stride) = grid_2d(ctx, threads)?;
            let c = grid.center;
            let uniform = uniform_buffer(
                ctx,
                "roma bom params",
                &BomParams { center_cell: [c.x, c.y, c.z, grid.cell_size_world], counts: [triangles.len() as u32, stride, 0, 0] },
            );
            let bind = self.voxelize.bind(ctx, &[(0, &uniform), (1, &tri_buffer), (2, &bom)]);
            dispatch_2d(&mut encoder, &self.voxelize, &bind, (gx, gy), timer.pass("roma bom"));
        }
        let (gx, gy, stride) = grid_2d(ctx, maps_count * r2)?;
        let uniform = uniform_buffer(ctx, "roma generate params", &GenerateParams { counts: [maps_count as u32, stride, 0, 0] });
        let bind = self.generate.bind(ctx, &[(0, &uniform), (1, &axes_buffer), (2, &bom), (3, &maps)]);
        dispatch_2d(&mut encoder, &self.generate, &bind, (gx, gy), timer.pass("roma generate"));
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        self.frame =
            Some(GpuRomaFrame { grid, candidates, to_map, origin_offset_cells: params.origin_offset_cells, bom, maps, to_map_rows });
        Ok(())
    }

    /// The BOM's words, read back (word `y·R + x`, as `OccupancyMap::<u128>::words`).
    pub fn bom_words(&self, ctx: &GpuContext) -> Result<Vec<u128>, GpuError> {
        let f = self.frame()?;
        read_back(ctx, &f.bom, (GPU_RESOLUTION * GPU_RESOLUTION) as usize)
    }

    /// Every OM's words, read back (layer-major, as `RomaMaps::<u128>::maps`).
    pub fn map_words(&self, ctx: &GpuContext) -> Result<Vec<u128>, GpuError> {
        let f = self.frame()?;
        read_back(ctx, &f.maps, f.candidates.len() * (GPU_RESOLUTION * GPU_RESOLUTION) as usize)
    }

    /// Snapped any-hit of `(origin, dir, t_max)`: the stratum of `dir`, then
    /// [`crate::RomaMaps::any_hit_snapped`] from `origin` as given (no offset), as `ao-roma` does.
    pub fn any_hit_snapped(&mut self, ctx: &GpuContext, queries: &[GpuQuery]) -> Result<Vec<bool>, GpuError> {
        let mut blocked: Vec<bool> = self.run(ctx, Pass::Query(Mode::AnyHit), queries)?.into_iter().map(|r| r != 0).collect();
        self.exact_any(ctx, queries, &mut blocked, |f, q| Some((Ray::new(q.origin.into(), snapped(f, q)), q.t_max)))?;
        Ok(blocked)
    }

    /// [`crate::RomaMaps::occluded_ray`] (the [`glimpse_trace::Visibility`] answer) for each ray.
    pub fn occluded(&mut self, ctx: &GpuContext, rays: &[(Ray, f32)]) -> Result<Vec<bool>, GpuError> {
        let queries: Vec<GpuQuery> = rays.iter().map(|(r, t)| GpuQuery::new(r.origin, r.dir, *t)).collect();
        let mut blocked: Vec<bool> = self.run(ctx, Pass::Query(Mode::Occluded), &queries)?.into_iter().map(|r| r != 0).collect();
        self.exact_any(ctx, &queries, &mut blocked, |f, q| {
            occluded_exact_ray(snapped(f, q), q.origin.into(), q.t_max, f.origin_offset_cells * f.grid.cell_size_world)
        })?;
        Ok(blocked)
    }

    /// Snapped closest hit of `(origin, dir, t_max)`: the stratum of `dir`, then
    /// [`crate::RomaMaps::closest_hit_snapped`] (world distance along the snapped direction).
    pub fn closest_hit_snapped(&mut self, ctx: &GpuContext, queries: &[GpuQuery]) -> Result<Vec<Option<f32>>, GpuError> {
        let mut hits: Vec<Option<f32>> = self
            .run(ctx, Pass::Query(Mode::ClosestHit), queries)?
            .into_iter()
            .map(|r| (r != u32::MAX).then(|| f32::from_bits(r)))
            .collect();
        // The exact planes: the nearer of the two, as `RomaMaps::closest_hit_snapped`.
        if let (Some(scene), Some(tracer), Some(f)) = (&self.exact, &mut self.exact_tracer, &self.frame) {
            let rays: Vec<(Ray, f32)> = queries.iter().map(|q| (Ray::new(q.origin.into(), snapped(f, q)), q.t_max)).collect();
            for (hit, exact) in hits.iter_mut().zip(tracer.closest_hit(ctx, scene, &rays)?) {
                *hit = match (*hit, exact.map(|h| h.t)) {
                    (Some(g), Some(e)) => Some(if e < g { e } else { g }),
                    (g, e) => g.or(e),
                };
            }
        }
        Ok(hits)
    }

    /// [`crate::RomaMaps::any_hit_unsnapped`] of each segment `from → to` (world; made with
    /// [`GpuQuery::segment`]): the OM of its direction's stratum, a DDA of at most `max_steps`
    /// texel fetches.
    pub fn any_hit_unsnapped(&mut self, ctx: &GpuContext, segments: &[GpuQuery], max_steps: u32) -> Result<Vec<bool>, GpuError> {
        let mut blocked: Vec<bool> = self.run(ctx, Pass::Dda(max_steps), segments)?.into_iter().map(|r| r != 0).collect();
        // As `RomaMaps::any_hit_unsnapped`: the segment itself, un-snapped.
        self.exact_any(ctx, segments, &mut blocked, |_, q| {
            let (from, to) = (Vec3::from(q.origin), Vec3::from(q.dir));
            let dir = (to - from).try_normalize()?;
            Some((Ray::new(from, dir), (to - from).length()))
        })?;
        Ok(blocked)
    }

    /// Runs the query kernel over `queries` in chunks within the binding and dispatch limits.
    fn run(&mut self, ctx: &GpuContext, pass: Pass, queries: &[GpuQuery]) -> Result<Vec<u32>, GpuError> {
        let f = self.frame.as_ref().ok_or_else(|| GpuError::Validation("GPU ROMA queried before it was built".into()))?;
        let query_bytes = size_of::<GpuQuery>() as u64;
        let chunk = (ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size) / query_bytes).clamp(1, 1 << 22) as usize;
        let mut out = Vec::with_capacity(queries.len());
        let mut timer = GpuTimer::new(ctx, queries.len().div_ceil(chunk).max(1) as u32);
        let (kernel, name, w) = match pass {
            Pass::Query(Mode::ClosestHit) => (&self.query, "roma closest-hit", Mode::ClosestHit as u32),
            Pass::Query(mode) => (&self.query, "roma any-hit", mode as u32),
            Pass::Dda(steps) => (&self.dda, "roma dda", steps),
        };
        for part in queries.chunks(chunk) {
            let q_buf = match &mut self.queries {
                Some(b) => {
                    b.upload(ctx, part)?;
                    b
                }
                None => {
                    let mut b = ReusableBuffer::new(ctx, "roma queries", size_of_val(part) as u64)?;
                    b.upload(ctx, part)?;
                    self.queries.insert(b)
                }
            };
            let r_buf = match &mut self.results {
                Some(b) => {
                    b.reserve(ctx, 4 * part.len() as u64)?;
                    b
                }
                None => self.results.insert(ReusableBuffer::new(ctx, "roma results", 4 * part.len() as u64)?),
            };
            let (gx, gy, stride) = grid_2d(ctx, part.len() as u64)?;
            let uniform = uniform_buffer(
                ctx,
                "roma query params",
                &QueryParams {
                    counts: [part.len() as u32, stride, f.candidates.n, w],
                    scales: [f.grid.cell_size_world, f.origin_offset_cells, 0.0, 0.0],
                },
            );
            let bind = kernel.bind(ctx, &[(0, &uniform), (1, &q_buf.buffer), (2, &f.to_map_rows), (3, &f.maps), (4, &r_buf.buffer)]);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            dispatch_2d(&mut encoder, kernel, &bind, (gx, gy), timer.pass(name));
            ctx.queue.submit([encoder.finish()]);
            out.extend(read_back::<u32>(ctx, &r_buf.buffer, part.len())?);
        }
        self.last_times = timer.finish(ctx)?;
        Ok(out)
    }
}

/// A query's direction snapped to its stratum's candidate (`CandidateSet::select`, the kernel's
/// `select_candidate`).
fn snapped(f: &GpuRomaFrame, q: &GpuQuery) -> Vec3 {
    let (k, sign) = f.candidates.select(q.dir.into());
    f.candidates.dirs[k] * sign
}

/// The rays of the CPU `ao-roma`'s single frame ([`crate::technique::ambient_occlusion`]): per
/// GBuffer pixel that sees geometry, `spp` cosine-weighted directions around the shading normal
/// from `Rng::for_pixel(seed, pixel, frame_index)`, from the position moved `offset_world` along
/// the geometric normal; and the pixels they belong to.
pub fn ao_queries(gbuffer: &GBuffer, spp: u32, radius: f32, offset_world: f32, seed: u64, frame_index: u32) -> (Vec<GpuQuery>, Vec<usize>) {
    let (mut queries, mut pixels) = (Vec::new(), Vec::new());
    for i in (0..gbuffer.len()).filter(|&i| gbuffer.is_hit(i)) {
        let origin = gbuffer.position[i] + gbuffer.normal[i] * offset_world;
        let basis = Frame::from_z(gbuffer.shading_normal[i]);
        let mut rng = Rng::for_pixel(seed, i as u64, frame_index as u64);
        for _ in 0..spp {
            queries.push(GpuQuery::new(origin, basis.to_world(cosine_hemisphere(rng.next_2d())), radius));
        }
        pixels.push(i);
    }
    (queries, pixels)
}

/// `ao-roma`'s single frame (before the temporal accumulation) on the GPU: the CPU's rays
/// ([`ao_queries`]), snapped and traced by the query kernel against the frame built last, and
/// combined as the CPU combines them ([`crate::weighting`], `cosine_weight`: `snap_weight=cos`).
#[allow(clippy::too_many_arguments)]
pub fn ambient_occlusion(
    ctx: &GpuContext,
    roma: &mut GpuRoma,
    gbuffer: &GBuffer,
    spp: u32,
    radius: f32,
    cosine_weight: bool,
    seed: u64,
    frame_index: u32,
) -> Result<Image, GpuError> {
    if spp == 0 {
        return Err(GpuError::Validation("ao-roma needs spp ≥ 1".into()));
    }
    let f = roma.frame()?;
    let offset = f.grid.cell_size_world * f.origin_offset_cells;
    let (queries, pixels) = ao_queries(gbuffer, spp, radius, offset, seed, frame_index);
    let occluded = roma.any_hit_snapped(ctx, &queries)?;
    let f = roma.frame()?;
    let spp = spp as usize;
    let mut samples = vec![None; gbuffer.len() * spp];
    for (n, &i) in pixels.iter().enumerate() {
        for (slot, j) in samples[i * spp..(i + 1) * spp].iter_mut().zip(n * spp..) {
            let (k, sign) = f.candidates.select(queries[j].dir.into());
            let weight = if cosine_weight { f.candidates.cosine_weight(k, sign, gbuffer.shading_normal[i]) } else { 1.0 };
            *slot = Some(SnappedSample { open: !occluded[j] as u8 as f32, weight });
        }
    }
    let mut image = Image::new(gbuffer.width, gbuffer.height);
    let width = gbuffer.width as usize;
    for (row, out) in image.pixels.chunks_mut(width).enumerate() {
        crate::weighting::open_fractions(&samples[row * width * spp..(row + 1) * width * spp], spp, out);
    }
    Ok(image)
}

/// `glimpse bench gpu`'s ROMA row: GPU kernel times of one build and of the `occluded_ray`
/// query over the bench's AO rays, the CPU ROMA on the same frame and rays, and how many
/// answers differ from the CPU's.
#[derive(Clone, Debug, Default)]
pub struct BenchRow {
    pub n: u32,
    pub rays: usize,
    /// GPU kernel times (timestamps; `None` without timestamp queries).
    pub bom_ms: Option<f64>,
    pub generate_ms: Option<f64>,
    pub query_ms: Option<f64>,
    /// CPU ROMA wall times on this machine (rayon over every core).
    pub cpu_bom_ms: f64,
    pub cpu_generate_ms: f64,
    pub cpu_query_ms: f64,
    /// GPU answers that differ from the CPU ROMA's.
    pub differ: usize,
}

/// Builds ROMA (the paper's AO setting, frame 0) for `frame` on the GPU and on the CPU and
/// answers `rays` with both (`occluded_ray`: snapped, offset origin).
pub fn bench(ctx: &GpuContext, frame: &glimpse_scene::SceneFrame, rays: &[(Ray, f32)], seed: u64) -> Result<BenchRow, GpuError> {
    let params = RomaParams::default();
    let triangles = frame.occluding_triangles();
    let mut gpu = GpuRoma::new(ctx)?;
    // Untimed builds and queries of the whole batch first: pipelines, buffers and the GPU's
    // clocks warm up outside the measurement.
    gpu.build(ctx, &triangles, frame.bounds, &params, seed, 0, &mut GpuTimer::new(ctx, 2))?;
    glimpse_gpu::timer::warm_up(|| gpu.occluded(ctx, rays).map(drop))?;
    let mut timer = GpuTimer::new(ctx, 2);
    gpu.build(ctx, &triangles, frame.bounds, &params, seed, 0, &mut timer)?;
    let times = timer.finish(ctx)?;
    let kernel = |times: &[KernelTime], name: &str| times.iter().find(|t| t.name == name).map(|t| t.ms);
    let occluded = gpu.occluded(ctx, rays)?;
    let query_ms = kernel(&gpu.last_times, "roma any-hit");

    let cpu = crate::Roma::build_from_triangles(&triangles, frame.bounds, &params, seed, 0);
    let t = std::time::Instant::now();
    let mut cpu_occluded = vec![false; rays.len()];
    {
        use rayon::prelude::*;
        rays.par_chunks(4096)
            .zip(cpu_occluded.par_chunks_mut(4096))
            .for_each(|(r, o)| glimpse_trace::Visibility::occluded_batch(&cpu, r, o));
    }
    let cpu_query_ms = t.elapsed().as_secs_f64() * 1e3;
    let differ = occluded.iter().zip(&cpu_occluded).filter(|(g, c)| g != c).count();
    Ok(BenchRow {
        n: params.n,
        rays: rays.len(),
        bom_ms: kernel(&times, "roma bom"),
        generate_ms: kernel(&times, "roma generate"),
        query_ms,
        cpu_bom_ms: cpu.timings().voxelize_ms,
        cpu_generate_ms: cpu.timings().generate_ms,
        cpu_query_ms,
        differ,
    })
}

impl BenchRow {
    /// The row as printed lines; `exact_any_hit_ms` is the GPU exact tracer's any-hit kernel time
    /// on the same rays and device (for the ratio).
    pub fn lines(&self, exact_any_hit_ms: Option<f64>) -> Vec<String> {
        let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3} ms"));
        let rate = |ms: f64| if ms > 0.0 { format!("{:.2} Mrays/s", self.rays as f64 / ms * 1e-3) } else { "-".into() };
        let ratio = match (exact_any_hit_ms, self.query_ms) {
            (Some(e), Some(q)) if q > 0.0 => format!("{:.2}x the GPU exact any-hit kernel's speed", e / q),
            _ => "no ratio (no timestamps)".into(),
        };
        vec![
            format!(
                "roma (128³, n={}) GPU kernels: bom {}, generate {}, query {} ({}); {ratio}",
                self.n,
                ms(self.bom_ms),
                ms(self.generate_ms),
                ms(self.query_ms),
                self.query_ms.map_or("-".into(), rate),
            ),
            format!(
                "roma CPU (wall): bom {:.3} ms, generate {:.3} ms, query {:.3} ms ({})",
                self.cpu_bom_ms,
                self.cpu_generate_ms,
                self.cpu_query_ms,
                rate(self.cpu_query_ms)
            ),
            format!(
                "roma agreement with the CPU ROMA (occluded_ray): {:.4} % ({} of {} differ)",
                100.0 - 100.0 * self.differ as f64 / self.rays.max(1) as f64,
                self.differ,
                self.rays
            ),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan_coefficients_are_the_cpus() {
        let atan = |x: f32| {
            let x2 = x * x;
            x * (ATAN[0] + x2 * (ATAN[1] + x2 * (ATAN[2] + x2 * (ATAN[3] + x2 * (ATAN[4] + x2 * ATAN[5])))))
        };
        let mut rng = Rng::new(1, 2);
        for _ in 0..10_000 {
            let x = 2.0 * rng.next_f32() - 1.0;
            assert_eq!(atan(x).to_bits(), glimpse_core::fast_math::atan_unit(x).to_bits(), "x = {x}");
        }
    }

    /// `query.wgsl`'s `apply` sums a row as (x + z) + (y + w), the grouping of glam's SSE2
    /// 4-wide dot that `MapTransform::apply` compiles to on x86-64.
    #[test]
    fn map_transform_sums_as_the_kernel_does() {
        let mut rng = Rng::new(1, 1);
        let mut f = || rng.next_f32() * 300.0 - 150.0;
        for _ in 0..10_000 {
            let (r, p) = (glimpse_core::Vec4::new(f(), f(), f(), f()), Vec3::new(f(), f(), f()));
            let kernel = (r.x * p.x + r.z * p.z) + (r.y * p.y + r.w);
            assert_eq!(r.dot(p.extend(1.0)).to_bits(), kernel.to_bits(), "{r} · {p}");
        }
    }

    #[test]
    fn hex_literals_are_exact() {
        assert_eq!(hexf(1.0), "0x1.000000p0f");
        assert_eq!(hexf(-0.5), "-0x1.000000p-1f");
        assert_eq!(hexf(64.0), "0x1.000000p6f");
        assert_eq!(hexf(1.5), "0x1.000000p0f".replace("000000", "800000"));
    }
}

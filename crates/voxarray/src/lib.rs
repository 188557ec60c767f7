//! glimpse-voxarray: the 2D array of voxelizations of Wang, Liang, Meng and Popescu, "Fast
//! Ray-Scene Intersection for Interactive Shadow Rendering with Thousands of Dynamic Lights"
//! (IEEE TVCG 2017), read through our spec `shared/specs/voxel-array-shadows.md` (errata there).
//!
//! One stage of the paper per file:
//! 1. [`directions`]: the (θ, φ) grid of row directions, `DiscretizeDirection` (Alg. 3 line 1).
//! 2. [`voxelize`]: Alg. 1 with `SPVoxelization` along three axes and the φ+90° transposition.
//! 3. [`query`]: Alg. 3, the midpoint row clipped by a mask (off-by-one fixed), with the bias.
//! 4. [`compress`]: Alg. 2, the row dictionary and packed indices.
//! 5. [`dynamic`]: Alg. 5 (rigid instances, one array per object type) and Alg. 6 (per-frame
//!    rebuild by rotating the fragments of one rasterization).
//! 6. [`technique`]: `lights-voxarray`, Alg. 4 (every light at every pixel, diffuse shading).
//! 7. [`batch`]: Alg. 3 for batches of segments, lanes of 8 with their row loads overlapped.
//! 8. `gpu` (feature `gpu`): Alg. 3 on the GPU, `query.wgsl`, the array uploaded once.
//!
//! [`VoxArray`] holds an array at resolution 32, 64 or 128 (rows `u32`/`u64`/`u128`, chosen at
//! run time), compressed or not, and implements [`Visibility`].

pub mod batch;
pub mod compress;
pub mod directions;
pub mod disk_cache;
pub mod dynamic;
pub mod extent8;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod query;
pub mod row;
pub mod shade8;
pub mod technique;
pub mod voxelize;

pub use compress::{CompressParams, Compressed, CompressionReport};
pub use directions::Directions;
pub use row::Row;
pub use voxelize::Grid;

use glimpse_core::{Ray, Vec3};
use glimpse_render::direct::PunctualSample;
/// ε_v and ε_s (moved to glimpse-render so the baselines report them too).
pub use glimpse_render::metrics::epsilon;
use glimpse_render::{ParamError, Params, TechniqueInfo};
use glimpse_scene::SceneFrame;
use glimpse_trace::Visibility;

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![technique::LightsVoxArray::info()]
}

/// Build and query settings. `Default` is the paper's: 128³, 90×90 directions (k = 2°),
/// compressed with a 1M-row dictionary and 4 steps. The bias is ours (the paper has none; see
/// [`query`]): 1 cell at the shaded point and 1 cell at the light, and the shaded point moved
/// 1.5 cells along its normal where the normal is known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxArrayParams {
    /// Voxels per axis: 32, 64 or 128.
    pub resolution: u32,
    /// Angles per axis over 180° (even): 90 = k 2°, 60 = 3°, 30 = 6°.
    pub directions: u32,
    pub bias_start_cells: f32,
    pub bias_end_cells: f32,
    /// Shaded points move this many cells along the normal (toward the light) before the query,
    /// where the caller knows the normal (`lights-voxarray`, the ε metrics); the `Visibility`
    /// trait gets no normal and uses only the along-row bias.
    pub normal_offset_cells: f32,
    /// `Visibility` trait only (no normal there): ignore the occupied run touching the start
    /// (helps rays toward lights in front of the surface, hurts rays into it; off by default).
    pub skip_start_run: bool,
    /// Alg. 2 on (`None`: the uncompressed array).
    pub compress: Option<CompressParams>,
    /// Vertices clustered to cubes of this many cells before Alg. 1 (`cluster`; 0 = off, the
    /// paper; see [`voxelize::cluster_vertices`]).
    pub cluster_cells: f32,
}

impl Default for VoxArrayParams {
    fn default() -> Self {
        Self {
            resolution: 128,
            directions: 90,
            bias_start_cells: 1.0,
            bias_end_cells: 1.0,
            normal_offset_cells: 1.5,
            skip_start_run: false,
            compress: Some(CompressParams::default()),
            cluster_cells: DEFAULT_CLUSTER_CELLS,
        }
    }
}

/// The default `cluster`: a quarter of a cell.
pub const DEFAULT_CLUSTER_CELLS: f32 = 0.25;

impl VoxArrayParams {
    /// The defaults under `refine` ([`crate::technique::REFINE_BELOW_LIGHTS`]): with false shadows removed by
    /// exact rays, smaller start offsets (normal offset 0.75 cells, bias 0.5 at both ends) trade
    /// them for fewer missed occluders. Measured (`--example error_sources`, 96 × 64, refined
    /// |ε_s|): `sponza-interior` 5.64 % at the paper-side defaults (1.5 / 1 / 1) → 1.96 %;
    /// `million-triangles` 4.90 % → 2.17 %; 0.5 / 0.5 gives 1.49 % on Sponza for 63 % of the
    /// decisions traced instead of 57 %.
    pub fn refined() -> Self {
        Self { normal_offset_cells: 0.75, bias_start_cells: 0.5, bias_end_cells: 0.5, ..Self::default() }
    }

    /// The uncompressed variant of the defaults.
    pub fn uncompressed() -> Self {
        Self { compress: None, ..Self::default() }
    }

    /// Reads `resolution`, `directions`, `bias`, `bias_light`, `normal_offset`,
    /// `skip_start_run`, `compress`, `dictionary`, `cluster`, `steps` and `profile`
    /// (`paper`: the 1M-row dictionary), with `self` as the defaults.
    pub fn read(self, params: &Params) -> Result<Self, ParamError> {
        let invalid = |key: &str, v: u32, m: &str| ParamError::Invalid { key: key.into(), value: v.to_string(), message: m.into() };
        let resolution = params.u32("resolution", self.resolution, 32, 128)?;
        if ![32, 64, 128].contains(&resolution) {
            return Err(invalid("resolution", resolution, "must be 32, 64 or 128"));
        }
        let directions = params.u32("directions", self.directions, 2, 360)?;
        if !directions.is_multiple_of(2) {
            return Err(invalid("directions", directions, "must be even (the φ+90° transposition)"));
        }
        // `profile=paper`: the paper's 1M-row dictionary instead of ours (every distinct row up
        // to 16M, `compress::DEFAULT_DICTIONARY_ROWS`).
        let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
        let c = match self.compress {
            Some(c) if paper && c.dictionary_rows == CompressParams::default().dictionary_rows => CompressParams::paper(),
            Some(c) => c,
            None if paper => CompressParams::paper(),
            None => CompressParams::default(),
        };
        let compress = params.bool("compress", self.compress.is_some())?;
        let dictionary_rows = params.u32("dictionary", c.dictionary_rows, 1, 1 << 24)?;
        let steps = params.u32("steps", c.steps, 0, 8)?;
        Ok(Self {
            resolution,
            directions,
            bias_start_cells: params.f32("bias", self.bias_start_cells, 0.0, 64.0)?,
            bias_end_cells: params.f32("bias_light", self.bias_end_cells, 0.0, 64.0)?,
            normal_offset_cells: params.f32("normal_offset", self.normal_offset_cells, 0.0, 64.0)?,
            skip_start_run: params.bool("skip_start_run", self.skip_start_run)?,
            compress: compress.then_some(CompressParams { dictionary_rows, steps, seed: c.seed }),
            cluster_cells: params.f32("cluster", self.cluster_cells, 0.0, 4.0)?,
        })
    }
}

/// The rows of an array: flat, or through the dictionary.
#[derive(Clone, Debug)]
pub enum Rows<R: Row> {
    Plain(Vec<R>),
    Compressed(Compressed<R>),
}

/// An array of `n × n` voxelizations with `R::BITS`-bit rows.
#[derive(Clone, Debug)]
pub struct Array<R: Row> {
    pub grid: Grid,
    pub dirs: Directions,
    pub rows: Rows<R>,
    pub bias_start_cells: f32,
    pub bias_end_cells: f32,
    pub normal_offset_cells: f32,
    pub skip_start_run: bool,
    pub build_ms: f64,
    pub compression: Option<CompressionReport>,
    /// Segments are cut to the grid's inscribed sphere before the query (a focused array,
    /// `focus=auto`: the occluders lie inside, the rest of a segment crosses none). Not stored
    /// in the disk cache: the technique sets it.
    pub clip_to_sphere: bool,
}

impl<R: Row> Array<R> {
    /// Alg. 1 over world-space triangles, then (if asked) Alg. 2.
    pub fn build(triangles: &[[Vec3; 3]], p: &VoxArrayParams) -> Self {
        let grid = Grid::around(triangles, R::BITS);
        Self::build_in(triangles, grid, p)
    }

    /// Alg. 1 in a given grid.
    pub fn build_in(triangles: &[[Vec3; 3]], grid: Grid, p: &VoxArrayParams) -> Self {
        let dirs = Directions::new(p.directions);
        let sw = std::time::Instant::now();
        let clustered;
        let triangles = if p.cluster_cells > 0.0 {
            clustered = voxelize::cluster_vertices(triangles, &grid, p.cluster_cells);
            &clustered[..]
        } else {
            triangles
        };
        // Compressed: Alg. 1 streamed θ-slab by θ-slab into Alg. 2, never holding the plain
        // array (2 GB at the defaults; see `compress::compress_slabs`).
        let (rows, compression) = match &p.compress {
            Some(c) => {
                let fill = |i: usize, slab: &mut [R]| voxelize::voxelize_slab(triangles, &grid, &dirs, i, slab);
                let (compressed, report) = compress::compress_slabs(dirs.n as usize, voxelize::slab_rows::<R>(&dirs), fill, c);
                (Rows::Compressed(compressed), Some(report))
            }
            None => (Rows::Plain(voxelize::build_array::<R>(triangles, &grid, &dirs)), None),
        };
        let build_ms = sw.elapsed().as_secs_f64() * 1e3;
        Array {
            grid,
            dirs,
            rows,
            bias_start_cells: p.bias_start_cells,
            bias_end_cells: p.bias_end_cells,
            normal_offset_cells: p.normal_offset_cells,
            skip_start_run: p.skip_start_run,
            build_ms,
            compression,
            clip_to_sphere: false,
        }
    }

    /// Replaces plain rows by their Alg. 2 compression (no-op if already compressed).
    pub fn compress(&mut self, c: &CompressParams) {
        if let Rows::Plain(rows) = &self.rows {
            let (compressed, _, report) = compress::compress(rows, c);
            self.rows = Rows::Compressed(compressed);
            self.compression = Some(report);
        }
    }

    pub fn resolution(&self) -> u32 {
        R::BITS
    }

    pub fn row_count(&self) -> usize {
        (self.dirs.n as usize).pow(2) * (R::BITS as usize).pow(2)
    }

    /// Row `index` of the flat array (decoded through the dictionary if compressed).
    #[inline]
    pub fn row(&self, index: usize) -> R {
        match &self.rows {
            Rows::Plain(v) => v[index],
            Rows::Compressed(c) => c.row(index),
        }
    }

    /// Alg. 3 on the segment `start → end` (world space).
    #[inline]
    pub fn occluded_segment(&self, start: Vec3, end: Vec3) -> bool {
        match query::extent(&self.grid, &self.dirs, start, end, self.bias_start_cells, self.bias_end_cells) {
            Some(x) => query::clip_hits(self.row(x.row_index(R::BITS)), x.s, x.e),
            None => false,
        }
    }

    /// Alg. 3 on a shadow sample of a surface point: the start moved `normal_offset_cells` along
    /// the normal (toward the light), then the biased segment query.
    #[inline]
    pub fn occluded_from_surface(&self, ps: &PunctualSample, normal: Vec3) -> bool {
        let (a, b) = self.surface_segment(ps, normal);
        self.occluded_segment(a, b)
    }

    /// The segment [`Self::occluded_from_surface`] queries: the start moved along the normal.
    #[inline]
    pub fn surface_segment(&self, ps: &PunctualSample, normal: Vec3) -> (Vec3, Vec3) {
        let (a, b) = self.segment(&ps.shadow, ps.t_max);
        let n = if normal.dot(ps.shadow.dir) < 0.0 { -normal } else { normal };
        self.clipped(a + n * (self.normal_offset_cells / self.grid.scale), b)
    }

    /// `a → b`, cut to the grid's inscribed sphere where `clip_to_sphere`; a segment that misses
    /// it becomes one outside the grid (which no query finds occluded).
    #[inline]
    fn clipped(&self, a: Vec3, b: Vec3) -> (Vec3, Vec3) {
        if !self.clip_to_sphere {
            return (a, b);
        }
        let r = 0.4995 * self.grid.resolution as f32 / self.grid.scale;
        let (c, d) = (self.grid.center, b - a);
        let (dd, f) = (d.length_squared(), a - c);
        let (half_b, cc) = (f.dot(d), f.length_squared() - r * r);
        let disc = half_b * half_b - dd * cc;
        if dd <= 0.0 || disc < 0.0 {
            return if cc <= 0.0 { (a, b) } else { (c + Vec3::splat(4.0 * r), c + Vec3::splat(4.0 * r)) };
        }
        let root = disc.sqrt();
        let (t0, t1) = (((-half_b - root) / dd).max(0.0), ((-half_b + root) / dd).min(1.0));
        if t0 > t1 {
            return (c + Vec3::splat(4.0 * r), c + Vec3::splat(4.0 * r));
        }
        (a + d * t0, a + d * t1)
    }

    /// Bytes held (rows or dictionary + packed indices, plus the rotation table).
    pub fn memory_bytes(&self) -> usize {
        let rot = self.dirs.rotations.len() * std::mem::size_of::<glimpse_core::Mat3>();
        rot + match &self.rows {
            Rows::Plain(v) => v.len() * std::mem::size_of::<R>(),
            Rows::Compressed(c) => c.memory_bytes(),
        }
    }

    /// Table 8's uncompressed size: one `N`-bit row per row.
    pub fn uncompressed_bytes(&self) -> u64 {
        self.row_count() as u64 * (R::BITS as u64 / 8)
    }

    /// The segment a shadow ray covers, with an infinite `t_max` cut where the ray leaves the
    /// grid's cube.
    #[inline]
    pub(crate) fn segment(&self, ray: &Ray, t_max: f32) -> (Vec3, Vec3) {
        let far = (ray.origin - self.grid.center).length() + 0.87 * self.grid.resolution as f32 / self.grid.scale;
        (ray.origin, ray.at(t_max.min(far)))
    }
}

impl<R: Row> Visibility for Array<R> {
    /// Alg. 3 on the ray's segment, with the along-row bias and (if `skip_start_run`) the
    /// occupied run at the start ignored: the trait gives no normal to offset the start with.
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let (a, b) = self.segment(ray, t_max);
        let (a, b) = self.clipped(a, b);
        if !self.skip_start_run {
            return self.occluded_segment(a, b);
        }
        match query::extent(&self.grid, &self.dirs, a, b, self.bias_start_cells, self.bias_end_cells) {
            Some(x) => query::clip_hits_after_start_run(self.row(x.row_index(R::BITS)), &x),
            None => false,
        }
    }

    /// [`batch`]: lanes of 8 with their row loads in flight together; the same answers.
    fn occluded_batch(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        self.occluded_rays(rays, out)
    }
}

/// An array at the resolution chosen at run time.
#[derive(Clone, Debug)]
pub enum VoxArray {
    R32(Array<u32>),
    R64(Array<u64>),
    R128(Array<u128>),
}

macro_rules! each {
    ($self:expr, $a:ident => $e:expr) => {
        match $self {
            VoxArray::R32($a) => $e,
            VoxArray::R64($a) => $e,
            VoxArray::R128($a) => $e,
        }
    };
}

impl VoxArray {
    /// Alg. 1 (and Alg. 2 if `p.compress`) over the frame's triangles.
    pub fn build(frame: &SceneFrame, p: &VoxArrayParams) -> Self {
        Self::from_triangles(&frame.world_triangles(), p)
    }

    pub fn from_triangles(triangles: &[[Vec3; 3]], p: &VoxArrayParams) -> Self {
        match p.resolution {
            32 => VoxArray::R32(Array::build(triangles, p)),
            64 => VoxArray::R64(Array::build(triangles, p)),
            _ => VoxArray::R128(Array::build(triangles, p)),
        }
    }

    /// [`Self::from_triangles`] in the cube around `focus` (ours, [`glimpse_render::focus`]):
    /// queries inside the focus only, so the triangles that cannot reach it are left out.
    /// `None`: the paper's cube around the whole scene.
    pub fn from_triangles_in(triangles: &[[Vec3; 3]], focus: Option<glimpse_core::Aabb>, p: &VoxArrayParams) -> Self {
        let Some(focus) = focus else {
            return Self::from_triangles(triangles, p);
        };
        let grid = Grid::around_box(focus, p.resolution);
        let near: Vec<[Vec3; 3]> = triangles.iter().filter(|t| grid.may_touch(t)).copied().collect();
        match p.resolution {
            32 => VoxArray::R32(Array::build_in(&near, grid, p)),
            64 => VoxArray::R64(Array::build_in(&near, grid, p)),
            _ => VoxArray::R128(Array::build_in(&near, grid, p)),
        }
    }

    pub fn occluded_segment(&self, start: Vec3, end: Vec3) -> bool {
        each!(self, a => a.occluded_segment(start, end))
    }

    pub fn occluded_from_surface(&self, ps: &PunctualSample, normal: Vec3) -> bool {
        each!(self, a => a.occluded_from_surface(ps, normal))
    }

    pub fn surface_segment(&self, ps: &PunctualSample, normal: Vec3) -> (Vec3, Vec3) {
        each!(self, a => a.surface_segment(ps, normal))
    }

    /// Batched [`Self::occluded_segment`] (see [`batch`]): one dispatch per batch.
    pub fn occluded_segments(&self, segments: &[(Vec3, Vec3)], out: &mut [bool]) {
        each!(self, a => a.occluded_segments(segments, out))
    }

    pub fn memory_bytes(&self) -> usize {
        each!(self, a => a.memory_bytes())
    }

    pub fn uncompressed_bytes(&self) -> u64 {
        each!(self, a => a.uncompressed_bytes())
    }

    /// [`Array::clip_to_sphere`].
    pub fn set_clip_to_sphere(&mut self, on: bool) {
        each!(self, a => a.clip_to_sphere = on)
    }

    pub fn normal_offset_cells(&self) -> f32 {
        each!(self, a => a.normal_offset_cells)
    }

    pub fn build_ms(&self) -> f64 {
        each!(self, a => a.build_ms)
    }

    pub fn compression(&self) -> Option<&CompressionReport> {
        each!(self, a => a.compression.as_ref())
    }

    pub fn grid(&self) -> &Grid {
        each!(self, a => &a.grid)
    }
}

impl Visibility for VoxArray {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        each!(self, a => a.occluded(ray, t_max))
    }

    /// One match on the resolution per batch, not per ray.
    fn occluded_batch(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        each!(self, a => a.occluded_rays(rays, out))
    }
}

//! glimpse-roma: the ray-aligned occupancy map array of Zeng, Xu, Wang, Wu and Yan, "Ray-aligned
//! Occupancy Map Array for Fast Approximate Ray Tracing" (EGSR 2023, CGF 42(4)), read through
//! our spec `shared/specs/roma.md` (errata marked there).
//!
//! One frame of ROMA, in the paper's order (one file per stage):
//! 1. [`occupancy`]: the base occupancy map (BOM), three axis passes united, jittered per frame.
//! 2. [`directions`]: `n×n` stratified candidate directions on a hemisphere (concentric map),
//!    re-drawn per frame, and the stratum lookup that "snaps" a ray.
//! 3. [`generate`]: Alg. 1, the BOM rotated into one occupancy map per candidate direction.
//! 4. [`trace`]: Alg. 2 (snapped any-hit and closest-hit, ±z) and the un-snapped DDA.
//! 5. [`technique`]: `ao-roma`, `gi-roma`, `soft-roma`, with [`accumulate`] over frames.
//! 6. `gpu` (feature `gpu`): BOM, Generate and the snapped queries in WGSL compute, bit for bit
//!    the CPU's maps (docs/gpu.md, "ROMA").
//!
//! [`Roma`] is one frame's structure at resolution 32, 64 or 128 (words `u32`/`u64`/`u128`,
//! chosen at run time), and implements [`Visibility`] and [`ClosestHit`] for arbitrary rays by
//! snapping them (see [`Roma`]'s notes on what that means for agreement with exact rays).

pub mod auto;
pub mod directions;
pub mod generate;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod technique;
pub mod trace;
pub mod weighting;

pub use directions::CandidateSet;
pub use glimpse_voxel::{Accumulator, DEFAULT_ACCUMULATE, frame_jitter};
/// The voxel structures ROMA shares with the distance-field baseline (crate `glimpse-voxel`).
pub use glimpse_voxel::{accumulate, grid, occupancy, word};
pub use grid::Grid;
pub use occupancy::{OccupancyMap, Voxelization};
pub use word::Word;

use glimpse_core::{Aabb, Frame, Ray, Rng, Vec3, Vec4};
use glimpse_render::focus::{ExactTriangles, FocusCache};
use glimpse_render::{ParamError, Params, Stopwatch, TechniqueInfo};
use glimpse_scene::SceneFrame;
use glimpse_trace::{ClosestHit, Hit, Visibility};
use trace::MapSegment;

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![technique::AoRoma::info(), technique::GiRoma::info(), technique::SoftRoma::info()]
}

/// ROMA's build and tracing settings. `Default` is the paper's AO/GI setting (§6, §7.1, Fig. 9):
/// positional resolution 128², angular resolution 4², the BOM rasterized at texel centres along
/// x, y and z and united, 1.5-cell origin offset, ≤ 8 DDA steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RomaParams {
    /// Positional resolution R (cells per axis = bits per texel): 32, 64 or 128.
    pub resolution: u32,
    /// Angular resolution n: n×n candidate directions (4 for AO/GI, 8 for soft shadows).
    pub n: u32,
    pub voxelization: Voxelization,
    /// Per-frame BOM jitter and re-drawn candidates (false: no jitter, stratum centres).
    pub jitter: bool,
    /// Ray-origin offset along the surface normal, in cells (paper §6: 1.5).
    pub origin_offset_cells: f32,
    /// Texel columns an un-snapped ray may visit (paper §4.2: 8 for soft shadows).
    pub dda_steps: u32,
    /// `n=auto`: `n` is chosen from the scene at the first prepare ([`RomaParams::resolve_n`]).
    pub auto_n: bool,
    /// `focus=auto` (ours; the paper's cube holds the whole scene): the grid surrounds the
    /// triangles other than the scene's supporting planes, which are tested exactly
    /// ([`glimpse_render::focus`]), where that box is much smaller than the scene's.
    pub focus: bool,
}

impl Default for RomaParams {
    fn default() -> Self {
        Self {
            resolution: 128,
            n: 4,
            voxelization: Voxelization::PAPER,
            jitter: true,
            origin_offset_cells: 1.5,
            dda_steps: 8,
            auto_n: false,
            focus: false,
        }
    }
}

impl RomaParams {
    /// Reads `resolution`, `n`, `voxelization`, `jitter`, `offset`, `focus` (`auto` unless
    /// `profile=paper`) and (when `with_dda`) `dda_steps`, with `self` as the defaults.
    pub fn read(self, params: &Params, with_dda: bool) -> Result<Self, ParamError> {
        let resolution = params.u32("resolution", self.resolution, 32, 128)?;
        if ![32, 64, 128].contains(&resolution) {
            return Err(ParamError::Invalid {
                key: "resolution".into(),
                value: resolution.to_string(),
                message: "must be 32, 64 or 128".into(),
            });
        }
        let default = if self.voxelization == Voxelization::Conservative { "conservative" } else { "sampled" };
        let voxelization = match params.choice("voxelization", default, &["sampled", "conservative"])?.as_str() {
            "conservative" => Voxelization::Conservative,
            _ => Voxelization::PAPER,
        };
        // `n=auto` where the technique defaults to it (ao-roma, gi-roma), unless `profile=paper`.
        let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
        let auto_n = params.text("n", if self.auto_n && !paper { "auto" } else { "" }) == "auto";
        Ok(Self {
            resolution,
            n: if auto_n { self.n } else { params.u32("n", self.n, 1, 32)? },
            auto_n,
            voxelization,
            jitter: params.bool("jitter", self.jitter)?,
            origin_offset_cells: params.f32("offset", self.origin_offset_cells, 0.0, 16.0)?,
            dda_steps: if with_dda { params.u32("dda_steps", self.dda_steps, 1, 1024)? } else { self.dda_steps },
            focus: params.choice("focus", if paper { "scene" } else { "auto" }, &["auto", "scene"])? == "auto",
        })
    }
}

impl RomaParams {
    /// The defaults of `ao-roma` and `gi-roma`: the paper's, with `n=auto` ([`auto`]).
    pub fn with_auto_n() -> Self {
        Self { auto_n: true, ..Self::default() }
    }

    /// Resolves `n=auto` on `frame` seen by `camera` ([`auto`]); returns the share of escaping
    /// AO rays it measured, `None` when `n` was given.
    pub fn resolve_n(
        &mut self,
        frame: &SceneFrame,
        tracer: &glimpse_trace::ExactTracer,
        camera: &glimpse_scene::Camera,
        seed: u64,
    ) -> Option<f32> {
        if !self.auto_n {
            return None;
        }
        let escape = auto::escape_fraction(frame, tracer, camera, seed);
        (self.n, self.auto_n) = (auto::choose_n(escape), false);
        Some(escape)
    }

    /// Bytes of one build, for the memory budget: n² maps of R² texels of R bits, plus the BOM
    /// and the bit array Generate reads it through (R³ bits each).
    pub fn estimated_bytes(&self) -> u64 {
        let r = self.resolution as u64;
        ((self.n as u64).pow(2) + 2) * r * r * r / 8
    }
}

/// Wall time of one build, by stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildTimings {
    /// Finding the supporting planes (`focus=auto`).
    pub focus_ms: f64,
    pub voxelize_ms: f64,
    pub generate_ms: f64,
}

/// World point → cell coordinates of one map, as three affine rows (the map's "view-projection
/// matrix" of Alg. 2 line 15, scaled to cells).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapTransform {
    pub rows: [Vec4; 3],
}

impl MapTransform {
    pub fn new(grid: &Grid, axes: &Frame) -> Self {
        let inv = 1.0 / grid.cell_size_world;
        let half = grid.resolution as f32 * 0.5;
        let row = |a: Vec3| (a * inv).extend(half - a.dot(grid.center) * inv);
        Self { rows: [row(axes.x), row(axes.y), row(axes.z)] }
    }

    #[inline]
    pub fn apply(&self, p: Vec3) -> Vec3 {
        let p = p.extend(1.0);
        Vec3::new(self.rows[0].dot(p), self.rows[1].dot(p), self.rows[2].dot(p))
    }
}

/// One frame's ROMA at one word width.
#[derive(Clone, Debug)]
pub struct RomaMaps<W: Word> {
    pub grid: Grid,
    pub candidates: CandidateSet,
    /// Axes of OM k (depth along candidate k).
    pub axes: Vec<Frame>,
    /// World → cell coordinates of OM k.
    pub to_map: Vec<MapTransform>,
    pub bom: OccupancyMap<W>,
    /// The OMs, layer-major: word `k·R² + y·R + x`.
    pub maps: Vec<W>,
    pub origin_offset_cells: f32,
    /// The supporting planes a focused grid leaves out, tested exactly by every query (empty
    /// where the grid holds the whole scene).
    pub exact: ExactTriangles,
    /// The focus's share of the scene's diagonal, where the grid is focused.
    pub focus_share: Option<f32>,
    pub timings: BuildTimings,
}

impl<W: Word> RomaMaps<W> {
    /// Generates the array from a BOM and candidates (Alg. 1 for every OM).
    pub fn generate(grid: Grid, bom: OccupancyMap<W>, candidates: CandidateSet, origin_offset_cells: f32) -> Self {
        let axes: Vec<Frame> = candidates.dirs.iter().map(|&d| grid::om_axes(d)).collect();
        let maps = generate::generate_all(&bom, &axes);
        let to_map = axes.iter().map(|a| MapTransform::new(&grid, a)).collect();
        let (exact, focus_share) = (ExactTriangles::default(), None);
        Self { grid, candidates, axes, to_map, bom, maps, origin_offset_cells, exact, focus_share, timings: BuildTimings::default() }
    }

    #[inline]
    pub fn word(&self, k: usize, x: u32, y: u32) -> W {
        let r = W::BITS as usize;
        self.maps[k * r * r + y as usize * r + x as usize]
    }

    /// OM k as a stand-alone map (copies).
    pub fn map(&self, k: usize) -> OccupancyMap<W> {
        let r2 = (W::BITS * W::BITS) as usize;
        OccupancyMap { words: self.maps[k * r2..(k + 1) * r2].to_vec() }
    }

    /// Alg. 2 `Trace` of the snapped ray from map-cell point `q` along `±z` over `depth_cells`
    /// (∞: to the end of the volume): the texel word and the slice range `(t_start, t_end)`.
    #[inline]
    fn column(&self, k: usize, plus: bool, q: Vec3, depth_cells: f32) -> Option<(W, u32, u32)> {
        let r = W::BITS as f32;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.x < r && q.y < r) {
            return None;
        }
        let (t_start, t_end) = trace::slice_range(q.z, plus, depth_cells, W::BITS)?;
        Some((self.word(k, q.x as u32, q.y as u32), t_start, t_end))
    }

    /// Snapped any-hit from map-cell point `q` of OM k (see [`RomaMaps::any_hit_snapped`]).
    #[inline]
    pub fn any_hit_column(&self, k: usize, plus: bool, q: Vec3, depth_cells: f32) -> bool {
        self.column(k, plus, q, depth_cells).is_some_and(|(u, t_start, t_end)| trace::any_hit(trace::range_bits(u, t_start, t_end)))
    }

    /// Snapped any-hit along `sign · d_k` from world point `origin` over world distance `t_max`
    /// (∞: to the end of the volume); no offset applied here.
    #[inline]
    pub fn any_hit_snapped(&self, k: usize, sign: f32, origin: Vec3, t_max: f32) -> bool {
        self.any_hit_column(k, sign > 0.0, self.to_map[k].apply(origin), t_max / self.grid.cell_size_world)
            || self.exact.any_hit(origin, self.candidates.dirs[k] * sign, t_max)
    }

    /// Snapped closest hit along `sign · d_k`: world distance from `origin` (≥ 0) to Alg. 2's
    /// hit depth (centre of the first occupied slice towards +z, its entry face towards −z).
    #[inline]
    pub fn closest_hit_snapped(&self, k: usize, sign: f32, origin: Vec3, t_max: f32) -> Option<f32> {
        let plus = sign > 0.0;
        let q = self.to_map[k].apply(origin);
        let in_grid = self.column(k, plus, q, t_max / self.grid.cell_size_world).and_then(|(u, t_start, t_end)| {
            let z_hit = trace::closest_hit_slices(trace::range_bits(u, t_start, t_end), t_start.max(t_end), plus)?;
            let cells = if plus { z_hit - q.z } else { q.z - z_hit };
            Some(cells.max(0.0) * self.grid.cell_size_world)
        });
        // The nearer of the two; the exact search is not cut at the grid's hit, so that its
        // answer does not depend on the grid's (the GPU port takes the same minimum).
        match (in_grid, self.exact.closest_hit(origin, self.candidates.dirs[k] * sign, t_max)) {
            (Some(g), Some(e)) => Some(if e < g { e } else { g }),
            (g, e) => g.or(e),
        }
    }

    /// The exact part of [`RomaMaps::occluded_ray`]: the planes a focused grid leaves out, along
    /// the snapped ray from the origin moved `origin_offset_cells` along it, `t_max` shortened
    /// at both ends ([`occluded_exact_ray`]).
    #[inline]
    fn exact_occluded(&self, k: usize, sign: f32, ray: &Ray, t_max: f32) -> bool {
        if self.exact.is_empty() {
            return false;
        }
        let offset = self.origin_offset_cells * self.grid.cell_size_world;
        occluded_exact_ray(self.candidates.dirs[k] * sign, ray.origin, t_max, offset)
            .is_some_and(|(r, t)| self.exact.any_hit(r.origin, r.dir, t))
    }

    /// [`Visibility::occluded`] for a bare ray: snapped, the origin moved `origin_offset_cells`
    /// along the snapped direction (i.e. along the map's z), `t_max` shortened at both ends.
    #[inline]
    pub fn occluded_ray(&self, ray: &Ray, t_max: f32) -> bool {
        let (k, sign) = self.candidates.select(ray.dir);
        self.occluded_snapped(k, sign, ray, t_max)
    }

    /// [`RomaMaps::occluded_ray`] after selection: `ray` snapped to `sign · dirs[k]`.
    #[inline(always)]
    fn occluded_snapped(&self, k: usize, sign: f32, ray: &Ray, t_max: f32) -> bool {
        let mut q = self.to_map[k].apply(ray.origin);
        q.z += sign * self.origin_offset_cells;
        let depth = t_max / self.grid.cell_size_world - 2.0 * self.origin_offset_cells;
        (depth > 0.0 && self.any_hit_column(k, sign > 0.0, q, depth)) || self.exact_occluded(k, sign, ray, t_max)
    }

    /// [`RomaMaps::occluded_ray`] for a batch: stratum selection runs over [`directions::LANES`]
    /// rays at a time ([`CandidateSet::select_lanes`], which the compiler vectorizes); the
    /// transform, word fetch and bit test per ray. Answers equal `occluded_ray`'s, ray for ray
    /// (acceptance check 7b).
    pub fn occluded_rays(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        use directions::LANES;
        let (mut chunks, mut outs) = (rays.chunks_exact(LANES), out.chunks_exact_mut(LANES));
        for (rs, os) in (&mut chunks).zip(&mut outs) {
            let (mut dx, mut dy, mut dz) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
            for l in 0..LANES {
                (dx[l], dy[l], dz[l]) = (rs[l].0.dir.x, rs[l].0.dir.y, rs[l].0.dir.z);
            }
            let (k, sign) = self.candidates.select_lanes(&dx, &dy, &dz);
            let mut q = [Vec3::ZERO; LANES];
            for l in 0..LANES {
                q[l] = self.to_map[k[l] as usize].apply(rs[l].0.origin);
            }
            for l in 0..LANES {
                let mut q = q[l];
                q.z += sign[l] * self.origin_offset_cells;
                let depth = rs[l].1 / self.grid.cell_size_world - 2.0 * self.origin_offset_cells;
                let k = k[l] as usize;
                os[l] =
                    (depth > 0.0 && self.any_hit_column(k, sign[l] > 0.0, q, depth)) || self.exact_occluded(k, sign[l], &rs[l].0, rs[l].1);
            }
        }
        for ((ray, t_max), o) in chunks.remainder().iter().zip(outs.into_remainder()) {
            *o = self.occluded_ray(ray, *t_max);
        }
    }

    /// Un-snapped any-hit of the segment `from → to` (world) through the OM of its direction's
    /// stratum, with at most `max_steps` texel fetches.
    pub fn any_hit_unsnapped(&self, from: Vec3, to: Vec3, max_steps: u32) -> bool {
        let Some(dir) = (to - from).try_normalize() else {
            return false;
        };
        let (k, _) = self.candidates.select(dir);
        let seg = MapSegment { from: self.to_map[k].apply(from), to: self.to_map[k].apply(to) };
        seg.clip(W::BITS as f32).is_some_and(|seg| trace::any_hit_dda(seg, max_steps, |x, y| self.word(k, x, y)))
            || self.exact.any_hit(from, dir, (to - from).length())
    }

    pub fn memory_bytes(&self) -> usize {
        self.maps.len() * std::mem::size_of::<W>() + self.bom.memory_bytes() + self.exact.memory_bytes()
    }
}

/// One frame's ROMA at the resolution chosen at run time.
///
/// As a [`Visibility`] / [`ClosestHit`] backend (for `bench rays` and other callers that only
/// have rays, no surface normals): the ray's direction is **snapped** to its stratum's candidate,
/// the origin is moved `origin_offset_cells` (1.5) cells along the snapped direction (the paper
/// moves it along the surface normal, which a bare ray does not carry), and a finite `t_max` is
/// shortened by the same amount so a segment ending on a light does not hit the light's own
/// cells. Agreement with the exact tracer is therefore measured for *snapped* answers against
/// *exact un-snapped* rays; ROMA's own techniques sample the candidate directions directly
/// (cosine sample → stratum → candidate) and offset along the normal.
#[derive(Clone, Debug)]
pub enum Roma {
    R32(RomaMaps<u32>),
    R64(RomaMaps<u64>),
    R128(RomaMaps<u128>),
}

/// Runs `$body` with `$m` bound to the `RomaMaps<W>` inside a [`Roma`].
#[macro_export]
macro_rules! with_maps {
    ($roma:expr, $m:ident => $body:expr) => {
        match $roma {
            $crate::Roma::R32($m) => $body,
            $crate::Roma::R64($m) => $body,
            $crate::Roma::R128($m) => $body,
        }
    };
}

impl Roma {
    /// Builds ROMA for `frame`: BOM (jittered for `frame_index`), candidates (drawn for
    /// `frame_index` from `seed`), Generate.
    /// With `params.focus`, the grid surrounds the triangles other than the supporting planes
    /// (where that pays, [`Focus::for_all_rays`]) and those planes are tested exactly.
    pub fn build(frame: &SceneFrame, params: &RomaParams, seed: u64, frame_index: u32) -> Roma {
        Self::build_cached(frame, params, &mut FocusCache::default(), seed, frame_index)
    }

    /// [`Roma::build`] with the focus from `cache` (a technique's, kept across its frames).
    pub fn build_cached(frame: &SceneFrame, params: &RomaParams, cache: &mut FocusCache, seed: u64, frame_index: u32) -> Roma {
        let sw = Stopwatch::start();
        let triangles = frame.occluding_triangles();
        let gather_ms = sw.ms();
        let sw = Stopwatch::start();
        let focus = if params.focus { cache.for_all_rays(frame, &triangles) } else { None };
        let focus_ms = sw.ms();
        let mut roma = match &focus {
            None => Self::build_from_triangles(&triangles, frame.bounds, params, seed, frame_index),
            Some(f) => {
                let (inside, exact) = f.split(&triangles);
                let mut roma = Self::build_from_triangles(&inside, f.bounds, params, seed, frame_index);
                let share = f.share_of(frame.bounds);
                with_maps!(&mut roma, m => (m.exact, m.focus_share) = (exact, Some(share)));
                roma
            }
        };
        // Gathering the world-space triangles belongs to the BOM pass.
        with_maps!(&mut roma, m => (m.timings.voxelize_ms, m.timings.focus_ms) = (m.timings.voxelize_ms + gather_ms, focus_ms));
        roma
    }

    /// [`Roma::build`] from world-space triangles within `bounds`.
    pub fn build_from_triangles(triangles: &[[Vec3; 3]], bounds: Aabb, params: &RomaParams, seed: u64, frame_index: u32) -> Roma {
        let (grid, candidates) = frame_grid_and_candidates(bounds, params, seed, frame_index);
        match params.resolution {
            32 => Roma::R32(build_maps(triangles, grid, candidates, params)),
            64 => Roma::R64(build_maps(triangles, grid, candidates, params)),
            _ => Roma::R128(build_maps(triangles, grid, candidates, params)),
        }
    }

    pub fn grid(&self) -> &Grid {
        with_maps!(self, m => &m.grid)
    }

    pub fn candidates(&self) -> &CandidateSet {
        with_maps!(self, m => &m.candidates)
    }

    pub fn cell_size_world(&self) -> f32 {
        self.grid().cell_size_world
    }

    pub fn timings(&self) -> BuildTimings {
        with_maps!(self, m => m.timings)
    }

    /// The focus's share of the scene's diagonal where the grid is focused.
    pub fn focus_share(&self) -> Option<f32> {
        with_maps!(self, m => m.focus_share)
    }

    pub fn memory_bytes(&self) -> usize {
        with_maps!(self, m => m.memory_bytes())
    }

    /// Occupied BOM cells.
    pub fn bom_cells(&self) -> u64 {
        with_maps!(self, m => m.bom.count())
    }

    /// The candidate of `d`'s stratum and its sign (see [`CandidateSet::select`]).
    #[inline]
    pub fn select(&self, d: Vec3) -> (usize, f32) {
        self.candidates().select(d)
    }

    #[inline]
    pub fn any_hit_snapped(&self, k: usize, sign: f32, origin: Vec3, t_max: f32) -> bool {
        with_maps!(self, m => m.any_hit_snapped(k, sign, origin, t_max))
    }

    #[inline]
    pub fn closest_hit_snapped(&self, k: usize, sign: f32, origin: Vec3, t_max: f32) -> Option<f32> {
        with_maps!(self, m => m.closest_hit_snapped(k, sign, origin, t_max))
    }

    #[inline]
    pub fn any_hit_unsnapped(&self, from: Vec3, to: Vec3, max_steps: u32) -> bool {
        with_maps!(self, m => m.any_hit_unsnapped(from, to, max_steps))
    }

    fn origin_offset_world(&self) -> f32 {
        with_maps!(self, m => m.origin_offset_cells) * self.cell_size_world()
    }

    /// The snapped form of a bare ray, as the [`Visibility`] impl traces it: (candidate, sign,
    /// offset origin, shortened `t_max`), or `None` when nothing is left of the segment.
    #[inline]
    pub fn snapped_segment(&self, ray: &Ray, t_max: f32) -> Option<(usize, f32, Vec3, f32)> {
        let (k, sign) = self.select(ray.dir);
        let offset = self.origin_offset_world();
        let t = if t_max.is_finite() { t_max - 2.0 * offset } else { t_max };
        (t > 0.0).then(|| (k, sign, ray.origin + self.candidates().dirs[k] * (sign * offset), t))
    }
}

/// The ray a bare `occluded_ray` query traces through the exact triangles: from `origin` moved
/// `offset` (world) along the snapped direction `d`, a finite `t_max` shortened by `offset` at
/// both ends; `None` when nothing is left. Shared with the GPU port's exact pass.
#[inline]
pub fn occluded_exact_ray(d: Vec3, origin: Vec3, t_max: f32, offset: f32) -> Option<(Ray, f32)> {
    let t = if t_max.is_finite() { t_max - 2.0 * offset } else { t_max };
    (t > 0.0).then(|| (Ray::new(origin + d * offset, d), t))
}

/// The grid (jittered for `frame_index`) and the candidates (drawn for `frame_index` from
/// `seed`) of one frame: what [`Roma::build_from_triangles`] and the GPU build share.
pub fn frame_grid_and_candidates(bounds: Aabb, params: &RomaParams, seed: u64, frame_index: u32) -> (Grid, CandidateSet) {
    let jitter = if params.jitter { frame_jitter(seed, frame_index) } else { Vec3::ZERO };
    let grid = Grid::around(bounds, params.resolution, jitter);
    let mut rng = Rng::new(seed, 0xd1_0000 + frame_index as u64);
    (grid, CandidateSet::draw(params.n, &mut rng, params.jitter))
}

fn build_maps<W: Word>(triangles: &[[Vec3; 3]], grid: Grid, candidates: CandidateSet, params: &RomaParams) -> RomaMaps<W> {
    let sw = Stopwatch::start();
    let bom = occupancy::voxelize::<W>(triangles, &grid, params.voxelization);
    let voxelize_ms = sw.ms();
    let sw = Stopwatch::start();
    let mut maps = RomaMaps::generate(grid, bom, candidates, params.origin_offset_cells);
    maps.timings = BuildTimings { voxelize_ms, generate_ms: sw.ms(), ..Default::default() };
    maps
}

impl Visibility for Roma {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        with_maps!(self, m => m.occluded_ray(ray, t_max))
    }

    fn occluded_batch(&self, rays: &[(Ray, f32)], out: &mut [bool]) {
        with_maps!(self, m => m.occluded_rays(rays, out))
    }
}

impl ClosestHit for Roma {
    /// The hit distance `t` is along the **snapped** direction, from the ray's origin; ROMA knows
    /// occupancy, not triangles, so `instance` and `triangle` are `u32::MAX` and `b1 = b2 = 0`.
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let (k, sign, o, t) = self.snapped_segment(ray, t_max)?;
        let offset = self.origin_offset_world();
        let d = self.closest_hit_snapped(k, sign, o, t)?;
        Some(Hit { t: d + offset, b1: 0.0, b2: 0.0, instance: u32::MAX, triangle: u32::MAX })
    }
}

//! glimpse-baselines: the comparisons the papers make. For now the distance field of the ROMA
//! paper (§6, Table 2): 3D jump flooding on ROMA's own BOM at the same resolution, three mip
//! levels, sphere tracing with at most 64 iterations — with the techniques `ao-df` and `soft-df`
//! and a [`Visibility`] backend for `glimpse bench rays`.
//!
//! - [`distance_field`]: jump flooding, fixed-point storage, mip levels.
//! - [`sphere_trace`]: the mip-accelerated sphere tracer.
//! - [`technique`]: `ao-df`, `soft-df`.

pub mod distance_field;
pub mod ism;
pub mod ortho;
pub mod per_light_maps;
pub mod shadowmap;
pub mod sphere_trace;
pub mod technique;

pub use distance_field::DistanceField;
pub use sphere_trace::SphereTraceParams;

use glimpse_core::{Ray, Vec3};
use glimpse_render::focus::{ExactTriangles, FocusCache};
use glimpse_render::{ParamError, Params, Stopwatch, TechniqueInfo};
use glimpse_scene::SceneFrame;
use glimpse_trace::Visibility;
use glimpse_voxel::occupancy::{self, Voxelization};
use glimpse_voxel::{Grid, OccupancyMap, Word};

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![technique::AoDf::info(), technique::SoftDf::info(), shadowmap::LightsShadowMap::info(), ism::LightsIsm::info()]
}

/// Distance-field settings. `Default` is the paper's DF for AO: 128³, ≤ 64 iterations, built
/// from the same (jittered, 3-axis) BOM as ROMA, origins 1.5 cells off the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DfParams {
    /// Cells per axis: 32, 64 or 128 (the BOM's resolution).
    pub resolution: u32,
    pub voxelization: Voxelization,
    /// Per-frame BOM jitter (as ROMA's).
    pub jitter: bool,
    pub origin_offset_cells: f32,
    pub trace: SphereTraceParams,
    /// `focus=auto`: the grid surrounds all but the scene's supporting planes, which are tested
    /// exactly, as ROMA's ([`glimpse_render::focus`]); `false` is the paper's scene cube.
    pub focus: bool,
}

impl Default for DfParams {
    fn default() -> Self {
        Self {
            resolution: 128,
            voxelization: Voxelization::PAPER,
            jitter: true,
            origin_offset_cells: 1.5,
            trace: SphereTraceParams::default(),
            focus: false,
        }
    }
}

impl DfParams {
    /// Reads `resolution`, `voxelization`, `jitter`, `offset`, `steps` with `self` as defaults,
    /// and `focus` (`auto` unless `profile=paper`, as ROMA's).
    pub fn read(self, params: &Params) -> Result<Self, ParamError> {
        let resolution = params.u32("resolution", self.resolution, 32, 128)?;
        if ![32, 64, 128].contains(&resolution) {
            return Err(ParamError::Invalid {
                key: "resolution".into(),
                value: resolution.to_string(),
                message: "must be 32, 64 or 128".into(),
            });
        }
        let voxelization = match params.choice("voxelization", "sampled", &["sampled", "conservative"])?.as_str() {
            "conservative" => Voxelization::Conservative,
            _ => Voxelization::PAPER,
        };
        let max_steps = params.u32("steps", self.trace.max_steps, 1, 4096)?;
        let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
        Ok(Self {
            resolution,
            voxelization,
            jitter: params.bool("jitter", self.jitter)?,
            origin_offset_cells: params.f32("offset", self.origin_offset_cells, 0.0, 16.0)?,
            trace: SphereTraceParams { max_steps, ..self.trace },
            focus: params.choice("focus", if paper { "scene" } else { "auto" }, &["auto", "scene"])? == "auto",
        })
    }
}

/// Build timings by stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DfTimings {
    pub focus_ms: f64,
    pub voxelize_ms: f64,
    pub jump_flood_ms: f64,
}

/// One frame's distance field with its tracing settings.
#[derive(Clone, Debug)]
pub struct DfScene {
    pub field: DistanceField,
    pub params: DfParams,
    pub timings: DfTimings,
    /// The supporting planes a focused grid leaves out (empty where it holds the whole scene).
    pub exact: ExactTriangles,
    /// The focus's share of the scene's diagonal, where the grid is focused.
    pub focus_share: Option<f32>,
}

impl DfScene {
    /// BOM (same grid, jitter, voxelization and focus as ROMA's for this seed and frame) → field.
    pub fn build(frame: &SceneFrame, params: &DfParams, seed: u64, frame_index: u32) -> DfScene {
        Self::build_cached(frame, params, &mut FocusCache::default(), seed, frame_index)
    }

    /// [`DfScene::build`] with the focus from `cache` (a technique's, kept across its frames).
    pub fn build_cached(frame: &SceneFrame, params: &DfParams, cache: &mut FocusCache, seed: u64, frame_index: u32) -> DfScene {
        let sw = Stopwatch::start();
        let all = frame.occluding_triangles();
        let gathered_ms = sw.ms();
        let focus = if params.focus { cache.for_all_rays(frame, &all) } else { None };
        // Gathering the triangles and splitting them count as the BOM's, as ROMA's.
        let focus_ms = sw.ms() - gathered_ms;
        let (triangles, exact, bounds) = match &focus {
            Some(f) => {
                let (inside, exact) = f.split(&all);
                (inside, exact, f.bounds)
            }
            None => (all, ExactTriangles::default(), frame.bounds),
        };
        let jitter = if params.jitter { glimpse_voxel::frame_jitter(seed, frame_index) } else { Vec3::ZERO };
        let grid = Grid::around(bounds, params.resolution, jitter);
        fn field<W: Word>(t: &[[Vec3; 3]], grid: Grid, v: Voxelization) -> (DistanceField, f64) {
            let sw = Stopwatch::start();
            let bom: OccupancyMap<W> = occupancy::voxelize(t, &grid, v);
            let voxelize_ms = sw.ms();
            (DistanceField::from_bom(&bom, grid), voxelize_ms)
        }
        let start = sw.ms();
        let (field, bom_ms) = match params.resolution {
            32 => field::<u32>(&triangles, grid, params.voxelization),
            64 => field::<u64>(&triangles, grid, params.voxelization),
            _ => field::<u128>(&triangles, grid, params.voxelization),
        };
        let total = sw.ms();
        let voxelize_ms = start - focus_ms + bom_ms;
        let timings = DfTimings { focus_ms, voxelize_ms, jump_flood_ms: total - start - bom_ms };
        let focus_share = focus.map(|f| f.share_of(frame.bounds));
        DfScene { field, params: *params, timings, exact, focus_share }
    }

    pub fn cell_size_world(&self) -> f32 {
        self.field.grid.cell_size_world
    }

    /// Is the segment `from → from + dir·t_max` blocked (sphere tracing, no offsets)?
    #[inline]
    pub fn blocked(&self, from: Vec3, dir: Vec3, t_max: f32) -> bool {
        self.field.sphere_trace(from, dir, t_max, &self.params.trace).hit.is_some() || self.exact.any_hit(from, dir, t_max)
    }
}

impl Visibility for DfScene {
    /// As ROMA's backend: the origin moves `origin_offset_cells` along the ray (a bare ray has no
    /// normal) and a finite `t_max` is shortened by the same amount at the far end.
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let offset = self.params.origin_offset_cells * self.cell_size_world();
        let t = if t_max.is_finite() { t_max - 2.0 * offset } else { t_max };
        t > 0.0 && self.blocked(ray.origin + ray.dir * offset, ray.dir, t)
    }
}

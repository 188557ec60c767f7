//! glimpse-dvf: discrete visibility fields rebuilt every frame. Günay and Akyüz, "Real-time
//! Discrete Visibility Fields for Ray-Traced Dynamic Scenes" (Computers & Graphics 2025), which
//! moves the precomputation of Xu et al. 2022 ("Precomputed Discrete Visibility Fields for
//! Real-Time Ray-Traced Environment Lighting", EGSR; the paper calls it "Yang et al.") into five
//! compute passes, read through our spec `shared/specs/dvf.md` (errata E1–E8 there).
//!
//! One frame's build, in the paper's order (one file per stage, each a timed parallel pass):
//! 1. [`areas`] (CS1): world-space triangles, areas and normals.
//! 2. [`scan`] (CS2, CS3): Blelloch up-sweep and down-sweep of the areas in blocks.
//! 3. [`points`] + [`field`] (CS4): area-proportional point samples (Eq. 1 ceiling, Eq. 2; hash
//!    or Hammersley), N_r rays each ([`rays`]), traced exactly and OR-ed atomically into the
//!    cell's octahedral visible/occluded masks ([`grid`]).
//! 4. [`labels`] (CS5): the per-cell occlusion label.
//!
//! The runtime ([`technique`], `env-dvf`) is Xu et al.'s Algorithm 3 with the spec's errata E2
//! and E3 fixed. With the `gpu` feature, [`gpu`] runs the same passes and the shading in WGSL
//! compute (the masks and labels bit for bit the CPU's).

pub mod areas;
pub mod bright;
pub mod field;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod grid;
pub mod labels;
pub mod points;
pub mod raybatch;
pub mod rays;
pub mod scan;
pub mod technique;

pub use field::Atomics;
pub use grid::{Grid, Masks};
pub use points::{PointSampling, Rounding};

use glimpse_render::{ParamError, Params, Stats, TechniqueInfo};
use glimpse_scene::SceneFrame;
use glimpse_trace::Visibility;
use rayon::prelude::*;

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![technique::EnvDvf::info()]
}

/// How the `l_occ = 0` branch gets E_unshad(n).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unshadowed {
    /// Order-2 SH irradiance of the map (Ramamoorthi and Hanrahan), ÷π: the paper's.
    Sh,
    /// The fragment's own N_r rays, untraced: (1/N_r) Σ L(ω). Deviation (not the paper): removes
    /// the SH error, so only mask errors remain.
    Rays,
}

/// Which cells' masks a fragment reads (`footprint`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Footprint {
    /// The cell that holds the fragment: the paper's.
    Cell,
    /// The union of the 2×2×2 cells whose centres surround the fragment (ours): a pixel is
    /// trusted only where every nearby cell that saw it agrees, so a fragment away from the
    /// samples of its own cell (an ear tip over a cell of samples under the ear) traces the rays
    /// its neighbourhood disagrees on instead of taking its cell's word.
    Around,
}

/// DVF settings. `Default` is the paper's Sponza setting where it has one (N_r = 128,
/// N_P = 10M, ceiling, hash, 77 cells along the longest axis as its 77×48×34 grid,
/// workgroups of 1024); the octahedral resolution R is not stated by the paper (our 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DvfParams {
    /// N_r: rays per point sample and per fragment (`rays`).
    pub rays: u32,
    /// Rays per point sample in the build (`build_rays`; 0, the default, means N_r as in the
    /// paper). Deviation when set: with R = 8 a sample's hemisphere covers ~32 pixels, so far fewer
    /// than 128 rays already reach most of them.
    pub build_rays: u32,
    /// N_P: requested point samples (`points`).
    pub points: u32,
    pub rounding: Rounding,
    pub sampling: PointSampling,
    /// Cells along the longest axis of the scene bounds, cubic cells (`grid`).
    pub grid: u32,
    /// Octahedral map resolution R (`octahedral`), R×R pixels per mask.
    pub octahedral: u32,
    /// Most point samples one CS4 task takes (`task_points`; the paper illustrates 3).
    pub task_points: u32,
    /// Prefix-sum workgroup size (`workgroup`; the paper's 1024 = maxComputeWorkGroupInvocations).
    pub workgroup: u32,
    /// Rotate ray sets about the normal (`rotation=normal`) instead of a Cranley-Patterson shift.
    pub rotate_about_normal: bool,
    pub unshadowed: Unshadowed,
    pub atomics: Atomics,
    /// Trace rays whose pixel is in neither mask (`unknown=trace`; the paper: skip).
    pub trace_unknown: bool,
    /// Which hemispheres the samples trace ([`Sides`]).
    pub sides: Sides,
    /// Trace every ray toward the map's brightest `bright_sr` sr whatever the masks say
    /// (`bright=on`; ours, [`bright`]). `auto` (the default) turns it on for maps that are not
    /// low-frequency ([`choose_bright`]); the paper: off.
    pub bright: bool,
    /// The solid angle (sr) of the map's brightest texels that `bright` traces (`bright_sr`).
    pub bright_sr: f32,
    /// Which cells' masks a fragment reads (`footprint=around|cell`; ours, [`Footprint`]).
    pub footprint: Footprint,
    /// Which of `points`, `grid` and `rounding` are still to be chosen from the frame
    /// ([`DvfParams::for_frame`]; `points=auto` etc., the defaults): the paper's values are
    /// sized for a GPU and Sponza, and cost minutes per frame on a CPU or on other scenes.
    pub auto: AutoBudget,
}

/// The sample budget's keys left to [`DvfParams::for_frame`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct AutoBudget {
    pub points: bool,
    pub grid: bool,
    pub rounding: bool,
    /// `unshadowed=auto`: SH or rays from the map's frequency and the field's occlusion ([`choose_unshadowed`]).
    pub unshadowed: bool,
    /// `bright=auto`: on for maps that are not low-frequency ([`choose_bright`]).
    pub bright: bool,
}

impl AutoBudget {
    pub const ALL: AutoBudget = AutoBudget { points: true, grid: true, rounding: true, unshadowed: true, bright: true };
}

/// Which hemispheres a point sample traces (`sides`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sides {
    /// About the winding normal only (the paper, `profile=paper`).
    Front,
    /// Both, on every triangle (ours, the default): a double-sided surface seen from its back
    /// is not treated as open, and the back rays of a thin closed solid (a wall box) mark the
    /// directions through it occluded in the cells of both its faces.
    Both,
    /// Both on the instances the camera sees from behind, the front elsewhere (ours).
    Seen,
}

/// The relative noise of an N_r-ray estimate of the unshadowed irradiance above which
/// `unshadowed=auto` takes E_unshad from the fragment's own rays instead of the SH.
///
/// Why: the `l_occ = 0` branch computes E = E_unshad − (1/N_r) Σ_hit L. With the SH's noiseless
/// E_unshad, the subtracted Monte Carlo term carries all the estimator's noise: on a map with
/// small bright regions (a sun, softboxes) one occluded ray towards them subtracts many times
/// the pixel's true value, and the clamp at 0 leaves black or over-bright blocks (RMSE 0.37 on
/// the warehouse map at 320×180 against `env-exact`, 0.020 with rays). The paper assumes
/// low-frequency light, where the two agree; this rule keeps the SH there. Measured at
/// N_r = 128 (`--example map_noise`): `cornell-lit`'s sky 0.040, `scenes/sponza-dvf.toml`'s dim
/// sun 0.055 (SH: RMSE 0.0022), the warehouse map 1.16, the `sky` built-in 3.4, the studio map
/// 4.4; the threshold sits in that gap.
pub const SH_MAX_RELATIVE_NOISE: f32 = 0.25;

/// The relative standard deviation of `env-exact`'s N_r-ray cosine-weighted estimate of the
/// unshadowed irradiance (luminance), the largest over 14 normals (the axes and the cube's
/// diagonals): √(E[L²]/E[L]² − 1) / √N_r, by quadrature over the map's texels. 0 for a constant
/// map; large for a map whose light comes from a few small bright regions.
pub fn cosine_estimator_noise(env: &glimpse_scene::Environment, rays: u32) -> f32 {
    use glimpse_core::{Vec3, luminance};
    use rayon::prelude::*;
    let mut normals: Vec<Vec3> = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    for s in 0..8 {
        let sign = |b: u32| if s >> b & 1 == 1 { -1.0 } else { 1.0 };
        normals.push(Vec3::new(sign(0), sign(1), sign(2)).normalize());
    }
    let grid = glimpse_scene::SphereGrid::for_map(env, 64, 32);
    // Per normal: Σ L cos dω and Σ L² cos dω (first and second moments, up to 1/π).
    let moments = (0..grid.height)
        .into_par_iter()
        .map(|y| {
            let d_omega = grid.row_solid_angle(y);
            let mut m = vec![(0.0f64, 0.0f64); normals.len()];
            grid.for_row(env, y, |d, l| {
                let l = luminance(l).max(0.0) as f64;
                for (m, n) in m.iter_mut().zip(&normals) {
                    let c = n.dot(d);
                    if c > 0.0 {
                        let wgt = (c * d_omega) as f64;
                        m.0 += l * wgt;
                        m.1 += l * l * wgt;
                    }
                }
            });
            m
        })
        .reduce(
            || vec![(0.0, 0.0); normals.len()],
            |mut a, b| {
                for (a, b) in a.iter_mut().zip(b) {
                    (a.0, a.1) = (a.0 + b.0, a.1 + b.1);
                }
                a
            },
        );
    // Cosine-weighted pdf cos/π: E[L] = Σ L cos dω / π, E[L²] = Σ L² cos dω / π.
    let pi = std::f64::consts::PI;
    let cv =
        moments.iter().filter(|m| m.0 > 0.0).map(|&(m1, m2)| ((m2 / pi) / (m1 / pi).powi(2) - 1.0).max(0.0).sqrt()).fold(0.0f64, f64::max);
    (cv / (rays.max(1) as f64).sqrt()) as f32
}

/// The share of mostly-occluded cells ([`Dvf::occluded_cell_fraction`]) above which
/// `unshadowed=auto` takes E_unshad from the fragment's rays even on a low-frequency map.
///
/// Why: in an enclosed scene the light that arrives is a small difference E_unshad − E_occ of
/// two large terms, and the order-2 SH's error in E_unshad is not small against it. Measured at
/// 96×64 against `env-exact` on the same samples (SH → rays): `interior-openings` (a room lit
/// through a window, 81 % occluded cells) RMSE 0.0056 → 0.0025; `scenes/sponza-dvf.toml` (98 %)
/// 0.0075 → 0.0074, FLIP 0.29 → 0.16; the open scenes keep the SH (`cornell-lit` 24 %: 0.0085 →
/// 0.0084; `million-triangles` 0 %). The cost: every ray's map lookup in the shading.
pub const SH_MAX_OCCLUDED_CELLS: f32 = 0.5;

/// The share of the cells with `seen(cell)` (any mask pixel set) labelled `l_occ = 1`: one loop
/// for the CPU field ([`Dvf::occluded_cell_fraction`]) and the GPU's read-back labels and masks.
pub fn occluded_cell_fraction(labels: &[u8], seen: impl Fn(usize) -> bool) -> f32 {
    let (mut cells, mut occluded) = (0u64, 0u64);
    for (c, &l) in labels.iter().enumerate() {
        if seen(c) {
            cells += 1;
            occluded += u64::from(l);
        }
    }
    if cells == 0 { 0.0 } else { occluded as f32 / cells as f32 }
}

/// `unshadowed=auto`'s choice for a map whose N_r-ray estimate has relative noise `noise`
/// ([`cosine_estimator_noise`]) in a field whose share of mostly-occluded cells is `occluded`.
pub fn choose_unshadowed(noise: f32, occluded: f32) -> Unshadowed {
    if noise > SH_MAX_RELATIVE_NOISE || occluded > SH_MAX_OCCLUDED_CELLS { Unshadowed::Rays } else { Unshadowed::Sh }
}

/// `bright=auto`'s choice for a map whose N_r-ray estimate has relative noise `noise`
/// ([`cosine_estimator_noise`]): on where the map is not low-frequency (the threshold of
/// [`SH_MAX_RELATIVE_NOISE`]), where a few small regions send most of the light and the masks'
/// pixels cannot resolve them. The paper's domain, low-frequency maps, keeps Algorithm 3 as is.
pub fn choose_bright(noise: f32) -> bool {
    noise > SH_MAX_RELATIVE_NOISE
}

/// `bright_sr`'s default: the brightest 0.2 sr (1.6 % of the sphere), at most 6 % of a
/// fragment's cosine-weighted rays; 67 % of the warehouse map's power, 89 % of the studio map's.
pub const BRIGHT_SOLID_ANGLE: f32 = 0.2;

/// Pixels per point sample the automatic budget aims at: about 40,000 samples at 1280×720, where
/// `points=40000 grid=40 unknown=trace` measured RMSE 0.0023 on Sponza at 2.1× `env-exact`'s speed
/// (docs/techniques/environment-lighting.md).
pub const PIXELS_PER_POINT: u32 = 24;
/// The automatic budget's bounds on N_P.
pub const AUTO_POINTS: std::ops::RangeInclusive<u32> = 10_000..=10_000_000;
/// Primary rays across the image with which `sides=seen` finds the instances seen from behind
/// (about 9K rays at 16:9; a cost next to N_P × N_r build rays).
pub const BACK_PROBE_ACROSS: u32 = 128;
/// Samples per surface cell the automatic grid aims at (N_P / grid²: 25 at 40,000 and 40).
pub const SAMPLES_PER_CELL: f32 = 25.0;

/// Our defaults: the paper's, except both hemispheres (`sides=both`), rays whose pixel no sample
/// saw traced (`unknown=trace`), masks read over the fragment's 2×2×2 cells (`footprint=around`)
/// and the sample budget chosen from the frame (`auto`).
impl Default for DvfParams {
    fn default() -> Self {
        Self { sides: Sides::Both, trace_unknown: true, footprint: Footprint::Around, auto: AutoBudget::ALL, ..Self::paper() }
    }
}

impl DvfParams {
    /// Reads every key (names shared with `env-exact` where they mean the same: `rays`,
    /// `rotation`), with `self` as the defaults.
    ///
    /// `profile=paper` starts from the paper's exact settings ([`DvfParams::paper`]).
    pub fn read(self, p: &Params) -> Result<Self, ParamError> {
        let base = if p.choice("profile", "default", &["default", "paper"])? == "paper" { Self::paper() } else { self };
        base.read_keys(p)
    }

    /// The paper's settings (its Sponza configuration: N_P = 10M, a 77-cell grid, ceiling
    /// rounding, front hemispheres only, unknown rays skipped).
    pub fn paper() -> Self {
        Self {
            rays: 128,
            build_rays: 0,
            points: 10_000_000,
            rounding: Rounding::Ceil,
            sampling: PointSampling::Hash,
            grid: 77,
            octahedral: 8,
            task_points: 64,
            workgroup: 1024,
            rotate_about_normal: false,
            unshadowed: Unshadowed::Sh,
            atomics: Atomics::PerSample,
            sides: Sides::Front,
            trace_unknown: false,
            bright: false,
            bright_sr: BRIGHT_SOLID_ANGLE,
            footprint: Footprint::Cell,
            auto: AutoBudget::default(),
        }
    }

    /// Whether a map's N_r-ray noise ([`cosine_estimator_noise`]) is needed: by
    /// `unshadowed=auto` or `bright=auto`.
    pub fn wants_map_noise(&self) -> bool {
        self.auto.unshadowed || self.auto.bright
    }

    /// The map's brightest directions for this `bright_sr` and octahedral R, when `bright` may
    /// be on (`on`, or `auto` before the map's noise decides).
    pub fn bright_directions(&self, env: &glimpse_scene::Environment) -> Option<bright::BrightDirections> {
        (self.bright || self.auto.bright).then(|| bright::BrightDirections::new(env, self.bright_sr, self.octahedral)).flatten()
    }

    /// The instances (sorted) whose samples also trace their back hemisphere: every one of
    /// `instances` with `sides=both`, none with `front`, and with `sides=seen` those
    /// `seen_from_behind` returns ([`glimpse_render::FrameContext::instances_seen_from_behind`]).
    ///
    /// What `seen` is for, and why it is not the default: a one-sided surface's back rays
    /// describe where no pixel looks, and they land in the cell of everything near it. Under an
    /// open ground plane they escape, so the plane's cells say "visible" downwards, and a bunny's
    /// underside in the same cell, whose downward rays hit the plane, skips them:
    /// `million-triangles` RMSE 0.0074 with both sides, 0.0065 with `seen` (320 × 180, against
    /// `env-exact` on the same rays). But the back rays of a thin closed solid (a wall box) are
    /// what keeps its inner face's cells right: `interior-openings` 0.0022 with both, 0.018
    /// with `seen` (bright blocks on the walls).
    pub fn back_instances(&self, instances: usize, seen_from_behind: impl FnOnce() -> Vec<u32>) -> Vec<u32> {
        match self.sides {
            Sides::Front => Vec::new(),
            Sides::Both => (0..instances as u32).collect(),
            Sides::Seen => seen_from_behind(),
        }
    }

    /// [`Self::back_instances`] for a frame: `sides=seen` probes its camera with
    /// [`BACK_PROBE_ACROSS`] rays across.
    pub fn back_instances_in(&self, ctx: &glimpse_render::FrameContext) -> Vec<u32> {
        self.back_instances(ctx.frame.scene.instances.len(), || ctx.instances_seen_from_behind(BACK_PROBE_ACROSS))
    }

    /// The parameters for a frame of `pixels` pixels over `triangles` triangles, with the
    /// automatic keys chosen:
    /// - N_P = pixels / [`PIXELS_PER_POINT`], within [`AUTO_POINTS`]: the build's rays
    ///   (N_P × N_r × sides) stay a fraction of the reference's (pixels × N_r);
    /// - grid = √(N_P / [`SAMPLES_PER_CELL`]) cells along the longest axis, within 8..=77, so a
    ///   surface cell holds about 25 samples;
    /// - rounding: ceiling (the paper) unless there are more than 4 N_P triangles, where the
    ///   ceiling's one sample per triangle would multiply the budget (1M triangles: 1M samples);
    ///   then the rounded running total (`cumulative`), which keeps N_P and, unlike Xu et al.'s
    ///   `round`, still samples meshes made of triangles smaller than one share.
    ///   Below that the ceiling adds at most one sample per triangle, as in the measured Sponza
    ///   configuration (66K triangles, `points=40000`: about 100K samples).
    pub fn for_frame(&self, pixels: u64, triangles: usize) -> DvfParams {
        let mut p = *self;
        if self.auto.points {
            p.points = (pixels / PIXELS_PER_POINT as u64).clamp(*AUTO_POINTS.start() as u64, *AUTO_POINTS.end() as u64) as u32;
        }
        if self.auto.grid {
            p.grid = ((p.points as f32 / SAMPLES_PER_CELL).sqrt().round() as u32).clamp(8, 77);
        }
        if self.auto.rounding {
            p.rounding = if triangles as u64 > 4 * p.points as u64 { Rounding::Cumulative } else { Rounding::Ceil };
        }
        p.auto = AutoBudget::default();
        p
    }

    fn read_keys(self, p: &Params) -> Result<Self, ParamError> {
        let octahedral = p.u32("octahedral", self.octahedral, 1, grid::MAX_RESOLUTION)?;
        // `auto` (the default) or a number; a number turns the key's automatic choice off.
        let auto_or = |key: &str, auto: bool| -> Result<bool, ParamError> { Ok(p.text(key, if auto { "auto" } else { "" }) == "auto") };
        let auto = AutoBudget {
            points: auto_or("points", self.auto.points)?,
            grid: auto_or("grid", self.auto.grid)?,
            rounding: auto_or("rounding", self.auto.rounding)?,
            unshadowed: auto_or("unshadowed", self.auto.unshadowed)?,
            bright: auto_or("bright", self.auto.bright)?,
        };
        let rounding_default = match self.rounding {
            Rounding::Ceil => "ceil",
            Rounding::Round => "round",
            Rounding::Cumulative => "cumulative",
        };
        Ok(Self {
            auto,
            rays: p.u32("rays", self.rays, 1, 1 << 16)?,
            build_rays: p.u32("build_rays", self.build_rays, 0, 1 << 16)?,
            points: if auto.points { self.points } else { p.u32("points", self.points, 0, 1 << 30)? },
            rounding: if auto.rounding {
                self.rounding
            } else {
                match p.choice("rounding", rounding_default, &["ceil", "round", "cumulative"])?.as_str() {
                    "round" => Rounding::Round,
                    "cumulative" => Rounding::Cumulative,
                    _ => Rounding::Ceil,
                }
            },
            sampling: if p.choice("sampling", "hash", &["hash", "hammersley"])? == "hammersley" {
                PointSampling::Hammersley
            } else {
                PointSampling::Hash
            },
            grid: if auto.grid { self.grid } else { p.u32("grid", self.grid, 1, 4096)? },
            octahedral,
            task_points: p.u32("task_points", self.task_points, 1, 1 << 20)?,
            workgroup: p.u32("workgroup", self.workgroup, 1, 1 << 16)?,
            rotate_about_normal: p.choice("rotation", "cp", &["cp", "normal"])? == "normal",
            unshadowed: if auto.unshadowed {
                self.unshadowed
            } else if p.choice("unshadowed", if self.unshadowed == Unshadowed::Rays { "rays" } else { "sh" }, &["sh", "rays"])? == "rays" {
                Unshadowed::Rays
            } else {
                Unshadowed::Sh
            },
            atomics: if p.choice("atomics", "sample", &["sample", "ray"])? == "ray" { Atomics::PerRay } else { Atomics::PerSample },
            sides: match p.choice("sides", sides_name(self.sides), &["front", "both", "seen"])?.as_str() {
                "front" => Sides::Front,
                "seen" => Sides::Seen,
                _ => Sides::Both,
            },
            trace_unknown: p.choice("unknown", if self.trace_unknown { "trace" } else { "skip" }, &["skip", "trace"])? == "trace",
            bright: if auto.bright {
                self.bright
            } else {
                p.choice("bright", if self.bright { "on" } else { "off" }, &["off", "on"])? == "on"
            },
            bright_sr: p.f32("bright_sr", self.bright_sr, 1e-6, 4.0 * std::f32::consts::PI)?,
            footprint: match p
                .choice("footprint", if self.footprint == Footprint::Around { "around" } else { "cell" }, &["cell", "around"])?
                .as_str()
            {
                "around" => Footprint::Around,
                _ => Footprint::Cell,
            },
        })
    }
}

fn sides_name(s: Sides) -> &'static str {
    match s {
        Sides::Front => "front",
        Sides::Both => "both",
        Sides::Seen => "seen",
    }
}

/// One frame's field: the grid, the masks and the labels (plus what the build counted).
#[derive(Debug)]
pub struct Dvf {
    pub grid: Grid,
    pub masks: Masks,
    /// l_occ per cell.
    pub labels: Vec<u8>,
    /// Point samples placed (Σ N(T_k)).
    pub samples: u64,
    pub rays_traced: u64,
    pub triangles: usize,
}

impl Dvf {
    /// Cells whose masks hold any ray (the cells the samples reached).
    pub fn seen_cells(&self) -> usize {
        (0..self.masks.cells()).filter(|&c| self.masks.counts(c) != (0, 0)).count()
    }

    /// The share of the cells that saw any sample ray whose label is `l_occ = 1` (mostly
    /// occluded): near 1 in a closed interior, low in an open scene.
    pub fn occluded_cell_fraction(&self) -> f32 {
        occluded_cell_fraction(&self.labels, |c| self.masks.counts(c) != (0, 0))
    }

    /// The five stages, each timed into `stats`: vertices (the CPU update), areas (CS1),
    /// upsweep (CS2), downsweep (CS3), clear, dvf (CS4), labels (CS5). `back_instances`
    /// (sorted; [`DvfParams::back_instances`]) also sample their back hemispheres. `reuse` lends
    /// the previous frame's masks (cleared, not reallocated, when the size is unchanged).
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        frame: &SceneFrame,
        back_instances: &[u32],
        vis: &dyn Visibility,
        p: &DvfParams,
        seed: u64,
        frame_index: u32,
        reuse: Option<Masks>,
        stats: &mut Stats,
    ) -> Dvf {
        let mesh = stats.time("vertices", || areas::WorldMesh::gather(frame, back_instances));
        let (areas, normals) = stats.time("areas", || areas::areas_and_normals(&mesh));
        let levels = stats.time("upsweep", || scan::up_sweep_passes(&areas, p.workgroup as usize));
        let (prefix, total) = stats.time("downsweep", || scan::down_sweep_passes(levels));
        let grid = Grid::from_bounds(frame.bounds, p.grid);
        let masks = stats.time("clear", || match reuse {
            Some(mut m) => {
                m.reset(grid.cell_count(), p.octahedral);
                m
            }
            None => Masks::new(grid.cell_count(), p.octahedral),
        });
        let (samples, rays_traced) = stats.time("dvf", || {
            let counts = points::sample_counts(p.points, &areas, &prefix, total, p.rounding);
            let first_ids: Vec<u64> = prefix.par_iter().enumerate().map(|(k, &s)| points::first_sample_id(p.points, s, total, k)).collect();
            let tasks = points::tasks(&counts, p.task_points);
            let settings = field::SampleSettings {
                sampling: p.sampling,
                rays: if p.build_rays == 0 { p.rays } else { p.build_rays },
                rotate_about_normal: p.rotate_about_normal,
                seed,
                frame_index,
            };
            let rays = field::build_masks(vis, &mesh, &normals, &first_ids, &tasks, &grid, &masks, &settings, p.atomics, true);
            (counts.iter().map(|&c| c as u64).sum::<u64>(), rays)
        });
        let labels = stats.time("labels", || labels::occlusion_labels(&masks));
        stats.rays += rays_traced;
        stats.memory_bytes = stats.memory_bytes.max(masks.memory_bytes() + labels.len() + mesh.memory_bytes() + areas.len() * 20);
        Dvf { grid, masks, labels, samples, rays_traced, triangles: mesh.indices.len() }
    }

    pub fn memory_bytes(&self) -> usize {
        self.masks.memory_bytes() + self.labels.len()
    }

    /// Cells labelled occluded.
    pub fn occluded_cells(&self) -> usize {
        self.labels.iter().filter(|&&l| l == 1).count()
    }
}

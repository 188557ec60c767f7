//! glimpse-lightcuts: stochastic light cuts over VPLs (M. Tavasszy, "Stochastic Light Cut
//! Exploration for Real-Time Dynamic Global Illumination", MSc thesis, TU Delft 2021; spec
//! ../shared/specs/stochastic-lightcuts.md), with the thesis' baselines SST (Tatzgern et al. 2020)
//! and RTSLC (Lin and Yuksel 2020), and the brute-force VPL sum as their ground truth.
//!
//! Modules, one stage of the thesis each: [`vpl`] (§4.1: bounded RSM, pVPL estimate, filter,
//! hierarchical warping), [`tree`] (§4.2: keys, bitonic sort, perfect SST, parallel build),
//! [`cut`] (§5.1: shallow cuts, blending, mock cuts), [`sample`] (§5.2–5.3: traversal and cluster
//! evaluation), [`upsample`] (Ch. 6: joint bilateral upsampling), [`technique`] (the four ids).
//! docs/techniques/lightcuts.md lists every choice where the thesis is silent.

pub mod cut;
pub mod sample;
pub mod technique;
pub mod tree;
pub mod upsample;
pub mod vpl;

pub use glimpse_render::Stopwatch;
pub use technique::VplTechnique;
pub use tree::{Flatness, Sst, SstNode, Vpl};

use glimpse_render::{ParamError, Params, TechniqueInfo};

/// The four techniques.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// `vpl-exact`: every VPL, exact visibility.
    Exact,
    /// `vpl-lightcuts`: the thesis' method.
    Lightcuts,
    /// `vpl-sst`: traversal from the root, stopping at flat nodes.
    Sst,
    /// `vpl-rtslc`: traversal from the cut nodes to leaves.
    Rtslc,
}

impl Variant {
    pub fn id(self) -> &'static str {
        match self {
            Variant::Exact => "vpl-exact",
            Variant::Lightcuts => "vpl-lightcuts",
            Variant::Sst => "vpl-sst",
            Variant::Rtslc => "vpl-rtslc",
        }
    }
}

/// The thesis' absolute lengths (the pVPL radius cap 1, σ_max 0.3) are read in units of this
/// fraction of the scene's diagonal by default (see [`LightcutsParams::length_unit`]), so the
/// same scene in centimetres or metres gives the same picture (crates/eval/tests/scale_invariance.rs).
/// 1: the thesis' values on a scene about 1 m across (our Cornell box: diagonal 0.96 m). Measured
/// (`glimpse eval SCENE -t vpl-lightcuts,vpl-sst,vpl-rtslc --size 96x64 --spp 8 --set
/// profile=paper --set pvpl_radius=R --set sigma_max=S`, RMSE of vpl-lightcuts vs vpl-exact):
/// Cornell 0.054 at a unit of diagonal/40, 0.037 at the diagonal; Sponza (diagonal 41.6 m)
/// 0.053 at diagonal/4, 0.044 at the diagonal, 0.041 at 1 m (the thesis' own scene and
/// setting, assuming metres). A fraction small enough for Sponza loses on the Cornell box, so
/// the diagonal it is.
pub const LENGTH_UNIT_PER_DIAGONAL: f32 = 1.0;

/// The default `stop_ratio` (see [`LightcutsParams::stop_ratio`]).
pub const DEFAULT_STOP_RATIO: f32 = 0.1;

/// The default light-cut block size `block` (ours: one cut per pixel). On the CPU a cut costs
/// about 1.5–2.6 µs, a small part of a pixel's shadow rays, and a cut shared by an 8×8 block
/// (the thesis' [`THESIS_BLOCK`], chosen for a GPU's cost) fits the block's other pixels badly:
/// per-pixel cuts lower the MSE 1.4–8× on the suite scenes for 5–10 % more frame time
/// (docs/techniques/lightcuts.md, "Block size").
pub const DEFAULT_BLOCK: u32 = 1;

/// The thesis' block size k (§5.1.1, Fig. 7.5): one cut per 8×8 pixels (`profile=paper`).
pub const THESIS_BLOCK: u32 = 8;

/// The thesis' per-pixel sample budget n (= the largest cut), its §7 setting: `glimpse suite`
/// runs the VPL methods at it, since at a few samples the cut of n nodes degenerates.
pub const THESIS_SPP: u32 = 32;

/// Parameters (`--set key=value`); `Default` is the thesis' setting where it gives one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightcutsParams {
    /// `vpl_count`: total VPLs, a power of two (thesis 4096).
    pub vpl_count: u32,
    /// `rsm_resolution`: per light, a power of two (thesis 512). With `rsm_per_light` (the
    /// default, `rsm_resolution=auto`) it is the largest: each light gets the thesis' texels per
    /// VPL ([`vpl::rsm_resolution_for`]).
    pub rsm_resolution: u32,
    /// Size each light's RSM by the VPLs it gets (ours; `rsm_resolution=N` or `profile=paper`
    /// give every light N², the thesis' single light 512²). A scene with many lights otherwise
    /// renders many 512² maps for a few VPLs each: `sponza-interior` (4 points, a panel) spent
    /// 545 of its 594 ms per 96×64 frame generating VPLs.
    pub rsm_per_light: bool,
    /// `pvpl_samples`: G-buffer samples per pVPL (thesis "a few"; ours 4).
    pub pvpl_samples: u32,
    /// `pvpl_radius`: unit of the capped 1/x² radius, in scene units; `None` (`auto`, the
    /// default) takes [`Self::length_unit`]. The thesis caps the distribution "to 1" in scene
    /// units, a length that means something else in every scene's units.
    pub pvpl_radius: Option<f32>,
    /// `profile=paper`: the thesis' absolute lengths (pVPL radius cap 1, σ_max 0.3) in scene
    /// units; by default they are in units of the scene's diagonal
    /// ([`LENGTH_UNIT_PER_DIAGONAL`]), so the same scene in centimetres or metres gives the same
    /// picture. The keys the thesis leaves open keep our
    /// values in both profiles.
    pub paper_units: bool,
    /// `filter_radius`, `filter_sigma`: the edge-aware Gaussian (texels) [UNSPEC: ours 2, 1].
    pub filter_radius: u32,
    pub filter_sigma: f32,
    /// `defensive`: flux PDF fraction mixed into the selection PDF (ours: 0.05, unbiased weights).
    pub defensive: f32,
    /// `clamp`: 1/d² is clamped at d = clamp × scene diagonal, for every VPL and cluster alike
    /// (the thesis does not say; ours 0.01).
    pub clamp: f32,
    /// `sim_normal`: n_min of Eq. 5.3 (cosine) [UNSPEC: ours 0.9].
    pub sim_normal: f32,
    /// `sim_distance`: d_max of Eq. 5.3 as a fraction of the scene diagonal [UNSPEC: ours 0.05].
    pub sim_distance: f32,
    /// `block`: light cut block size k ([`DEFAULT_BLOCK`] 1, ours; thesis and `profile=paper`:
    /// [`THESIS_BLOCK`] 8).
    pub block: u32,
    /// `v_min`, `sigma_max`: Eq. 5.6 (thesis 0.7, 0.3; σ_z is the variance along the normal,
    /// a squared length). `flatness.sigma_max` holds the thesis' 0.3 in units of
    /// [`Self::length_unit`]²: scene units with `profile=paper`, the diagonal by default (see
    /// [`Self::flatness`]).
    pub flatness: Flatness,
    /// `stop_ratio` (ours; `profile=paper`: ∞, Eq. 5.6 alone): a flat cluster ends a traversal
    /// only where its box's diagonal is at most this × its distance from the shaded point
    /// ([`sample::stops_at`]). The substitute Gaussian stands in for the cluster's VPLs well only
    /// where the cluster is small as seen from the point; near ones are traversed on. Measured
    /// on 12 scenes (docs/techniques/lightcuts.md, "The stop rule"): 0.1 lowers the RMSE
    /// against `vpl-exact` on 9 and the FLIP on all 12, at the same frame time.
    pub stop_ratio: f32,
    /// `cluster_light`: how a stopped cluster lights the shaded point, `vpl` (ours, the default
    /// of `vpl-lightcuts`: one of its VPLs picked ∝ intensity, unbiased) or `substitute` (the
    /// thesis' §5.3 Gaussian point light; `profile=paper`, and `vpl-sst`'s default, whose
    /// method the substitute is). See [`sample::ClusterLight`].
    pub cluster_light: sample::ClusterLight,
    /// `half_res`: GI at half resolution + joint bilateral upsampling (thesis option; off).
    pub half_res: bool,
    /// `include_direct`: add the direct light (the thesis' final image); default true.
    pub include_direct: bool,
    /// `direct_samples`: area-light/environment samples for the direct light (ours 16).
    pub direct_samples: u32,
}

impl Default for LightcutsParams {
    fn default() -> Self {
        Self {
            vpl_count: 4096,
            rsm_resolution: 512,
            rsm_per_light: true,
            pvpl_samples: 4,
            pvpl_radius: None,
            paper_units: false,
            filter_radius: 2,
            filter_sigma: 1.0,
            defensive: 0.05,
            clamp: 0.01,
            sim_normal: 0.9,
            sim_distance: 0.05,
            block: DEFAULT_BLOCK,
            flatness: Flatness::default(),
            stop_ratio: DEFAULT_STOP_RATIO,
            cluster_light: sample::ClusterLight::Vpl,
            half_res: false,
            include_direct: true,
            direct_samples: 16,
        }
    }
}

fn power_of_two(key: &str, v: u32) -> Result<u32, ParamError> {
    if v.is_power_of_two() {
        Ok(v)
    } else {
        Err(ParamError::Invalid { key: key.into(), value: v.to_string(), message: "must be a power of two".into() })
    }
}

impl LightcutsParams {
    /// Reads the keys `variant` uses (`vpl-exact` reads only those that change the VPLs, the
    /// clamp and the direct light, so eval's reference sees the same VPL set).
    pub fn read(params: &Params, variant: Variant) -> Result<Self, ParamError> {
        let d = Self::default();
        let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
        let rsm_auto = params.text("rsm_resolution", "auto") == "auto";
        let mut p = Self {
            vpl_count: power_of_two("vpl_count", params.u32("vpl_count", d.vpl_count, 2, 1 << 20)?)?,
            rsm_resolution: if rsm_auto {
                d.rsm_resolution
            } else {
                power_of_two("rsm_resolution", params.u32("rsm_resolution", d.rsm_resolution, 2, 4096)?)?
            },
            rsm_per_light: rsm_auto && !paper,
            pvpl_samples: params.u32("pvpl_samples", d.pvpl_samples, 0, 256)?,
            pvpl_radius: match params.text("pvpl_radius", "auto").as_str() {
                "auto" => None,
                _ => Some(params.f32("pvpl_radius", 1.0, 1e-6, f32::MAX)?),
            },
            paper_units: paper,
            filter_radius: params.u32("filter_radius", d.filter_radius, 0, 16)?,
            filter_sigma: params.f32("filter_sigma", d.filter_sigma, 1e-3, 100.0)?,
            defensive: params.f32("defensive", d.defensive, 0.0, 1.0)?,
            clamp: params.f32("clamp", d.clamp, 0.0, 1.0)?,
            sim_normal: params.f32("sim_normal", d.sim_normal, -1.0, 1.0)?,
            sim_distance: params.f32("sim_distance", d.sim_distance, 0.0, f32::INFINITY)?,
            include_direct: params.bool("include_direct", d.include_direct)?,
            direct_samples: params.u32("direct_samples", d.direct_samples, 0, 4096)?,
            ..d
        };
        if variant != Variant::Exact {
            p.block = params.u32("block", if paper { THESIS_BLOCK } else { d.block }, 1, 256)?;
            p.flatness = Flatness {
                v_min: params.f32("v_min", d.flatness.v_min, 0.0, 2.0)?,
                sigma_max: params.f32("sigma_max", d.flatness.sigma_max, 0.0, f32::INFINITY)?,
            };
            let stop_default = if paper { f32::INFINITY } else { d.stop_ratio };
            p.stop_ratio = params.f32("stop_ratio", stop_default, 1e-6, f32::INFINITY)?;
            let substitute_default = paper || variant == Variant::Sst;
            p.cluster_light = match params
                .choice("cluster_light", if substitute_default { "substitute" } else { "vpl" }, &["vpl", "substitute"])?
                .as_str()
            {
                "vpl" => sample::ClusterLight::Vpl,
                _ => sample::ClusterLight::Substitute,
            };
            p.half_res = params.bool("half_res", d.half_res)?;
        }
        Ok(p)
    }

    /// The VPL generation settings for a scene of diagonal `diag`.
    /// The length the thesis' absolute thresholds (the pVPL radius cap, σ_max) are measured in
    /// for a scene of diagonal `diag`: 1 scene unit under `profile=paper`, else
    /// [`LENGTH_UNIT_PER_DIAGONAL`] of the diagonal.
    pub fn length_unit(&self, diag: f32) -> f32 {
        if self.paper_units { 1.0 } else { LENGTH_UNIT_PER_DIAGONAL * diag }
    }

    /// Eq. 5.6's thresholds in scene units for a scene of diagonal `diag` (σ_z is a variance, so
    /// σ_max scales with the unit squared).
    pub fn flatness(&self, diag: f32) -> Flatness {
        let u = self.length_unit(diag);
        Flatness { v_min: self.flatness.v_min, sigma_max: self.flatness.sigma_max * u * u }
    }

    pub fn vpl_params(&self, diag: f32) -> vpl::VplParams {
        vpl::VplParams {
            count: self.vpl_count,
            rsm_resolution: self.rsm_resolution,
            rsm_per_light: self.rsm_per_light,
            pvpl_samples: self.pvpl_samples,
            pvpl_radius: self.pvpl_radius.unwrap_or(self.length_unit(diag)),
            filter_radius: self.filter_radius,
            filter_sigma: self.filter_sigma,
            defensive: self.defensive,
            clamp: self.clamp * diag,
            similarity: technique::similarity(self, diag),
        }
    }
}

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    [Variant::Exact, Variant::Lightcuts, Variant::Sst, Variant::Rtslc].into_iter().map(VplTechnique::info).collect()
}

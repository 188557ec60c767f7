//! glimpse-wavecache: real-time all-frequency global illumination with Haar-wavelet radiance
//! caching (Xing, Pan, Chen, Wu, Wang and Wang 2024, "Real-time all-frequency global illumination
//! with radiance caching"), for static scenes, against the path tracer `pt`.
//!
//! - [`halfcube`]: the half-cube map layout and texel solid angles (Sec. 4.2, [29]);
//! - [`haar`]: the non-standard 2D Haar quadtree (Eq. 13), pruning by β, fp16 ([`half`]), the
//!   coefficient dot product (Eq. 6, the paper's ⊗);
//! - [`brdf`]: GGX BRDF × cosine tables over the ω_o grid, bilinear blending (Sec. 4.2, 5.2);
//! - [`points`]: weighted sample elimination (Sec. 4.1, Eq. 7 corrected) and the octrees (Sec. 4.3);
//! - [`bake`]: the lighting precomputation (Sec. 4.3, 6);
//! - [`cache`]: the whole precomputation, its disk cache and its storage;
//! - [`technique`]: `wavecache`, the runtime (Sec. 5, Eqs. 15–21).
//!
//! [`WavecacheParams::default`] is sized for a 2-core CPU (a few minutes of precomputation at
//! 320×240); [`WavecacheParams::paper`] holds the paper's values (GPU-hours of precomputation).

pub mod bake;
pub mod brdf;
pub mod cache;
pub mod env_direct;
pub mod haar;
pub mod half;
pub mod halfcube;
pub mod points;
pub mod technique;

pub use cache::WaveCache;
pub use technique::Wavecache;

use glimpse_render::bsdf::BrdfModel;
use glimpse_render::{ParamError, Params, TechniqueInfo};

/// How a mesh is shaded (paper Sec. 4.1's split).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Class {
    /// Irradiance cache (Eq. 19).
    Diffuse = 0,
    /// Radiance half-cube maps ⊗ BRDF trees (Eq. 20).
    Glossy = 1,
    /// Roughness below the mirror threshold: traced as a perfect mirror (Eq. 18), no cache.
    Mirror = 2,
}

impl Class {
    pub fn from_u32(v: u32) -> Class {
        match v {
            0 => Class::Diffuse,
            1 => Class::Glossy,
            _ => Class::Mirror,
        }
    }
}

/// The frame ω_o is expressed in for the BRDF lookup, against a radiance map stored in the cache
/// point's frame (the paper leaves the mismatch between the pixel's and the point's normals
/// implicit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WoFrame {
    /// The paper: ω_o in the pixel's shading frame, used as is against the point's map (the lobe
    /// lands off by the angle between the two normals).
    Pixel,
    /// ω_o in the point's frame (the lobe off by twice that angle).
    Point,
    /// Ours (default): the ω_o whose mirror direction about the point's normal is the pixel's
    /// mirror direction, so sharp lobes look up the map where the true reflection is.
    Reflect,
}

/// Whether a glossy map leaves the environment's direct light out (`env_direct`, ours; see
/// [`WavecacheParams::env_direct`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EnvDirect {
    /// Where the environment's brighter half (by power) spans under [`ENV_DIRECT_TEXELS`]
    /// texels of the material's map: the map cannot resolve it.
    Auto,
    On,
    /// The paper: every map holds all the light.
    Off,
}

/// `env_direct_pixel_samples`' default: the fewest environment samples a pixel read from the
/// cache takes. Measured at 96 × 64 and 4 spp against `pt` at 4,096 spp, MSE with 32 / 64 / 128 /
/// 256 / 1,024 samples per pixel: `studio-objects` 1.02e-2 / 6.62e-3 / 6.40e-3 / 5.96e-3 /
/// 5.58e-3, `textured-glossy` 6.64e-3 / 5.56e-3 / 4.31e-3 / 3.96e-3 / –; the shading costs 1.7×
/// (`studio-objects`) to 2.5× (`textured-glossy`) at 256, under 0.1 s at that size.
pub const ENV_DIRECT_PIXEL_SAMPLES: u32 = 256;

/// `env_direct=auto`'s bound on the environment's brighter half, in texels of (π/N)² sr: the
/// warehouse map's spans 3.4 texels of a 32² map (0.83 of a 16² one), the studio map's 0.54,
/// the built-in sky's 441.
pub const ENV_DIRECT_TEXELS: f32 = 1.0;

/// `env_direct=auto`'s bound on the lobe, in texels (2α against π/N, as `sharp_texels`): a lobe
/// of many texels averages a sub-texel light over several texels of its own and barely aliases
/// it, while the samples' noise remains (`mixed-lights`' roughness-0.5 bunny, 2.5 texels of its
/// 16² maps, under the warehouse map: MSE 2.7e-4 → 2.9e-4 split). Spot and the studio sphere
/// (roughness 0.3 on 32² maps) span 1.8.
pub const ENV_DIRECT_LOBE_TEXELS: f32 = 2.0;

/// `sharp_texels`' default: lobes under half a texel of their map are traced. Measured at 96 × 64
/// against 4,096-spp `pt` (docs/techniques/wavecache.md, "How sharp is sharp"): at 1 (sessions
/// 10–23) `textured-glossy`'s roughness-0.2 floor (0.8 texel) was traced, MSE 3.99e-2 at 4 spp
/// and 1.17e-2 at 16; read from its 32² maps 6.59e-3 and 4.16e-3 (`studio-objects`' 0.2 teapot
/// 1.31e-2 → 1.13e-2); `glints`' 0.12 sphere (0.3 texel) stays traced (from the maps: MSE 3.8 →
/// 10.5, 153 pixels black where lit).
pub const SHARP_TEXELS: f32 = 0.5;

/// `trace_disagree=auto`'s factor where the cached light comes from small sources.
pub const AUTO_DISAGREE: f32 = 3.0;

/// Whether the environment's brighter half (by power) spans under 0.01 sr, about one texel of a
/// 32² radiance map: a studio map's softboxes (0.0052 sr), not the warehouse map (0.032) nor a
/// sky (4.25). Its shadows are hard, and blending cache points across them smears light into
/// the umbra (`trace_disagree=auto`).
pub fn small_env_source(env: Option<&glimpse_scene::Environment>) -> bool {
    env.is_some_and(|e| e.half_power_solid_angle() < 0.01)
}

/// The solid angle, in sr, that the emitters sending the brighter half of the area lights'
/// power span from a quarter of the scene's diagonal away (each emissive instance as the disc
/// of its bounding sphere; `None` without emissive triangles): the area lights' analogue of
/// [`glimpse_scene::Environment::half_power_solid_angle`]. `glints`' 2 cm spheres: 0.0034 sr;
/// the built-in `cornell`'s ceiling light 0.38.
pub fn emitters_half_power_solid_angle(frame: &glimpse_scene::SceneFrame) -> Option<f32> {
    use std::collections::BTreeMap;
    let mut instances: BTreeMap<u32, (f64, glimpse_core::Aabb)> = BTreeMap::new();
    for e in &frame.emissive {
        let (power, bounds) = instances.entry(e.instance).or_insert((0.0, glimpse_core::Aabb::EMPTY));
        *power += (glimpse_core::luminance(e.radiance) * e.area) as f64;
        *bounds = e.vertices.iter().fold(*bounds, |b, v| b.grow(*v));
    }
    let total: f64 = instances.values().map(|(p, _)| p).sum();
    if instances.is_empty() || total.is_nan() || total <= 0.0 {
        return None;
    }
    let distance = 0.25 * frame.bounds.extent().length();
    let mut by_power: Vec<_> = instances.into_values().collect();
    by_power.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (mut power, mut solid_angle) = (0.0, 0.0f32);
    for (p, b) in by_power {
        if power >= 0.5 * total {
            break;
        }
        power += p;
        let radius = 0.5 * b.extent().length();
        solid_angle += (std::f32::consts::PI * radius * radius / (distance * distance)).min(2.0 * std::f32::consts::PI);
    }
    Some(solid_angle)
}

/// Whether the light the cache holds comes mostly from small sources, whose shadows are hard
/// (`trace_disagree=auto`): an environment whose brighter half spans under 0.01 sr
/// ([`small_env_source`]), or, with no environment, area lights whose brighter half spans under
/// 0.01 sr ([`emitters_half_power_solid_angle`]: `glints`' emissive spheres, not a Cornell
/// box's ceiling light). Punctual lights are shaded at the pixel, not cached. A small emitter
/// under an environment is left out: how the two compare in power is not known here, and under
/// a sky a pixel traced for the sky's contact shadows costs its spp for little (session 19).
pub fn small_cached_sources(frame: &glimpse_scene::SceneFrame) -> bool {
    match frame.scene.environment.as_ref() {
        Some(env) => small_env_source(Some(env)),
        None => emitters_half_power_solid_angle(frame).is_some_and(|o| o < 0.01),
    }
}

/// Default `brdf_max_tables` (ours): a table takes about 24 MiB at the default ω_o grid and
/// resolution (`scenes/extra/forest`: 95 tables, 2.39 GiB), so 96 keep the tables near 2.3 GiB,
/// under the 4 GiB target with the lighting cache (under 0.1 GiB on every suite scene).
pub const DEFAULT_BRDF_MAX_TABLES: u32 = 96;

/// The BRDF tables' bound in bytes (ours): fewer tables than `brdf_max_tables` where tables as
/// large as they can be would pass it (a finer `brdf_res` or ω_o grid;
/// [`cache::BrdfPlan::max_tables`]). At the defaults it allows 97 tables of 39 MB at most, so
/// `brdf_max_tables` (96) binds there, and leaves 0.46 GiB of the 4 GiB target to the lighting
/// cache.
pub const BRDF_TABLES_MAX_BYTES: u64 = 3_800_000_000;

/// The default `budget`: the lighting precomputation's paths, about the tuned `glossy` scene's
/// and the bunnys (58M and 76M paths; 21 s and 35 s on the 2-core development machine).
pub const DEFAULT_PATH_BUDGET: u64 = 80_000_000;

/// The default `path_floor`: about the lightest suite scene's plan (`warehouse-objects`, 10.2M
/// paths), so no suite or tuned scene changes and no scene's cache is sparser than the points
/// the budgets give a light one.
pub const DEFAULT_PATH_FLOOR: u64 = 10_000_000;

/// The default `ray_budget`: a little over the larger of the tuned scenes' precomputes
/// (`bunny-glossy`: 75.8M paths at 3.62 rays per path = 274M rays; `glossy` 200M), so they and
/// every scene with shorter paths keep their plan, while a closed interior (`sponza-interior`:
/// 12.9 rays per path) gets proportionally fewer paths
/// (`cargo run --release -p glimpse-wavecache --example path_length -- SCENE…`).
pub const DEFAULT_RAY_BUDGET: u64 = 280_000_000;

/// The default `trace_far`, in r_max (chosen from the measurements in docs/techniques/wavecache.md,
/// "Far points").
pub const DEFAULT_TRACE_FAR: f32 = 4.0;

/// Every parameter of the technique (`--set key=value`). Paper values in the comments.
#[derive(Clone, Debug, PartialEq)]
pub struct WavecacheParams {
    /// ω_o grid over cos θ_o (paper 172 [INF: the first factor of "172×1080"]).
    pub brdf_grid_u1: u32,
    /// ω_o grid over φ_o (paper 1080).
    pub brdf_grid_u2: u32,
    /// BRDF half-cube resolution N (paper 128).
    pub brdf_res: u32,
    /// Strata per axis inside each BRDF texel (paper: stratified, count unspecified).
    pub brdf_strata: u32,
    /// Multiplies the paper's BRDF β (0.1 for r ≤ 0.2, else 0.2) to give a β relative to the root
    /// scaling coefficient (the paper's absolute scale is unknown).
    pub brdf_beta_scale: f32,
    /// At most this many BRDF tables (ours; 0: no limit, `profile=paper`): beyond it the glossy
    /// roughnesses snap to fewer levels ([`cache::BrdfPlan::new`]).
    pub brdf_max_tables: u32,
    /// Table 2's radiance-map resolution is divided by this (paper 1).
    pub map_scale: u32,
    /// Path-traced samples per radiance texel (paper 128).
    pub texel_samples: u32,
    /// `texel_light_samples` (ours; 0 in `profile=paper`, which path-traces the texels alone):
    /// light samples per map texel, on average, shared by the area lights and the environment and
    /// splatted into the texel of their direction, combined with the texels' own samples by the
    /// balance heuristic ([`bake::Integrator::radiance_map`]). A small bright source (a softbox, a
    /// 2 cm sphere) covering part of a texel is otherwise found by one of its `texel_samples`
    /// rays or none: the texel reads many times its light or nothing, a black or a glinting
    /// highlight on the glossy surface (`textured-glossy`). One shadow ray each.
    pub texel_light_samples: u32,
    /// Radiance β relative to the map's root scaling coefficient (paper: 1000 in its own units).
    pub radiance_beta: f32,
    /// Paths per diffuse point's irradiance.
    pub irradiance_samples: u32,
    /// Cache points over all diffuse meshes, by area (paper: 81,579–1,317,000 per scene).
    pub diffuse_points: u32,
    /// Cache points over all glossy meshes, by area.
    pub glossy_points: u32,
    /// Fewest points per mesh.
    pub min_points: u32,
    /// `curvature_deg` (ours, session 27; 0 = off, `profile=paper`): a glossy mesh gets at
    /// least enough points that neighbouring ones' normals lie about this far apart: its
    /// normals' coverage of the sphere of directions (sr) / (π θ²), 33 for a sphere at 20°.
    /// Why: points are shared by area, and `scenes/extra/gallery`'s 120 small spheres beside a
    /// large glossy floor got 16 each, 28° apart on a 0.25 m sphere, whose products were twice
    /// the highlight a map at the pixel gives. 20° (MSE against 4,096-spp `pt` 0.149 → 0.075,
    /// precompute 34 → 50 s there) rather than 15° (0.070, 75 s, more pixels over 2× `pt`).
    pub curvature_deg: f32,
    /// Closest spacing (r_max) a mesh's points are given, in units of the scene's diagonal
    /// (`min_spacing`; 0: none, the paper's profile): a class's budget is shared by area, so a
    /// class of tiny total area got its whole budget there ([`cache::plan_points`]).
    pub min_spacing: f32,
    /// Most paths the lighting precomputation traces (`budget`; 0: no limit, the paper's
    /// profile): both point budgets shrink together to fit ([`cache::plan_points`]).
    pub path_budget: u64,
    /// Fewest paths the lighting precomputation traces (`path_floor`, ours; 0: none, the paper's
    /// profile): where the point budgets give fewer, both scale up together to it (bounded by
    /// `min_spacing` and by the path budget). Sponza as one rough glossy mesh got 4,000 points
    /// (r_max 0.74 m) and 1.4M paths, a fifth of the lightest suite scene's, and a third of its
    /// pixels were traced as beyond the cache ([`cache::plan_points`]).
    pub path_floor: u64,
    /// Most rays the lighting precomputation traces (`ray_budget`; 0: no limit): the path budget
    /// becomes `ray_budget` / the scene's mean rays per path, measured by a pilot
    /// ([`cache::mean_rays_per_path`]), when that is smaller ([`Self::effective_path_budget`]).
    pub ray_budget: u64,
    /// Scattering vertices of the precompute paths, counted as `pt` counts them (pt's default 8).
    pub max_depth: u32,
    /// Sparsification strength for the irradiance (diffuse) points (0 = off).
    pub sparsify: f32,
    /// Points whose energy is below this are dropped (Sec. 6's low-energy points; 0 = none).
    pub min_energy: f32,
    /// `enclosed_share` (ours; 1 = off, `profile=paper`): a point whose probe rays
    /// ([`bake::ENCLOSURE_RAYS`]) hit the back of a one-sided surface in more than this share is
    /// buried inside a closed mesh (Suzanne's eyeballs inside her head, interpenetrating props):
    /// it is not baked and not kept. Its cached light is the dark inside, which the query handed
    /// to visible pixels nearby as black patches (`studio-objects`). See
    /// docs/techniques/wavecache.md ("Buried points").
    pub enclosed_share: f32,
    /// m: candidates examined per query, nearest octree box first (0: exact argmax; the paper
    /// gives no value). 128, about four leaves: the blending kernel's neighbours fit in it, and
    /// on the eight suite scenes the images equal the exact search's (32, one leaf, still let
    /// a pixel miss a point 0.4 r_max away that lay in the next box: docs/techniques/wavecache.md,
    /// "The query").
    pub query_m: u32,
    /// λ of the position/normal score.
    pub normal_weight: f32,
    /// Normal cutoff in degrees.
    pub normal_cutoff_deg: f32,
    /// `search_radius` (ours, in units of the mesh's r_max; the paper gives none, the spec
    /// suggests 2): only points this near rank by the normal cutoff first; farther ones compete
    /// on the plain score. Unbounded (`inf`, `profile=paper`), a shaded point whose neighbours
    /// all face elsewhere (a thin ledge, an arch's underside) took a point of its own
    /// orientation anywhere in the mesh: on `sponza-interior`, points 10 m away in the sky's
    /// light (67 pixels over 2× `pt`). 8: see docs/techniques/wavecache.md ("The query").
    pub search_radius: f32,
    /// `trace_far` (ours, in units of the mesh's r_max; `inf` = never, `profile=paper`): a shaded
    /// point whose chosen cache point lies farther than this, or outside the normal cutoff (no
    /// point of its orientation within the search radius; session 19), or that finds none, is
    /// shaded by tracing its lobe as a sharp lobe is (`Runtime::traced_sample`, at the pixel's
    /// spp) rather than from a point that cached another place's light. The cache's points
    /// follow area, so a surface with no point of its own orientation near (Sponza's ledges and
    /// undersides) otherwise reads one several r_max away or turned 90°: black where lit, or
    /// over 2× `pt`. See docs/techniques/wavecache.md ("Far points").
    pub trace_far: f32,
    /// `trace_disagree` (ours; `inf` = never, `profile=paper`): a diffuse pixel whose blended
    /// points' irradiances differ by more than this factor (brightest over darkest luminance) is
    /// traced as a far one is. Such points straddle a shadow edge or a bright spot the cache
    /// samples coarsely, and their weighted mean paints light into the umbra (`studio-objects`:
    /// 63 pixels over 2× `pt`, 25 with 3). The traced pixels take the pixel's spp, and on the
    /// tuned `bunny-glossy` (a sky) at 128 spp (0.6 % of the pixels, its contact shadow) the
    /// shading took 3× as long, so the default, `auto` ([`WavecacheParams::disagree_auto`]), is
    /// [`AUTO_DISAGREE`] only where the cached light comes from small sources
    /// ([`small_cached_sources`]: a studio map, small emitters without a map), whose shadow
    /// edges are hard, and never elsewhere. See
    /// docs/techniques/wavecache.md ("Disagreeing points").
    pub trace_disagree: f32,
    /// `trace_disagree=auto` (the default): `trace_disagree` is chosen from the light sources.
    pub disagree_auto: bool,
    /// `trace_lonely` (ours, session 25; `profile=paper`: false): where `trace_disagree` applies,
    /// a diffuse pixel with no point inside the blend kernel (its nearest point of a like
    /// normal lies beyond `blend_radius` × r_max) is traced too. On a curved surface (Suzanne's
    /// brow and ears) the normal cutoff hands such a pixel a point 2–3 r_max away, lit or
    /// shadowed unlike it (0.2 where `pt` has 1.9), and with one point there is no
    /// disagreement to see. See docs/techniques/wavecache.md ("Disagreeing points").
    pub trace_lonely: bool,
    /// `far_samples` (ours, session 34): a pixel traced for its cache points (`trace_far`,
    /// `trace_disagree`, `trace_lonely`) takes at least this many traced samples, whatever the
    /// spp. Each sample is one light sample per source and one BSDF bounce; under a studio map's
    /// softboxes four of them left such pixels 3–8× off `pt` (`studio-objects` at 4 spp: MSE
    /// against 4,096-spp `pt` 5.67e-3 → 4.17e-3 with 16). See docs/techniques/wavecache.md
    /// ("Traced pixels' samples").
    pub far_samples: u32,
    /// `validity` (ours, session 34; 0.3, within Ward's usual 0.1–0.3; `inf` = off, `profile=paper`):
    /// where `trace_lonely` applies, a diffuse or glossy pixel
    /// none of whose points inside the kernel is valid for it by Ward's irradiance-caching error,
    /// distance / the point's reach + √(1 − n·n) < `validity` (reach: the harmonic mean of the
    /// point's probe rays' hit distances), is traced as a lonely one is. In a fold, the light
    /// changes faster than the points are spaced: a `studio-objects` Suzanne pixel read one lit
    /// point 1.98 r_max away at 2.11 where `pt` has 0.21 (0.16 traced). See
    /// docs/techniques/wavecache.md ("Traced pixels' samples").
    pub validity: f32,
    /// `blend` (ours; the paper reads one point, `profile=paper`: 1): a diffuse mesh's irradiance
    /// is the weighted mean of its `blend` best-scoring points within `blend_radius` × r_max
    /// (biweight kernel × the normals' cosine, inside the normal cutoff) instead of the best
    /// point's alone. One point per shaded point made the image a mosaic of the points' Voronoi
    /// cells: blocky shadows, and a dark point (a crease, a concave corner) painted over its
    /// whole cell. See docs/techniques/wavecache.md ("Blending points").
    pub blend: u32,
    /// `blend` for glossy meshes (ours; `profile=paper`: 1): their points' reflected radiance
    /// (Eq. 20), blended alike. Each point costs a wavelet product, so fewer than `blend`.
    pub blend_glossy: u32,
    /// The blending kernel's radius in units of the mesh's r_max (points are about 2 r_max apart).
    pub blend_radius: f32,
    /// Quadtree layers traversed in the product (0: all).
    pub layers: u32,
    /// Roughness below which a surface is a mirror (paper 0.1).
    pub mirror_roughness: f32,
    /// Mirror chain depth (paper 4); also the depth of traced sharp glossy samples.
    pub mirror_depth: u32,
    /// Glossy lobes narrower than their radiance map's texel are traced, one BSDF sample per
    /// pixel sample (`trace_sharp`, ours; off in `profile=paper`; see
    /// [`technique::lobe_finer_than_map`]).
    pub trace_sharp: bool,
    /// How many radiance-map texels a glossy lobe must span to be read from the map
    /// (`sharp_texels`, ours; [`technique::lobe_finer_than_map`]). 0.5 by default ([`SHARP_TEXELS`]):
    /// a lobe of half a texel to one reads a texel about as wide as itself, and tracing it
    /// instead costs more in noise than it saves in bias (session 24, against 4,096-spp `pt`).
    /// 2 is the Nyquist rule (a map resolves only what spans two of its samples): it takes a
    /// small bright source's highlight from 2.1× `pt` to within noise on `textured-glossy`, but it
    /// also traces the tuned scenes' gold (r 0.25) and copper (r 0.3), so `glossy`'s shading goes
    /// from 71 to 911 ms at 128 spp and the ≥ 20× speed-up over `pt` is lost
    /// (docs/techniques/wavecache.md).
    pub sharp_texels: f32,
    /// `sharp_env` (ours, off by default): where the environment's brighter half (by power) fits
    /// within one texel of a material's radiance map (`Environment::half_power_solid_angle` <
    /// (π/N)²: a studio map's softboxes, a small sun), that material traces its lobes below two
    /// texels (`sharp_texels` 2, the Nyquist rule) instead of one: the map cannot resolve the
    /// light, and a lobe of one to two texels then aliases it (`textured-glossy`'s highlights).
    /// Smooth and mid-frequency maps (the tuned scenes' sky, the warehouse map) keep
    /// `sharp_texels`. Off by default: it trades that bias for the traced lobes' noise, which
    /// on `studio-objects` at 16 spp doubles the MSE (docs/techniques/wavecache.md, "How sharp
    /// is sharp").
    pub sharp_env: bool,
    /// `env_direct` (ours; `auto` by default, `off` in `profile=paper`): a glossy map stores the
    /// light it would hold without the environment's direct light, plus the environment's
    /// visibility per texel (weighted by the map's radiance), and the runtime integrates the
    /// pixel's own BRDF against the environment map × that visibility by light and BSDF
    /// sampling, with no rays. A map of N² texels cannot resolve a softbox of a fraction of a
    /// texel, and Eq. 20's texel product then aliases it (2× `pt` on `textured-glossy`);
    /// visibility varies slowly where the light does not. `auto`: where the environment's
    /// brighter half spans under [`ENV_DIRECT_TEXELS`] texels of the material's map and its lobe
    /// under [`ENV_DIRECT_LOBE_TEXELS`] (docs/techniques/wavecache.md, "The environment's direct
    /// light").
    pub env_direct: EnvDirect,
    /// Environment samples per pixel sample for `env_direct` (half BSDF, half map; balance
    /// heuristic); runtime only.
    pub env_direct_samples: u32,
    /// At least this many `env_direct` samples at a pixel read from the cache, whatever the spp
    /// (ours; runtime only). The cache is meant to be noise-free, and these samples trace no
    /// rays, so a pixel's estimate should not get noisier at low spp: at 4 spp against `pt` at
    /// 4,096 (96 × 64), 256 instead of 8 × 4 take `studio-objects`' MSE 1.02e-2 → 5.96e-3 and
    /// `textured-glossy`'s 6.64e-3 → 3.96e-3 (docs/techniques/wavecache.md).
    pub env_direct_pixel_samples: u32,
    /// Clear-coat ray chain depth (paper 3; spec §5: "The maximum tracing depth is set to 3").
    pub coat_depth: u32,
    /// Above this many punctual lights (ours; default [`CACHE_PUNCTUAL_ABOVE`], `profile=paper`:
    /// never), their direct light on diffuse surfaces is cached with the rest of the irradiance
    /// instead of traced per light at every pixel (the paper's rule, Eq. 15/16, which costs a
    /// shadow ray per light and pixel: 200 lights made the shading 3.4× `pt`'s at 4 spp).
    /// Glossy and traced pixels still trace every light.
    pub cache_punctual_above: u32,
    /// Non-metals at or above this roughness use the irradiance cache (the paper's "diffuse"
    /// materials; glTF has no pure Lambertian).
    pub diffuse_roughness: f32,
    /// `pbr` (pt's default) or `lambert` (every material Lambertian, as `pt brdf=lambert`).
    pub brdf: BrdfModel,
    /// How ω_o enters the BRDF lookup at a cache point of another normal (spec §5.4).
    pub wo_frame: WoFrame,
    /// Read and write the disk cache.
    pub disk_cache: bool,
    /// Show a progress bar during the precomputation.
    pub progress: bool,
    /// Instances whose back faces the camera sees, sorted (not a `--set` key: [`technique`] finds
    /// them with probe rays before the precomputation; part of the cache key). Their cache points are made on both sides: a point
    /// caches the light of one hemisphere, and one-sided points would hand the front's light to a
    /// back face (the light inside a Cornell box on the outside of its wall).
    pub back_sides: Vec<u32>,
}

impl Default for WavecacheParams {
    fn default() -> Self {
        Self {
            brdf_grid_u1: 32,
            brdf_grid_u2: 128,
            brdf_res: 32,
            brdf_strata: 2,
            brdf_beta_scale: 0.01,
            brdf_max_tables: DEFAULT_BRDF_MAX_TABLES,
            map_scale: 4,
            texel_samples: 16,
            texel_light_samples: 4,
            radiance_beta: 1e-3,
            irradiance_samples: 512,
            diffuse_points: 20000,
            glossy_points: 4000,
            min_points: 16,
            curvature_deg: 20.0,
            min_spacing: 1e-3,
            path_budget: DEFAULT_PATH_BUDGET,
            path_floor: DEFAULT_PATH_FLOOR,
            ray_budget: DEFAULT_RAY_BUDGET,
            max_depth: 8,
            sparsify: 1.0,
            min_energy: 0.0,
            enclosed_share: 0.5,
            query_m: 128,
            normal_weight: 1.0,
            normal_cutoff_deg: 30.0,
            search_radius: 8.0,
            trace_far: DEFAULT_TRACE_FAR,
            trace_disagree: f32::INFINITY,
            disagree_auto: true,
            trace_lonely: true,
            far_samples: 16,
            validity: 0.3,
            blend: 4,
            blend_glossy: 2,
            blend_radius: 2.0,
            sharp_env: false,
            env_direct: EnvDirect::Auto,
            env_direct_samples: 8,
            env_direct_pixel_samples: ENV_DIRECT_PIXEL_SAMPLES,
            layers: 0,
            mirror_roughness: 0.1,
            mirror_depth: 4,
            trace_sharp: true,
            sharp_texels: SHARP_TEXELS,
            coat_depth: 3,
            cache_punctual_above: CACHE_PUNCTUAL_ABOVE,
            diffuse_roughness: 0.8,
            brdf: BrdfModel::Pbr,
            wo_frame: WoFrame::Reflect,
            disk_cache: true,
            progress: true,
            back_sides: Vec::new(),
        }
    }
}

impl WavecacheParams {
    /// The paper's settings where it gives them (Sec. 4, 6, Table 2).
    pub fn paper() -> Self {
        Self {
            brdf_grid_u1: 172,
            brdf_grid_u2: 1080,
            brdf_res: 128,
            brdf_max_tables: 0,
            map_scale: 1,
            texel_samples: 128,
            texel_light_samples: 0,
            path_budget: 0,
            path_floor: 0,
            ray_budget: 0,
            min_spacing: 0.0,
            curvature_deg: 0.0,
            trace_sharp: false,
            sharp_texels: 1.0,
            search_radius: f32::INFINITY,
            trace_far: f32::INFINITY,
            trace_disagree: f32::INFINITY,
            disagree_auto: false,
            trace_lonely: false,
            validity: f32::INFINITY,
            blend: 1,
            blend_glossy: 1,
            enclosed_share: 1.0,
            env_direct: EnvDirect::Off,
            cache_punctual_above: u32::MAX,
            ..Self::default()
        }
    }

    /// Whether a scene with `lights` punctual lights has their direct light on diffuse
    /// surfaces in the cache ([`WavecacheParams::cache_punctual_above`]).
    pub fn caches_punctual(&self, lights: usize) -> bool {
        lights > self.cache_punctual_above as usize
    }

    /// These parameters with every setting that only the runtime reads (the progress bar, the
    /// disk-cache switch, the tracing of sharp lobes, the query, the product's layers, the ω_o
    /// frame, the mirror and coat chains) at its default: what the precomputation depends on,
    /// and so what the disk cache's key hashes.
    pub fn precompute_part(&self) -> Self {
        let d = Self::default();
        Self {
            disk_cache: d.disk_cache,
            progress: d.progress,
            trace_sharp: d.trace_sharp,
            sharp_texels: d.sharp_texels,
            sharp_env: d.sharp_env,
            env_direct_samples: d.env_direct_samples,
            env_direct_pixel_samples: d.env_direct_pixel_samples,
            query_m: d.query_m,
            normal_weight: d.normal_weight,
            normal_cutoff_deg: d.normal_cutoff_deg,
            search_radius: d.search_radius,
            trace_far: d.trace_far,
            trace_disagree: d.trace_disagree,
            disagree_auto: d.disagree_auto,
            trace_lonely: d.trace_lonely,
            far_samples: d.far_samples,
            validity: d.validity,
            blend: d.blend,
            blend_glossy: d.blend_glossy,
            blend_radius: d.blend_radius,
            layers: d.layers,
            wo_frame: d.wo_frame,
            mirror_depth: d.mirror_depth,
            coat_depth: d.coat_depth,
            ..self.clone()
        }
    }

    /// The path budget once the ray budget is applied at `rays_per_path` (0: no limit).
    pub fn effective_path_budget(&self, rays_per_path: f64) -> u64 {
        let from_rays = (self.ray_budget > 0).then(|| ((self.ray_budget as f64 / rays_per_path.max(1.0)) as u64).max(1));
        match (self.path_budget, from_rays) {
            (0, None) => 0,
            (0, Some(r)) => r,
            (b, None) => b,
            (b, Some(r)) => b.min(r),
        }
    }

    /// Reads every key (defaults above; `profile=paper` starts from [`WavecacheParams::paper`]).
    pub fn read(params: &Params) -> Result<Self, ParamError> {
        let base = match params.choice("profile", "cpu", &["cpu", "paper"])?.as_str() {
            "paper" => Self::paper(),
            _ => Self::default(),
        };
        let pow2 = |key: &str, v: u32| -> Result<u32, ParamError> {
            if v.is_power_of_two() {
                Ok(v)
            } else {
                Err(ParamError::Invalid { key: key.into(), value: v.to_string(), message: "must be a power of two".into() })
            }
        };
        Ok(Self {
            brdf_grid_u1: params.u32("brdf_grid_u1", base.brdf_grid_u1, 1, 4096)?,
            brdf_grid_u2: params.u32("brdf_grid_u2", base.brdf_grid_u2, 1, 8192)?,
            brdf_res: pow2("brdf_res", params.u32("brdf_res", base.brdf_res, 4, 512)?)?,
            brdf_strata: params.u32("brdf_strata", base.brdf_strata, 1, 64)?,
            brdf_beta_scale: params.f32("brdf_beta_scale", base.brdf_beta_scale, 0.0, 1e6)?,
            brdf_max_tables: params.u32("brdf_max_tables", base.brdf_max_tables, 0, 1 << 16)?,
            map_scale: pow2("map_scale", params.u32("map_scale", base.map_scale, 1, 32)?)?,
            texel_samples: params.u32("texel_samples", base.texel_samples, 1, 1 << 20)?,
            texel_light_samples: params.u32("texel_light_samples", base.texel_light_samples, 0, 1 << 20)?,
            radiance_beta: params.f32("radiance_beta", base.radiance_beta, 0.0, 1e6)?,
            irradiance_samples: params.u32("irradiance_samples", base.irradiance_samples, 1, 1 << 24)?,
            diffuse_points: params.u32("diffuse_points", base.diffuse_points, 1, 50_000_000)?,
            glossy_points: params.u32("glossy_points", base.glossy_points, 1, 50_000_000)?,
            min_points: params.u32("min_points", base.min_points, 1, 1_000_000)?,
            curvature_deg: params.f32("curvature_deg", base.curvature_deg, 0.0, 180.0)?,
            min_spacing: params.f32("min_spacing", base.min_spacing, 0.0, 1.0)?,
            path_budget: params.i64("budget", base.path_budget as i64, 0, 1 << 40)? as u64,
            path_floor: params.i64("path_floor", base.path_floor as i64, 0, 1 << 40)? as u64,
            ray_budget: params.i64("ray_budget", base.ray_budget as i64, 0, 1 << 44)? as u64,
            max_depth: params.u32("max_depth", base.max_depth, 1, 1024)?,
            sparsify: params.f32("sparsify", base.sparsify, 0.0, 1.0)?,
            min_energy: params.f32("min_energy", base.min_energy, 0.0, f32::INFINITY)?,
            enclosed_share: params.f32("enclosed_share", base.enclosed_share, 0.0, 1.0)?,
            query_m: params.u32("query_m", base.query_m, 0, u32::MAX)?,
            normal_weight: params.f32("normal_weight", base.normal_weight, 0.0, 1e6)?,
            normal_cutoff_deg: params.f32("normal_cutoff_deg", base.normal_cutoff_deg, 0.0, 180.0)?,
            search_radius: params.f32("search_radius", base.search_radius, 0.0, f32::INFINITY)?,
            trace_far: params.f32("trace_far", base.trace_far, 0.0, f32::INFINITY)?,
            trace_disagree: match params.text("trace_disagree", if base.disagree_auto { "auto" } else { "inf" }).as_str() {
                "auto" => base.trace_disagree,
                _ => params.f32("trace_disagree", base.trace_disagree, 1.0, f32::INFINITY)?,
            },
            disagree_auto: params.text("trace_disagree", if base.disagree_auto { "auto" } else { "inf" }) == "auto",
            trace_lonely: params.bool("trace_lonely", base.trace_lonely)?,
            far_samples: params.u32("far_samples", base.far_samples, 1, 4096)?,
            validity: params.f32("validity", base.validity, 0.0, f32::INFINITY)?,
            blend: params.u32("blend", base.blend, 1, technique::MAX_BLEND as u32)?,
            blend_glossy: params.u32("blend_glossy", base.blend_glossy, 1, technique::MAX_BLEND as u32)?,
            blend_radius: params.f32("blend_radius", base.blend_radius, 0.0, 1e6)?,
            layers: params.u32("layers", base.layers, 0, 32)?,
            mirror_roughness: params.f32("mirror_roughness", base.mirror_roughness, 0.0, 1.0)?,
            mirror_depth: params.u32("mirror_depth", base.mirror_depth, 1, 64)?,
            trace_sharp: params.bool("trace_sharp", base.trace_sharp)?,
            sharp_texels: params.f32("sharp_texels", base.sharp_texels, 0.0, 1024.0)?,
            sharp_env: params.bool("sharp_env", base.sharp_env)?,
            env_direct: match params
                .choice("env_direct", if base.env_direct == EnvDirect::Off { "off" } else { "auto" }, &["auto", "on", "off"])?
                .as_str()
            {
                "on" => EnvDirect::On,
                "off" => EnvDirect::Off,
                _ => EnvDirect::Auto,
            },
            env_direct_samples: params.u32("env_direct_samples", base.env_direct_samples, 2, 1 << 16)?,
            env_direct_pixel_samples: params.u32("env_direct_pixel_samples", base.env_direct_pixel_samples, 0, 1 << 16)?,
            coat_depth: params.u32("coat_depth", base.coat_depth, 1, 64)?,
            cache_punctual_above: params.u32("cache_punctual_above", base.cache_punctual_above, 0, u32::MAX)?,
            diffuse_roughness: params.f32("diffuse_roughness", base.diffuse_roughness, 0.0, 1.01)?,
            brdf: match params.choice("brdf", "pbr", &["pbr", "lambert"])?.as_str() {
                "lambert" => BrdfModel::Lambert,
                _ => BrdfModel::Pbr,
            },
            wo_frame: match params.choice("wo_frame", "reflect", &["reflect", "pixel", "point"])?.as_str() {
                "pixel" => WoFrame::Pixel,
                "point" => WoFrame::Point,
                _ => WoFrame::Reflect,
            },
            disk_cache: params.bool("cache", base.disk_cache)?,
            progress: params.bool("progress", base.progress)?,
            back_sides: Vec::new(),
        })
    }

    /// Whether instance `i` gets cache points on both sides ([`WavecacheParams::back_sides`]).
    pub fn two_sided(&self, i: usize) -> bool {
        self.back_sides.binary_search(&(i as u32)).is_ok()
    }

    /// Whether the glossy maps (N² texels) of a material of `roughness` leave the environment's
    /// direct light to the runtime ([`WavecacheParams::env_direct`]).
    pub fn split_env(&self, env: Option<&glimpse_scene::Environment>, map_res: u32, roughness: f32) -> bool {
        let Some(env) = env else {
            return false;
        };
        match self.env_direct {
            EnvDirect::Off => false,
            EnvDirect::On => true,
            EnvDirect::Auto => {
                let unresolved = env.half_power_solid_angle() < ENV_DIRECT_TEXELS * (std::f32::consts::PI / map_res as f32).powi(2);
                unresolved && technique::lobe_finer_than_map(roughness, map_res, ENV_DIRECT_LOBE_TEXELS)
            }
        }
    }

    /// Radiance-map resolution for a roughness: Table 2 / `map_scale` (at least 4).
    pub fn map_resolution(&self, roughness: f32) -> Option<u32> {
        bake::table2_resolution(roughness).map(|n| (n / self.map_scale).max(4))
    }

    /// The class of a material. The paper's materials are glTF's; of the other models, a
    /// Lambertian `diffuse` one is cached as diffuse, a conductor (no diffuse lobe: its
    /// `metallic` is 0, so the rule below would call a rough one diffuse) as glossy or a mirror
    /// by its roughness, and smooth glass, whose lobes are deltas, is traced
    /// ([`technique::Runtime`]'s glass chain) like a mirror, with no cache points.
    pub fn classify(&self, m: &glimpse_scene::Material) -> Class {
        use glimpse_scene::MaterialModel;
        if self.brdf == BrdfModel::Lambert || m.is_emissive() || m.model == MaterialModel::Diffuse {
            Class::Diffuse
        } else if matches!(m.model, MaterialModel::Dielectric { .. }) {
            Class::Mirror
        } else if matches!(m.model, MaterialModel::Conductor { .. }) {
            if m.roughness < self.mirror_roughness { Class::Mirror } else { Class::Glossy }
        } else if m.roughness < self.mirror_roughness {
            Class::Mirror
        } else if m.metallic <= 0.0 && m.roughness >= self.diffuse_roughness {
            Class::Diffuse
        } else {
            Class::Glossy
        }
    }
}

/// Default [`WavecacheParams::cache_punctual_above`]: more punctual lights than `pt` samples
/// one by one at every vertex (8), by a margin.
pub const CACHE_PUNCTUAL_ABOVE: u32 = 32;

/// The techniques of this crate, for the registry.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![Wavecache::info()]
}

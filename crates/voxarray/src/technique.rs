//! `lights-voxarray`: Alg. 4, "Lighting using 2D array of scene voxelizations" — every light
//! tested at every pixel through the array (no clustering, no light sampling), diffuse shading.
//!
//! Gap filled: `Shade(shadow, n)` is undefined in the paper; we sum the Lambertian term of each
//! unoccluded light exactly as `lights-exact` does (same lights, same shadow segments, same
//! facing test), so the only difference between the two images is the visibility decisions.
//! Structure per scene kind: static → Alg. 1 (+ Alg. 2), built once and kept across frames;
//! rigid moving instances → Alg. 5 (type arrays built once, transforms per frame); deforming
//! meshes → Alg. 6 every frame, uncompressed.
//! Order (ours, same result): pixels are shaded in tiles of [`TILE`] pixels with the light
//! loop outside, so one light's queries from neighbouring pixels read the same voxelization and
//! nearby rows (cache locality; a GPU warp gets the same); each tile × light is formed in
//! structure-of-arrays form, 8 pixels at a time with AVX2, and its row loads are issued
//! together ([`crate::shade8`]). Each pixel sums its lights in the scene's order, so the image
//! is bit-identical to the per-sample path (`tiled=false`, tiles of [`PIXELS_PER_TILE`]
//! scanline pixels, segments formed one by one) and to the scalar code (`simd=false` or
//! `GLIMPSE_VOXARRAY_SCALAR=1`); `tests/shade.rs` checks it.
//! Shaded points move `normal_offset` cells along their normal before the query (see
//! [`crate::query`] for the bias).
//!
//! Measured (issue #14; 2 cores shared with other jobs, so wall times swing 2×; release build,
//! median of 3 interleaved runs; array from the disk cache; "CPU" = the process's task-clock
//! minus the same run with `--set lights=1`, i.e. the shade's CPU time):
//! `glimpse render many-lights -t lights-voxarray --size 320x240 --set epsilon=false`
//! - before (the previous commit's binary, per-sample path, AVX2 pass 1): shade 4627 ms wall,
//!   4347 ms CPU;
//! - this binary, `tiled=false simd=false` (all scalar): 7529 ms wall, 6245 ms CPU;
//!   `tiled=false` (per-sample, AVX2 pass 1): 4192 / 4250; `simd=false` (tiled, scalar):
//!   8177 / 6360;
//! - tiled AVX2 (default): 1479 ms wall, 1015 ms CPU: 4.3× the previous path's CPU time;
//! - `-t lights-exact` in the same session: 9420 ms wall, 6264 ms CPU, so lights-voxarray
//!   shades 6.2× faster than lights-exact by CPU time (6.4× by wall time; was 1.51×).
//!
//! Every image above is byte-identical. Where the tiled shade's time goes now (perf): about
//! 40 % the row loads (index word, then dictionary row: memory-bound), 35 % pass 1's extents
//! (`extent8`: divisions, square roots, arc tangents, gathers), 20 % forming the segments.

use crate::disk_cache;
use crate::dynamic::{self, Instanced};
use crate::row::Row;
use crate::shade8::Tile;
use crate::{Array, VoxArray, VoxArrayParams, extent8};
use glimpse_core::{Image, Ray, Vec3};
use glimpse_render::direct::{self, Shading};
use glimpse_render::focus::Focus;
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::{Scene, WorldLight};
use glimpse_trace::{GBuffer, Visibility};
use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;
use std::f32::consts::PI;

/// Pixels shaded together, light by light, by the per-sample path (`tiled=false`): consecutive
/// pixels of a scanline.
pub const PIXELS_PER_TILE: usize = 64;

/// The tiled shader's tile, width × height pixels: a square of the image, so one light's
/// segments from it are nearby and read fewer distinct rows than a scanline's.
pub const TILE: (usize, usize) = (8, 8);

/// The structure a frame is shaded with.
pub enum Structure {
    Static(VoxArray),
    Instanced(Instanced),
    Deforming(VoxArray),
}

impl Visibility for Structure {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => a.occluded(ray, t_max),
            Structure::Instanced(a) => a.occluded(ray, t_max),
        }
    }
}

impl Structure {
    /// The static array's cell in world units (`None` where the scene has no static part).
    pub fn cell_size(&self) -> Option<f32> {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => Some(a.grid().cell_size_world()),
            Structure::Instanced(a) => a.static_part.as_ref().map(|a| a.grid().cell_size_world()),
        }
    }

    /// Alg. 3 (or Alg. 5) on a shadow sample, with the normal offset.
    pub fn occluded_from_surface(&self, ps: &direct::PunctualSample, normal: Vec3) -> bool {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => a.occluded_from_surface(ps, normal),
            Structure::Instanced(a) => a.occluded_from_surface(ps, normal),
        }
    }

    /// The segment [`Self::occluded_from_surface`] queries (in the world, before any instance's
    /// transform).
    pub fn surface_segment(&self, ps: &direct::PunctualSample, normal: Vec3) -> (Vec3, Vec3) {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => a.surface_segment(ps, normal),
            Structure::Instanced(a) => a.surface_segment(ps, normal),
        }
    }

    /// `out[k] = self.occluded_from_surface(&samples[k].0, samples[k].1)`; a single array
    /// answers the batch with its row loads overlapped ([`crate::batch`]).
    /// `simd`: the AVX2 pass 1 of the batch (where the CPU has it); the answers are the same.
    pub fn occluded_from_surfaces(
        &self,
        samples: &[(direct::PunctualSample, Vec3)],
        segments: &mut Vec<(Vec3, Vec3)>,
        out: &mut [bool],
        simd: bool,
    ) {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => {
                // One match on the resolution per batch, not per sample.
                fn batch<R: Row>(
                    a: &Array<R>,
                    samples: &[(direct::PunctualSample, Vec3)],
                    segments: &mut Vec<(Vec3, Vec3)>,
                    out: &mut [bool],
                    simd: bool,
                ) {
                    segments.clear();
                    segments.extend(samples.iter().map(|(ps, n)| a.surface_segment(ps, *n)));
                    a.occluded_segments_with(segments, out, simd);
                }
                match a {
                    VoxArray::R32(a) => batch(a, samples, segments, out, simd),
                    VoxArray::R64(a) => batch(a, samples, segments, out, simd),
                    VoxArray::R128(a) => batch(a, samples, segments, out, simd),
                }
            }
            Structure::Instanced(a) => {
                for ((ps, n), o) in samples.iter().zip(out) {
                    *o = a.occluded_from_surface(ps, *n);
                }
            }
        }
    }

    pub fn memory_bytes(&self) -> usize {
        match self {
            Structure::Static(a) | Structure::Deforming(a) => a.memory_bytes(),
            Structure::Instanced(a) => a.memory_bytes(),
        }
    }
}

pub struct LightsVoxArray {
    /// How many of the scene's punctual lights to use (from the start of the list).
    pub lights: u32,
    pub params: VoxArrayParams,
    /// Array settings of the rigid object types (Alg. 5; the paper: 32³ for the airplanes).
    pub type_params: VoxArrayParams,
    pub settings: Settings,
    pub structure: Option<Structure>,
    /// Measure ε_v / ε_s of the shadow decisions against exact rays after each render (untimed;
    /// reported in `Stats::metrics`, so `glimpse eval` lists them).
    pub epsilon: bool,
    /// Load and store a static scene's compressed array in the disk cache (`disk_cache`).
    pub disk_cache: bool,
    /// Shade with the tiled shader ([`crate::shade8`]: tile × light in structure-of-arrays
    /// form); `false`: the per-sample path (each light's samples of a tile formed one by one,
    /// then batched). The same image.
    pub tiled: bool,
    /// AVX2 where the CPU has it (segment formation, extents, sums); `false`, or
    /// `GLIMPSE_VOXARRAY_SCALAR=1`, runs the scalar code. The same image.
    pub simd: bool,
    /// Confirm each occluded answer with an exact shadow ray (ours; see [`REFINE_BELOW_LIGHTS`]).
    pub refine: bool,
    /// With `refine`, the cells (of the static array) over which a visible answer is checked by
    /// the exact ray from the surface (`refine_near`, ours; see [`REFINE_NEAR_CELLS`]); 0: off.
    pub refine_near_cells: f32,
    /// `focus=auto` (ours; `profile=paper`: `scene`): a static scene's array covers the
    /// triangles that can block a shadow ray ([`Focus`]) where their box's diagonal is under a
    /// quarter of the scene's, instead of the whole scene, and queries the part of each
    /// segment inside it.
    pub focus: bool,
    /// The focus the static array was built in (`None`: the whole scene).
    pub focus_box: Option<Focus>,
}

/// `refine` (ours): whether the array's "occluded" answers are confirmed by an exact shadow ray.
///
/// The paper's ε_s stays small because "occasional visibility errors cancel out" over its
/// 1,024–7,088 lights per pixel; it names hard shadows as the failure and suggests handling the
/// lights that cast them conventionally (§6.5). With n lights a wrong decision moves a pixel's
/// ε_s by 1/n, so at the array's ε_v of 5–15 % the errors cannot average below 3 % unless
/// n ≳ ε_v / 0.03² ≈ 100. Below [`REFINE_BELOW_LIGHTS`] lights, `auto` therefore lets the array
/// answer "visible" (the rays an exact tracer pays most for: they cross the whole scene) and
/// traces `lights-exact`'s own ray where the array answers "occluded", which removes every false
/// shadow. What is left is the array's missed occluders, so the start offsets shrink to
/// [`VoxArrayParams::refined`]'s (a false shadow now costs a ray, a miss is an error).
/// Measured (`--example error_sources`, 96 × 64, |ε_s|): `sponza-interior` 13.8 % → 1.96 %,
/// `million-triangles` 10.2 % → 2.17 %, exact rays for 57 % and 37 % of the decisions.
/// `refine=exact` / `none` force it; `profile=paper` is `none`.
pub const REFINE_BELOW_LIGHTS: usize = 128;

/// Whether `exact` finds `lights-exact`'s shadow ray from `s` to `light` occluded (the ray and
/// segment `lights-exact` traces, `direct::punctual`).
#[inline]
pub fn exactly_occluded(exact: &dyn Visibility, light: &WorldLight, s: &direct::Shading) -> bool {
    let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
    exact.occluded(&ps.shadow, ps.t_max)
}

/// `refine_near`'s default: under `refine` a "visible" answer is also checked by the exact
/// shadow ray over its first 2 cells from the surface. The array's start offsets (0.75 cell
/// along the normal, 0.5 cell of bias) and its rows' drift off the ray step over occluders
/// there: the contact shadows of objects about a cell across. Measured (`--example
/// error_sources -- SCENE 96 64 normal_offset=0.75 bias=0.5 bias_light=0.5`, |ε_s| refined →
/// with 1 / 2 / 3 near cells): `scenes/extra/forest` (400 heads 0.4–1.1 m tall under 0.46 m
/// cells) 9.69 % → 4.79 / **1.92** / 0.58 %, `sponza-interior` 1.98 % → 0.85 / **0.58** / 0.42 %,
/// `million-triangles` 2.18 % → 1.17 / **0.96** / 0.91 %. A short ray still starts at the
/// tracer's top level and costs about 60 % of a full one, so with few lights the refined
/// shading runs at 0.6–1.1× `lights-exact`'s speed (docs/techniques/voxarray.md).
pub const REFINE_NEAR_CELLS: f32 = 2.0;

/// `refine`'s exact checks on a frame's shadow decisions: an "occluded" answer stands only if
/// `lights-exact`'s own ray agrees, and a "visible" one only if that ray's first `near` world
/// units are clear too.
#[derive(Clone, Copy)]
pub struct Refine<'a> {
    pub exact: &'a dyn Visibility,
    /// World distance along the shadow ray checked exactly behind a visible answer (0: none).
    pub near: f32,
}

impl Refine<'_> {
    /// The refined answer for the shadow sample `ps`, given the array's.
    #[inline]
    pub fn occluded(&self, array_occluded: bool, ps: &direct::PunctualSample) -> bool {
        if array_occluded {
            self.exact.occluded(&ps.shadow, ps.t_max)
        } else {
            self.near > 0.0 && self.exact.occluded(&ps.shadow, ps.t_max.min(self.near))
        }
    }
}

/// Reads `refine` (`auto`, `exact`, `none`) for a scene with `lights` lights.
pub fn read_refine(params: &Params, lights: usize) -> Result<bool, RenderError> {
    let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
    let default = if paper { "none" } else { "auto" };
    Ok(match params.choice("refine", default, &["auto", "exact", "none"])?.as_str() {
        "exact" => true,
        "none" => false,
        _ => lights < REFINE_BELOW_LIGHTS,
    })
}

impl LightsVoxArray {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "lights-voxarray",
            family: "many lights",
            reference: Some("lights-exact"),
            description: "every light at every pixel through the 2D array of voxelizations (Wang et al. 2017); resolution, directions, bias, bias_light, normal_offset, skip_start_run, compress, dictionary, steps, cluster (ours), refine (ours: auto, exact, none), focus (ours: auto, scene), type_resolution, lights, epsilon, disk_cache, tiled, simd",
            create: |scene: &Scene, settings, params| {
                glimpse_render::require(scene, "lights-voxarray", glimpse_render::Need::PunctualLights)?;
                Ok(Box::new(LightsVoxArray::new(scene, settings, params)?))
            },
        }
    }

    pub fn new(scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let all = (scene.lights.len() as u32).max(1);
        let lights = params.u32("lights", all, 1, u32::MAX)?;
        let refine = read_refine(params, scene.lights.len().min(lights as usize))?;
        let defaults = if refine { VoxArrayParams::refined() } else { VoxArrayParams::default() };
        let p = defaults.read(params)?;
        let type_resolution = params.u32("type_resolution", p.resolution, 32, 128)?;
        if ![32, 64, 128].contains(&type_resolution) {
            return Err(glimpse_render::ParamError::Invalid {
                key: "type_resolution".into(),
                value: type_resolution.to_string(),
                message: "must be 32, 64 or 128".into(),
            }
            .into());
        }
        Ok(Self {
            lights,
            params: p,
            type_params: VoxArrayParams { resolution: type_resolution, ..p },
            settings: *settings,
            structure: None,
            epsilon: params.bool("epsilon", true)?,
            disk_cache: params.bool("disk_cache", true)?,
            tiled: params.bool("tiled", true)?,
            simd: params.bool("simd", true)?,
            refine,
            refine_near_cells: params.f32("refine_near", REFINE_NEAR_CELLS, 0.0, 1024.0)?,
            focus: read_focus(params)?,
            focus_box: None,
        })
    }
}

impl LightsVoxArray {
    /// `refine`'s checks on `structure` with the exact tracer `exact` (`None` without `refine`).
    pub fn refine_for<'a>(&self, structure: &Structure, exact: &'a dyn Visibility) -> Option<Refine<'a>> {
        self.refine.then(|| Refine { exact, near: self.refine_near_cells * structure.cell_size().unwrap_or(0.0) })
    }
}

/// Reads `focus` (`auto`, `scene`; `profile=paper`: `scene`).
pub fn read_focus(params: &Params) -> Result<bool, RenderError> {
    let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
    Ok(params.choice("focus", if paper { "scene" } else { "auto" }, &["auto", "scene"])? == "auto")
}

/// Whether the scene's geometry is the same at every time.
pub fn is_static(scene: &Scene) -> bool {
    scene.geometry_is_static()
}

impl Technique for LightsVoxArray {
    fn id(&self) -> &'static str {
        "lights-voxarray"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        let scene = ctx.scene();
        // The build's peak: the plain array (d² voxelizations of N³ bits) when uncompressed;
        // streamed into the compression, a 32-bit id per row plus the packed indices (the
        // slabs' distinct-row tables come on top and depend on the scene).
        if self.structure.is_none() {
            let (n, d) = (self.params.resolution as u64, self.params.directions as u64);
            let rows = d * d * n * n;
            let (what, bytes) = match &self.params.compress {
                None => (format!("lights-voxarray: the {n}³ × {d}² array of voxelizations"), rows * n / 8),
                Some(c) => {
                    let bits = crate::compress::index_bits(c.dictionary_rows as usize) as u64;
                    (format!("lights-voxarray: building the {n}³ × {d}² array streamed into its compression"), rows * 4 + rows * bits / 8)
                }
            };
            glimpse_core::memory_budget::check(what, bytes)?;
        }
        if scene.meshes.iter().any(|m| m.deformation.is_some()) {
            let p = VoxArrayParams { compress: None, ..self.params };
            self.structure = Some(Structure::Deforming(stats.time("alg6 rebuild", || dynamic::rebuild(&ctx.frame, &p))));
        } else if !is_static(scene) {
            match &mut self.structure {
                Some(Structure::Instanced(s)) => stats.time("alg5 update", || s.update(&ctx.frame)),
                _ => {
                    let s = stats.time("alg5 build", || Instanced::build(&ctx.frame, &self.params, &self.type_params));
                    self.structure = Some(Structure::Instanced(s));
                }
            }
        } else if self.structure.is_none() {
            let triangles = ctx.frame.world_triangles();
            let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.lights as usize)];
            self.focus_box = if self.focus { stats.time("focus", || Focus::occluders(&triangles, ctx.frame.bounds, lights)) } else { None };
            let focus = self.focus_box.as_ref().map(|f| f.bounds);
            // A static scene's compressed array is cached on disk (see `disk_cache`).
            let cache = if self.disk_cache && self.params.compress.is_some() { glimpse_render::structure_cache_dir() } else { None };
            let path = cache.map(|dir| disk_cache::path_for(&dir, &triangles, focus, &self.params));
            let loaded = path.as_ref().and_then(|path| stats.time("load cached array", || disk_cache::load(path, &self.params)));
            let a = match loaded {
                Some(a) => a,
                None => {
                    // Alg. 1 streamed into Alg. 2 (one stage: the slabs are voxelized as they
                    // are compressed, never held whole).
                    let a = stats.time("alg1+2 voxelize and compress", || VoxArray::from_triangles_in(&triangles, focus, &self.params));
                    if let Some(path) = &path
                        && let Err(e) = stats.time("store cached array", || disk_cache::store(path, &a))
                    {
                        eprintln!("warning: lights-voxarray: cannot cache the array: {e}");
                    }
                    a
                }
            };
            let mut a = a;
            a.set_clip_to_sphere(focus.is_some());
            self.structure = Some(Structure::Static(a));
        }
        stats.memory_bytes = self.structure.as_ref().map_or(0, |s| s.memory_bytes());
        if let Some(Structure::Static(a) | Structure::Deforming(a)) = &self.structure {
            // The grid's cell, in the stats so a report can say what resolution bounds the error.
            stats.metrics.push(("cell_m".to_owned(), a.grid().cell_size_world() as f64));
        }
        if let Some(f) = &self.focus_box {
            // The focus's share of the scene's diagonal: what it did to the cell.
            stats.metrics.push(("focus_share".to_owned(), f.share_of(ctx.frame.bounds) as f64));
        }
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let Some(vis) = &self.structure else {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "render before prepare".into() });
        };
        let mut stats = Stats { memory_bytes: vis.memory_bytes(), ..Default::default() };
        let lights = &ctx.frame.lights[..ctx.frame.lights.len().min(self.lights as usize)];
        if (out.width, out.height) != (gbuffer.width, gbuffer.height) {
            return Err(RenderError::Unsupported { technique: "lights-voxarray".into(), message: "image and GBuffer sizes differ".into() });
        }
        // A focused array clips its segments to its sphere, which the AVX2 path does not.
        let simd = self.simd && self.focus_box.is_none() && extent8::avx2_available();
        let tiled = match vis {
            Structure::Static(a) | Structure::Deforming(a) if self.tiled => Some(a),
            _ => None,
        };
        let confirmed = AtomicU64::new(0);
        let refine = self.refine_for(vis, &ctx.tracer);
        let how = How { simd, refine, confirmed: &confirmed };
        stats.rays = stats.time("shade", || match tiled {
            Some(VoxArray::R32(a)) => shade_tiled(a, ctx, gbuffer, lights, out, &how),
            Some(VoxArray::R64(a)) => shade_tiled(a, ctx, gbuffer, lights, out, &how),
            Some(VoxArray::R128(a)) => shade_tiled(a, ctx, gbuffer, lights, out, &how),
            None => shade_samples(vis, ctx, gbuffer, lights, out, &how),
        });
        if self.epsilon {
            let e = crate::epsilon::epsilon(&ctx.frame, gbuffer, &ctx.tracer, lights.len(), |_, ps, s| {
                let o = vis.occluded_from_surface(ps, s.normal);
                refine.map_or(o, |r| r.occluded(o, ps))
            });
            stats.metrics = e.to_metrics();
        }
        if self.refine {
            // The share of the shadow decisions that paid for an exact ray.
            let share = confirmed.into_inner() as f64 / stats.rays.max(1) as f64;
            stats.metrics.push(("refined_pct".to_owned(), 100.0 * share));
            if let Some(r) = refine.filter(|r| r.near > 0.0) {
                // How far from the surface the visible answers were checked exactly.
                stats.metrics.push(("near_m".to_owned(), r.near as f64));
            }
        }
        Ok(stats)
    }
}

/// How a frame is shaded: AVX2 or scalar, and with `refine` the exact checks and the count of
/// the occluded answers they confirmed with a full ray.
#[derive(Clone, Copy)]
struct How<'a> {
    simd: bool,
    refine: Option<Refine<'a>>,
    confirmed: &'a AtomicU64,
}

/// Alg. 4 with the tiled shader ([`crate::shade8`]): bands of [`TILE`]`.1` image rows in
/// parallel, each cut into tiles of [`TILE`] pixels shaded with the light loop outside (one
/// light's queries from neighbouring pixels read the same voxelization and nearby rows). Returns
/// the shadow decisions made.
fn shade_tiled<R: Row>(array: &Array<R>, ctx: &FrameContext, gbuffer: &GBuffer, lights: &[WorldLight], out: &mut Image, how: &How) -> u64 {
    let How { simd, refine, confirmed } = *how;
    let width = out.width as usize;
    let (tw, th) = TILE;
    out.pixels
        .par_chunks_mut(width * th)
        .enumerate()
        .map_init(
            || (Tile::default(), Vec::new()),
            |(tile, pixels), (band, px)| {
                let base = band * width * th;
                let rows = px.len() / width;
                let mut rays = 0u64;
                for x0 in (0..width).step_by(tw) {
                    pixels.clear();
                    pixels.extend((0..rows).flat_map(|y| (x0..(x0 + tw).min(width)).map(move |x| base + y * width + x)));
                    tile.load(gbuffer, pixels);
                    for light in lights {
                        rays += tile.shade_light(array, light, simd, refine);
                    }
                    confirmed.fetch_add(std::mem::take(&mut tile.confirmed), Ordering::Relaxed);
                    let mut hits = tile.results().peekable();
                    for (k, &i) in pixels.iter().enumerate() {
                        px[i - base] = match hits.next_if(|h| h.0 == k) {
                            Some((_, s, e)) => gbuffer.emission[i] + s.albedo / PI * e,
                            None => direct::background(&ctx.frame, gbuffer.view_dir[i]),
                        };
                    }
                }
                ctx.progress.add(px.len() as u64);
                rays
            },
        )
        .sum()
}

/// Alg. 4 sample by sample (the path before [`crate::shade8`], kept as its reference): in
/// tiles of [`PIXELS_PER_TILE`] consecutive pixels with the light loop outside, one light's
/// samples of a tile formed one by one and their queries batched ([`crate::batch`]). Returns the
/// shadow decisions made.
fn shade_samples(vis: &Structure, ctx: &FrameContext, gbuffer: &GBuffer, lights: &[WorldLight], out: &mut Image, how: &How) -> u64 {
    let How { simd, refine, confirmed } = *how;
    out.pixels
        .par_chunks_mut(PIXELS_PER_TILE)
        .enumerate()
        .map(|(tile, px)| {
            let base = tile * PIXELS_PER_TILE;
            let shading: Vec<Option<Shading>> = (0..px.len()).map(|k| Shading::from_gbuffer(gbuffer, base + k)).collect();
            let mut e = vec![Vec3::ZERO; px.len()];
            let mut rays = 0u64;
            // Reused per light: the tile's shadow queries, their segments and answers.
            let (mut samples, mut pixel, mut segments, mut occluded) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for light in lights {
                samples.clear();
                pixel.clear();
                for (k, s) in shading.iter().enumerate() {
                    let Some(s) = s else { continue };
                    let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
                    let cos = s.cos(ps.wi);
                    if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
                        continue;
                    }
                    samples.push((ps, s.normal));
                    pixel.push((k, cos));
                }
                occluded.clear();
                occluded.resize(samples.len(), false);
                vis.occluded_from_surfaces(&samples, &mut segments, &mut occluded, simd);
                rays += samples.len() as u64;
                for (((ps, _), &(k, cos)), &o) in samples.iter().zip(&pixel).zip(&occluded) {
                    let o = match refine {
                        Some(r) => {
                            confirmed.fetch_add(o as u64, Ordering::Relaxed);
                            r.occluded(o, ps)
                        }
                        None => o,
                    };
                    if !o {
                        e[k] += ps.irradiance * cos;
                    }
                }
            }
            for (k, p) in px.iter_mut().enumerate() {
                let i = base + k;
                *p = match &shading[k] {
                    Some(s) => gbuffer.emission[i] + s.albedo / PI * e[k],
                    None => direct::background(&ctx.frame, gbuffer.view_dir[i]),
                };
            }
            ctx.progress.add(px.len() as u64);
            rays
        })
        .sum()
}

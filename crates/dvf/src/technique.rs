//! `env-dvf`: the runtime of Xu et al.'s Algorithm 3 (the paper's §2.1.2, "used as-is") on the
//! field built in `prepare` every frame, with the spec's corrections: the occluded-region test
//! belongs to the `l_occ = 0` branch (E2) and `E = E_unshad − E_occ` comes after the ray loop
//! (E3; the prose's "l_occ = 1" there is also E3).
//!
//! Per pixel: the cell c of the surface point; the same N_r rays as `env-exact` (same pixel RNG,
//! same Hammersley set, same rotation, same spawn, same below-surface rule); then
//! - `l_occ(c) = 1`: trace only rays whose octahedral pixel is set in O_c^V; E = (1/N_r) Σ_miss L;
//! - `l_occ(c) = 0`: trace only rays set in O_c^O; E = E_unshad(n) − (1/N_r) Σ_hit L,
//!
//! and L_out = ρ E. `unknown=trace` (a deviation, not the paper) also traces rays whose pixel is
//! set in neither mask (directions no sample of the cell saw, e.g. in under-sampled cells, which
//! the paper's rule shades unshadowed or black). Normalisation (spec §3.2): (1/N_r) Σ L V estimates E/π under cosine-weighted
//! rays, so E_unshad is the SH irradiance ÷ π. L_i(ω) of traced rays is the map's radiance (as the
//! reference), not its SH reconstruction. Choices where the paper is silent: E is clamped at 0
//! per channel (SH ringing can make E_unshad − E_occ negative); the SH coefficients are projected
//! from the map's texels once (stage "sh", the paper's "precomputed constant values").
//!
//! Runtime loop (issue #14): [`Runtime::irradiance`] forms a fragment's whole ray set at once
//! ([`crate::raybatch`]: AVX2 directions bit-identical to [`RaySet::direction`], octahedral pixels
//! and horizon bits 8 at a time), selects the rays to trace with one mask lookup per ray, skips
//! cells whose trace mask is empty, and traces the selected rays through `occluded_batch` with
//! prefetched environment lookups: the same rays and sums in the same order, so the same image
//! bit for bit (tests/batched.rs). `GLIMPSE_DVF_PER_RAY=1` runs the old per-ray loop. Measured on
//! Sponza (`scenes/sponza-dvf.toml`, 2 shared cores at load 4–6, so CPU seconds are the stable
//! figure; medians of 3 `glimpse render` runs, interleaved): 1280×720 env-exact 34.3 CPU s,
//! env-dvf per-ray 17.6, batched 11.0 (1.95× → 3.12×; wall 37.6 / 26.4 / 11.5 s); 320×180
//! 2.43 / 2.16 / 1.56 CPU s (1.12× → 1.56×). The shade alone (example `dvf_shade`, 1280×720):
//! 9.06 → 3.15 CPU s for 11.1M traced rays; what is left of the frame is mostly the build's
//! 25.3M rays and the shade's traced ones.

use crate::bright::BrightDirections;
use crate::raybatch::{self, Block, Former};
use crate::rays::RaySet;
use crate::{Dvf, DvfParams, Footprint, Unshadowed};
use glimpse_core::sh::Sh9;
use glimpse_core::{Image, Vec3};
use glimpse_render::direct::{self, Shading};
use glimpse_render::{FrameContext, Params, RenderError, Settings, Stats, Technique, TechniqueInfo};
use glimpse_scene::{Environment, Scene};
use glimpse_trace::{GBuffer, Visibility};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::Ordering;

pub struct EnvDvf {
    pub params: DvfParams,
    pub settings: Settings,
    /// This frame's field (after `prepare`).
    pub dvf: Option<Dvf>,
    /// SH of the environment (projected on the first `prepare`).
    pub sh: Option<Sh9>,
    /// Forces every cell's label (tests of the estimator identities); `None`: the field's.
    pub force_label: Option<u8>,
    /// The map's relative N_r-ray noise, when `unshadowed=auto` or `bright=auto` measured it.
    pub map_noise: Option<f32>,
    /// The map's brightest directions for the masks' R (with the SH, once per map); traced
    /// when `bright` is on.
    pub bright: Option<BrightDirections>,
}

impl EnvDvf {
    pub fn info() -> TechniqueInfo {
        TechniqueInfo {
            id: "env-dvf",
            family: "environment lighting",
            reference: Some("env-exact"),
            description: "discrete visibility field rebuilt per frame (Günay and Akyüz 2025 / Xu et al. 2022): rays=128 points=10000000 grid=77 octahedral=8 sampling=hash|hammersley rounding=ceil|round rotation=cp|normal; ours: rounding=cumulative unknown=skip|trace unshadowed=auto|sh|rays sides=both|front|seen build_rays bright=auto|on|off bright_sr=0.2 footprint=around|cell; profile=paper (sides=front, bright=off, footprint=cell)",
            create: |scene: &Scene, settings, params| {
                glimpse_render::technique::require(scene, "env-dvf", glimpse_render::technique::Need::Environment)?;
                Ok(Box::new(EnvDvf::new(settings, params)?))
            },
        }
    }

    pub fn new(settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        Ok(Self {
            params: DvfParams::default().read(params)?,
            settings: *settings,
            dvf: None,
            sh: None,
            force_label: None,
            map_noise: None,
            bright: None,
        })
    }

    /// The runtime over this frame's field (after `prepare`; `None` without an environment).
    pub fn runtime<'a>(&'a self, ctx: &'a FrameContext) -> Option<Runtime<'a>> {
        Some(Runtime {
            dvf: self.dvf.as_ref()?,
            vis: &ctx.tracer,
            env: ctx.frame.scene.environment.as_ref()?,
            sh: self.sh.as_ref()?,
            unshadowed: self.params.unshadowed,
            trace_unknown: self.params.trace_unknown,
            bright: self.bright.as_ref().filter(|_| self.params.bright),
            force_label: self.force_label,
            footprint: self.params.footprint,
        })
    }
}

/// Order-2 SH of the environment's radiance, by midpoint quadrature over an equirectangular grid
/// of at least the map's resolution (and at least 128×64, so that tiny maps such as a constant
/// 1×1 are integrated through `radiance`'s bilinear lookup, not as one texel).
pub fn project_environment(env: &Environment) -> Sh9 {
    let grid = glimpse_scene::SphereGrid::for_map(env, 128, 64);
    let rows: Vec<Sh9> = (0..grid.height)
        .into_par_iter()
        .map(|y| {
            let d_omega = grid.row_solid_angle(y);
            let mut sh = Sh9::default();
            grid.for_row(env, y, |d, l| sh.add_sample(d, l, d_omega));
            sh
        })
        .collect();
    let mut sum = Sh9::default();
    for r in rows {
        for (c, v) in sum.coeffs.iter_mut().zip(r.coeffs) {
            *c += v;
        }
    }
    sum
}

/// The exact estimate `env-exact` makes with this ray set: (1/N_r) Σ_unoccluded L (rays traced).
pub fn brute_force(vis: &dyn Visibility, env: &Environment, s: &Shading, set: &RaySet) -> (Vec3, u64) {
    let (mut sum, mut rays) = (Vec3::ZERO, 0u64);
    for k in 0..set.count {
        let d = set.direction(k);
        if s.cos(d) <= 0.0 {
            continue;
        }
        rays += 1;
        if !vis.occluded(&s.spawn(d), f32::INFINITY) {
            sum += env.radiance(d) * (1.0 / set.count as f32);
        }
    }
    (sum, rays)
}

/// What the runtime needs besides the field.
pub struct Runtime<'a> {
    pub dvf: &'a Dvf,
    pub vis: &'a dyn Visibility,
    pub env: &'a Environment,
    pub sh: &'a Sh9,
    pub unshadowed: Unshadowed,
    /// Also trace rays whose pixel is in neither mask (`unknown=trace`; the paper skips them).
    pub trace_unknown: bool,
    /// Also trace rays toward the map's brightest directions (`bright`; the paper: `None`).
    pub bright: Option<&'a BrightDirections>,
    pub force_label: Option<u8>,
    /// Whose masks a fragment reads (`footprint`).
    pub footprint: Footprint,
}

/// Which runtime loop `Runtime::irradiance` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RuntimePath {
    /// Every ray formed, tested and traced one at a time (the loop before issue #14).
    PerRay,
    /// The ray set formed as a block ([`crate::raybatch`]), the rays to trace selected from
    /// the cell's masks, then traced in batches: the same rays, the same sums in the same order.
    Batched(Former),
}

impl RuntimePath {
    /// `GLIMPSE_DVF_PER_RAY=1` selects the per-ray loop (for comparisons); otherwise the batched
    /// one with the AVX2 former where available (`GLIMPSE_DVF_SCALAR=1`: the scalar former).
    pub fn from_env() -> RuntimePath {
        static PATH: std::sync::LazyLock<RuntimePath> = std::sync::LazyLock::new(|| {
            if std::env::var_os("GLIMPSE_DVF_PER_RAY").is_some_and(|v| v != "0") {
                RuntimePath::PerRay
            } else {
                RuntimePath::Batched(raybatch::default_former())
            }
        });
        *PATH
    }
}

/// Rays traced per `occluded_batch` call.
const TRACE_BATCH: usize = 16;

impl Runtime<'_> {
    /// The fragment's visible and occluded words: its cell's, or (footprint) the union over
    /// the 2×2×2 cells around it.
    fn fragment_words(&self, position: Vec3, cell: usize) -> ([u64; crate::grid::MAX_WORDS], [u64; crate::grid::MAX_WORDS]) {
        let masks = &self.dvf.masks;
        let words = masks.words_per_mask;
        let (mut v, mut o) = ([0u64; crate::grid::MAX_WORDS], [0u64; crate::grid::MAX_WORDS]);
        let mut add = |c: usize| {
            for w in 0..words {
                v[w] |= masks.visible[c * words + w].load(Ordering::Relaxed);
                o[w] |= masks.occluded[c * words + w].load(Ordering::Relaxed);
            }
        };
        match self.footprint {
            Footprint::Cell => add(cell),
            Footprint::Around => self.dvf.grid.cells_around(position).into_iter().for_each(add),
        }
        (v, o)
    }

    /// Algorithm 3 for one fragment: (E/π, rays traced), by [`RuntimePath::from_env`]'s loop.
    pub fn irradiance(&self, s: &Shading, set: &RaySet) -> (Vec3, u64) {
        self.irradiance_by(s, set, RuntimePath::from_env())
    }

    /// Algorithm 3 by a chosen loop (sets over [`raybatch::MAX_RAYS`] rays always run per ray).
    pub fn irradiance_by(&self, s: &Shading, set: &RaySet, path: RuntimePath) -> (Vec3, u64) {
        match path {
            RuntimePath::Batched(former) if set.count as usize <= raybatch::MAX_RAYS => self.irradiance_batched(s, set, former),
            _ => self.irradiance_per_ray(s, set),
        }
    }

    /// The per-ray loop: each ray formed, its pixel found, its mask bits read, then traced.
    pub fn irradiance_per_ray(&self, s: &Shading, set: &RaySet) -> (Vec3, u64) {
        let cell = self.dvf.grid.cell_of(s.position);
        let label = self.force_label.unwrap_or(self.dvf.labels[cell]);
        let r = self.dvf.masks.resolution;
        let (vw, ow) = self.fragment_words(s.position, cell);
        let inv = 1.0 / set.count as f32;
        let (mut sum, mut unshadowed, mut rays) = (Vec3::ZERO, Vec3::ZERO, 0u64);
        for k in 0..set.count {
            let d = set.direction(k);
            if s.cos(d) <= 0.0 {
                continue;
            }
            let pixel = crate::grid::octahedral_pixel(d, r);
            let bit = |m: &[u64]| (m[pixel as usize / 64] >> (pixel % 64)) & 1 == 1;
            let (v, o) = (bit(&vw), bit(&ow));
            let bright = self.bright.is_some_and(|b| b.may_hold(pixel) && b.holds(d, &|| self.env.radiance(d)));
            if label == 1 {
                // Mostly occluded: trace inside the visible region, add what escapes.
                if v || (self.trace_unknown && !o) || bright {
                    rays += 1;
                    if !self.vis.occluded(&s.spawn(d), f32::INFINITY) {
                        sum += self.env.radiance(d) * inv;
                    }
                }
            } else {
                if self.unshadowed == Unshadowed::Rays {
                    unshadowed += self.env.radiance(d) * inv;
                }
                // Mostly visible: trace inside the occluded region, add what is blocked.
                if o || (self.trace_unknown && !v) || bright {
                    rays += 1;
                    if self.vis.occluded(&s.spawn(d), f32::INFINITY) {
                        sum += self.env.radiance(d) * inv;
                    }
                }
            }
        }
        self.finish(s, label, sum, unshadowed, rays)
    }

    /// E from the traced sum (label 1: E = sum; label 0: E = max(E_unshad − sum, 0)).
    #[inline]
    fn finish(&self, s: &Shading, label: u8, sum: Vec3, unshadowed: Vec3, rays: u64) -> (Vec3, u64) {
        if label == 1 {
            return (sum, rays);
        }
        let e_unshad = match self.unshadowed {
            Unshadowed::Sh => self.sh.irradiance(s.shading_normal) / PI,
            Unshadowed::Rays => unshadowed,
        };
        ((e_unshad - sum).max(Vec3::ZERO), rays)
    }

    /// The batched loop: the cell's "trace this pixel" mask (label 1: V, or V ∪ ¬O with
    /// `unknown=trace`; label 0: O, or O ∪ ¬V), the whole set's directions, pixels and horizon
    /// bits at once, one mask lookup per ray into a bit set of the rays to trace, then those
    /// rays traced in batches in ascending k, so every sum adds the same terms in the same order
    /// as [`Self::irradiance_per_ray`]. A cell whose trace mask is empty forms no directions
    /// (unless `unshadowed=rays` needs them for E_unshad). L(ω) through [`raybatch::radiance`]
    /// (`env.radiance` without its divisions), rays spawned from one origin per fragment (the
    /// one `Shading::spawn` computes for every ray above the geometric horizon).
    pub fn irradiance_batched(&self, s: &Shading, set: &RaySet, former: Former) -> (Vec3, u64) {
        let cell = self.dvf.grid.cell_of(s.position);
        let label = self.force_label.unwrap_or(self.dvf.labels[cell]);
        let masks = &self.dvf.masks;
        let words = masks.words_per_mask;
        let mut select = [0u64; crate::grid::MAX_WORDS];
        let unknown = if self.trace_unknown { !0u64 } else { 0 };
        let mut any = 0u64;
        let (vw, ow) = self.fragment_words(s.position, cell);
        for (w, t) in select[..words].iter_mut().enumerate() {
            let (v, o) = (vw[w], ow[w]);
            *t = if label == 1 { v | (unknown & !o) } else { o | (unknown & !v) };
            any |= *t | self.bright.map_or(0, |b| b.coarse[w]);
        }
        let inv = 1.0 / set.count as f32;
        let rays_unshadowed = label != 1 && self.unshadowed == Unshadowed::Rays;
        if any == 0 && !rays_unshadowed {
            return self.finish(s, label, Vec3::ZERO, Vec3::ZERO, 0);
        }
        let mut b = Block::default();
        raybatch::form(set, s.normal, s.shading_normal, masks.resolution, former, &mut b);
        // One lookup per ray: bit k of `trace` = ray k is above the horizon and its pixel set.
        let mut trace = [0u64; raybatch::RAY_WORDS];
        let n = b.count;
        if words == 1 {
            let t = select[0];
            for (k, &p) in b.pixel[..n].iter().enumerate() {
                trace[k / 64] |= ((t >> (p & 63)) & 1) << (k % 64);
            }
        } else {
            for (k, &p) in b.pixel[..n].iter().enumerate() {
                trace[k / 64] |= ((select[p as usize / 64] >> (p % 64)) & 1) << (k % 64);
            }
        }
        for (t, u) in trace.iter_mut().zip(b.used) {
            *t &= u;
        }
        // `bright`: a ray toward the map's brightest texels is traced whatever the masks say.
        let is_bright = |k: usize, radiance: &dyn Fn() -> Vec3| {
            self.bright.is_some_and(|bright| bright.may_hold(b.pixel[k]) && bright.holds(b.direction(k), radiance))
        };
        let mut unshadowed = Vec3::ZERO;
        if rays_unshadowed {
            // In chunks: every tap's texels prefetched before the first is read. The radiance
            // read for E_unshad also decides `bright`.
            let mut taps = [(0usize, raybatch::Tap::default()); TRACE_BATCH];
            let mut m = 0;
            let mut add = |taps: &[(usize, raybatch::Tap)], unshadowed: &mut Vec3| {
                for &(k, ref t) in taps {
                    let l = raybatch::tap_radiance(self.env, t);
                    *unshadowed += l * inv;
                    if is_bright(k, &|| l) {
                        trace[k / 64] |= 1 << (k % 64);
                    }
                }
            };
            for k in bits(&b.used) {
                taps[m] = (k, raybatch::tap(self.env, b.direction(k)));
                raybatch::prefetch(self.env, &taps[m].1);
                m += 1;
                if m == TRACE_BATCH {
                    add(&taps, &mut unshadowed);
                    m = 0;
                }
            }
            add(&taps[..m], &mut unshadowed);
        } else if self.bright.is_some() {
            for k in bits(&b.used) {
                if is_bright(k, &|| raybatch::radiance(self.env, b.direction(k))) {
                    trace[k / 64] |= 1 << (k % 64);
                }
            }
        }
        // Label 1 adds what escapes, label 0 what is blocked.
        let add_when_occluded = label != 1;
        let (mut sum, mut rays) = (Vec3::ZERO, 0u64);
        let mut batch = [(glimpse_core::Ray::new(Vec3::ZERO, Vec3::Z), f32::INFINITY); TRACE_BATCH];
        let mut index = [0usize; TRACE_BATCH];
        let mut occluded = [false; TRACE_BATCH];
        let mut m = 0;
        let flush = |m: usize, batch: &[(glimpse_core::Ray, f32)], index: &[usize], occluded: &mut [bool], sum: &mut Vec3| {
            self.vis.occluded_batch(&batch[..m], &mut occluded[..m]);
            // The lookups of the rays that count, texels prefetched before any is read.
            let mut taps = [raybatch::Tap::default(); TRACE_BATCH];
            let mut n = 0;
            for (&k, &o) in index[..m].iter().zip(&occluded[..m]) {
                if o == add_when_occluded {
                    taps[n] = raybatch::tap(self.env, b.direction(k));
                    raybatch::prefetch(self.env, &taps[n]);
                    n += 1;
                }
            }
            for t in &taps[..n] {
                *sum += raybatch::tap_radiance(self.env, t) * inv;
            }
        };
        // `s.spawn(d)` of a traced ray: above the geometric horizon (n·d > 0, or NaN), so its
        // origin is always pushed along +n: one origin per fragment.
        let origin = glimpse_core::ray::offset_origin(s.position, s.normal, s.error_scale);
        for k in bits(&trace) {
            batch[m] = (glimpse_core::Ray::new(origin, b.direction(k)), f32::INFINITY);
            index[m] = k;
            m += 1;
            rays += 1;
            if m == TRACE_BATCH {
                flush(m, &batch, &index, &mut occluded, &mut sum);
                m = 0;
            }
        }
        if m > 0 {
            flush(m, &batch, &index, &mut occluded, &mut sum);
        }
        self.finish(s, label, sum, unshadowed, rays)
    }
}

/// The set bits of a ray bit set, ascending.
fn bits(set: &[u64; raybatch::RAY_WORDS]) -> impl Iterator<Item = usize> + '_ {
    set.iter().enumerate().flat_map(|(w, &word)| {
        let mut word = word;
        std::iter::from_fn(move || {
            (word != 0).then(|| {
                let b = word.trailing_zeros() as usize;
                word &= word - 1;
                w * 64 + b
            })
        })
    })
}

impl Technique for EnvDvf {
    fn id(&self) -> &'static str {
        "env-dvf"
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        if let (None, Some(env)) = (&self.sh, ctx.frame.scene.environment.as_ref()) {
            self.sh = Some(stats.time("sh", || project_environment(env)));
            if self.params.wants_map_noise() {
                // Once per map, as the SH: how noisy N_r rays of it are (with the field's
                // occlusion, below) decides E_unshad's source, and whether bright rays are traced.
                self.map_noise = Some(stats.time("map noise", || crate::cosine_estimator_noise(env, self.params.rays)));
            }
            self.bright = stats.time("bright", || self.params.bright_directions(env));
        }
        let reuse = self.dvf.take().map(|d| d.masks);
        // The sample budget for this frame's size and triangle count (`points=auto` …).
        let p = self.params.for_frame(ctx.width as u64 * ctx.height as u64, ctx.frame.scene.triangle_count());
        let grid = crate::grid::Grid::from_bounds(ctx.frame.bounds, p.grid);
        let mask_bytes = 2 * 8 * ((p.octahedral as u64).pow(2).div_ceil(64));
        let what = format!("env-dvf: {} cells of {}² visibility masks", grid.cell_count(), p.octahedral);
        glimpse_core::memory_budget::check(what, grid.cell_count() as u64 * (mask_bytes + 1))?;
        let back = stats.time("back sides", || self.params.back_instances_in(ctx));
        let dvf = Dvf::build(&ctx.frame, &back, &ctx.tracer, &p, self.settings.seed, ctx.frame_index, reuse, &mut stats);
        stats.metrics.push(("back_side_instances".to_owned(), back.len() as f64));
        stats.metrics.push(("points".to_owned(), p.points as f64));
        stats.metrics.push(("grid".to_owned(), p.grid as f64));
        stats.metrics.push(("build_rays".to_owned(), dvf.rays_traced as f64));
        stats.metrics.push(("seen_cells".to_owned(), dvf.seen_cells() as f64));
        let occluded = dvf.occluded_cell_fraction();
        stats.metrics.push(("occluded_cells".to_owned(), occluded as f64));
        if let Some(noise) = self.map_noise {
            if self.params.auto.unshadowed {
                self.params.unshadowed = crate::choose_unshadowed(noise, occluded);
            }
            if self.params.auto.bright {
                self.params.bright = crate::choose_bright(noise);
            }
            stats.metrics.push(("map_noise".to_owned(), noise as f64));
            stats.metrics.push(("unshadowed_rays".to_owned(), (self.params.unshadowed == Unshadowed::Rays) as u8 as f64));
        }
        // The share of the map's power that `bright` traces exactly (0: off).
        let bright = self.bright.as_ref().filter(|_| self.params.bright).map_or(0.0, |b| b.part.power_fraction);
        stats.metrics.push(("bright_power".to_owned(), bright as f64));
        stats.memory_bytes = stats.memory_bytes.max(dvf.memory_bytes());
        self.dvf = Some(dvf);
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let dvf = self
            .dvf
            .as_ref()
            .ok_or_else(|| RenderError::Unsupported { technique: "env-dvf".into(), message: "render called before prepare".into() })?;
        let mut stats = Stats { memory_bytes: dvf.memory_bytes(), ..Default::default() };
        let (n, about_normal) = (self.params.rays, self.params.rotate_about_normal);
        let rt = self.runtime(ctx);
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, rng| {
                let (Some(s), Some(rt)) = (Shading::from_gbuffer(gbuffer, i), rt.as_ref()) else {
                    return (Vec3::ZERO, 0);
                };
                // The reference's draw: one 2-D shift per pixel.
                let set = RaySet::new(s.shading_normal, n, rng.next_2d(), about_normal);
                let (e, rays) = rt.irradiance(&s, &set);
                (s.albedo * e, rays)
            })
        })?;
        Ok(stats)
    }
}

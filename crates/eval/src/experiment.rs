//! `glimpse eval`: each technique beside its reference on the same scene, GBuffer and seed.
//!
//! The reference of an approximate technique is the exact technique its registry entry names;
//! an exact technique's reference is itself at `ref_spp` samples (its converged answer). The
//! reference gets the same `--set` values, reading only those it knows (so `radius=` reaches both
//! `ao-roma` and `ao-exact`). An approximate technique's reference uses the same seed (the
//! same per-pixel random streams); an exact technique's reference uses another seed, so its
//! error is its own noise. References are cached on disk (see [`crate::cache`]).

use crate::cache::Cache;
use crate::progress::{with_progress, with_spinner};
use anyhow::{Context, Result};
use glimpse_core::{Image, ToneMap};
use glimpse_render::metrics::{ErrorMapKind, Metrics, error_map};
use glimpse_render::{FrameContext, Params, Registry, RenderError, Settings, Stats, Stopwatch, Technique};
use glimpse_scene::Scene;
use glimpse_trace::GBuffer;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

#[derive(Clone, Debug)]
pub struct EvalConfig {
    pub scene_spec: String,
    /// Technique ids; empty means every registered technique (or every approximate one, with
    /// `approximate_only`), skipping those the scene cannot run.
    pub techniques: Vec<String>,
    /// With an empty `techniques`: leave out the exact references as runs of their own (they
    /// still render as the approximations' references).
    pub approximate_only: bool,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub ref_spp: u32,
    pub seed: u64,
    pub time: f32,
    /// `key=value` technique parameters.
    pub params: Vec<String>,
    pub out_dir: PathBuf,
    pub cache: Cache,
    /// Also run each technique at fewer samples for the error-versus-time plot.
    pub sweep: bool,
    pub exposure: f32,
    /// Frames rendered per technique (`eval --frames N`), with frame indices 0..N on the same
    /// time: temporal techniques (ROMA, light cuts) are judged after N frames of accumulation, as
    /// they are used. See [`render_frames`].
    pub frames: u32,
    /// Command-line scene overrides (`--env`, `--sun`, `--light`, `--camera`, `--filter`, …).
    pub overrides: glimpse_scene::SceneOverrides,
    /// Also time each reference at the technique's own `spp` and seed (not cached), for the
    /// speed-up over the exact reference on the same GBuffer (`Run::reference_ms`).
    pub time_reference: bool,
    /// Send each reference and each technique's image to a running tev at this HOST:PORT as it
    /// is done (`--tev`); unreachable is an error before any work.
    pub tev: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SweepPoint {
    pub spp: u32,
    pub ms: f64,
    pub rmse: f64,
    pub flip: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Run {
    pub technique: String,
    pub reference: String,
    /// prepare, render, total and every stage, in milliseconds.
    pub ms: BTreeMap<String, f64>,
    pub memory_bytes: usize,
    pub rays: u64,
    pub metrics: BTreeMap<String, f64>,
    pub params: BTreeMap<String, String>,
    pub images: BTreeMap<String, String>,
    pub sweep: Vec<SweepPoint>,
    pub reference_cached: bool,
    /// Frames accumulated (1 for a single image).
    pub frames: u32,
    /// The reference's prepare + render time at this run's spp and seed, when timed.
    pub reference_ms: Option<f64>,
    /// The render part of `reference_ms` (its prepare is the rest).
    pub reference_render_ms: Option<f64>,
}

/// A technique not run because the scene lacks what it needs.
#[derive(Clone, Debug, Serialize)]
pub struct Skipped {
    pub technique: String,
    pub reason: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct EvalResults {
    pub scene: String,
    pub size: [u32; 2],
    pub spp: u32,
    pub ref_spp: u32,
    pub seed: u64,
    pub time: f32,
    pub gbuffer_ms: f64,
    pub peak_rss_bytes: Option<u64>,
    pub runs: Vec<Run>,
    pub skipped: Vec<Skipped>,
}

/// What one `prepare` + `render` produced.
pub struct Rendered {
    pub image: Image,
    pub prepare: Stats,
    pub render: Stats,
    /// Over several frames ([`render_frames`]): frame 0's prepare + render, which holds the
    /// one-time work (a precomputation, a structure build) that the per-frame median leaves out.
    pub first_frame_ms: Option<f64>,
}

/// The reference cache's key for technique `id` rendered with `params` at `spp` and `seed` over
/// `frames` frames on the run's scene, size, time, film and overrides.
fn reference_key(cfg: &EvalConfig, ctx: &FrameContext, id: &str, params: &Params, spp: u32, seed: u64, frames: u32) -> String {
    Cache::key(
        &[
            id,
            &format!("{:?}", params.effective()),
            &format!("{}x{}", cfg.width, cfg.height),
            &spp.to_string(),
            &seed.to_string(),
            &cfg.time.to_string(),
            &format!("film {} x{frames}", ctx.film.filter.name()),
            &cfg.overrides.cache_key(),
        ],
        &cfg.scene_spec,
    )
}

/// `env-exact` converged (`converged=true`: 4,096 rays, MIS with the map's importance sampling)
/// on the run's GBuffer, from the reference cache when there.
fn converged_env_exact(cfg: &EvalConfig, ctx: &FrameContext, gbuffer: &GBuffer, log: &mut impl FnMut(&str)) -> Result<Image> {
    let params = Params::parse(&["converged=true"])?;
    let settings = Settings { spp: 1, seed: cfg.seed.wrapping_add(0x5eed) };
    let key = reference_key(cfg, ctx, "env-exact", &params, 1, settings.seed, 1);
    if let Some(image) = cfg.cache.load(&key).filter(|i| i.width == cfg.width && i.height == cfg.height) {
        return Ok(image);
    }
    log("rendering env-exact converged=true (env-dvf's SH E_unshad is judged against it)");
    let mut exact = glimpse_render::env::EnvExact::new(&settings, &params)?;
    let image = render_once(&mut exact, ctx, gbuffer)?.image;
    cfg.cache.store(&key, &image);
    Ok(image)
}

/// `prepare` then `render`, each with a spinner or pixel bar on a terminal when it runs long
/// (references at high spp, a voxel array build, a wavelet precompute).
pub fn render_once(technique: &mut dyn Technique, ctx: &FrameContext, gbuffer: &GBuffer) -> Result<Rendered> {
    let id = technique.id();
    let prepare = with_spinner(&format!("preparing {id}"), || technique.prepare(ctx))?;
    let mut image = ctx.image();
    let render = with_progress(&format!("rendering {id}"), ctx, || technique.render(ctx, gbuffer, &mut image))?;
    Ok(Rendered { image, prepare, render, first_frame_ms: None })
}

/// A shading pass shorter than this is timed again ([`STEADY_REPEATS`] passes in all) and the
/// median kept: at a few milliseconds a single pass on a shared machine is mostly scheduling
/// noise (a shadow-map baseline went from 0.74× to 1.22× its reference between two runs of
/// the same code).
pub const STEADY_BELOW_MS: f64 = 100.0;
pub const STEADY_REPEATS: usize = 5;

/// `first` with its render stats replaced by the median of [`STEADY_REPEATS`] render passes when
/// its own pass took under [`STEADY_BELOW_MS`]. Only `render` is repeated: `prepare` is timed
/// once, as it ran, since a second one could find what the first cached.
pub fn steady_render(technique: &mut dyn Technique, ctx: &FrameContext, gbuffer: &GBuffer, first: Rendered) -> Result<Rendered> {
    if first.render.total_ms() >= STEADY_BELOW_MS {
        return Ok(first);
    }
    let mut passes = vec![first.render.clone()];
    for _ in 1..STEADY_REPEATS {
        let mut image = ctx.image();
        passes.push(technique.render(ctx, gbuffer, &mut image)?);
    }
    let render = median_by_ms(passes, Stats::total_ms);
    Ok(Rendered { render, ..first })
}

/// The item whose time is the median (the upper one of an even count); `items` is not empty.
fn median_by_ms<T>(mut items: Vec<T>, ms: impl Fn(&T) -> f64) -> T {
    items.sort_by(|a, b| ms(a).total_cmp(&ms(b)));
    items.swap_remove(items.len() / 2)
}

/// `frames` frames of the same (static) time with frame indices 0..frames, as a renderer uses a
/// temporal technique. Frame `i` shades primary sample `i` of every pixel (the film's filter
/// jitters the GBuffer from frame to frame, as temporal anti-aliasing does; `gbuffer` is frame
/// 0's), so averaging frames also anti-aliases. A technique that blends its own history (it
/// times an `accumulate` stage, as ROMA does) is judged by its last image; for any other
/// technique the frames are averaged here (the accumulation a renderer would apply). The stats
/// are the steady per-frame cost: those of the median frame by time, among the frames after the
/// first (which pays one-time costs: a cache load, the SH projection). One frame's time alone
/// decided comparisons at equal time by the noise of a shared machine (the light cuts against
/// `vpl-rtslc`, whose MSEs agree to 1 %).
pub fn render_frames(technique: &mut dyn Technique, ctx: &mut FrameContext, gbuffer: &GBuffer, frames: u32) -> Result<Rendered> {
    let frames = frames.max(1);
    let mut sum: Option<Image> = None;
    let mut last = None;
    let mut timed: Vec<(Stats, Stats)> = Vec::new();
    let mut first_frame_ms = None;
    for i in 0..frames {
        ctx.frame_index = i;
        ctx.film_pass = i;
        let jittered = (i > 0 && ctx.film.filter != glimpse_scene::Filter::PixelCentre).then(|| ctx.gbuffer());
        let r = render_once(technique, ctx, jittered.as_ref().unwrap_or(gbuffer));
        ctx.frame_index = 0;
        ctx.film_pass = 0;
        let r = r?;
        let self_accumulating = r.render.stages.iter().any(|(stage, _)| stage == "accumulate");
        if !self_accumulating {
            let total = sum.get_or_insert_with(|| Image::new(r.image.width, r.image.height));
            total.pixels.iter_mut().zip(&r.image.pixels).for_each(|(t, p)| *t += *p);
        }
        if i > 0 || frames == 1 {
            timed.push((r.prepare.clone(), r.render.clone()));
        } else {
            first_frame_ms = Some(r.prepare.total_ms() + r.render.total_ms());
        }
        last = Some(r);
    }
    let mut r = last.expect("at least one frame is rendered");
    if let Some(total) = sum {
        r.image.pixels = total.pixels.into_iter().map(|p| p / frames as f32).collect();
    }
    (r.prepare, r.render) = median_by_ms(timed, |(prepare, render)| prepare.total_ms() + render.total_ms());
    r.first_frame_ms = first_frame_ms;
    Ok(r)
}

/// File-name-safe form of a technique id.
fn slug(id: &str) -> String {
    id.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect()
}

/// The reference rendered again at the runs' own spp and seed.
struct TimedReference {
    /// Prepare + render, and render alone.
    ms: f64,
    render_ms: f64,
    image: Image,
    /// Its RMSE and pixel faults against the converged reference (single frames only).
    noise: Option<(f64, crate::suite::PixelFaults)>,
}

pub fn run_eval(cfg: &EvalConfig, registry: &Registry, mut log: impl FnMut(&str)) -> Result<EvalResults> {
    let mut scene: Scene = glimpse_scene::load(&cfg.scene_spec)?;
    if cfg.overrides.apply(&mut scene).map_err(anyhow::Error::msg)? {
        log(&format!("note: {}", glimpse_scene::auto::DEFAULT_LIGHT_NOTE));
    }
    for w in &scene.warnings {
        log(&format!("warning: {w}"));
    }
    let ids: Vec<String> = if cfg.techniques.is_empty() {
        registry.all().iter().filter(|t| !cfg.approximate_only || t.reference.is_some()).map(|t| t.id.to_owned()).collect()
    } else {
        cfg.techniques.clone()
    };
    // Check the parameters once against every technique named and its reference: a key none of
    // them reads is a typo. Techniques the scene cannot support (no lights of their kind) are an
    // error when named, and skipped with the reason when running everything.
    let all_params = Params::parse(&cfg.params)?;
    let settings = Settings { spp: cfg.spp, seed: cfg.seed };
    let mut runnable = Vec::new();
    let mut skipped = Vec::new();
    for id in ids {
        let info = registry.get(&id)?;
        let check = |tid: &str| -> Result<(), RenderError> { (registry.get(tid)?.create)(&scene, &settings, &all_params).map(|_| ()) };
        match check(&id).and_then(|_| check(info.reference.unwrap_or(info.id))) {
            Ok(()) => runnable.push(id),
            Err(RenderError::Unsupported { message, .. }) if cfg.techniques.is_empty() => {
                log(&format!("skipping {id}: {message}"));
                skipped.push(Skipped { technique: id, reason: message });
            }
            Err(e) => return Err(e.into()),
        }
    }
    all_params.finish(&runnable.join(", "))?;
    let ids = runnable;
    std::fs::create_dir_all(&cfg.out_dir).with_context(|| format!("{}: cannot create the output directory", cfg.out_dir.display()))?;

    if let Some(address) = &cfg.tev {
        glimpse_core::tev::check_reachable(address).with_context(|| format!("--tev: cannot reach tev at {address}"))?;
    }
    // Each image to tev as it is done; a tev that went away stops the streaming, not the eval.
    let tev_live = std::cell::Cell::new(cfg.tev.is_some());
    let to_tev = |name: &str, img: &Image| {
        if let (true, Some(address)) = (tev_live.get(), &cfg.tev)
            && let Err(e) = glimpse_core::tev::send_image(address, name, img)
        {
            eprintln!("warning: --tev: {e}; not streaming any more");
            tev_live.set(false);
        }
    };
    let sw = Stopwatch::start();
    let mut ctx = with_spinner("building the scene's tracer", || FrameContext::new(&scene, cfg.time, cfg.width, cfg.height));
    let frames = cfg.frames.max(1);
    let gbuffer = ctx.gbuffer();
    let gbuffer_ms = sw.ms();
    let tone = ToneMap { exposure: cfg.exposure };
    let write = |name: &str, img: &Image| -> Result<String> {
        let file = format!("{name}.png");
        img.write(&cfg.out_dir.join(&file), tone)?;
        img.write(&cfg.out_dir.join(format!("{name}.exr")), tone)?;
        Ok(file)
    };

    let mut references: BTreeMap<(String, u64), (Image, bool, String)> = BTreeMap::new();
    // The reference re-rendered at the runs' own spp and seed: its time, and its image (on the
    // same samples as a single-frame technique's, so their difference is the approximation's
    // alone, without the noise that the converged reference removes).
    let mut reference_times: BTreeMap<String, TimedReference> = BTreeMap::new();
    let mut runs = Vec::new();
    for id in &ids {
        let info = registry.get(id)?;
        let ref_id = info.reference.unwrap_or(info.id).to_owned();
        // An approximate technique is compared with its reference on the same random streams
        // (same seed: where both trace the same rays, only the approximation differs); an exact
        // technique is compared with its own converged render from independent streams.
        let ref_seed = if info.reference.is_some() { cfg.seed } else { cfg.seed.wrapping_add(0x5eed) };
        let ref_key = (ref_id.clone(), ref_seed);
        if !references.contains_key(&ref_key) {
            // Over several frames the reference shades the same primary samples as the
            // technique (one pass per frame), its samples shared out among the passes.
            let ref_settings = Settings { spp: cfg.ref_spp.div_ceil(frames), seed: ref_seed };
            let ref_params = Params::parse(&cfg.params)?;
            let mut reference = (registry.get(&ref_id)?.create)(&scene, &ref_settings, &ref_params)?;
            let key = reference_key(cfg, &ctx, &ref_id, &ref_params, cfg.ref_spp, ref_settings.seed, frames);
            let (image, cached) = match cfg.cache.load(&key) {
                Some(img) if img.width == cfg.width && img.height == cfg.height => (img, true),
                _ => {
                    log(&format!("rendering reference {ref_id} at {} spp", cfg.ref_spp));
                    let r = render_frames(reference.as_mut(), &mut ctx, &gbuffer, frames)?;
                    cfg.cache.store(&key, &r.image);
                    (r.image, false)
                }
            };
            let file = write(&format!("ref-{}-seed{ref_seed}", slug(&ref_id)), &image)?;
            to_tev(&format!("ref {ref_id} seed {ref_seed}"), &image);
            references.insert(ref_key.clone(), (image, cached, file));
        }
        let (reference, reference_cached, reference_file) = &references[&ref_key];

        log(&format!("running {id}"));
        let params = Params::parse(&cfg.params)?;
        let mut technique = (info.create)(&scene, &settings, &params)?;
        let mut r = render_frames(technique.as_mut(), &mut ctx, &gbuffer, cfg.frames)?;
        if cfg.frames.max(1) == 1 {
            r = steady_render(technique.as_mut(), &ctx, &gbuffer, r)?;
        }
        let faults = crate::suite::PixelFaults::count(&r.image, reference);
        let metrics = Metrics::compute(&r.image, reference)?;
        let mse_trimmed = glimpse_render::metrics::mse_without_worst(&r.image, reference, crate::suite::TRIMMED_FRACTION)?;
        // Every technique of one eval shares spp, seed and parameters, so a reference is timed
        // once and its time serves each technique compared with it.
        if cfg.time_reference && info.reference.is_some() && !reference_times.contains_key(&ref_id) {
            let mut timed = (registry.get(&ref_id)?.create)(&scene, &settings, &Params::parse(&cfg.params)?)?;
            let first = render_once(timed.as_mut(), &ctx, &gbuffer)?;
            let t = steady_render(timed.as_mut(), &ctx, &gbuffer, first)?;
            // Its own noise at this spp against its converged render (single frames only), once
            // for every technique compared with it: the RMSE, and glints counted as the suite does.
            let noise = if cfg.frames.max(1) == 1 {
                Some((Metrics::compute(&t.image, reference)?.rmse, crate::suite::PixelFaults::count(&t.image, reference)))
            } else {
                None
            };
            let (ms, render_ms) = (t.prepare.total_ms() + t.render.total_ms(), t.render.total_ms());
            reference_times.insert(ref_id.clone(), TimedReference { ms, render_ms, image: t.image, noise });
        }
        let timed_reference = reference_times.get(&ref_id).filter(|_| cfg.time_reference && info.reference.is_some());
        let (reference_ms, reference_render_ms) = (timed_reference.map(|t| t.ms), timed_reference.map(|t| t.render_ms));
        // Same samples (a single frame only: accumulated frames shade other samples).
        let mut same_samples = Vec::new();
        if let Some(TimedReference { image: exact, noise: Some((rmse, own)), .. }) = timed_reference {
            let m = Metrics::compute(&r.image, exact)?;
            same_samples.push(("rmse_same_samples".to_owned(), m.rmse));
            same_samples.push(("flip_same_samples".to_owned(), m.flip));
            same_samples.push(("reference_rmse_same_spp".to_owned(), *rmse));
            // The reference technique's own faults at this spp, and the pixels where the
            // technique's faults are the same pixels: what the spp's noise alone produces.
            let (black_shared, over_shared) = crate::suite::PixelFaults::shared(&r.image, exact, reference);
            same_samples.push(("reference_over_twice_pixels".to_owned(), own.over_twice as f64));
            same_samples.push(("reference_black_where_lit_pixels".to_owned(), own.black_where_lit as f64));
            same_samples.push(("over_twice_shared_pixels".to_owned(), over_shared as f64));
            same_samples.push(("black_where_lit_shared_pixels".to_owned(), black_shared as f64));
        }
        // env-dvf with E_unshad from the map's SH is not on env-exact's samples in its
        // unshadowed term: both are measured against env-exact converged (4,096 MIS rays), once.
        let sh_unshadowed = r.prepare.metrics.iter().any(|(k, v)| k == "unshadowed_rays" && *v == 0.0);
        if let (true, "env-dvf", Some(TimedReference { image: exact, .. })) = (sh_unshadowed, id.as_str(), timed_reference) {
            let converged = converged_env_exact(cfg, &ctx, &gbuffer, &mut log)?;
            same_samples.push(("rmse_converged".to_owned(), Metrics::compute(&r.image, &converged)?.rmse));
            same_samples.push(("reference_rmse_converged".to_owned(), Metrics::compute(exact, &converged)?.rmse));
        }
        let mut ms = BTreeMap::new();
        ms.insert("prepare".to_owned(), r.prepare.total_ms());
        ms.insert("render".to_owned(), r.render.total_ms());
        ms.insert("total".to_owned(), r.prepare.total_ms() + r.render.total_ms());
        if let Some(first) = r.first_frame_ms {
            ms.insert("first_frame".to_owned(), first);
        }
        for (stage, t) in r.prepare.stages.iter().chain(&r.render.stages) {
            *ms.entry(stage.clone()).or_insert(0.0) += t;
        }
        to_tev(id, &r.image);
        let mut images = BTreeMap::new();
        images.insert("image".to_owned(), write(&slug(id), &r.image)?);
        images.insert("reference".to_owned(), reference_file.clone());
        let map = error_map(&r.image, reference, ErrorMapKind::FlipHdr)?;
        let err_file = format!("{}-error.png", slug(id));
        map.write(&cfg.out_dir.join(&err_file), ToneMap::default())?;
        images.insert("error".to_owned(), err_file);

        let mut sweep = Vec::new();
        if cfg.sweep {
            let mut spps: Vec<u32> = [cfg.spp / 8, cfg.spp / 4, cfg.spp / 2].into_iter().filter(|&s| s >= 1).collect();
            spps.dedup();
            for spp in spps {
                let mut t = (info.create)(&scene, &Settings { spp, seed: cfg.seed }, &Params::parse(&cfg.params)?)?;
                let s = render_once(t.as_mut(), &ctx, &gbuffer)?;
                let m = Metrics::compute(&s.image, reference)?;
                sweep.push(SweepPoint { spp, ms: s.prepare.total_ms() + s.render.total_ms(), rmse: m.rmse, flip: m.flip });
            }
            sweep.push(SweepPoint { spp: cfg.spp, ms: ms["total"], rmse: metrics.rmse, flip: metrics.flip });
        }
        log(&format!("  {id}: total {:.1} ms, RMSE {:.5}, FLIP {:.5}", ms["total"], metrics.rmse, metrics.flip));
        runs.push(Run {
            technique: id.clone(),
            reference: ref_id.clone(),
            ms,
            memory_bytes: r.prepare.memory_bytes.max(r.render.memory_bytes),
            rays: r.prepare.rays + r.render.rays,
            metrics: metrics
                .to_pairs()
                .into_iter()
                .map(|(k, v)| (k.to_owned(), v))
                .chain(r.prepare.metrics.iter().chain(&r.render.metrics).cloned())
                .chain(faults.to_pairs().map(|(k, v)| (k.to_owned(), v)))
                .chain(same_samples)
                .chain([("mse_trimmed".to_owned(), mse_trimmed)])
                .collect(),
            params: params.effective(),
            images,
            sweep,
            reference_cached: *reference_cached,
            frames: cfg.frames.max(1),
            reference_ms,
            reference_render_ms,
        });
    }

    let results = EvalResults {
        scene: cfg.scene_spec.clone(),
        size: [cfg.width, cfg.height],
        spp: cfg.spp,
        ref_spp: cfg.ref_spp,
        seed: cfg.seed,
        time: cfg.time,
        gbuffer_ms,
        peak_rss_bytes: crate::peak_rss_bytes(),
        runs,
        skipped,
    };
    glimpse_core::atomic_file::write_bytes_atomic(&cfg.out_dir.join("results.json"), serde_json::to_string_pretty(&results)?.as_bytes())
        .context("writing results.json")?;
    crate::report::write_html(&results, &cfg.out_dir.join("report.html"))?;
    Ok(results)
}

//! `glimpse play`: an animation rendered frame by frame. The scene is evaluated at successive
//! times, the exact tracer updated, and the technique's `prepare` runs every frame (so dynamic
//! techniques pay for their rebuild), with per-frame stage timings and their mean.

use crate::experiment::render_once;
use anyhow::{Context, Result};
use glimpse_core::ToneMap;
use glimpse_render::{FrameContext, Params, Registry, Settings, Stopwatch};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

#[derive(Clone, Debug)]
pub struct PlayConfig {
    pub scene_spec: String,
    pub technique: String,
    pub frames: u32,
    pub fps: f32,
    pub start_time: f32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub params: Vec<String>,
    pub out_dir: Option<PathBuf>,
    pub exposure: f32,
    /// Command-line scene overrides (`--env`, `--sun`, `--light`, `--camera`, …).
    pub overrides: glimpse_scene::SceneOverrides,
    /// Stream every frame to a running tev at this HOST:PORT (`--tev`).
    pub tev: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct FrameTiming {
    pub frame: u32,
    pub time: f32,
    /// "scene" (evaluate + tracer update), "gbuffer", "prepare", "render" and every stage.
    pub ms: BTreeMap<String, f64>,
}

pub fn run_play(cfg: &PlayConfig, registry: &Registry, mut log: impl FnMut(&FrameTiming)) -> Result<Vec<FrameTiming>> {
    let mut scene = glimpse_scene::load(&cfg.scene_spec)?;
    cfg.overrides.apply(&mut scene).map_err(anyhow::Error::msg)?;
    let params = Params::parse(&cfg.params)?;
    let mut technique = registry.create(&cfg.technique, &scene, &Settings { spp: cfg.spp, seed: cfg.seed }, &params)?;
    if let Some(dir) = &cfg.out_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the output directory", dir.display()))?;
    }
    let mut ctx = FrameContext::new(&scene, cfg.start_time, cfg.width, cfg.height);
    // One tev image, replaced by each frame as it is rendered.
    let mut tev = match &cfg.tev {
        Some(address) => Some(
            glimpse_core::tev::Tev::connect(address, &format!("{} {}", cfg.technique, cfg.scene_spec), cfg.width, cfg.height)
                .with_context(|| format!("--tev: cannot reach tev at {address}"))?,
        ),
        None => None,
    };
    let mut timings = Vec::new();
    for k in 0..cfg.frames {
        let time = cfg.start_time + k as f32 / cfg.fps;
        let sw = Stopwatch::start();
        if k > 0 {
            ctx.advance(time, k);
        }
        let scene_ms = sw.ms();
        let sw = Stopwatch::start();
        let gbuffer = ctx.gbuffer();
        let gbuffer_ms = sw.ms();
        let r = render_once(technique.as_mut(), &ctx, &gbuffer)?;
        let mut ms = BTreeMap::new();
        ms.insert("scene".to_owned(), scene_ms);
        ms.insert("gbuffer".to_owned(), gbuffer_ms);
        ms.insert("prepare".to_owned(), r.prepare.total_ms());
        ms.insert("render".to_owned(), r.render.total_ms());
        for (stage, t) in r.prepare.stages.iter().chain(&r.render.stages) {
            *ms.entry(format!("stage:{stage}")).or_insert(0.0) += t;
        }
        if let Some(dir) = &cfg.out_dir {
            r.image.write(&dir.join(format!("frame-{k:04}.png")), ToneMap { exposure: cfg.exposure })?;
        }
        if let Some(Err(e)) = tev.as_mut().map(|t| t.update(&r.image)) {
            eprintln!("warning: --tev: {e}; not streaming any more");
            tev = None;
        }
        let t = FrameTiming { frame: k, time, ms };
        log(&t);
        timings.push(t);
    }
    Ok(timings)
}

/// Mean of every timing over the frames.
pub fn mean_timings(frames: &[FrameTiming]) -> BTreeMap<String, f64> {
    let mut sum: BTreeMap<String, f64> = BTreeMap::new();
    for f in frames {
        for (k, v) in &f.ms {
            *sum.entry(k.clone()).or_insert(0.0) += v;
        }
    }
    let n = frames.len().max(1) as f64;
    sum.into_iter().map(|(k, v)| (k, v / n)).collect()
}

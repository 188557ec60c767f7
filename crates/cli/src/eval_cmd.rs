//! `glimpse eval` and `glimpse demo`.

use crate::args::{parse_size, parse_spp, parse_time};
use anyhow::Result;
use clap::Args;
use glimpse_eval::cache::Cache;
use glimpse_eval::experiment::{EvalConfig, EvalResults, run_eval};
use std::path::PathBuf;

#[derive(Args)]
pub struct EvalArgs {
    /// A built-in scene or a .gltf, .glb, .obj or .toml file.
    pub scene: String,
    /// Comma-separated technique ids (default: all).
    #[arg(short, long, value_delimiter = ',')]
    pub techniques: Vec<String>,
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    pub size: (u32, u32),
    #[arg(long, default_value_t = 16, value_parser = parse_spp)]
    pub spp: u32,
    /// Samples per pixel of the references.
    #[arg(long, default_value_t = 256, value_parser = parse_spp)]
    pub ref_spp: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[arg(long, default_value_t = 0.0, value_parser = parse_time)]
    pub time: f32,
    /// Technique parameter key=value (repeatable); references read the keys they know.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Skip the error-versus-time sweep (renders at fewer samples).
    #[arg(long)]
    pub no_sweep: bool,
    /// Do not read or write the reference cache.
    #[arg(long)]
    pub no_cache: bool,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Frames per technique (frame indices 0..N at the same time): temporal techniques (ROMA,
    /// light cuts) are judged after N frames of accumulation; timings are per frame.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub frames: u32,
    /// Output directory (report.html, results.json, images).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Send each technique's image and each reference to a running tev as it is done
    /// (HOST:PORT, default 127.0.0.1:14158).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = glimpse_core::tev::DEFAULT_ADDRESS)]
    pub tev: Option<String>,
    /// Where the techniques and their references run: cpu, or gpu (only the techniques with a
    /// GPU implementation; built with `--features gpu`).
    #[arg(long, value_enum, default_value_t = crate::device::Device::Cpu)]
    pub device: crate::device::Device,
    #[command(flatten)]
    pub overrides: crate::scene_args::SceneArgs,
}

#[derive(Args)]
pub struct DemoArgs {
    /// Output directory.
    #[arg(short, long, default_value = "demo")]
    pub output: PathBuf,
}

pub fn run(a: EvalArgs) -> Result<()> {
    for t in &a.techniques {
        crate::args::check_technique(t)?;
    }
    let registry = crate::device::registry(a.device, &a.techniques.iter().map(String::as_str).collect::<Vec<_>>())?;
    let cfg = EvalConfig {
        scene_spec: a.scene,
        techniques: a.techniques,
        approximate_only: false,
        width: a.size.0,
        height: a.size.1,
        spp: a.spp,
        ref_spp: a.ref_spp,
        seed: a.seed,
        time: a.time,
        params: a.set,
        out_dir: a.output,
        cache: if a.no_cache { Cache::disabled() } else { Cache { dir: Cache::default_dir() } },
        sweep: !a.no_sweep,
        exposure: a.exposure,
        frames: a.frames,
        overrides: a.overrides.overrides(),
        time_reference: false,
        tev: a.tev,
    };
    finish(&cfg, run_eval(&cfg, &registry, |m| eprintln!("{m}"))?)
}

/// Every approximate technique of the five papers on the built-in `cornell-lit` (the Cornell box
/// with its area light, four point lights and a sky through the open front, so every technique
/// applies) beside its exact reference (the references appear as the comparison images; they are
/// not also run against themselves, which for `vpl-exact` alone would cost a minute), small
/// enough to finish in about two minutes on two cores. One setting is not the default: the voxel
/// array builds 32 × 32 directions instead of 90 × 90 (its build dominates otherwise), as the
/// report's parameters say.
pub fn demo(a: DemoArgs) -> Result<()> {
    let cfg = EvalConfig {
        scene_spec: "cornell-lit".into(),
        techniques: Vec::new(),
        approximate_only: true,
        width: 256,
        height: 256,
        spp: 16,
        ref_spp: 256,
        seed: 0,
        time: 0.0,
        params: vec!["directions=32".into()],
        out_dir: a.output,
        cache: Cache { dir: Cache::default_dir() },
        sweep: true,
        exposure: 0.0,
        frames: 1,
        overrides: Default::default(),
        time_reference: false,
        tev: None,
    };
    finish(&cfg, run_eval(&cfg, &glimpse_eval::registry(), |m| eprintln!("{m}"))?)
}

fn finish(cfg: &EvalConfig, r: EvalResults) -> Result<()> {
    println!("{:<16} {:<12} {:>10} {:>10} {:>10} {:>9} {:>9}", "technique", "reference", "prepare", "render", "total ms", "RMSE", "FLIP");
    for run in &r.runs {
        println!(
            "{:<16} {:<12} {:>10.1} {:>10.1} {:>10.1} {:>9.5} {:>9.5}",
            run.technique,
            run.reference,
            run.ms["prepare"],
            run.ms["render"],
            run.ms["total"],
            run.metrics.get("rmse").copied().unwrap_or(f64::NAN),
            run.metrics.get("flip").copied().unwrap_or(f64::NAN)
        );
    }
    // Over several frames the columns are the median frame; a first frame far longer holds
    // one-time work (a precomputation, a static structure) that the median leaves out.
    for run in &r.runs {
        if let Some(&first) = run.ms.get("first_frame").filter(|&&f| f > 2.0 * run.ms["total"] + 1.0) {
            println!(
                "{}: the first of {} frames took {first:.1} ms (one-time work; the columns are the median frame)",
                run.technique, run.frames
            );
        }
    }
    println!("report: {}", cfg.out_dir.join("report.html").display());
    Ok(())
}

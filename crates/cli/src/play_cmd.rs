//! `glimpse play SCENE -t ID --frames N [-o DIR]`.

use crate::args::{parse_size, parse_spp, parse_time};
use anyhow::Result;
use clap::Args;
use glimpse_eval::play::{PlayConfig, mean_timings, run_play};
use std::path::PathBuf;

#[derive(Args)]
pub struct PlayArgs {
    pub scene: String,
    #[arg(short, long)]
    pub technique: String,
    #[arg(long, default_value_t = 16)]
    pub frames: u32,
    /// Frames per second of scene time.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    #[arg(long, default_value_t = 0.0, value_parser = parse_time)]
    pub start: f32,
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    pub size: (u32, u32),
    #[arg(long, default_value_t = 4, value_parser = parse_spp)]
    pub spp: u32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// Write the frames as DIR/frame-NNNN.png.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Stream every frame to a running tev (HOST:PORT, default 127.0.0.1:14158).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = glimpse_core::tev::DEFAULT_ADDRESS)]
    pub tev: Option<String>,
    /// Where the technique runs: cpu, or gpu (ao-exact, lights-exact, env-exact, ao-roma,
    /// lights-voxarray; built with `--features gpu`).
    #[arg(long, value_enum, default_value_t = crate::device::Device::Cpu)]
    pub device: crate::device::Device,
    #[command(flatten)]
    pub overrides: crate::scene_args::SceneArgs,
}

pub fn run(a: PlayArgs) -> Result<()> {
    if a.frames == 0 || a.frames > 100_000 {
        anyhow::bail!("--frames {}: must be between 1 and 100000", a.frames);
    }
    if !(a.fps.is_finite() && a.fps > 0.0) {
        anyhow::bail!("--fps {}: must be positive", a.fps);
    }
    let registry = crate::device::registry(a.device, &[&a.technique])?;
    let cfg = PlayConfig {
        scene_spec: a.scene,
        technique: a.technique,
        frames: a.frames,
        fps: a.fps,
        start_time: a.start,
        width: a.size.0,
        height: a.size.1,
        spp: a.spp,
        seed: a.seed,
        params: a.set,
        out_dir: a.output,
        exposure: a.exposure,
        overrides: a.overrides.overrides(),
        tev: a.tev,
    };
    let fmt = |ms: &std::collections::BTreeMap<String, f64>| ms.iter().map(|(k, v)| format!("{k} {v:.1}")).collect::<Vec<_>>().join(", ");
    let frames = run_play(&cfg, &registry, |f| println!("frame {:>4} t={:.3}s: {} ms", f.frame, f.time, fmt(&f.ms)))?;
    println!("mean over {} frames: {} ms", frames.len(), fmt(&mean_timings(&frames)));
    Ok(())
}

//! `glimpse bench rays SCENE --kind ao|shadow|gi`.

use crate::args::parse_size;
use anyhow::Result;
use clap::{Args, Subcommand};
use glimpse_eval::bench::{BenchConfig, RayKind, format_table, run_bench};

#[derive(Subcommand)]
pub enum BenchCommand {
    /// The same rays through every visibility backend: build time, Mrays/s, agreement.
    Rays(RaysArgs),
    /// The exact tracer on the GPU beside the CPU one: adapter, kernel times, rays/s, agreement
    /// (needs `--features gpu`).
    Gpu(crate::gpu_cmd::GpuArgs),
}

#[derive(Args)]
pub struct RaysArgs {
    pub scene: String,
    /// ao, shadow or gi.
    #[arg(long, default_value = "ao")]
    pub kind: String,
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// GBuffer size the rays start from.
    #[arg(long, default_value = "256x256", value_parser = parse_size)]
    pub size: (u32, u32),
    /// AO ray length (default: infinite, as ROMA's AO).
    #[arg(long, default_value_t = f32::INFINITY)]
    pub radius: f32,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Only these backends besides `exact` (comma-separated; `--backends` is the same). The GPU
    /// rows gpu-exact, gpu-roma, gpu-voxarray run only when named (built with `--features gpu`).
    #[arg(long, alias = "backends", value_delimiter = ',')]
    pub only: Vec<String>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub overrides: crate::scene_args::SceneArgs,
}

pub fn run(cmd: BenchCommand) -> Result<()> {
    let a = match cmd {
        BenchCommand::Rays(a) => a,
        BenchCommand::Gpu(a) => return crate::gpu_cmd::run(a),
    };
    if a.rays == 0 || a.rays > 100_000_000 {
        anyhow::bail!("--rays {}: must be between 1 and 100000000", a.rays);
    }
    if a.radius.is_nan() || a.radius <= 0.0 {
        anyhow::bail!("--radius {}: must be positive", a.radius);
    }
    // A typo in --only would otherwise benchmark `exact` alone and exit 0.
    let mut known: Vec<&str> = glimpse_eval::bench::backends().iter().map(|b| b.name).collect();
    known.extend(glimpse_eval::bench::GPU_BACKENDS);
    for name in &a.only {
        if cfg!(not(feature = "gpu")) && glimpse_eval::bench::GPU_BACKENDS.contains(&name.as_str()) {
            return Err(glimpse_eval::bench::gpu_backend_unavailable(name));
        }
        if !known.contains(&name.as_str()) {
            anyhow::bail!(
                "--only {name}: unknown backend{}; known: {}",
                crate::args::did_you_mean(name, known.iter().copied()),
                known.join(", ")
            );
        }
    }
    crate::args::check_scene(&a.scene)?;
    let cfg = BenchConfig {
        scene_spec: a.scene,
        kind: RayKind::parse(&a.kind)?,
        rays: a.rays,
        width: a.size.0,
        height: a.size.1,
        radius: a.radius,
        seed: a.seed,
        only: a.only,
        overrides: a.overrides.overrides(),
    };
    let r = run_bench(&cfg)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{}", format_table(&r));
    }
    Ok(())
}

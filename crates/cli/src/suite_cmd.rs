//! `glimpse suite`: every approximate technique on every suite scene at its defaults, beside its
//! reference (docs/suite.md).

use anyhow::Result;
use clap::Args;
use glimpse_eval::cache::Cache;
use glimpse_eval::suite::{SuiteConfig, markdown_table, run_suite};
use std::path::PathBuf;

#[derive(Args)]
pub struct SuiteArgs {
    /// Output directory (report.html, results.json, one folder of images per scene).
    #[arg(short, long, default_value = "suite")]
    pub output: PathBuf,
    /// Small images and fewer samples (96×64, 4 spp, references 64 spp): minutes on two cores.
    #[arg(long)]
    pub quick: bool,
    /// The folder of suite scenes.
    #[arg(long, default_value = "scenes/suite")]
    pub scenes: PathBuf,
    /// Do not read or write the reference cache.
    #[arg(long)]
    pub no_cache: bool,
    /// Only these suite scenes (file stems), in this order.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
}

pub fn run(a: SuiteArgs) -> Result<()> {
    let cfg = SuiteConfig {
        scenes_dir: a.scenes,
        out_dir: a.output,
        quick: a.quick,
        cache: if a.no_cache { Cache::disabled() } else { Cache { dir: Cache::default_dir() } },
        only: a.only,
    };
    let r = run_suite(&cfg, &glimpse_eval::registry(), |m| eprintln!("{m}"))?;
    print!("{}", markdown_table(&r));
    let red = r.cells.iter().filter(|c| !c.pass).count();
    println!("{} cells, {red} red; {:.0} s; report: {}", r.cells.len(), r.seconds, cfg.out_dir.join("report.html").display());
    Ok(())
}

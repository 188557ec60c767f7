//! The `glimpse` command line (the contract is in docs/cli.md): render, scenes, techniques.
//! Every failure prints one `error:` line naming the file or argument and exits non-zero.

mod aov;
mod args;
mod bench_cmd;
mod device;
mod eval_cmd;
mod exit;
mod gpu_cmd;
mod play_cmd;
mod render_cmd;
mod scene_args;
mod suite_cmd;
#[cfg(feature = "viewer")]
mod view;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "glimpse", version, about = "Fast approximate visibility and global illumination, measured against exact ray tracing")]
struct Cli {
    /// Worker threads for every parallel loop (rayon's global pool); 0 uses every core.
    #[arg(long, global = true, default_value_t = 0)]
    threads: usize,
    #[command(subcommand)]
    command: Command,
    /// Memory budget, e.g. 8G or 512M: work estimated to need more is refused up front (default:
    /// the machine's available memory).
    #[arg(long, global = true, value_parser = glimpse_core::memory_budget::parse_bytes)]
    max_memory: Option<u64>,
}

#[derive(Subcommand)]
enum Command {
    /// The five papers on one small built-in scene (cornell-lit): every approximate technique
    /// beside its reference, as a report grouped by paper.
    Demo(eval_cmd::DemoArgs),
    /// Render one image of a scene with one technique.
    Render(render_cmd::RenderArgs),
    /// Techniques beside their references: timings, metrics, report.html and results.json.
    Eval(eval_cmd::EvalArgs),
    /// Benchmarks.
    #[command(subcommand)]
    Bench(bench_cmd::BenchCommand),
    /// Render an animation frame by frame with per-frame stage timings.
    Play(play_cmd::PlayArgs),
    /// Open an interactive window on a scene: fly the camera, switch techniques, compare with the
    /// reference (built with `--features viewer`).
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
    /// Every approximate technique on every suite scene (scenes/suite) at its defaults: one report.
    Suite(suite_cmd::SuiteArgs),
    /// List the built-in scenes.
    Scenes,
    /// List the techniques and the reference each is compared with.
    Techniques,
}

fn main() -> ExitCode {
    exit::install_panic_hook();
    exit::install_interrupt_handler();
    let cli = Cli::parse();
    exit::panic_if_asked();
    glimpse_core::memory_budget::set_budget(cli.max_memory.unwrap_or(0));
    let frame = match &cli.command {
        // A render without --size takes its size from the scene file; render_cmd checks it there.
        Command::Render(a) => a.size,
        Command::Eval(a) => Some(a.size),
        Command::Play(a) => Some(a.size),
        _ => None,
    };
    if let Some(Err(e)) = frame.map(|(w, h)| glimpse_core::memory_budget::check_frame(w, h)) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let result = scene_args::set_threads(cli.threads).and_then(|()| match cli.command {
        Command::Demo(a) => eval_cmd::demo(a),
        Command::Render(a) => render_cmd::run(a),
        Command::Eval(a) => eval_cmd::run(a),
        Command::Bench(c) => bench_cmd::run(c),
        Command::Play(a) => play_cmd::run(a),
        #[cfg(feature = "viewer")]
        Command::View(a) => view::run(a),
        Command::Suite(a) => suite_cmd::run(a),
        Command::Scenes => {
            for name in glimpse_scene::builtin::NAMES {
                println!("{name:<18} {}", glimpse_scene::builtin::describe(name));
            }
            Ok(())
        }
        Command::Techniques => {
            println!("{:<18} {:<26} {:<14} description", "id", "family", "reference");
            for t in glimpse_eval::registry().all() {
                println!("{:<18} {:<26} {:<14} {}", t.id, t.family, t.reference.unwrap_or("(exact)"), t.description);
            }
            Ok(())
        }
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, outermost first.
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            // Guarantee the one-line promise even for multi-line messages from dependencies.
            let line = msg.join(": ").lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join("; ");
            eprintln!("error: {line}");
            ExitCode::FAILURE
        }
    }
}

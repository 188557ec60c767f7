//! The `glimpse` command line (the contract is in docs/cli.md): render, scenes, techniques.
//! Every failure prints one `error:` line naming the file or argument and exits non-zero.

mod args;
mod render_cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "glimpse", version, about = "Fast approximate visibility and global illumination, measured against exact ray tracing")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one image of a scene with one technique.
    Render(render_cmd::RenderArgs),
    /// List the built-in scenes.
    Scenes,
    /// List the techniques and the reference each is compared with.
    Techniques,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render_cmd::run(a),
        Command::Scenes => {
            for name in glimpse_scene::builtin::NAMES {
                println!("{name:<18} {}", glimpse_scene::builtin::describe(name));
            }
            Ok(())
        }
        Command::Techniques => {
            println!("{:<18} {:<26} {:<14} description", "id", "family", "reference");
            for t in registry().all() {
                println!("{:<18} {:<26} {:<14} {}", t.id, t.family, t.reference.unwrap_or("(exact)"), t.description);
            }
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, outermost first.
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", msg.join(": "));
            ExitCode::FAILURE
        }
    }
}

/// Every technique glimpse knows, from every technique crate.
pub fn registry() -> glimpse_render::Registry {
    glimpse_render::Registry::new(glimpse_render::techniques())
}

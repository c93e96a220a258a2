//! The `softsense` command line: parses arguments and calls the library, nothing more.
//! Each subcommand lives in its own file under `src/cli/`.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cli;

/// softsense: make a soft robot its own force sensor from RGB-D frames.
///
/// Results go to stdout (as JSON with --json); human messages and progress go to stderr.
#[derive(Parser)]
#[command(name = "softsense", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // Subcommands are added here, one line each, implemented in src/cli/<name>.rs.
    /// Finite-element model: static solve, compliance.
    Fem(cli::fem::FemArgs),
    /// Synthetic RGB-D scenes from the FE model (the direct model).
    Scene(cli::scene::SceneArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result: anyhow_like::Result = match cli.command {
        Command::Fem(a) => cli::fem::run(a),
        Command::Scene(a) => cli::scene::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("softsense: error: {e}");
            ExitCode::FAILURE
        }
    }
}

mod anyhow_like {
    /// The CLI's result: any error with a message.
    pub type Result = std::result::Result<(), Box<dyn std::error::Error>>;
}

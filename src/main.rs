//! The `softsense` command line: parses arguments and calls the library, nothing more.
//! Each subcommand lives in its own file under `src/cli/`.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cli;

/// softsense: make a soft robot its own force sensor from RGB-D frames.
#[derive(Parser)]
#[command(
    name = "softsense",
    version,
    about,
    long_about = "softsense: make a soft robot its own force sensor from RGB-D frames.\n\n\
Reads and writes point clouds (PCD ascii/binary/binary_compressed, PLY, XYZ) and turns \
RGB-D image pairs into organized clouds; filters them (pass-through, voxel grid, outlier \
removal, normals), segments them (colour region growing, Euclidean clusters) and finds \
contacts, each stage with PCL's or Open3D's exact semantics; solves the robot's \
finite-element model (static solve, compliance) and renders synthetic RGB-D scenes with \
known loads.\n\n\
Results go to stdout (as JSON with --json); human messages go to stderr. Exit codes: \
0 success, 1 a file or its content was refused (the message names the file), 2 bad \
command-line usage.",
    after_help = "Examples:\n  \
softsense sense clouds/scenes/tip_weight\n  \
softsense info clouds/demo_scene.pcd\n  \
softsense convert clouds/demo_scene.pcd /tmp/demo.ply\n  \
softsense convert --depth tests/fixtures/rgbd/depth.png --color tests/fixtures/rgbd/color.png \\\n      \
--intrinsics tests/fixtures/rgbd/intrinsics.json /tmp/frame.pcd\n\n\
Run `softsense help <command>` for a command's options and examples.",
    propagate_version = true
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    // Each variant's about/long_about lives on its Args struct, beside the options.
    Info(cli::info::InfoArgs),
    Convert(cli::convert::ConvertArgs),
    Import(cli::import::ImportArgs),
    Fem(cli::fem::FemArgs),
    Model(cli::model::ModelArgs),
    Colour(cli::colour::ColourArgs),
    Pose(cli::pose::PoseArgs),
    Filter(cli::filter::FilterArgs),
    Scene(cli::scene::SceneArgs),
    Segment(cli::segment::SegmentArgs),
    Cluster(cli::cluster::ClusterArgs),
    Contacts(cli::contacts::ContactsArgs),
    Explain(cli::explain::ExplainArgs),
    Hidden(cli::explain::HiddenArgs),
    Sense(cli::sense::SenseArgs),
    Markers(cli::markers::MarkersArgs),
    Control(cli::control::ControlArgs),
    Catheter(cli::catheter::CatheterArgs),
    Calibrate(cli::calibrate::CalibrateArgs),
    Score(cli::score::ScoreArgs),
    Batch(cli::batch::BatchArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The documents' tests check every documented command against this parser without
    // running it (tests/integration/doc_commands.rs).
    if std::env::var_os("SOFTSENSE_ARGS_ONLY").is_some() {
        return ExitCode::SUCCESS;
    }
    // Without it, Ctrl-C or a kill during a write leaves `.NAME.tmpPID` behind.
    if let Err(e) = softsense::io::atomic::install_signal_cleanup() {
        eprintln!("softsense: warning: cannot catch SIGINT/SIGTERM: {e}");
    }
    let result = match cli.command {
        Command::Info(args) => cli::info::run(&args),
        Command::Convert(args) => cli::convert::run(&args),
        Command::Import(args) => cli::import::run(&args),
        // A usage error inside `fem` or `scene` keeps its own exit code (2).
        Command::Fem(args) => cli::fem::run(args).map_err(usage_or_other),
        Command::Model(args) => cli::model::run(&args),
        Command::Colour(args) => cli::colour::run(&args),
        Command::Pose(args) => cli::pose::run(&args),
        Command::Filter(args) => cli::filter::run(&args),
        Command::Scene(args) => cli::scene::run(args).map_err(usage_or_other),
        Command::Segment(args) => cli::segment::run(&args),
        Command::Cluster(args) => cli::cluster::run(&args),
        Command::Contacts(args) => cli::contacts::run(&args),
        Command::Explain(args) => cli::explain::run(&args),
        Command::Hidden(args) => cli::explain::run_hidden(&args),
        Command::Sense(args) => cli::sense::run(&args),
        Command::Markers(args) => cli::markers::run(&args),
        Command::Control(args) => cli::control::run_control(&args),
        Command::Catheter(args) => cli::catheter::run_catheter(&args),
        Command::Calibrate(args) => cli::calibrate::run(&args),
        Command::Score(args) => cli::score::run(&args),
        Command::Batch(args) => cli::batch::run_batch(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("softsense: error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// A boxed error as the CLI error it is, if it is one.
fn usage_or_other(e: Box<dyn std::error::Error>) -> cli::CliError {
    match e.downcast::<cli::CliError>() {
        Ok(e) => *e,
        Err(e) => cli::CliError::Other(e),
    }
}

//! `softsense scene`: synthetic RGB-D truth from a scene file (the direct model).

use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use softsense::scene::{generate, Scene};
use std::path::PathBuf;

/// Synthetic scenes: solve the FE model under known loads and render RGB-D frames.
#[derive(Args, Debug)]
pub struct SceneArgs {
    #[command(subcommand)]
    command: SceneCommand,
}

#[derive(Subcommand, Debug)]
enum SceneCommand {
    /// Render every frame of SCENE into OUT_DIR (depth/colour PNGs, intrinsics, pose, truth).
    Generate {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output folder (created).
        out_dir: PathBuf,
    },
}

/// Runs the subcommand.
pub fn run(args: SceneArgs) -> Result<(), Box<dyn std::error::Error>> {
    match args.command {
        SceneCommand::Generate { scene, out_dir } => {
            let scene = Scene::load(&scene)?;
            let bar = ProgressBar::new(scene.spec.frames.len() as u64);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let truth = generate(&scene, &out_dir, |done, _| bar.set_position(done as u64))?;
            bar.finish_and_clear();
            for f in &truth.frames {
                eprintln!(
                    "frame {}: {} loads, {} Newton iterations, robot/probe/table pixels {:?}",
                    f.frame,
                    f.loads.len(),
                    f.newton_iterations,
                    f.pixels
                );
            }
            eprintln!(
                "wrote {} frames to {}",
                truth.frames.len(),
                out_dir.display()
            );
            Ok(())
        }
    }
}

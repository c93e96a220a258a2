//! `softsense explain`: the model-discrepancy workflow; `softsense hidden`: hidden-effect
//! datasets to test it on.

use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::discrepancy::data::load_frames;
use softsense::discrepancy::generate::{
    camera_for, generate_dataset, layout, DatasetSpec, EFFECT_TYPES,
};
use softsense::discrepancy::report::{describe, write_report};
use softsense::discrepancy::truth::parse_truth;
use softsense::discrepancy::{explain, DiscrepancyParams, Explanation, Outcome};
use softsense::fem::model::Model;
use softsense::render::discrepancy::{recorded_image_size, write_discrepancy_pictures};
use softsense::scene::truth::TruthRanges;
use std::path::{Path, PathBuf};

/// Find where the model and the recorded frames disagree, name the missing effect, add it
/// to the model and show the held-out residual before and after.
#[derive(Args, Debug)]
#[command(
    after_help = "Example:\n  softsense hidden /tmp/ds --model meshes/models/robot.toml --effects young --seed 3\n  \
softsense explain meshes/models/robot.toml /tmp/ds/frames --out /tmp/ds/report"
)]
pub struct ExplainArgs {
    /// Nominal model file (TOML).
    model: PathBuf,
    /// Recording folder (docs/recording-format.md) with each frame's recorded inputs
    /// (inputs.json, or actuators.json) and optionally the sensor's noise model
    /// (sensor.json).
    frames_dir: PathBuf,
    /// Robot colour (sRGB) for the colour model.
    #[arg(long, value_name = "R,G,B", value_parser = super::parse_rgb, default_value = "40,200,60")]
    robot_color: [u8; 3],
    /// Fraction of frames held out for confirmation.
    #[arg(long, default_value_t = 0.25)]
    holdout: f64,
    /// Report folder (index.md, explanation.json, effects.json, model_updated.toml).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the explanation as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// The files of `explain --out`'s report.
const REPORT_FILES: [&str; 6] = [
    "index.md",
    "explanation.json",
    "effects.json",
    "model_updated.toml",
    "residual_before_after.png",
    "criterion.png",
];

/// Runs `explain`.
pub fn run(args: &ExplainArgs) -> CliResult {
    if let Some(out) = &args.out {
        let mut inputs = super::recording_files(&args.frames_dir);
        inputs.push(args.model.clone());
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        super::check_files_dir(out, &REPORT_FILES, &inputs)?;
    }
    let model = Model::load(&args.model, None).map_err(softsense::Error::from)?;
    let color = softsense::segment::robot_color::RobotColorModel::with_reference(args.robot_color);
    let rec = load_frames(&args.frames_dir, &color).map_err(softsense::Error::from)?;
    if !args.frames_dir.join("sensor.json").exists() {
        eprintln!(
            "note: {} has no sensor.json: the default noise model (a D415-like camera) sets \
             the noise floor",
            args.frames_dir.display()
        );
    }
    let params = DiscrepancyParams {
        holdout: args.holdout,
        ..Default::default()
    };
    let x = explain(&model, &rec, &params).map_err(softsense::Error::from)?;
    let held_out =
        !softsense::discrepancy::split_frames(rec.frames.len(), args.holdout)[1].is_empty();
    print_outcome(&x, held_out);
    if let Some(out) = &args.out {
        let text = report_model_text(&args.model)?;
        let surface = model.problem.mesh.surface();
        // Pictures first: the report links those that were written.
        if let Err(e) = write_discrepancy_pictures(
            out,
            &x,
            &model.problem.mesh.nodes_in_rest,
            &surface.triangles,
            &rec.camera,
            recorded_image_size(&rec.camera),
        ) {
            eprintln!("pictures not written: {e}");
        }
        write_report(out, &x, &text, &model.units).map_err(softsense::Error::from)?;
        eprintln!("report: {}", out.join("index.md").display());
    }
    if args.json {
        let v = serde_json::to_value(&x).map_err(|e| CliError::Result(e.to_string()))?;
        print_json(&v)?;
    }
    Ok(())
}

/// The answer and the held-out RMS before and after (over all frames when none is held
/// out), on stderr.
fn print_outcome(x: &Explanation, held_out: bool) {
    match &x.outcome {
        Outcome::NoMissingEffect => eprintln!("no missing effect: residual at the noise floor"),
        Outcome::Explained { effects } => {
            for e in effects {
                eprintln!("explained: {}", describe(e));
            }
        }
        Outcome::UnexplainedResidual { regions, .. } => {
            eprintln!("unexplained residual remains in: {}", regions.join(", "))
        }
    }
    if let (Some(b), Some(a)) = (x.before.last(), x.after.last()) {
        eprintln!(
            "{} RMS {:.3} mm -> {:.3} mm (noise floor {:.3} mm)",
            if held_out {
                "held-out"
            } else {
                "no frame held out: training"
            },
            b.rms * 1e3,
            a.rms * 1e3,
            b.noise_rms * 1e3
        );
    }
}

/// The model file's text for the report folder: the updated model lives there, so a
/// relative mesh path is made absolute.
fn report_model_text(model: &Path) -> Result<String, CliError> {
    let text = std::fs::read_to_string(model)
        .map_err(|e| CliError::Result(format!("{}: {e}", model.display())))?;
    let mut v: toml::Value = toml::from_str(&text).map_err(|e| CliError::Result(e.to_string()))?;
    if let Some(mesh) = v.get_mut("mesh").and_then(|m| m.as_table_mut()) {
        if let Some(p) = mesh.get("path").and_then(|p| p.as_str()) {
            let pb = PathBuf::from(p);
            if pb.is_relative() && !p.contains("${") {
                let base = model.parent().unwrap_or(Path::new("."));
                let abs = std::fs::canonicalize(base.join(&pb)).unwrap_or(base.join(&pb));
                mesh.insert(
                    "path".into(),
                    toml::Value::String(abs.display().to_string()),
                );
            }
        }
    }
    toml::to_string(&v).map_err(|e| CliError::Result(e.to_string()))
}

/// Generate a hidden-effect dataset: OUT_DIR/frames (what `explain` reads) and
/// OUT_DIR/truth_hidden.json (the truth, never read by `explain`).
#[derive(Args, Debug)]
#[command(after_help = HIDDEN_HELP)]
pub struct HiddenArgs {
    /// Output folder: new or empty (written beside it and renamed into place when done,
    /// so a failed run leaves nothing).
    out_dir: PathBuf,
    #[arg(long, help = super::FORCE_HELP)]
    force: bool,
    /// Nominal model file (e.g. meshes/models/robot.toml in this repository).
    #[arg(long)]
    model: PathBuf,
    /// Comma-separated effect types to hide (none: a null dataset).
    #[arg(long, value_delimiter = ',', value_parser = clap::builder::PossibleValuesParser::new(EFFECT_TYPES))]
    effects: Vec<String>,
    /// Magnitude in [0, 1] (0: barely above noise, 1: large).
    #[arg(long, default_value_t = 0.5)]
    magnitude: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Number of frames.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// Render the frames from a body that is not the model (the hidden effects go on top
    /// of it): a preset (modulus, neo-hookean), [truth] keys inline
    /// ('young_factor = 1.1, formulation = "neo-hookean"') or a TOML file with them.
    /// Default: the model itself.
    #[arg(long, value_name = "TRUTH", value_parser = truth_arg)]
    truth: Option<TruthRanges>,
}

const HIDDEN_HELP: &str = "\
--truth: the keys of a scene file's [truth] table (docs/accuracy.md, truth that is not the model):
  young_factor    the body's Young's modulus over the model's (default 1), in (0, 10]
  poisson         the body's Poisson ratio (default the model's), in (-1, 0.5)
  formulation     \"corotational\" or \"neo-hookean\" (default the model's)
  mesh            another volume mesh of the same robot (relative to the TOML file)
  base_stiffness  a compliant base, total N/m along each axis (default clamped)
A number may be a range [lo, hi], drawn from --seed. Presets:
  modulus         young_factor = [0.85, 1.15]
  neo-hookean     formulation = \"neo-hookean\"
The body drawn is written to truth_hidden.json, which explain never reads.

Examples:
  softsense hidden /tmp/nh --model meshes/models/robot.toml --truth neo-hookean --effects gravity
  softsense hidden /tmp/m --model meshes/models/robot.toml --truth 'young_factor = 1.1'
  python3 tools/mesh/gen_meshes.py /tmp/fine --robot-h 4.4 --only robot
  softsense hidden /tmp/f --model meshes/models/robot.toml --truth 'mesh = \"/tmp/fine/robot.vtu\"'";

/// `--truth`'s parser: [`parse_truth`], its error as clap shows it.
fn truth_arg(s: &str) -> Result<TruthRanges, String> {
    parse_truth(s).map_err(|e| e.to_string())
}

/// Runs `hidden`.
pub fn run_hidden(args: &HiddenArgs) -> CliResult {
    // The default camera frames the four-legged robot; another body gets one aimed at it.
    let model = Model::load(&args.model, None).map_err(softsense::Error::from)?;
    let camera = camera_for(&model).map_err(softsense::Error::from)?;
    let spec = DatasetSpec {
        camera,
        model: args.model.clone(),
        frames: args.frames,
        seed: args.seed,
        effects: args.effects.clone(),
        magnitude: args.magnitude,
        truth: args.truth.clone(),
        ..Default::default()
    };
    let staged = super::staged_output_dir(&args.out_dir, &[&args.model], args.force)?;
    let (frames, truth) = layout(staged.path());
    generate_dataset(&spec, &frames, &truth).map_err(softsense::Error::from)?;
    staged.commit().map_err(super::output_error)?;
    let (frames, truth) = layout(&args.out_dir);
    eprintln!(
        "wrote {} frames to {}, truth to {}",
        args.frames,
        frames.display(),
        truth.display()
    );
    Ok(())
}

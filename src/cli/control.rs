//! `softsense control`: position control of a simulated soft robot on its FE model
//! (thesis chapter 3).

use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::control::output::write_run;
use softsense::control::run::{run, RunStatus};
use softsense::control::scenario::Scenario;
use softsense::render::control::write_pictures;
use std::path::PathBuf;

/// Closed-loop position control on the FE model, against a simulated robot.
#[derive(Args, Debug)]
#[command(
    long_about = "Position control of a soft robot with its FE model as the predictor of the \
Jacobian J = W_ea W_aa^-1 (thesis chapter 3), against a simulated robot.\n\n\
The scenario file (TOML) names the controller's model and law (open: the simulation-based \
predictor, 3.4; closed1: control 1, 3.19; closed2: control 2, 3.28-3.29; switched: control 2 \
with the open-loop fallback and the progressive switch 3.43 while features are lost), the \
plant's differences from the model (Young's modulus factor, an unmodelled hanging weight, \
actuator offset and gain), the sensor (noise, latency, lost steps) and the task (position, \
circle, follow). Lengths in the file are in mm. docs/control.md describes every field.\n\n\
Prints the summary (average and settled error, Theorem 2's mismatch gamma and gain bound); \
--out writes trajectory.csv, run.json and pictures.",
    after_help = "Examples:\n  \
softsense control scenarios/control/positioning.toml\n  \
softsense control scenarios/control/circle_control2.toml --out /tmp/circle\n  \
softsense control scenarios/control/switched.toml --json | jq .summary"
)]
pub struct ControlArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    /// Write trajectory.csv, run.json and pictures into this folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run this many steps instead of the scenario's.
    #[arg(long)]
    steps: Option<usize>,
    /// Print the run (summary and every step) as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `softsense control`.
pub fn run_control(args: &ControlArgs) -> CliResult {
    let mut scenario =
        Scenario::load(&args.scenario).map_err(|e| CliError::Result(e.to_string()))?;
    if let Some(n) = args.steps {
        scenario.steps = n;
        scenario
            .validate()
            .map_err(|e| CliError::Usage(format!("--steps: {e}")))?;
    }
    let bar = super::steps_bar(scenario.steps, &scenario.name);
    if let Some(out) = &args.out {
        let written = ["trajectory.csv", "run.json"];
        super::check_files_dir(out, &written, &[&args.scenario])?;
    }
    let result = run(&scenario, &mut |k, _| bar.set_position(k as u64));
    bar.finish_and_clear();
    let r = result.map_err(|e| CliError::Result(format!("{}: {e}", args.scenario.display())))?;
    if let Some(out) = &args.out {
        write_run(&r, out).map_err(|e| CliError::Result(e.to_string()))?;
        write_pictures(&r, out).map_err(|e| CliError::Result(e.to_string()))?;
    }
    if args.json {
        let value = serde_json::to_value(&r)
            .map_err(|e| CliError::Result(format!("cannot write JSON: {e}")))?;
        return print_json(&value);
    }
    let s = &r.summary;
    outln!("{} ({:?}, {} steps)", r.name, r.law, r.steps.len())?;
    match &r.status {
        RunStatus::Completed => {}
        RunStatus::Diverged { step } => {
            outln!("  DIVERGED at step {step}: the error passed 100 mm")?
        }
        RunStatus::Failed { step, reason } => outln!("  FAILED at step {step}: {reason}")?,
    }
    outln!(
        "  average error {:.3} mm, settled (last quarter) {:.3} mm, max {:.3} mm",
        s.average_error_mm,
        s.settled_error_mm,
        s.settled_max_mm
    )?;
    if let (Some(seen), Some(lost)) = (s.seen_error_mm, s.lost_error_mm) {
        outln!("  error while seen {seen:.3} mm, while lost {lost:.3} mm")?;
    }
    outln!(
        "  model-robot gap {:.3} mm; largest input step {:.4}; bounded steps {}",
        s.model_gap_mm,
        s.max_input_jump,
        s.bounded_steps
    )?;
    match s.gain_bound {
        Some(b) => outln!(
            "  Theorem 2: gamma {:.3}, gains below {:.3} are robustly stable",
            s.gamma,
            b
        )?,
        None => outln!(
            "  Theorem 2: gamma {:.3} >= 1, no gain is guaranteed",
            s.gamma
        )?,
    }
    if let Some(out) = &args.out {
        outln!("  wrote {}", out.display())?;
    }
    match r.status {
        RunStatus::Completed => Ok(()),
        _ => Err(CliError::Result(format!(
            "{}: the run did not complete",
            r.name
        ))),
    }
}

//! `softsense catheter`: a cable-driven catheter controlled through contacts on its FE
//! model, against a simulated robot (thesis chapter 5).

use super::{print_json, CliError, CliResult};
use clap::{Args, ValueEnum};
use softsense::catheter::output::write_run;
use softsense::catheter::run::{run, RunStatus};
use softsense::catheter::scenario::{Scenario, Scheme};
use softsense::catheter::statics::static_insertions;
use softsense::render::catheter::write_pictures;
use std::path::PathBuf;

/// Decoupled control of a catheter inserted through a tube it touches.
#[derive(Args, Debug)]
#[command(
    long_about = "Decoupled control of a cable-driven catheter through contacts (thesis chapter 5), \
simulated: insertion is the physician's (a constant speed, then a hold); the FE model's tip is \
driven to the tube's centreline by the QPCC (5.5-5.8), which also gives the contact forces along \
the whole catheter; the robot's cables are moved by the PD law u = -J+ [K_P e + K_D de] (5.22) on \
the plane normal to the path (Algorithm 5.1), with J = W_ea W_aa^-1 of the model, contacts \
included, and the tip measured by a noisy 20 Hz tracker calibrated on seven feature points \
(5.5.2). The robot is a second beam model (finer, or with another modulus or cable offset) with \
its contacts solved exactly.\n\n\
The scenario file (TOML) gives the catheter, the tube's pieces, the insertion, the controller, \
the robot and the tracker; lengths in mm. docs/catheter.md describes every field.\n\n\
Prints the tracking errors the thesis reports (mean on straight parts, maximum, final) and the \
contact forces; --out writes steps.csv, run.json and pictures (the path with the catheter and \
its contact forces, and the errors over time).\n\n\
--statics N instead pushes model and robot passively (cables slack) to N evenly spaced \
insertions up to insertion.end_mm and prints how far the model's tip is from the robot's at \
each (thesis 5.5.6: 3.35 mm on average over ten positions in a 3-D tube).\n\n\
--scheme coupled runs the baseline of 5.3.1 instead: insertion and the cables driven together \
to a desired point moving along the path, with the Jacobian of a model that ignores the tube. \
With controller.rotation_check_every > 0 it prints the smallest eigenvalue of sym(J_true J^+) \
(negative: the Jacobian is rotated, 5.5.7.1); the run stops as diverged once the tip is \
farther from its desired point than the tube's radius.",
    after_help = "Examples:\n  \
softsense catheter scenarios/catheter/tracking_0.6.toml\n  \
softsense catheter scenarios/catheter/positioning_60.toml --out /tmp/pos60\n  \
softsense catheter scenarios/catheter/tracking_2.4.toml --json | jq .summary\n  \
softsense catheter scenarios/catheter/insertions_3d.toml --statics 10\n  \
softsense catheter scenarios/catheter/jacobian_rotation.toml --scheme coupled"
)]
pub struct CatheterArgs {
    /// Scenario file (TOML).
    scenario: PathBuf,
    /// Write steps.csv, run.json and pictures into this folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the run (summary and every step) as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Instead of the loop, compare model and robot at N static passive insertions.
    #[arg(long, value_name = "N", conflicts_with = "out")]
    statics: Option<usize>,
    /// The control scheme, instead of the scenario's `controller.scheme`.
    #[arg(long, value_enum)]
    scheme: Option<SchemeArg>,
}

/// `--scheme`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum SchemeArg {
    /// Insertion left to the physician, bending on the contact-including J (5.3.2).
    Decoupled,
    /// The baseline: insertion and bending together, J of a model without the tube.
    Coupled,
}

/// Runs `softsense catheter`.
pub fn run_catheter(args: &CatheterArgs) -> CliResult {
    let mut scenario =
        Scenario::load(&args.scenario).map_err(|e| CliError::Result(e.to_string()))?;
    if let Some(scheme) = args.scheme {
        scenario.controller.scheme = match scheme {
            SchemeArg::Decoupled => Scheme::Decoupled,
            SchemeArg::Coupled => Scheme::Coupled,
        };
        scenario
            .validate()
            .map_err(|e| CliError::Result(e.to_string()))?;
    }
    if let Some(count) = args.statics {
        return run_statics(&scenario, count, args);
    }
    if let Some(out) = &args.out {
        let written = ["steps.csv", "run.json", "path.png", "errors.png"];
        super::check_files_dir(out, &written, &[&args.scenario])?;
    }
    let n = scenario.steps();
    let bar = super::steps_bar(n, &scenario.name);
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
    outln!(
        "{} ({} steps at {} Hz)",
        r.name,
        r.steps.len(),
        scenario.rate_hz
    )?;
    match &r.status {
        RunStatus::Failed { step, reason } => outln!("  FAILED at step {step}: {reason}")?,
        RunStatus::Diverged { step, error_mm } => outln!(
            "  DIVERGED at step {step}: the tip {error_mm:.1} mm from its desired point, past \
             the tube's radius"
        )?,
        RunStatus::Completed => {}
    }
    outln!(
        "  tracking error: mean on straight parts {:.3} mm, max {:.3} mm, mean {:.3} mm, last second {:.3} mm",
        s.straight_mean_mm, s.max_mm, s.mean_mm, s.final_mm
    )?;
    outln!(
        "  contacts on the robot: up to {} nodes, largest force {:.3} N",
        s.max_contacts,
        s.max_contact_n
    )?;
    outln!(
        "  tracker calibration on {} points: rms {:.3} mm, error {:.3} mm",
        s.calibration.points,
        1e3 * s.calibration.rms,
        1e3 * s.calibration.error
    )?;
    if let Some(margin) = s.min_rotation_margin {
        outln!(
            "  Jacobian rotation: smallest eigenvalue of sym(J_true J^+) {margin:.3}{}",
            if margin < 0.0 { " (rotated)" } else { "" }
        )?;
    }
    if s.unsettled_steps + s.qpcc_failures > 0 {
        outln!(
            "  warning: {} steps with a settle at its round limit, {} QPCC failures",
            s.unsettled_steps,
            s.qpcc_failures
        )?;
    }
    if let Some(out) = &args.out {
        outln!("  wrote {}", out.display())?;
    }
    match r.status {
        RunStatus::Completed => Ok(()),
        RunStatus::Failed { .. } | RunStatus::Diverged { .. } => Err(CliError::Result(format!(
            "{}: the run did not complete",
            r.name
        ))),
    }
}

/// `--statics N`: the model's tip against the robot's at N passive insertions.
fn run_statics(scenario: &Scenario, count: usize, args: &CatheterArgs) -> CliResult {
    let bar = super::steps_bar(count, &scenario.name);
    let result = static_insertions(scenario, count, &mut |k, _| bar.set_position(k as u64));
    bar.finish_and_clear();
    let r = result.map_err(|e| CliError::Result(format!("{}: {e}", args.scenario.display())))?;
    if args.json {
        let value = serde_json::to_value(&r)
            .map_err(|e| CliError::Result(format!("cannot write JSON: {e}")))?;
        return print_json(&value);
    }
    outln!(
        "{}: {} static insertions, cables slack",
        scenario.name,
        count
    )?;
    outln!("  insertion_mm  model_error_mm  model_contacts  robot_contacts  settled")?;
    for p in &r.positions {
        outln!(
            "  {:>12.1}  {:>14.3}  {:>14}  {:>14}  {}",
            1e3 * p.insertion,
            1e3 * p.error,
            p.model_contacts.len(),
            p.robot_contacts.len(),
            if p.settled { "yes" } else { "NO" }
        )?;
    }
    outln!(
        "  model tip error: mean {:.3} mm, max {:.3} mm",
        r.mean_mm,
        r.max_mm
    )?;
    if r.unsettled > 0 {
        outln!(
            "  warning: {} settles stopped at their round limit; positions marked NO are not \
             equilibria",
            r.unsettled
        )?;
    }
    Ok(())
}

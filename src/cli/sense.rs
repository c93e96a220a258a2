//! `softsense sense`: the whole chain per frame, from RGB-D frames to contact forces.

use super::{CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use softsense::fem::model::Model;
use softsense::sense::{compare, FrameReport, FrameStatus, Recording, SenseParams, Sensor};
use std::path::PathBuf;

/// Find where the robot is touched and how hard, frame by frame.
///
/// Reads a recording folder (depth_NNNN.png + color_NNNN.png, intrinsics.json, a camera
/// pose in calibration.json or camera_pose.json, optional actuators.json with the recorded
/// cable inputs), and for each frame: robot and touching objects by colour, contacts by
/// KD-tree search, each contact mapped onto the FE model, the surface features registered
/// along their normal lines, and the intensity QP solved with FE updates. Prints per frame
/// the forces (location in the robot frame, mapped node, force vector, magnitude and its
/// one-sigma uncertainty), the actuator forces, the residual and any warning. When the
/// folder has a truth.json (generated scenes), the errors against it are printed too;
/// truth.json is never used for the estimate.
///
/// Where no contact is seen (a weight hanging by a string), the model's force points
/// ([[force_points]] in the model file) are the candidate locations.
#[derive(Debug, Args)]
#[command(
    verbatim_doc_comment,
    after_help = "Examples:\n  \
softsense sense clouds/scenes/tip_weight\n  \
softsense sense clouds/scenes/probe_side --json > forces.jsonl\n  \
softsense sense clouds/scenes/two_probes --render /tmp/pictures\n\n\
Generate a scene first with `softsense scene generate SCENE.toml OUT_DIR`."
)]
pub struct SenseArgs {
    /// Recording folder.
    pub scene_dir: PathBuf,
    /// FE model file (TOML); default: the model named in the folder's truth.json.
    #[arg(long, value_name = "MODEL.toml")]
    pub model: Option<PathBuf>,
    /// Number of surface feature points.
    #[arg(long, value_name = "N", default_value_t = 51)]
    pub features: usize,
    /// Robot colour (sRGB) for the colour model.
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, default_value = "40,200,60")]
    pub robot_color: [u8; 3],
    /// Print one JSON object per frame (JSON lines) instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn parse_rgb(s: &str) -> Result<[u8; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [r, g, b] = parts[..] else {
        return Err("expected R,G,B, e.g. 40,200,60".into());
    };
    let c = |v: &str| {
        v.trim()
            .parse::<u8>()
            .map_err(|e| format!("colour {v:?}: {e}"))
    };
    Ok([c(r)?, c(g)?, c(b)?])
}

pub fn run(args: &SenseArgs) -> CliResult {
    let rec = Recording::open(&args.scene_dir).map_err(|e| CliError::Lib(e.into()))?;
    let model_path = match (&args.model, rec.model_path()) {
        (Some(m), _) => m.clone(),
        (None, Some(m)) => m,
        (None, None) => {
            return Err(CliError::Usage(format!(
                "{} has no truth.json naming its model: give --model MODEL.toml",
                args.scene_dir.display()
            )))
        }
    };
    let model = Model::load(&model_path, None).map_err(|e| CliError::Lib(e.into()))?;
    let mut params = SenseParams {
        robot_color: args.robot_color,
        ..Default::default()
    };
    params.features.count = args.features;
    let sensor = Sensor::new(model, rec.robot_from_camera, params);
    eprintln!(
        "{}: {} frames, model {}, pose from {}, {} feature points",
        args.scene_dir.display(),
        rec.frames.len(),
        model_path.display(),
        rec.pose_file.display(),
        sensor.features.len()
    );
    let bar = ProgressBar::new(rec.frames.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut reports = Vec::new();
    for &frame in &rec.frames {
        let mut report = match sensor.observe(&rec, frame) {
            Ok(obs) => sensor.sense(frame, &obs, rec.actuators_of(frame)),
            Err(e) => unreadable(frame, e.to_string()),
        };
        if let Some(t) = rec.truth_of(frame) {
            report.errors = Some(compare(&report, t));
        }
        bar.suspend(|| -> CliResult {
            if args.json {
                let line =
                    serde_json::to_string(&report).map_err(|e| CliError::Other(Box::new(e)))?;
                println!("{line}");
                Ok(())
            } else {
                print_human(&report);
                Ok(())
            }
        })?;
        bar.inc(1);
        reports.push(report);
    }
    bar.finish_and_clear();
    summary(&reports);
    if reports
        .iter()
        .all(|r| !matches!(r.status, FrameStatus::Sensed))
    {
        return Err(CliError::Result("no frame could be sensed".into()));
    }
    Ok(())
}

fn unreadable(frame: usize, why: String) -> FrameReport {
    FrameReport {
        frame,
        status: FrameStatus::Unreadable(why),
        robot_points: 0,
        object_points: 0,
        forces: Vec::new(),
        actuators: Vec::new(),
        features_visible: 0,
        features: 0,
        residual_rms: f64::NAN,
        updates: 0,
        identifiability: None,
        warnings: Vec::new(),
        errors: None,
        ms: 0.0,
    }
}

fn print_human(r: &FrameReport) {
    let status = match &r.status {
        FrameStatus::Sensed => "sensed".to_string(),
        other => format!("{other:?}"),
    };
    println!(
        "frame {:>4}: {status}, robot {} pts, objects {} pts, features {}/{}, residual {:.3} mm, {} FE updates, {:.0} ms",
        r.frame,
        r.robot_points,
        r.object_points,
        r.features_visible,
        r.features,
        r.residual_rms * 1e3,
        r.updates,
        r.ms
    );
    for (i, f) in r.forces.iter().enumerate() {
        println!(
            "  force {i} ({}{}): at ({:.1}, {:.1}, {:.1}) mm, F = ({:.3}, {:.3}, {:.3}) N, |F| = {:.3} ± {:.3} N",
            f.source,
            f.node.map(|n| format!(", node {n}")).unwrap_or_default(),
            f.location[0] * 1e3,
            f.location[1] * 1e3,
            f.location[2] * 1e3,
            f.force[0],
            f.force[1],
            f.force[2],
            f.magnitude,
            f.sigma
        );
    }
    if !r.actuators.is_empty() {
        let a: Vec<String> = r
            .actuators
            .iter()
            .map(|(n, f)| format!("{n} {f:.3}"))
            .collect();
        println!("  actuator forces (N): {}", a.join(", "));
    }
    for w in &r.warnings {
        println!("  warning: {w}");
    }
    for (k, e) in r.errors.iter().flatten().enumerate() {
        let t = e.truth_force;
        println!(
            "  truth {k}: F = ({:.3}, {:.3}, {:.3}) N at ({:.1}, {:.1}, {:.1}) mm -> location error {:.1} mm, force error {:.1}%, magnitude error {:.1}%",
            t[0],
            t[1],
            t[2],
            e.truth_at[0] * 1e3,
            e.truth_at[1] * 1e3,
            e.truth_at[2] * 1e3,
            e.location_error * 1e3,
            100.0 * e.force_error,
            100.0 * e.magnitude_error
        );
    }
}

fn summary(reports: &[FrameReport]) {
    let sensed = reports
        .iter()
        .filter(|r| matches!(r.status, FrameStatus::Sensed))
        .count();
    let errors: Vec<_> = reports
        .iter()
        .flat_map(|r| r.errors.iter().flatten())
        .collect();
    let ms: f64 = reports.iter().map(|r| r.ms).sum::<f64>() / reports.len().max(1) as f64;
    eprintln!(
        "{sensed}/{} frames sensed, {ms:.0} ms per frame",
        reports.len()
    );
    if !errors.is_empty() {
        let n = errors.len() as f64;
        let mean = |f: &dyn Fn(&&softsense::sense::LoadError) -> f64| {
            errors.iter().map(f).sum::<f64>() / n
        };
        let max = |f: &dyn Fn(&&softsense::sense::LoadError) -> f64| {
            errors.iter().map(f).fold(0.0, f64::max)
        };
        eprintln!(
            "against truth.json ({} loads): force error mean {:.2}% max {:.2}%, magnitude error mean {:.2}% max {:.2}%, location error mean {:.1} mm max {:.1} mm",
            errors.len(),
            100.0 * mean(&|e| e.force_error),
            100.0 * max(&|e| e.force_error),
            100.0 * mean(&|e| e.magnitude_error),
            100.0 * max(&|e| e.magnitude_error),
            1e3 * mean(&|e| e.location_error),
            1e3 * max(&|e| e.location_error)
        );
    }
}

//! `softsense markers calibrate`: the tracker-to-robot transform from the markers at rest.

use super::markers::{read_any_tracks, reference_error};
use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::fem::model::Model;
use softsense::markers::calib::{fit_robot_from_tracker, write_calibration};
use softsense::markers::reference::check_reference_frames;
use softsense::markers::{bind_markers, MarkersParams};
use std::path::PathBuf;

/// Fit the tracker-to-robot transform to the markers' rest positions (thesis 3.3).
#[derive(Args, Debug)]
#[command(
    long_about = "Fits robot_from_tracker, the rigid transform from the tracker's frame to \
the model's, to the markers at rest (thesis 3.3 calibrates with markers): each marker's \
tracked position (the mean of its entries in the first --reference-frames frames, which \
must show the body unloaded: one whose markers moved more than twice what --sigma-mm \
explains is refused) against its position on the model (POSITIONS, a track file \
in the model frame such as `markers layout --csv` writes, snapped onto the surface of the \
model's free equilibrium). Least squares (Kabsch); markers are matched by name. Needs at \
least 3 markers not on one line. Prints the transform and the residual per marker; --out \
writes it as JSON for `softsense markers --calibration`.",
    after_help = "Example:\n  \
softsense markers layout meshes/models/robot.toml --markers 8 --csv layout.csv\n  \
softsense markers calibrate take.csv meshes/models/robot.toml --positions layout.csv --out tracker.json\n  \
softsense markers take.csv meshes/models/robot.toml --calibration tracker.json"
)]
pub struct CalibrateArgs {
    /// Marker tracks in the tracker frame (softsense CSV or Motive export).
    tracks: PathBuf,
    /// Model file (TOML).
    model: PathBuf,
    /// The markers' positions on the model: a track file's first frame (m, model frame).
    #[arg(long, value_name = "TRACKS")]
    positions: PathBuf,
    /// The first N frames show the body unloaded; each marker's tracked position is their mean.
    #[arg(long, value_name = "N", default_value_t = 1)]
    reference_frames: usize,
    /// One sigma of a marker coordinate (mm): a reference frame whose markers moved more
    /// than this noise explains is loaded, and refused.
    #[arg(long, default_value_t = 0.1)]
    sigma_mm: f64,
    /// Write the calibration here (JSON: robot_from_tracker as a row-major 4x4, residuals);
    /// never one of the input files.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Up to 12 of `names`, `, `-separated, and how many more.
fn listed<'a>(names: impl ExactSizeIterator<Item = &'a String>) -> String {
    let n = names.len();
    let shown: Vec<&str> = names.take(12).map(String::as_str).collect();
    match n > shown.len() {
        true => format!("{} and {} more", shown.join(", "), n - shown.len()),
        false => shown.join(", "),
    }
}

/// Runs `softsense markers calibrate`.
pub fn run(args: &CalibrateArgs) -> CliResult {
    if args.reference_frames == 0 {
        return Err(CliError::Usage(
            "--reference-frames must be at least 1 frame".into(),
        ));
    }
    if !(args.sigma_mm > 0.0 && args.sigma_mm.is_finite()) {
        return Err(CliError::Usage(format!(
            "--sigma-mm {}: must be a positive number of millimetres",
            args.sigma_mm
        )));
    }
    if let Some(out) = &args.out {
        super::check_output_file(out, &[&args.tracks, &args.model, &args.positions])?;
    }
    let lib = |e: softsense::markers::MarkersError| CliError::Lib(e.into());
    let tracks = read_any_tracks(&args.tracks)?;
    let positions = read_any_tracks(&args.positions)?;
    let model = Model::load(&args.model, None).map_err(|e| CliError::Lib(e.into()))?;
    let free = (model.problem.without_loads())
        .solve_static(&model.newton)
        .map_err(|e| CliError::Lib(e.into()))?;
    let params = MarkersParams {
        sigma: args.sigma_mm * 1e-3,
        ..Default::default()
    };
    check_reference_frames(&tracks, args.reference_frames, &params)
        .map_err(|e| reference_error(&args.tracks, e))?;
    let head = &tracks.frames[..args.reference_frames];
    let first = positions.frames.first();
    let (mut names, mut tracked, mut placed) = (Vec::new(), Vec::new(), Vec::new());
    for (m, name) in tracks.names.iter().enumerate() {
        let seen: Vec<[f64; 3]> = head.iter().filter_map(|f| f.positions[m]).collect();
        let at = (positions.names.iter().position(|n| n == name))
            .and_then(|i| first.and_then(|f| f.positions[i]));
        let (false, Some(at)) = (seen.is_empty(), at) else {
            continue;
        };
        let n = seen.len() as f64;
        tracked.push([0, 1, 2].map(|a| seen.iter().map(|p| p[a]).sum::<f64>() / n));
        placed.push(at);
        names.push(name.clone());
    }
    if names.len() < 3 {
        let placed: Vec<&String> = (positions.names.iter().enumerate())
            .filter(|(i, _)| first.is_some_and(|f| f.positions[*i].is_some()))
            .map(|(_, n)| n)
            .collect();
        return Err(CliError::Result(format!(
            "{} and {}: {} markers are in both, matched by name and visible (a rigid fit needs at least 3); the tracks have [{}], the positions' first frame [{}]: name the markers alike in both files",
            args.tracks.display(),
            args.positions.display(),
            names.len(),
            listed(tracks.names.iter()),
            listed(placed.into_iter())
        )));
    }
    let surface = model.problem.mesh.surface();
    let bound = bind_markers(&free.positions, &surface, &names, &placed, 0.005)
        .map_err(|e| CliError::Lib(e.into()))?;
    let on_model: Vec<[f64; 3]> = bound
        .iter()
        .map(|b| b.at.position(&free.positions))
        .collect();
    let mut calibration = fit_robot_from_tracker(&names, &tracked, &on_model).map_err(lib)?;
    calibration.reference_frames = head.len();
    if let Some(out) = &args.out {
        write_calibration(out, &calibration).map_err(lib)?;
    }
    if args.json {
        let v = serde_json::to_value(&calibration).map_err(|e| CliError::Result(e.to_string()))?;
        return print_json(&v);
    }
    outln!(
        "robot_from_tracker from {} markers, residual RMS {:.3} mm",
        names.len(),
        1e3 * calibration.residual_rms_m
    )?;
    for row in calibration.robot_from_tracker.to_matrix() {
        outln!(
            "  [{:10.6}, {:10.6}, {:10.6}, {:10.6}]",
            row[0],
            row[1],
            row[2],
            row[3]
        )?;
    }
    for (name, r) in names.iter().zip(&calibration.residuals_m) {
        outln!("  {name}: residual {:.3} mm", 1e3 * r)?;
    }
    let skipped = tracks.names.len() - names.len();
    if skipped > 0 {
        eprintln!("warning: {skipped} markers left out (not visible in the reference frames or not in --positions)");
    }
    Ok(())
}

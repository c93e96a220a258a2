//! `softsense markers`: forces from tracked markers (thesis 4.4, 4.6.1, 4.7.1).

use super::{print_json, CliError, CliResult};
use clap::{Args, Subcommand};
use softsense::fem::model::Model;
use softsense::markers::bind::read_candidates;
use softsense::markers::calib::{read_calibration, rigid_fit_covariance, MarkerCalibration};
use softsense::markers::reference::reference_positions;
use softsense::markers::tracks::{flag_hidden, read_motive, read_tracks, MarkerTracks};
use softsense::markers::{
    bind_markers, locate_forces, refine_located, CandidateLocation, LocatedForce, MarkerFrame,
    MarkerSensor, MarkersParams,
};
use std::path::{Path, PathBuf};

/// Forces at candidate locations from marker tracks and an FE model.
#[derive(Args, Debug)]
#[command(
    long_about = "Forces at candidate locations from tracked markers and an FE model \
(thesis 4.4: the analytic least squares 4.9 iterated with the FE model, actuators held at \
the model file's cable inputs).\n\n\
Each marker is bound to the model's surface at the mean of its entries in the first \
--reference-frames frames (1 by default; else at its first visible entry), the surface \
taken in the model's free equilibrium (gravity and cable inputs, no loads): those frames \
must show the body unloaded; more frames than the file has, or one whose markers moved more \
than twice what --sigma-mm explains (a loaded frame), is refused. The reference's noise is common to every later frame and is \
included in sigma (its share is 1/N of a frame's); --reference binds at exact positions \
instead. Per frame, markers that are missing or farther \
than the hidden threshold from where they are expected (their last accepted position moved \
by their nearest accepted neighbours' displacement) lose their 3 rows; the \
forces are solved at all candidates together, and candidates whose force exceeds 5 sigma \
and 20% of the largest are reported as found, neighbours (--group-radius-mm) merged at their \
weighted centre. A force found at several neighbouring candidates lies between them: it is \
also reported refined to the surface node near them where one force explains the markers \
best (`refined`; null for a force found at one candidate). With --accumulate N each frame is \
solved with the rows of the last N frames stacked, as if they carried the same forces (the \
thesis's accumulation over frames, Remark 2): for a load held still, N frames divide the \
noise's share by sqrt(N); a load that changes within the window is smeared over it.\n\n\
TRACKS is softsense's CSV `frame,marker,x,y,z` (metres, model frame; a hidden marker has \
empty x,y,z) or an OptiTrack Motive CSV export (detected by its `Frame,Time` header; \
millimetres unless its header says otherwise). The tracker frame is taken as the model \
frame, unless --calibration maps it (`softsense markers calibrate`). Candidates come from --candidates (CSV `name,x,y,z,directions`, metres, directions \
`normal` or `3d`, each snapped to the nearest surface node; one more than 5 mm off the \
surface is refused) or else the model's [[force_points]].",
    after_help = "Examples:\n  \
softsense markers tracks.csv meshes/models/sheet.toml --candidates candidates.csv\n  \
softsense markers take.csv meshes/models/robot.toml --json | jq .located\n  \
softsense markers layout meshes/models/robot.toml --markers 8\n  \
softsense markers detect /tmp/painted --colour 30,60,230 --out tracks.csv",
    // `markers TRACKS MODEL` stays as it was; `layout` and `detect` are subcommands.
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
pub struct MarkersArgs {
    /// `layout`: propose where to put the markers; `detect`: find coloured markers in a
    /// recording; `calibrate`: fit the tracker-to-robot transform.
    #[command(subcommand)]
    command: Option<MarkersCommand>,
    /// Marker tracks: softsense CSV or OptiTrack Motive CSV export.
    #[arg(required = true)]
    tracks: Option<PathBuf>,
    /// Model file (TOML).
    #[arg(required = true)]
    model: Option<PathBuf>,
    /// Candidate force locations (CSV name,x,y,z,directions in m); default: the model's force points.
    #[arg(long)]
    candidates: Option<PathBuf>,
    /// Only these of the model's force points are candidates (comma-separated names): a
    /// force at a known point is solved alone, as the thesis's known-location experiments
    /// do, instead of sharing the markers' rows with points that carry nothing.
    #[arg(
        long,
        value_name = "NAME,...",
        value_delimiter = ',',
        conflicts_with = "candidates"
    )]
    force_points: Vec<String>,
    /// One sigma of a marker coordinate (mm).
    #[arg(long, default_value_t = 0.1)]
    sigma_mm: f64,
    /// A marker farther than this from where it is expected (its last accepted position
    /// moved by its nearest accepted neighbours' displacement in the frame) is hidden (mm).
    #[arg(long, default_value_t = 5.0)]
    hidden_jump_mm: f64,
    /// Found candidates closer than this are one located force (mm); a force found at
    /// several is refined to the surface node between them that explains the markers best.
    #[arg(long, default_value_t = 30.0)]
    group_radius_mm: f64,
    /// Solve each frame with the rows of this many frames up to it stacked, taken to carry
    /// the same forces (thesis Remark 2; 1: each frame alone).
    #[arg(long, default_value_t = 1)]
    accumulate: usize,
    /// The first N frames show the body unloaded: each marker is bound at the mean of its
    /// entries there, and that reference's noise (1/N of a frame's) is in the forces' sigma.
    /// At most the file's frames; a loaded frame among them is refused.
    #[arg(long, value_name = "N", default_value_t = 1)]
    reference_frames: usize,
    /// Bind the markers at this track file's first frame instead, taken as exact (model
    /// frame, unloaded; e.g. `markers layout --csv` or a generator's `markers_truth.csv`).
    #[arg(long, value_name = "TRACKS", conflicts_with = "reference_frames")]
    reference: Option<PathBuf>,
    /// The tracks are in the tracker's frame: map them into the model's with this
    /// calibration (from `softsense markers calibrate --out`).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Write a picture per frame into this folder (frame_NNNN.png): top and side views with
    /// the markers at rest and now (displacements magnified), hidden markers, candidates and
    /// the located forces with their values.
    #[arg(long, value_name = "DIR")]
    render: Option<PathBuf>,
    /// Print one JSON document per frame on stdout.
    #[arg(long)]
    json: bool,
}

/// Subcommands of `softsense markers`.
#[derive(Subcommand, Debug)]
pub enum MarkersCommand {
    // No doc comments on the variants: they would replace each command's long help with
    // its one-line summary; the summaries are the Args structs' doc comments.
    Layout(super::markers_layout::LayoutArgs),
    Detect(super::markers_detect::DetectArgs),
    Calibrate(super::markers_calib::CalibrateArgs),
}

/// The candidates of `--candidates`, else the model's force points (those named in
/// `names` when it is not empty).
pub(crate) fn load_candidates(
    model: &Model,
    model_file: &std::path::Path,
    path: Option<&std::path::Path>,
    names: &[String],
) -> Result<Vec<CandidateLocation>, CliError> {
    let mesh = &model.problem.mesh;
    if path.is_none() && model.force_points.is_empty() {
        return Err(CliError::Usage(format!(
            "{}: the model has no force points: give --candidates FILE (CSV name,x,y,z,directions), or add [[force_points]] to the model file (name, at in its units, and normal = true or a direction; as in meshes/models/robot.toml)",
            model_file.display()
        )));
    }
    if let Some(missing) = names
        .iter()
        .find(|n| !model.force_points.iter().any(|e| &e.name == *n))
    {
        let known: Vec<&str> = model.force_points.iter().map(|e| e.name.as_str()).collect();
        return Err(CliError::Usage(format!(
            "--force-points: the model has no force point {missing:?} (its force points: {})",
            known.join(", ")
        )));
    }
    let candidates: Vec<CandidateLocation> = match path {
        Some(p) => read_candidates(p, mesh).map_err(|e| CliError::Lib(e.into()))?,
        None => (model.force_points.iter())
            .filter(|e| names.is_empty() || names.contains(&e.name))
            .map(|e| CandidateLocation::from_force_point(e, mesh))
            .collect(),
    };
    Ok(candidates)
}

pub(crate) fn read_any_tracks(path: &std::path::Path) -> Result<MarkerTracks, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::Result(format!("{}: {e}", path.display())))?;
    let motive = text.lines().any(|l| l.trim_start().starts_with("Frame,"));
    let tracks = if motive {
        read_motive(path)
    } else {
        read_tracks(path)
    };
    tracks.map_err(|e| CliError::Lib(e.into()))
}

/// Runs `softsense markers`.
pub fn run(args: &MarkersArgs) -> CliResult {
    match &args.command {
        Some(MarkersCommand::Layout(a)) => return super::markers_layout::run(a),
        Some(MarkersCommand::Detect(a)) => return super::markers_detect::run(a),
        Some(MarkersCommand::Calibrate(a)) => return super::markers_calib::run(a),
        None => {}
    }
    let (Some(tracks_path), Some(model_path)) = (&args.tracks, &args.model) else {
        return Err(CliError::Usage("give TRACKS and MODEL".into()));
    };
    if !(args.sigma_mm > 0.0 && args.hidden_jump_mm > 0.0 && args.group_radius_mm >= 0.0) {
        return Err(CliError::Usage(
            "--sigma-mm and --hidden-jump-mm must be positive, --group-radius-mm not negative"
                .into(),
        ));
    }
    if args.reference_frames == 0 {
        return Err(CliError::Usage(
            "--reference-frames must be at least 1 frame".into(),
        ));
    }
    if args.accumulate == 0 {
        return Err(CliError::Usage(
            "--accumulate must be at least 1 frame".into(),
        ));
    }
    let params = MarkersParams {
        sigma: args.sigma_mm * 1e-3,
        hidden_jump: args.hidden_jump_mm * 1e-3,
        group_radius: args.group_radius_mm * 1e-3,
        ..Default::default()
    };
    let (tracks, calibration) = tracks_in_model_frame(tracks_path, args.calibration.as_deref())?;
    let model = Model::load(model_path, None).map_err(|e| CliError::Lib(e.into()))?;
    let mesh = &model.problem.mesh;
    let candidates = load_candidates(
        &model,
        model_path,
        args.candidates.as_deref(),
        &args.force_points,
    )?;
    let (first, counts) = bound_positions(&tracks, args, &params)?;
    let surface = mesh.surface();
    // The first frame shows the body unloaded: the model's free equilibrium, not its rest.
    let free = (model.problem.without_loads())
        .solve_static(&model.newton)
        .map_err(|e| CliError::Lib(e.into()))?;
    let markers = bind_markers(
        &free.positions,
        &surface,
        &tracks.names,
        &first,
        params.max_bind_distance,
    )
    .map_err(|e| CliError::Lib(e.into()))?;
    let mut sensor = MarkerSensor::new(
        &model.problem,
        model.newton.clone(),
        markers,
        candidates,
        params,
    )
    .map_err(|e| CliError::Lib(e.into()))?
    .with_reference_frames(&counts);
    // The calibration's error is one rigid offset in every frame: its share is in σ, taken
    // as independent of the reference's (an upper bound when both come from the same frames).
    sensor.calibration_covariance = calibration.map(|c| {
        let rest: Vec<[f64; 3]> = (sensor.markers.iter())
            .map(|m| m.at.position(&free.positions))
            .collect();
        rigid_fit_covariance(&c.model_positions_m, &rest, c.reference_frames)
    });
    let hidden = flag_hidden(&tracks, &sensor.params);
    let measured: Vec<Vec<Option<[f64; 3]>>> = (tracks.frames.iter().zip(&hidden))
        .map(|(f, flags)| {
            (f.positions.iter().zip(flags))
                .map(|(p, h)| if *h { None } else { *p })
                .collect()
        })
        .collect();
    if let Some(dir) = &args.render {
        super::check_files_dir(dir, &[], &[])?;
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::Result(format!("{}: {e}", dir.display())))?;
    }
    let mut previous = None;
    for (i, f) in tracks.frames.iter().enumerate() {
        let window: Vec<&[Option<[f64; 3]>]> = measured
            [(i + 1).saturating_sub(args.accumulate)..=i]
            .iter()
            .map(Vec::as_slice)
            .collect();
        let mut est = sensor
            .solve_frames(f.frame, &window, previous.as_ref())
            .map_err(|e| CliError::Lib(e.into()))?;
        let located = locate_forces(&est, &sensor.locations, &sensor.params);
        if located.is_empty() {
            est.warnings.extend(unseen_forces(&sensor, &est));
        }
        let refined = refine_between(&sensor, &est, &measured[i], &located)?;
        print_frame(
            &sensor,
            &tracks,
            &est,
            (&located[..], &refined[..]),
            args.json,
        )?;
        if let Some(dir) = &args.render {
            let rest = (sensor.markers.iter())
                .map(|m| m.at.position(&free.positions))
                .collect::<Vec<_>>();
            render_frame(
                dir,
                &sensor,
                &est,
                (&rest, &measured[i]),
                &located,
                &surface,
            )?;
        }
        previous = Some(est);
    }
    Ok(())
}

/// Writes `dir/frame_NNNN.png` for `est`: the markers at `rest` and as `measured`.
fn render_frame(
    dir: &std::path::Path,
    sensor: &MarkerSensor,
    est: &MarkerFrame,
    (rest, measured): (&[[f64; 3]], &[Option<[f64; 3]>]),
    located: &[LocatedForce],
    surface: &softsense::fem::mesh::Surface,
) -> CliResult {
    use softsense::render::markers::{marker_picture, MarkerMark, MarkerPicture};
    let path = dir.join(format!("frame_{:04}.png", est.frame));
    let fail = |e: &dyn std::fmt::Display| CliError::Result(format!("{}: {e}", path.display()));
    let markers: Vec<MarkerMark> = (rest.iter().zip(measured).enumerate())
        .map(|(m, (r, now))| MarkerMark {
            rest: *r,
            current: *now,
            hidden: est.hidden.contains(&m),
        })
        .collect();
    let candidates: Vec<[f64; 3]> = sensor.locations.iter().map(|c| c.position).collect();
    let forces: Vec<([f64; 3], [f64; 3])> = located.iter().map(|l| (l.centre, l.force)).collect();
    let positions = match &est.solution {
        Some(s) => &s.positions,
        None => &sensor.problem.mesh.nodes_in_rest,
    };
    let title = format!("frame {}: {:?}", est.frame, est.status);
    let pic = MarkerPicture {
        title: &title,
        triangles: &surface.triangles,
        positions,
        markers: &markers,
        candidates: &candidates,
        forces: &forces,
    };
    let canvas = marker_picture(&pic, 480, 400).map_err(|e| fail(&e))?;
    canvas.save_png(&path).map_err(|e| fail(&e))
}

/// The tracks, mapped into the model frame by the calibration at `calibration` when given.
fn tracks_in_model_frame(
    path: &std::path::Path,
    calibration: Option<&std::path::Path>,
) -> Result<(MarkerTracks, Option<MarkerCalibration>), CliError> {
    let mut tracks = read_any_tracks(path)?;
    let Some(file) = calibration else {
        return Ok((tracks, None));
    };
    let c = read_calibration(file).map_err(|e| CliError::Lib(e.into()))?;
    for p in tracks
        .frames
        .iter_mut()
        .flat_map(|f| f.positions.iter_mut().flatten())
    {
        *p = c.robot_from_tracker.apply(*p);
    }
    Ok((tracks, Some(c)))
}

/// Where each marker is bound (m, model frame) and how many measured frames that
/// position averages (0: exact, from `--reference`): the mean of its visible entries in
/// the first `--reference-frames` frames, else its first visible entry (refused when one of
/// those frames is loaded: [`reference_positions`]).
fn bound_positions(
    tracks: &MarkerTracks,
    args: &MarkersArgs,
    params: &MarkersParams,
) -> Result<(Vec<[f64; 3]>, Vec<usize>), CliError> {
    if let Some(path) = &args.reference {
        let reference = read_any_tracks(path)?;
        let first = reference.frames.first();
        let positions = (tracks.names.iter())
            .map(|name| {
                let m = reference.names.iter().position(|n| n == name);
                m.and_then(|m| first.and_then(|f| f.positions[m]))
                    .ok_or_else(|| {
                        CliError::Result(format!(
                            "{}: no position of marker {name} in its first frame",
                            path.display()
                        ))
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        return Ok((positions, vec![0; tracks.names.len()]));
    }
    let tracks_path = args.tracks.as_deref().unwrap_or(Path::new("TRACKS"));
    let reference = reference_positions(tracks, args.reference_frames, params)
        .map_err(|e| reference_error(tracks_path, e))?;
    Ok((reference.positions, reference.counts))
}

/// A reference that the arguments cannot give from the track file `path` (too many frames,
/// a loaded one among them) is a usage error; the rest are the library's.
pub(crate) fn reference_error(path: &Path, e: softsense::markers::MarkersError) -> CliError {
    use softsense::markers::MarkersError as E;
    match e {
        E::ReferenceFramesTooMany { .. } | E::ReferenceFrameLoaded { .. } => {
            CliError::Usage(format!("{}: {e}", path.display()))
        }
        e => CliError::Lib(e.into()),
    }
}

/// The located forces spread over more than one found candidate (a force between
/// candidates) moved by [`refine_located`] to the surface node that explains the markers
/// best; a force found at one candidate alone is left there.
fn refine_between(
    sensor: &MarkerSensor,
    est: &MarkerFrame,
    measured: &[Option<[f64; 3]>],
    located: &[LocatedForce],
) -> Result<Vec<Option<LocatedForce>>, CliError> {
    let between: Vec<LocatedForce> = (located.iter())
        .filter(|l| l.candidates.len() > 1)
        .cloned()
        .collect();
    let mut refined = refine_located(sensor, est, measured, &between)
        .map_err(|e| CliError::Lib(e.into()))?
        .into_iter();
    Ok(located
        .iter()
        .map(|l| {
            if l.candidates.len() > 1 {
                refined.next()
            } else {
                None
            }
        })
        .collect())
}

/// When a frame locates no force, the smallest force each candidate would have been found
/// with (found_sigmas times its σ): "nothing located" then says how large a force could go
/// unseen. On the SOFA finger (3 candidates along a cantilever) that is 1-7 N against
/// 0.14-0.5 N loads, and the frames said nothing.
fn unseen_forces(sensor: &MarkerSensor, est: &MarkerFrame) -> Option<String> {
    if est.forces.len() != sensor.locations.len() {
        return None;
    }
    let mut k = 0;
    let limits: Vec<String> = (sensor.locations.iter())
        .map(|c| {
            let n = c.candidates.len();
            let sigma = est.sigma[k..k + n].iter().copied().fold(0.0, f64::max);
            k += n;
            format!("{} {:.3} N", c.name, sensor.params.found_sigmas * sigma)
        })
        .collect();
    Some(format!(
        "no force located; a force is found only above {} sigma, here: {}",
        sensor.params.found_sigmas,
        limits.join(", ")
    ))
}

fn print_frame(
    sensor: &MarkerSensor,
    tracks: &MarkerTracks,
    est: &MarkerFrame,
    (located, refined): (&[LocatedForce], &[Option<LocatedForce>]),
    json: bool,
) -> CliResult {
    let hidden: Vec<&str> = est
        .hidden
        .iter()
        .map(|&m| tracks.names[m].as_str())
        .collect();
    if json {
        let v = serde_json::json!({
            "frame": est.frame, "status": est.status, "forces_n": est.forces,
            "sigma_n": est.sigma, "i_w_n_per_m": est.i_w, "hidden": hidden,
            "rows": est.rows, "unknowns": est.unknowns, "updates": est.updates,
            "residual_rms_m": est.residual_rms, "located": located, "refined": refined,
            "warnings": est.warnings,
        });
        return print_json(&v);
    }
    outln!(
        "frame {}: {:?}, {} rows for {} unknowns, I_w {:.3} N/m, residual {:.3} mm, {} FE updates, hidden [{}]",
        est.frame, est.status, est.rows, est.unknowns, est.i_w, 1e3 * est.residual_rms,
        est.updates, hidden.join(", ")
    )?;
    for (c, f) in sensor.locations.iter().zip(&est.forces) {
        outln!(
            "  {}: F = ({:.4}, {:.4}, {:.4}) N",
            c.name,
            f[0],
            f[1],
            f[2]
        )?;
    }
    for (l, r) in located.iter().zip(refined) {
        let names: Vec<&str> = l
            .candidates
            .iter()
            .map(|&i| sensor.locations[i].name.as_str())
            .collect();
        let c = l.centre.map(|v| 1e3 * v);
        outln!(
            "  located at ({:.1}, {:.1}, {:.1}) mm from [{}]: F = ({:.4}, {:.4}, {:.4}) N",
            c[0],
            c[1],
            c[2],
            names.join(", "),
            l.force[0],
            l.force[1],
            l.force[2]
        )?;
        let Some(r) = r else { continue };
        let c = r.centre.map(|v| 1e3 * v);
        outln!(
            "    between candidates, refined to ({:.1}, {:.1}, {:.1}) mm: F = ({:.4}, {:.4}, {:.4}) N",
            c[0],
            c[1],
            c[2],
            r.force[0],
            r.force[1],
            r.force[2]
        )?;
    }
    for w in &est.warnings {
        eprintln!("warning: frame {}: {w}", est.frame);
    }
    Ok(())
}

//! `softsense sense`: the whole chain per frame, from RGB-D frames to contact forces.

use super::sense_print::{colourless, no_robot_hint, print_human, summary};
use super::{stdout_closed, CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use softsense::fem::model::Model;
use softsense::recording::RecordingError;
use softsense::sense::{
    compare, default_window, FrameReport, FrameStatus, Hold, HoldParams, Observation, Recording,
    Rig, SenseError, SenseParams, SenseResult, Sensor, View,
};
use std::path::PathBuf;

/// Find where the robot is touched and how hard, frame by frame.
///
/// Reads a recording folder (depth_NNNN.png + color_NNNN.png + intrinsics.json, a PCL
/// grabber sequence STEM_depth.tiff + STEM_rgb.tiff + STEM.xml, or Open3D depth/ + color/
/// folders; a camera pose in calibration.json or camera_pose.json, or --pose; optional
/// inputs.json or actuators.json with the recorded cable inputs per frame; without them,
/// the cable inputs `softsense calibrate` wrote into calibration.json, else the model
/// file's; see docs/recording-format.md), and for each frame: robot and touching
/// objects by colour, contacts by KD-tree search, each contact mapped onto the FE model,
/// the surface features registered along their normal lines, and the intensity QP solved
/// with FE updates. Prints per frame the forces (location in the robot frame, mapped
/// node, force vector, magnitude and its one-sigma uncertainty, then "3-D ±": the largest
/// one-sigma of the force over all directions, often several times the magnitude's, since
/// normal-line registration sees a tangential force only through the faces it tilts; with
/// --json also the force's 3x3 covariance in N²), the actuator forces, the residual and
/// any warning (among them, a force whose 3-D σ is over 2.5% of its magnitude: trust its
/// direction, or its magnitude, less). When the folder has a truth.json (generated
/// scenes), the errors against it are printed too;
/// truth.json is never used for the estimate.
///
/// A folder of several cameras (one sub-folder each with its frames, camera files and
/// pose; the inputs and truth at the top, as `scene generate` writes a scene with
/// [[cameras]]) is sensed as one: all cameras' robot points in the robot frame are
/// registered together, each with its own camera's depth noise, and the contacts come
/// from all of them. A camera without a frame, whose frame cannot be read, or that shows
/// no robot point (no_robot: check its pose) is left out of that frame and named in its
/// report ("cameras"); the others are sensed. Camera folders that are one folder (a
/// symlink) are one camera, with a warning.
///
/// Where no contact is seen (a weight hanging by a string), the model's force points
/// ([[force_points]] in the model file) are the candidate locations. Where one is seen,
/// the data choose the touched node among the surface nodes near it: first at the
/// unloaded state, again after two FE updates under the estimated load, and again at
/// the estimated state (up to twice); whenever the choice moves, the new node is
/// estimated. If the FE model cannot carry the estimated load at the chosen node (an
/// element inverts, or Newton finds no equilibrium), the next best node is tried, and a
/// warning names the node that failed.
#[derive(Debug, Args)]
#[command(
    about = "The main job: where the robot is touched and how hard, frame by frame",
    verbatim_doc_comment,
    after_help = "Examples:\n  \
softsense sense clouds/scenes/tip_weight\n  \
softsense sense clouds/scenes/probe_side --json > forces.jsonl\n  \
softsense sense clouds/scenes/two_probes --render /tmp/pictures\n  \
softsense sense clouds/scenes/two_probes --rerun /tmp/two_probes.rrd   # built with --features rerun\n  \
softsense sense my_grabber_folder --pose camera_pose.json --model meshes/models/robot.toml\n  \
softsense sense /tmp/two_cameras --cameras front   # one camera of a two-camera folder\n  \
tools/real/punyo.sh OUT   # --membrane: a bubble seen from inside (its command: docs/real-data.md)\n\n\
Generate a scene first with `softsense scene generate SCENE.toml OUT_DIR`."
)]
pub struct SenseArgs {
    /// Recording folder.
    pub scene_dir: PathBuf,
    /// FE model file (TOML); default: the model named in the folder's truth.json, else in
    /// its calibration.json (a path relative to the folder), so a recording copied away
    /// from its model needs this.
    #[arg(long, value_name = "MODEL.toml")]
    pub model: Option<PathBuf>,
    /// Camera pose file ({"robot_from_camera": 4x4 row-major, metres}), instead of the
    /// folder's calibration.json or camera_pose.json; needed for folders without one (PCL
    /// grabber and Open3D recordings).
    #[arg(long, value_name = "POSE.json")]
    pub pose: Option<PathBuf>,
    /// Number of surface feature points (the thesis used 51).
    #[arg(long, value_name = "N", default_value_t = SenseParams::default().features.count,
          value_parser = super::parse_positive)]
    pub features: usize,
    /// Robot colour (sRGB) for the colour model.
    #[arg(long, value_name = "R,G,B", value_parser = super::parse_rgb, default_value = "40,200,60")]
    pub robot_color: [u8; 3],
    /// A frame with more seen contacts than this is not estimated: its status says "too
    /// many contacts". Dozens of contacts come from depth and colour that do not match or
    /// from objects all around the robot, not from touches, and estimating them takes
    /// seconds per frame for no answer.
    #[arg(long, value_name = "N", default_value_t = SenseParams::default().max_contacts,
          value_parser = super::parse_positive)]
    pub max_contacts: usize,
    /// Print one JSON object per frame (JSON lines) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write a picture per frame into this folder (frame_NNNN.png): the colour frame with
    /// the robot segment tinted, the feature points (registered / hidden), the seen
    /// contacts and the estimated force arrows with their magnitudes.
    #[arg(long, value_name = "OUT_DIR")]
    pub render: Option<PathBuf>,
    /// Write a rerun recording (.rrd) of every frame, to step through in the rerun viewer
    /// (`rerun OUT.rrd`): each camera's pose, pinhole and colour frame, the robot and
    /// object points, the deformed FE surface, the feature points and their registration
    /// lines, the contacts, force arrows with their one-sigma ellipsoids, the status and
    /// warnings, and the forces plotted over frames (docs/rerun.md). Needs a softsense
    /// built with `--features rerun`.
    #[arg(long, value_name = "OUT.rrd")]
    pub rerun: Option<PathBuf>,
    /// Frames sensed at the same time (default: the number of threads, from
    /// RAYON_NUM_THREADS or the cores); each next frame goes to the first that is done.
    /// Output stays in frame order and every frame's answer is the same for any value;
    /// more frames at once raise the frames per second while each frame takes longer.
    #[arg(long, value_name = "N", value_parser = super::parse_positive)]
    pub window: Option<usize>,
    /// Sense the frames as a live stream: each frame whose contacts are where the previous
    /// frame saw them (each within 5 mm; or no contact in either, the model's force points
    /// then), with the same cable inputs, starts from the previous frame's locations and
    /// forces, and the next frame is read while this one is sensed. On a real stream,
    /// where the load changes little between frames, a frame takes about half the time;
    /// the answers agree with the untracked ones within the loop's tolerance (1 mN or a
    /// quarter of a force's σ, each). A contact that moved on is located again. A frame
    /// then depends on the frames before it, so frames are not sensed side by side
    /// (`--window` does not apply). Tracked frames say "tracked" (JSON: "tracked": true).
    #[arg(long, conflicts_with = "window")]
    pub track: bool,
    /// What the deformed FE surface is registered against. `dense`: every robot point the
    /// camera sees (up to 4000, evenly subsampled), each with its own depth noise;
    /// `features`: 300-600 feature points, each the mean of a 5 mm disc of points; `auto`:
    /// dense for a frame with one seen contact, and with several after a reference
    /// (`--reference-frames`), features otherwise (without a reference two contacts were
    /// located better from features; tip weights are held by them). Dense costs about
    /// 85 ms per frame; docs/dense-registration.md has the sweeps behind the rule.
    #[arg(long, value_enum, default_value_t = RegistrationArg::Auto)]
    pub registration: RegistrationArg,
    /// Dense registration takes at most N robot points per camera (every k-th of those it
    /// sees). Fewer save little and lose accuracy: at 2000 and 1000 a probe frame took 0.85
    /// and 0.90 of the default's instructions, and a one-probe sweep had 49 and 37 of 100
    /// loads within 5% against 52 (docs/performance.md, "Fewer dense rows"). The sigma of
    /// the forces comes from the rows used, and grows as they get fewer.
    #[arg(long, value_name = "N", value_parser = super::parse_positive,
          default_value_t = softsense::inverse::DenseParams::default().max_points)]
    pub dense_points: usize,
    /// In a folder of several cameras (one sub-folder each), sense with these cameras only
    /// (their folder names), e.g. to compare one camera against all on the same frames.
    #[arg(long, value_name = "NAME,...", value_delimiter = ',')]
    pub cameras: Option<Vec<String>>,
    /// Take the first N frames, which must show the body unloaded, as the reference (a
    /// tare): the model's unloaded surface is matched to what the cameras see there, and
    /// later frames are sensed relative to it. A real body's rest shape and sag differ
    /// from its model's (another modulus, another mesh, a base that gives); without a
    /// reference that difference is read as force (docs/sensing.md, "A reference from
    /// unloaded frames"). The reference frames are sensed too and marked "reference"; a
    /// contact seen in one is refused.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub reference_frames: usize,
    /// A frame that carries a known load, FRAME=NEWTONS (its total force's magnitude, e.g. a
    /// weight hung from the robot): with --reference-frames, the model's Young's modulus is
    /// scaled until that frame reads its load (the reference re-taken at each modulus),
    /// and the modulus's uncertainty joins every force's sigma. The frame is sensed too and
    /// marked "reference". Prints the modulus to put in the model file's [material].
    #[arg(long, value_name = "FRAME=NEWTONS", value_parser = parse_known_load, requires = "reference_frames")]
    pub known_load: Option<(usize, f64)>,
    /// Fuse each force over the frames its load is held (a weight left hanging, a probe
    /// pressed and kept still): while every force of the stream stays within 5 mm of where
    /// it was and within its noise of the fused force (chi-square of 3 at 95%), the frames'
    /// forces are fused by their inverse covariances, and the fused sigma shrinks as
    /// 1/sqrt(n) down to what every frame shares (the reference's noise and the modulus's
    /// uncertainty). A force that moves or changes starts a new hold; a failed, unreliable
    /// or reference frame ends it. Each frame then also prints its fused forces ("held";
    /// JSON "held": since, frames, force, magnitude, sigma, covariance).
    #[arg(long)]
    pub hold: bool,
    /// With --reference-frames, find the model's Young's modulus from the body's own
    /// weight: the reference frames' sag against the model's sag under its gravity and
    /// density (the model's density must be the body's). No known load is needed; a wrong
    /// density, or a shape the cables bend differently, is read as modulus.
    #[arg(long, requires = "reference_frames", conflicts_with = "known_load")]
    pub modulus_from_sag: bool,
    #[command(flatten)]
    pub membrane: super::sense_membrane::MembraneArgs,
}

/// `FRAME=NEWTONS`.
fn parse_known_load(s: &str) -> Result<(usize, f64), String> {
    let (frame, load) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected FRAME=NEWTONS, e.g. 3=0.26"))?;
    let frame = frame
        .trim()
        .parse()
        .map_err(|e| format!("{frame:?}: {e}"))?;
    let load: f64 = load.trim().parse().map_err(|e| format!("{load:?}: {e}"))?;
    if !(load.is_finite() && load > 0.0) {
        return Err(format!(
            "{load}: the known load must be a positive number of newtons"
        ));
    }
    Ok((frame, load))
}

pub fn run(args: &SenseArgs) -> CliResult {
    if args.membrane.membrane {
        return super::sense_membrane::run(args);
    }
    if let Some(dir) = &args.render {
        super::check_files_dir(dir, &[], &[])?;
    }
    let rig = open_rig(args)?;
    let rec = rig.shared();
    for w in &rig.warnings {
        eprintln!("warning: {w}");
    }
    let model_path = model_path(args, rec)?;
    let model = Model::load(&model_path, None).map_err(|e| CliError::Lib(e.into()))?;
    let mut params = SenseParams::with_options(
        args.registration.into(),
        args.robot_color,
        Some(args.max_contacts),
        Some(args.features),
    );
    params.dense_rows.max_points = args.dense_points;
    let mut sensor = Sensor::for_rig(model, &rig, params).map_err(|e| match e {
        SenseError::NoPose { .. } => CliError::Usage(format!(
            "{e}: give --pose POSE.json, or find it with `softsense calibrate`"
        )),
        e => CliError::Lib(e.into()),
    })?;
    let inputs = use_recorded_inputs(rec, &mut sensor)?;
    take_reference(args, &rig, &mut sensor)?;
    let poses: Vec<String> = (rig.cameras.iter())
        .filter_map(|c| c.recording.pose_file.as_deref())
        .map(|p| super::shown_path(p).display().to_string())
        .collect();
    eprintln!(
        "{}: {} frames, model {}, pose from {}, cable inputs {inputs}, {} feature points",
        args.scene_dir.display(),
        rig.frames.len(),
        super::shown_path(&model_path).display(),
        poses.join(", "),
        sensor.features.len()
    );
    if let Some(dir) = &args.render {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::Result(format!("{}: {e}", dir.display())))?;
    }
    if let Some(path) = &args.rerun {
        let named = [Some(&model_path), args.pose.as_ref()];
        super::rerun_out::check_path(path, &rig, named.into_iter().flatten())?;
    }
    let mut rerun = match &args.rerun {
        Some(path) => Some(super::rerun_out::RerunOut::create(path, &sensor, &rig)?),
        None => None,
    };
    let bar = ProgressBar::new(rig.frames.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut reports = Vec::new();
    let window = if args.track {
        1
    } else {
        args.window.unwrap_or_else(default_window)
    };
    let clock = std::time::Instant::now();
    let mut hold = (args.hold).then(|| {
        let frames = sensor.tare().map_or(0, |t| t.frames);
        Hold::new(HoldParams::default(), frames, sensor.params.model_error)
    });
    let each = |obs: &SenseResult<Observation>, mut report: FrameReport| -> Result<(), Halt> {
        let frame = report.frame;
        if let Some(hold) = &mut hold {
            hold.push(&mut report);
        }
        if let Some(t) = rec.truth_of(frame) {
            report.errors = Some(compare(&report, t));
        }
        if let (Some(dir), Ok(obs)) = (&args.render, obs) {
            for view in &obs.views {
                let name = match rig.is_one_folder() {
                    true => format!("frame_{frame:04}.png"),
                    false => format!("frame_{frame:04}_{}.png", rig.cameras[view.camera].name),
                };
                let path = dir.join(name);
                let camera = &rig.cameras[view.camera].recording;
                picture(camera, &sensor, view, &report, &path)
                    .map_err(|e| CliError::Result(format!("{}: {e}", path.display())))
                    .map_err(Halt::Failed)?;
            }
        }
        if let Some(out) = &mut rerun {
            out.frame(&sensor, obs, &report).map_err(Halt::Failed)?;
        }
        bar.suspend(|| -> CliResult {
            if args.json {
                let line =
                    serde_json::to_string(&report).map_err(|e| CliError::Other(Box::new(e)))?;
                outln!("{line}")?;
                Ok(())
            } else {
                print_human(&report)
            }
        })
        .map_err(Halt::Failed)?;
        bar.inc(1);
        reports.push(report);
        // Nobody reads stdout any more (`| head`) and no pictures or recording are being
        // written: the remaining frames would produce nothing.
        if stdout_closed() && args.render.is_none() && args.rerun.is_none() {
            return Err(Halt::ReaderGone);
        }
        Ok(())
    };
    let streamed = if args.track {
        sensor.track_frames(&rig, &rig.frames, each)
    } else {
        sensor.sense_frames(&rig, &rig.frames, window, each)
    };
    match streamed {
        Ok(()) => {}
        Err(Halt::ReaderGone) => eprintln!(
            "stdout was closed: stopped after {} of {} frames",
            reports.len(),
            rig.frames.len()
        ),
        Err(Halt::Failed(e)) => return Err(e),
    }
    let wall_ms = clock.elapsed().as_secs_f64() * 1e3;
    bar.finish_and_clear();
    if let (Some(out), Some(path)) = (rerun, &args.rerun) {
        let frames = out.finish()?;
        eprintln!(
            "wrote {} ({frames} frames); open it with `rerun {}`",
            path.display(),
            path.display()
        );
    }
    summary(&reports, wall_ms, window, args.track);
    if reports
        .iter()
        .all(|r| !matches!(r.status, FrameStatus::Sensed))
    {
        return Err(CliError::Result(format!(
            "no frame could be sensed{}",
            no_robot_hint(&reports, colourless(&rig))
        )));
    }
    Ok(())
}

/// Takes the first `--reference-frames` frames of `rig` as the sensor's reference, and says
/// how far the body sat off its model.
fn take_reference(args: &SenseArgs, rig: &Rig, sensor: &mut Sensor) -> CliResult {
    let n = args.reference_frames;
    if n == 0 {
        return Ok(());
    }
    if n >= rig.frames.len() {
        return Err(CliError::Usage(format!(
            "--reference-frames {n}: the recording has {} frames; the reference must leave some to sense",
            rig.frames.len()
        )));
    }
    let frames: Vec<usize> = rig.frames[..n].to_vec();
    if let Some((frame, load)) = args.known_load {
        if !rig.frames.contains(&frame) || frames.contains(&frame) {
            return Err(CliError::Usage(format!(
                "--known-load {frame}={load}: frame {frame} is not a frame of the recording after the reference frames"
            )));
        }
        let fit = (sensor.calibrate_modulus(rig, &frames, frame, load, &Default::default()))
            .map_err(|e| CliError::Lib(e.into()))?;
        let known = format!(", known to {:.2}%", 100.0 * fit.relative_sigma);
        let rounds = (fit.rounds.len(), fit.converged);
        print_modulus("modulus", sensor, fit.factor, fit.young, rounds, &known);
    }
    if args.modulus_from_sag {
        let fit = (sensor.fit_modulus_from_sag(rig, &frames, Default::default()))
            .map_err(|e| CliError::Lib(e.into()))?;
        let rounds = (fit.rounds.len(), fit.converged);
        print_modulus(
            "modulus from the sag",
            sensor,
            fit.factor,
            fit.young,
            rounds,
            "",
        );
    }
    let tare = match sensor.tare() {
        Some(tare) => tare,
        None => (sensor.take_reference(rig, &frames, Default::default()))
            .map_err(|e| CliError::Lib(e.into()))?,
    };
    eprintln!(
        "reference: frames {:?}: the body sits {:.3} mm RMS off the model's unloaded surface (a node at most {:.3} mm); {:.3} mm RMS is left, the depth noise and detail finer than the mesh",
        frames,
        tare.rms_before * 1e3,
        tare.largest_offset() * 1e3,
        tare.rms_after * 1e3
    );
    Ok(())
}

/// Prints a fitted modulus: its factor over the model file's, the rounds `(count,
/// converged)`, and the value to put in the model file (in its units) and in Pa.
fn print_modulus(
    what: &str,
    sensor: &Sensor,
    factor: f64,
    young: f64,
    rounds: (usize, bool),
    tail: &str,
) {
    let units = sensor.model.units.pressure;
    let converged = if rounds.1 { "" } else { ", not converged" };
    eprintln!(
        "{what}: {factor:.4} times the model file's ({} rounds{converged}): young = {:.6e} in the model file's units ({young:.4e} Pa){tail}",
        rounds.0,
        young / units,
    );
}

/// The recording folder: one camera (with `--pose` applied) or several.
fn open_rig(args: &SenseArgs) -> Result<Rig, CliError> {
    let mut rig = Rig::open(&args.scene_dir).map_err(|e| CliError::Lib(e.into()))?;
    if let Some(pose) = &args.pose {
        rig = rig.with_pose_file(pose).map_err(|e| match e {
            RecordingError::PoseForRig { .. } => CliError::Usage(format!("--pose: {e}")),
            e => CliError::Lib(e.into()),
        })?;
    }
    match &args.cameras {
        Some(names) if rig.is_one_folder() => Err(CliError::Usage(format!(
            "--cameras {} is for a folder of several cameras; {} is one camera's",
            names.join(","),
            args.scene_dir.display()
        ))),
        Some(names) => rig
            .keep_cameras(names)
            .map_err(|e| CliError::Usage(e.to_string())),
        None => Ok(rig),
    }
}

/// Which cable inputs `sensor` senses with, in words: the recorded ones, else the
/// calibration's (set on `sensor`), else the model file's.
fn use_recorded_inputs(rec: &Recording, sensor: &mut Sensor) -> Result<String, CliError> {
    use softsense::recording::InputsFile;
    let recorded = rec.recorded.as_ref().map(|r| r.kind);
    let file = rec.calibration_file().unwrap_or(&rec.dir).to_path_buf();
    let calibrated = sensor
        .use_recording_inputs(rec)
        .map_err(|e| CliError::Result(format!("{}: {e}", file.display())))?;
    Ok(match (recorded, calibrated) {
        (Some(InputsFile::Actuators), _) => "recorded (actuators.json)".to_string(),
        (recorded, true) => {
            let calibrated = format!("calibrated ({})", super::shown_path(&file).display());
            match recorded {
                Some(_) => format!("recorded (inputs.json), else {calibrated}"),
                None => calibrated,
            }
        }
        (Some(InputsFile::Inputs), false) => "recorded (inputs.json)".to_string(),
        (None, false) => "the model file's".to_string(),
    })
}

/// The model file: `--model`, else the one the recording names.
fn model_path(args: &SenseArgs, rec: &Recording) -> Result<PathBuf, CliError> {
    match (&args.model, rec.model_path()) {
        (Some(m), _) => Ok(m.clone()),
        (None, Some(m)) if !m.exists() => {
            let by = rec.model_named_by().unwrap_or_default();
            Err(CliError::Usage(format!(
                "{} names the model as {}, which is not there (from the recording's folder, or from here): give --model MODEL.toml",
                by.display(),
                m.display()
            )))
        }
        (None, Some(m)) => Ok(m),
        (None, None) => Err(CliError::Usage(format!(
            "{} has no truth.json or calibration.json naming its model: give --model MODEL.toml",
            args.scene_dir.display()
        ))),
    }
}

/// Why the frame stream stopped early.
enum Halt {
    Failed(CliError),
    /// stdout's reader has gone and nothing else is being written.
    ReaderGone,
}

/// The frame of `view`'s camera (`rec`) as [`softsense::render::frame_picture`] draws it.
fn picture(
    rec: &Recording,
    sensor: &Sensor,
    view: &View,
    report: &FrameReport,
    path: &std::path::Path,
) -> Result<(), Box<dyn std::error::Error>> {
    softsense::render::frame_picture(&rec.camera.intrinsics, sensor, view, report)?
        .save_png(path)?;
    Ok(())
}

/// `--registration`'s values ([`softsense::sense::Registration`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RegistrationArg {
    /// Dense for a frame with one seen contact (or several, after a reference),
    /// features otherwise.
    Auto,
    /// The feature points.
    Features,
    /// Every robot point.
    Dense,
}

impl From<RegistrationArg> for softsense::sense::Registration {
    fn from(arg: RegistrationArg) -> Self {
        match arg {
            RegistrationArg::Auto => Self::Auto,
            RegistrationArg::Features => Self::Features,
            RegistrationArg::Dense => Self::Dense,
        }
    }
}

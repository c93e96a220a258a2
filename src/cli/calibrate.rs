//! `softsense calibrate`: camera pose and initial actuator inputs from one RGB-D frame of
//! the robot and a rough pose (thesis 3.3.2, markers not needed).

use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::calibrate::{
    calibrate, camera_agreement, read_pose, recording_robot_points, CalibrateParams, Calibration,
    CalibrationStatus, IterationReport,
};
use softsense::fem::model::Model;
use softsense::math::Iso3;
use softsense::recording::{Recording, Rig};
use std::path::{Path, PathBuf};

/// Calibrate the camera-to-robot transform and the cable inputs from a frame.
#[derive(Args, Debug)]
#[command(
    about = "Camera-to-robot pose and cable inputs from one frame and a rough pose",
    long_about = "Calibrate the camera-to-robot transform and the initial cable inputs of the \
FE model from one RGB-D frame of the robot (thesis 3.3.2, Algorithm 3.1), without markers: \
ICP on the exact closest FE surface points, then the actuator QP (3.18) with the pose, \
re-solving the FE model until both settle.\n\n\
SCENE_DIR is a recording folder in any layout `sense` reads (depth_NNNN.png + \
color_NNNN.png + intrinsics.json as `softsense scene generate` writes them, a PCL grabber \
sequence, or Open3D depth/ + color/ folders; docs/recording-format.md). The rough start pose is \
{\"robot_from_camera\": 4x4} (--start, default SCENE_DIR/rough_pose.json); it should be \
within about 10 degrees and 30 mm. Writes calibration.json (robot_from_camera, the \
cable tensions and shortenings, and the model file's path) into SCENE_DIR or --out. \
`softsense sense` on that folder then takes its pose, its model, and its cable inputs for \
frames without recorded ones (actuators.json); calibrate on a frame where nothing \
touches the robot.\n\n\
A folder of several cameras (one sub-folder each, as `sense` reads it) is calibrated camera \
by camera: each from its own NAME/rough_pose.json, each written to NAME/calibration.json, \
on the same frame number; then every pair of cameras is checked against each other on the \
robot's surface (each camera's robot points against a plane through the other's nearest \
points, where both see the robot): the median, RMS and 95th percentile distance. A few \
tenths of a millimetre is noise; more says one pose is off.",
    after_help = "Examples:\n  softsense calibrate clouds/scenes/calib meshes/models/robot.toml \
--start clouds/scenes/calib/rough_pose.json\n  \
softsense calibrate my_two_cameras meshes/models/robot.toml   # front/ and side/, each with rough_pose.json"
)]
pub struct CalibrateArgs {
    /// Recording folder (any layout `sense` reads).
    scene_dir: PathBuf,
    /// FE model file (TOML).
    model: PathBuf,
    /// Rough robot_from_camera pose (JSON); default SCENE_DIR/rough_pose.json.
    #[arg(long)]
    start: Option<PathBuf>,
    /// Frame number to use (depth_NNNN's number; in PCL grabber and Open3D folders the
    /// position in name order from 0).
    #[arg(long, default_value_t = 0)]
    frame: usize,
    /// Robot colour (sRGB) for the colour model, as in `sense`.
    #[arg(long, value_name = "R,G,B", value_parser = super::parse_rgb, default_value = "40,200,60")]
    robot_color: [u8; 3],
    /// Where to write calibration.json (default SCENE_DIR/calibration.json).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `softsense calibrate`.
pub fn run(args: &CalibrateArgs) -> CliResult {
    let params = CalibrateParams {
        color: softsense::segment::robot_color::RobotColorModel::with_reference(args.robot_color),
        ..Default::default()
    };
    let model = Model::load(&args.model, None).map_err(softsense::Error::from)?;
    let rig = Rig::open(&args.scene_dir).map_err(softsense::Error::from)?;
    if rig.is_one_folder() {
        let start = start_pose(args.start.as_deref(), &args.scene_dir)?;
        let out = (args.out.clone()).unwrap_or_else(|| args.scene_dir.join("calibration.json"));
        check_out(args, &out)?;
        let rec = &rig.cameras[0].recording;
        let (cal, written, _) = calibrate_camera(args, rec, &model, &params, &start, &out)?;
        return finish(args, &cal, &written);
    }
    if args.out.is_some() || args.start.is_some() {
        return Err(CliError::Usage(format!(
            "{} has cameras {}: each camera's rough pose is read from its folder \
             (NAME/rough_pose.json) and its calibration written there (NAME/calibration.json), \
             so --start and --out do not apply",
            args.scene_dir.display(),
            rig.camera_names().join(", ")
        )));
    }
    let mut seen = Vec::new();
    for camera in &rig.cameras {
        let dir = &camera.recording.dir;
        eprintln!("camera {}:", camera.name);
        let start = start_pose(None, dir)?;
        let out = dir.join("calibration.json");
        let (cal, written, points) =
            calibrate_camera(args, &camera.recording, &model, &params, &start, &out)
                .map_err(|e| CliError::Result(format!("camera {}: {e}", camera.name)))?;
        if !args.json {
            outln!("camera {}:", camera.name)?;
            print_summary(&cal)?;
        }
        seen.push((camera.name.clone(), cal, written, points));
    }
    report_agreement(&seen, args.json)?;
    let poor: Vec<&str> = (seen.iter())
        .filter(|(_, cal, _, _)| cal.status == CalibrationStatus::PoorFit)
        .map(|(name, _, _, _)| name.as_str())
        .collect();
    if !poor.is_empty() {
        return Err(CliError::Result(format!(
            "the fit did not match the frame of camera(s) {}: start pose too far off or wrong model",
            poor.join(", ")
        )));
    }
    Ok(())
}

/// Calibrates one camera of `rec` from `start`, writes `out` and checks for a touch;
/// returns the calibration, what was written, and its robot points in the robot frame.
fn calibrate_camera(
    args: &CalibrateArgs,
    rec: &Recording,
    model: &Model,
    params: &CalibrateParams,
    start: &Iso3,
    out: &Path,
) -> Result<(Calibration, serde_json::Value, Vec<[f64; 3]>), CliError> {
    let points = recording_robot_points(rec, args.frame, params).map_err(softsense::Error::from)?;
    eprintln!("{} robot points in frame {}", points.len(), args.frame);
    let cal =
        calibrate(model, &points, start, params, print_progress).map_err(softsense::Error::from)?;
    let written = write_result(args, &cal, out)?;
    eprintln!("wrote {}", out.display());
    if cal.status != CalibrationStatus::PoorFit {
        touch_check(rec, args.frame, model, params, &cal)?;
    }
    let pose = softsense::math::pose::Pose::from_matrix(&cal.robot_from_camera)
        .map_err(|e| CliError::Result(e.to_string()))?;
    let in_robot = points.iter().map(|&p| pose.apply(p)).collect();
    Ok((cal, written, in_robot))
}

/// Prints one camera's result and fails on a poor fit.
fn finish(args: &CalibrateArgs, cal: &Calibration, written: &serde_json::Value) -> CliResult {
    if args.json {
        print_json(written)?;
    } else {
        print_summary(cal)?;
    }
    if cal.status == CalibrationStatus::PoorFit {
        return Err(CliError::Result(format!(
            "the fit did not match the frame (residual RMS {:.3} mm): start pose too far off \
             or wrong model",
            cal.residual_rms * 1e3
        )));
    }
    Ok(())
}

/// How well each pair of calibrated cameras agrees on the robot's surface (their robot
/// points in the robot frame), printed; with `json`, every camera's calibration and the
/// pairs as one JSON object.
fn report_agreement(seen: &[Calibrated], json: bool) -> CliResult {
    let mut pairs = Vec::new();
    for (i, (a, _, _, pa)) in seen.iter().enumerate() {
        for (b, _, _, pb) in &seen[i + 1..] {
            let agreement = camera_agreement(pa, pb, AGREEMENT_RADIUS, 4);
            if !json {
                match &agreement {
                    Some(g) => outln!(
                        "cameras {a} and {b} agree on the robot's surface over {} points: \
                         median {:.3} mm, RMS {:.3} mm, 95% within {:.3} mm",
                        g.overlap_points,
                        g.median * 1e3,
                        g.rms * 1e3,
                        g.p95 * 1e3
                    )?,
                    None => outln!("cameras {a} and {b} see no part of the robot in common")?,
                }
            }
            pairs.push(serde_json::json!({"cameras": [a, b], "agreement": agreement}));
        }
    }
    if json {
        let cameras: serde_json::Map<String, serde_json::Value> = (seen.iter())
            .map(|(name, _, written, _)| (name.clone(), written.clone()))
            .collect();
        print_json(&serde_json::json!({"cameras": cameras, "agreement": pairs}))?;
    }
    Ok(())
}

/// A camera's name, calibration, what was written, and its robot points (robot frame).
type Calibrated = (String, Calibration, serde_json::Value, Vec<[f64; 3]>);

/// Two cameras see the same surface where the other's 10 nearest points are within this
/// (m): a few point spacings at 0.5 m.
const AGREEMENT_RADIUS: f64 = 0.004;

/// Refuses an `out` that is a file calibrate reads: a frame, the camera files, the model
/// or the start pose. calibration.json itself is calibrate's own output, written again.
fn check_out(args: &CalibrateArgs, out: &Path) -> CliResult {
    let start = (args.start.clone()).unwrap_or_else(|| args.scene_dir.join("rough_pose.json"));
    let mut inputs = super::recording_files(&args.scene_dir);
    inputs.retain(|p| !p.ends_with("calibration.json"));
    inputs.extend([args.model.clone(), start]);
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    super::check_output_file(out, &inputs)
}

/// The rough start pose: `start`, else DIR/rough_pose.json.
fn start_pose(start: Option<&Path>, dir: &Path) -> Result<Iso3, CliError> {
    let start_path = start.map_or_else(|| dir.join("rough_pose.json"), Path::to_path_buf);
    if !start_path.exists() {
        return Err(CliError::Usage(format!(
            "no rough start pose: {} does not exist (give --start POSE.json with \
             {{\"robot_from_camera\": 4x4}})",
            start_path.display()
        )));
    }
    Ok(read_pose(&start_path).map_err(softsense::Error::from)?)
}

/// One line per outer iteration on stderr.
fn print_progress(i: usize, r: &IterationReport) {
    eprintln!(
        "iteration {i}: rms {:.3} mm over {} points, pose moved {:.3} mm {:.4} deg, \
         tensions moved {:.4} N",
        r.residual_rms * 1e3,
        r.matched,
        r.translation_change * 1e3,
        r.rotation_change.to_degrees(),
        r.tension_change
    )
}

/// Writes the result to `out` with the model it used (relative to the file's folder where
/// it can be), so that `sense` on the folder finds the model without --model; returns
/// what it wrote.
fn write_result(
    args: &CalibrateArgs,
    cal: &Calibration,
    out: &Path,
) -> Result<serde_json::Value, CliError> {
    let mut result = serde_json::to_value(cal).map_err(|e| CliError::Result(e.to_string()))?;
    let out_dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let model_named = softsense::scene::relative_to(&args.model, &out_dir)
        .or_else(|| std::fs::canonicalize(&args.model).ok())
        .unwrap_or_else(|| args.model.clone());
    result["model"] = serde_json::Value::String(model_named.display().to_string());
    let text = serde_json::to_string_pretty(&result)
        .map_err(|e| CliError::Result(format!("cannot encode the result: {e}")))?;
    softsense::io::atomic::write(out, text.as_bytes())
        .map_err(|e| CliError::Result(e.to_string()))?;
    Ok(result)
}

/// The human-readable summary on stdout: status, pose matrix, cable inputs.
fn print_summary(cal: &Calibration) -> CliResult {
    outln!(
        "status {:?} after {} iterations, residual RMS {:.3} mm over {} points",
        cal.status,
        cal.iterations,
        cal.residual_rms * 1e3,
        cal.points
    )?;
    outln!("robot_from_camera:")?;
    for row in cal.robot_from_camera {
        outln!(
            "  {:>10.6} {:>10.6} {:>10.6} {:>10.6}",
            row[0],
            row[1],
            row[2],
            row[3]
        )?;
    }
    for a in &cal.actuators {
        outln!(
            "cable {:<8} tension {:>8.4} N  shortening {:>8.3} mm",
            a.name,
            a.tension,
            a.shortening * 1e3
        )?;
    }
    Ok(())
}

/// Warns when an object touches the robot in the calibrated frame: the calibration then
/// took its dent for the robot's shape (and the cable inputs bent to match it). The frame
/// is seen as `sense` would see it at the calibrated pose: cropped above the table, robot
/// and objects by colour, the same contact detection.
fn touch_check(
    rec: &Recording,
    frame: usize,
    model: &Model,
    params: &CalibrateParams,
    cal: &Calibration,
) -> CliResult {
    use softsense::sense::{SenseParams, Sensor};
    let robot_from_camera = softsense::math::pose::Pose::from_matrix(&cal.robot_from_camera)
        .map_err(|e| CliError::Result(e.to_string()))?;
    let sense_params = SenseParams {
        color: params.color,
        ..Default::default()
    };
    let sensor = Sensor::new(model.clone(), robot_from_camera, sense_params);
    let obs = sensor
        .observe(rec, frame)
        .map_err(|e| CliError::Lib(e.into()))?;
    let contacts = sensor
        .contacts(&obs)
        .map_err(|e| CliError::Result(e.to_string()))?;
    for c in &contacts {
        let [x, y, z] = c.centroid.map(|v| v * 1e3);
        eprintln!(
            "warning: frame {}: an object touches the robot at ({x:.1}, {y:.1}, {z:.1}) mm \
             (robot frame, {} contact points): the calibration took its dent for the \
             robot's shape; calibrate on a frame where nothing touches the robot (--frame)",
            frame, c.points
        );
    }
    Ok(())
}

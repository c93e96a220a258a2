//! `softsense pose look-at`: a rough camera pose for `calibrate`, from where the camera is
//! and what it looks at.

use super::{CliError, CliResult};
use clap::Args;
use softsense::camera::{Camera, PinholeIntrinsics};
use softsense::math::pose::Pose;
use softsense::recording::Recording;
use std::path::PathBuf;

/// Arguments of `softsense pose`.
#[derive(Debug, Args)]
#[command(
    about = "Write a rough robot_from_camera pose (rough_pose.json) from a look-at or clicked points",
    long_about = "Write the rough pose `calibrate` starts from, {\"robot_from_camera\": 4x4}, in one \
of two ways; calibrate needs it within about 10 degrees and 30 mm.\n\n\
A look-at: where the camera is (--eye), a point it looks at (--target) and which way is up in \
the image (--up: the robot-frame direction that appears upwards), all in the robot frame, in \
metres, measured with a ruler.\n\n\
Clicked points: three or more pixels of a recording's frame, each with the robot-frame point \
it shows (--recording DIR --click U,V=X,Y,Z ...; a corner of the base, the tip, a marked spot): \
each pixel is read in 3-D from the frame's depth (the median of its 3x3 window), and the rigid \
fit of those points onto the robot points (Kabsch) is the pose; its RMS residual is printed.\n\n\
The robot frame is the model's mesh frame (after its placement), in metres: a mesh in mm \
with its base at z = 0 and the camera 40 cm above and 30 cm in front of it is, for example, \
--eye 0,-0.3,0.4 --target 0,0,0.05 --up 0,0,1.",
    after_help = "Examples:\n  softsense pose --eye 0,-0.3,0.4 --target 0,0,0.05 --up 0,0,1 --out rough_pose.json\n  \
softsense pose --recording REC --click 320,400=0,0,0 --click 410,380=0.05,0,0 --click 330,120=0,0,0.12 --out REC/rough_pose.json"
)]
pub struct PoseArgs {
    /// Camera centre in the robot frame (m), X,Y,Z.
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        required_unless_present = "click"
    )]
    pub eye: Option<String>,
    /// A point the camera looks at (m), X,Y,Z.
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        required_unless_present = "click"
    )]
    pub target: Option<String>,
    /// A pixel and the robot-frame point it shows, U,V=X,Y,Z (pixels; metres); three or
    /// more, with --recording.
    #[arg(long, value_name = "U,V=X,Y,Z", allow_hyphen_values = true, requires = "recording", conflicts_with_all = ["eye", "target"])]
    pub click: Vec<String>,
    /// The recording whose frame the clicks are on.
    #[arg(long, value_name = "DIR")]
    pub recording: Option<PathBuf>,
    /// The frame the clicks are on.
    #[arg(long, default_value_t = 0)]
    pub frame: usize,
    /// The robot-frame direction that appears upwards in the image, X,Y,Z.
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        default_value = "0,0,1"
    )]
    pub up: String,
    /// Where to write the pose (JSON).
    #[arg(long, default_value = "rough_pose.json")]
    pub out: PathBuf,
}

fn vec3(name: &str, s: &str) -> Result<[f64; 3], CliError> {
    super::model_new::parse_vec3(s).map_err(|e| CliError::Usage(format!("--{name} {s:?}: {e}")))
}

/// Runs `softsense pose`.
pub fn run(args: &PoseArgs) -> CliResult {
    if let Some(dir) = &args.recording {
        return from_clicks(args, dir);
    }
    let (eye, target) = (args.eye.as_deref(), args.target.as_deref());
    let (eye, target) = (
        vec3("eye", eye.unwrap_or(""))?,
        vec3("target", target.unwrap_or(""))?,
    );
    // look_at puts the camera's y axis (down the image) along -up.
    let up = vec3("up", &args.up)?;
    let any = PinholeIntrinsics {
        width: 1,
        height: 1,
        fx: 1.0,
        fy: 1.0,
        cx: 0.5,
        cy: 0.5,
    };
    let camera = Camera::look_at(any, eye, target, up).ok_or_else(|| {
        CliError::Usage("--eye and --target coincide, or --up is along the line of sight".into())
    })?;
    let pose = camera.robot_from_camera();
    write_pose(args, pose)?;
    let d = softsense::math::norm(softsense::math::sub(target, eye));
    super::out(format_args!(
        "{}: camera at ({}, {}, {}) m, looking {:.3} m to ({}, {}, {}); next: softsense calibrate RECORDING MODEL --start {}\n",
        args.out.display(), eye[0], eye[1], eye[2], d, target[0], target[1], target[2], args.out.display()
    ))
}

fn write_pose(args: &PoseArgs, pose: &Pose) -> CliResult {
    let json = serde_json::json!({ "robot_from_camera": pose });
    super::check_output_file(&args.out, &[])?;
    softsense::io::atomic::write(&args.out, format!("{json:#}\n").as_bytes())
        .map_err(|e| CliError::Result(e.to_string()))
}

/// The pose that carries the clicked pixels' 3-D points onto their robot points.
fn from_clicks(args: &PoseArgs, dir: &std::path::Path) -> CliResult {
    if args.click.len() < 3 {
        return Err(CliError::Usage(format!(
            "{} --click given: a pose needs three or more pixels with their robot points",
            args.click.len()
        )));
    }
    let lib = |e: softsense::recording::RecordingError| CliError::Lib(e.into());
    let recording = Recording::open(dir).map_err(lib)?;
    let cloud = recording.read_frame(args.frame).map_err(lib)?;
    let (mut seen, mut robot) = (Vec::new(), Vec::new());
    for click in &args.click {
        let bad = || {
            CliError::Usage(format!(
                "--click {click:?}: give U,V=X,Y,Z, e.g. 320,240=0,0,0.1"
            ))
        };
        let (pixel, at) = click.split_once('=').ok_or_else(bad)?;
        let uv: Vec<u32> = pixel
            .split(',')
            .filter_map(|c| c.trim().parse().ok())
            .collect();
        let [u, v] = uv[..] else { return Err(bad()) };
        seen.push(depth_at(&cloud, u, v).ok_or_else(|| {
            CliError::Result(format!(
                "--click {click}: no depth at or around pixel ({u}, {v}) of frame {} ({}x{}): click a spot the camera measured",
                args.frame, cloud.width, cloud.height
            ))
        })?);
        robot.push(vec3("click", at)?);
    }
    let iso = softsense::geometry::rigid::kabsch(&seen, &robot).ok_or_else(|| {
        CliError::Result("the clicked points fit no pose (all on one line?)".into())
    })?;
    let pose = Pose::from_iso(&iso);
    let rms = (seen.iter().zip(&robot))
        .map(|(s, r)| softsense::math::norm(softsense::math::sub(pose.apply(*s), *r)).powi(2))
        .sum::<f64>()
        / seen.len() as f64;
    write_pose(args, &pose)?;
    super::out(format_args!(
        "{}: fitted to {} clicked points, RMS residual {:.1} mm (a few mm is clicking; tens of mm, a wrong point); next: softsense calibrate {} MODEL --start {}\n",
        args.out.display(),
        seen.len(),
        1e3 * rms.sqrt(),
        dir.display(),
        args.out.display()
    ))
}

/// The camera-frame point at pixel (u, v): the median of its 3x3 window's valid points.
fn depth_at(cloud: &softsense::cloud::PointCloud, u: u32, v: u32) -> Option<[f64; 3]> {
    if u >= cloud.width || v >= cloud.height {
        return None;
    }
    let mut window: Vec<[f64; 3]> = Vec::new();
    for y in v.saturating_sub(1)..=(v + 1).min(cloud.height - 1) {
        for x in u.saturating_sub(1)..=(u + 1).min(cloud.width - 1) {
            let p = cloud.positions[(y * cloud.width + x) as usize];
            if p.iter().all(|c| c.is_finite()) {
                window.push(p.map(f64::from));
            }
        }
    }
    if window.is_empty() {
        return None;
    }
    // The median depth's point: a window across an edge keeps one surface's point.
    window.sort_by(|a, b| a[2].total_cmp(&b[2]));
    Some(window[window.len() / 2])
}

//! `softsense pose look-at`: a rough camera pose for `calibrate`, from where the camera is
//! and what it looks at.

use super::{CliError, CliResult};
use clap::Args;
use softsense::camera::{Camera, PinholeIntrinsics};
use std::path::PathBuf;

/// Arguments of `softsense pose`.
#[derive(Debug, Args)]
#[command(
    about = "Write a rough robot_from_camera pose (rough_pose.json) from a look-at",
    long_about = "Write the rough pose `calibrate` starts from, {\"robot_from_camera\": 4x4}, from \
where the camera is (--eye), a point it looks at (--target) and which way is up in the image \
(--up: the robot-frame direction that appears upwards), all in the robot frame, in metres. \
Measure them with a ruler: calibrate needs the pose within about 10 degrees and 30 mm.\n\n\
The robot frame is the model's mesh frame (after its placement), in metres: a mesh in mm \
with its base at z = 0 and the camera 40 cm above and 30 cm in front of it is, for example, \
--eye 0,-0.3,0.4 --target 0,0,0.05 --up 0,0,1.",
    after_help = "Example:\n  softsense pose --eye 0,-0.3,0.4 --target 0,0,0.05 --up 0,0,1 --out rough_pose.json"
)]
pub struct PoseArgs {
    /// Camera centre in the robot frame (m), X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub eye: String,
    /// A point the camera looks at (m), X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub target: String,
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
    let v: Vec<f64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(CliError::Usage(format!(
            "--{name} {s:?}: give three numbers X,Y,Z"
        ))),
    }
}

/// Runs `softsense pose`.
pub fn run(args: &PoseArgs) -> CliResult {
    let (eye, target) = (vec3("eye", &args.eye)?, vec3("target", &args.target)?);
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
    let json = serde_json::json!({ "robot_from_camera": pose });
    super::check_output_file(&args.out, &[])?;
    softsense::io::atomic::write(&args.out, format!("{json:#}\n").as_bytes())
        .map_err(|e| CliError::Result(e.to_string()))?;
    let d = softsense::math::norm(softsense::math::sub(target, eye));
    super::out(format_args!(
        "{}: camera at ({}, {}, {}) m, looking {:.3} m to ({}, {}, {}); next: softsense calibrate RECORDING MODEL --start {}\n",
        args.out.display(), eye[0], eye[1], eye[2], d, target[0], target[1], target[2], args.out.display()
    ))
}

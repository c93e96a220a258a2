//! A recorded (or generated) RGB-D sequence: a folder as written by `softsense scene
//! generate`: `depth_NNNN.png`, `color_NNNN.png`, `intrinsics.json`, a pose
//! (`calibration.json` from `softsense calibrate`, else `camera_pose.json`), optionally
//! `actuators.json` (recorded actuator inputs) and `truth.json` (only read to report errors,
//! never for the estimate).

use super::{SenseError, SenseResult};
use crate::calibrate::ActuatorCalibration;
use crate::io::intrinsics::{read_camera_model, CameraModel};
use crate::math::pose::{Pose, PoseError};
use crate::scene::{ActuatorTruth, FrameTruth, Truth};
use std::path::{Path, PathBuf};

/// A recorded (or generated) RGB-D sequence.
#[derive(Clone, Debug)]
pub struct Recording {
    /// The folder.
    pub dir: PathBuf,
    /// Intrinsics and depth units.
    pub camera: CameraModel,
    /// The camera's pose in the robot frame.
    pub robot_from_camera: Pose,
    /// Which file the pose came from.
    pub pose_file: PathBuf,
    /// Frame numbers, ascending.
    pub frames: Vec<usize>,
    /// Recorded actuator inputs per frame, if any.
    pub actuators: Option<Vec<Vec<ActuatorTruth>>>,
    /// The cable inputs of the calibration (`calibration.json`'s `actuators`), if the pose
    /// came from one: for frames without recorded inputs, see
    /// [`Sensor::use_calibrated_inputs`](super::Sensor::use_calibrated_inputs).
    pub calibrated: Option<Vec<ActuatorCalibration>>,
    /// The model file the calibration names (`calibration.json`'s `model`), as written.
    pub calibration_model: Option<String>,
    /// The generator's truth, if any (used for error reports only).
    pub truth: Option<Truth>,
}

fn file_err(path: &Path, e: impl std::fmt::Display) -> SenseError {
    SenseError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> SenseResult<T> {
    let text = std::fs::read_to_string(path).map_err(|e| file_err(path, e))?;
    serde_json::from_str(&text).map_err(|e| file_err(path, e))
}

#[derive(serde::Deserialize)]
struct PoseFile {
    robot_from_camera: [[f64; 4]; 4],
    /// The cable inputs `softsense calibrate` found (calibration.json only).
    #[serde(default)]
    actuators: Option<Vec<ActuatorCalibration>>,
    /// The model file the calibration used, relative to the file's folder unless absolute
    /// (calibration.json only).
    #[serde(default)]
    model: Option<String>,
}

impl Recording {
    /// Opens a recording folder: finds the frames, reads intrinsics and the pose
    /// (`calibration.json` if present, else `camera_pose.json`), and the optional
    /// `actuators.json` and `truth.json`.
    pub fn open(dir: &Path) -> SenseResult<Self> {
        let entries = std::fs::read_dir(dir).map_err(|e| file_err(dir, e))?;
        let mut frames: Vec<usize> = entries
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let num = name.strip_prefix("depth_")?.strip_suffix(".png")?;
                num.parse().ok()
            })
            .collect();
        frames.sort_unstable();
        if frames.is_empty() {
            return Err(SenseError::NoFrames(dir.display().to_string()));
        }
        let camera = read_camera_model(dir.join("intrinsics.json"))?;
        let calib = dir.join("calibration.json");
        let pose_file = if calib.exists() {
            calib
        } else {
            dir.join("camera_pose.json")
        };
        let pose: PoseFile = read_json(&pose_file)?;
        // A scale or shear in the pose would put every point somewhere else, and frames
        // were then estimated with nonsense, flagged unreliable at best.
        let robot_from_camera = Pose::from_matrix(&pose.robot_from_camera).map_err(|e| {
            let PoseError::NotRigid { reason } = e;
            file_err(
                &pose_file,
                format!("robot_from_camera is not a rigid transform: {reason}"),
            )
        })?;
        let opt = |name: &str| {
            let p = dir.join(name);
            p.exists().then_some(p)
        };
        let actuators = opt("actuators.json").map(|p| read_json(&p)).transpose()?;
        let truth = opt("truth.json").map(|p| read_json(&p)).transpose()?;
        Ok(Self {
            dir: dir.to_path_buf(),
            camera,
            robot_from_camera,
            calibrated: pose.actuators,
            calibration_model: pose.model,
            pose_file,
            frames,
            actuators,
            truth,
        })
    }

    /// The model file named by the truth (generated scenes), else by the calibration, if
    /// any (see [`Recording::model_named_by`]). A relative path is taken from the
    /// recording's folder; if nothing is there, as it is (recordings made before
    /// 2026-11-24 name it from the directory `scene generate` ran in).
    pub fn model_path(&self) -> Option<PathBuf> {
        self.model_source().map(|(path, _)| path)
    }

    /// The file that names [`Recording::model_path`]: `truth.json`, else the pose file
    /// (`calibration.json`); `None` when neither names a model.
    pub fn model_named_by(&self) -> Option<PathBuf> {
        self.model_source().map(|(_, by)| by)
    }

    // The truth's model unless it is missing where the calibration's is there: a recording
    // copied away from the repository keeps a truth.json naming a path that no longer
    // resolves, while `softsense calibrate` names the model it was given.
    fn model_source(&self) -> Option<(PathBuf, PathBuf)> {
        let resolve = |named: &str| {
            let named = PathBuf::from(named);
            let in_dir = self.dir.join(&named);
            if named.is_relative() && in_dir.exists() {
                in_dir
            } else {
                named
            }
        };
        let truth = self.truth.as_ref().map(|t| resolve(&t.model_path));
        let calibration = self.calibration_model.as_deref().map(resolve);
        match (truth, calibration) {
            (Some(t), Some(c)) if !t.exists() && c.exists() => Some((c, self.pose_file.clone())),
            (Some(t), _) => Some((t, self.dir.join("truth.json"))),
            (None, Some(c)) => Some((c, self.pose_file.clone())),
            (None, None) => None,
        }
    }

    /// The recorded actuator inputs of `frame`, if any.
    pub fn actuators_of(&self, frame: usize) -> Option<&[ActuatorTruth]> {
        self.actuators
            .as_ref()
            .and_then(|a| a.get(frame))
            .map(|v| v.as_slice())
    }

    /// The truth of `frame`, if any.
    pub fn truth_of(&self, frame: usize) -> Option<&FrameTruth> {
        self.truth
            .as_ref()
            .and_then(|t| t.frames.iter().find(|f| f.frame == frame))
    }

    /// Paths of the depth and colour images of `frame`.
    pub fn frame_paths(&self, frame: usize) -> (PathBuf, PathBuf) {
        (
            self.dir.join(format!("depth_{frame:04}.png")),
            self.dir.join(format!("color_{frame:04}.png")),
        )
    }
}

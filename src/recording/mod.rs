//! One recording folder format, read by every command that takes frames (`sense`,
//! `calibrate`, `explain`, `filter`) and written by `scene generate` and `hidden`
//! ([`RecordingWriter`]).
//!
//! A folder holds frames in one of three [`Layout`]s (softsense's own, a PCL image grabber
//! sequence, an Open3D RGB-D dataset), and optionally:
//! - `calibration.json` (from `softsense calibrate`) or `camera_pose.json`: the camera pose
//!   `robot_from_camera` (a pose can also be given to [`Recording::with_pose`]);
//! - `inputs.json` (one [`FrameInput`] per frame: cable inputs and known loads) or
//!   `actuators.json` (per frame, each cable's [`ActuatorTruth`]): the recorded inputs;
//! - `truth.json`: the generator's truth, for error reports only.
//!
//! File names inside these files (the model) resolve against the folder, never the working
//! directory. The format is in `docs/recording-format.md`.
//!
//! ```
//! use softsense::recording::{Layout, Recording};
//! let rec = Recording::open("clouds/scenes/tip_weight".as_ref()).unwrap();
//! assert_eq!(rec.layout, Layout::Softsense);
//! assert!(rec.robot_from_camera.is_some());
//! assert_eq!(rec.inputs_of(rec.frames[0]).unwrap().cables.len(), 4);
//! ```

mod inputs;
mod layout;
pub mod schema;
mod write;

pub use inputs::{InputsFile, RecordedInputs};
pub use layout::{list_frames, FrameFiles, Layout};
pub use schema::{
    ActuatorCalibration, ActuatorTruth, CableInput, Calibration, FrameInput, FrameTruth, Truth,
};
pub use write::{write_json, RecordingWriter};

use crate::io::intrinsics::{read_camera_model, CameraModel};
use crate::io::IoError;
use crate::math::pose::{Pose, PoseError};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of reading a recording folder.
#[derive(Debug, Error)]
pub enum RecordingError {
    /// An image or camera file could not be read.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A JSON file could not be read or parsed.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// No frame in any known layout.
    #[error(
        "{path}: no frames (depth_NNNN.png + color_NNNN.png + intrinsics.json, \
         STEM_depth.tiff + STEM_rgb.tiff + STEM.xml, or depth/ + color/ folders with \
         intrinsics.json)"
    )]
    NoFrames {
        /// The folder.
        path: PathBuf,
    },
    /// A depth image without a camera file.
    #[error("{depth}: no camera file (STEM.xml or intrinsics.json) for this depth image")]
    NoCamera {
        /// The depth image.
        depth: PathBuf,
    },
    /// Frames of two layouts in one folder.
    #[error("{path}: frames of two layouts (depth_NNNN.* and STEM_depth.*): keep one")]
    MixedLayouts {
        /// The folder.
        path: PathBuf,
    },
    /// Open3D layout with a different number of depth and colour images.
    #[error("{path}: {color} colour images for {depth} depth images")]
    Unpaired {
        /// Depth images.
        depth: usize,
        /// Colour images.
        color: usize,
        /// The colour folder.
        path: PathBuf,
    },
    /// Two images of the same kind for one frame number.
    #[error("{first} and {second} are both frame {number}: keep one")]
    DuplicateFrame {
        /// The frame number.
        number: usize,
        /// One image.
        first: PathBuf,
        /// The other.
        second: PathBuf,
    },
    /// A frame number the recording does not have.
    #[error("no frame {frame} in the recording (frames {first}..={last})")]
    NoSuchFrame {
        /// The frame asked for.
        frame: usize,
        /// First frame.
        first: usize,
        /// Last frame.
        last: usize,
    },
}

/// `Result` of reading a recording.
pub type RecordingResult<T> = std::result::Result<T, RecordingError>;

/// A recorded (or generated) RGB-D sequence.
#[derive(Clone, Debug)]
pub struct Recording {
    /// The folder.
    pub dir: PathBuf,
    /// How the folder lays out its frames.
    pub layout: Layout,
    /// Intrinsics and depth units of the first frame (a PCL grabber frame may carry its own:
    /// [`Recording::camera_of`]).
    pub camera: CameraModel,
    /// The camera's pose in the robot frame, if the folder or the caller gave one.
    pub robot_from_camera: Option<Pose>,
    /// Which file the pose came from.
    pub pose_file: Option<PathBuf>,
    /// Frame numbers, ascending.
    pub frames: Vec<usize>,
    files: Vec<FrameFiles>,
    cameras: Vec<CameraModel>,
    /// Recorded inputs per frame (`inputs.json`, else `actuators.json`), if any.
    pub recorded: Option<RecordedInputs>,
    /// The cable inputs of the calibration (`calibration.json`'s `actuators`), if the pose
    /// came from one.
    pub calibrated: Option<Vec<ActuatorCalibration>>,
    /// The model file the calibration names (`calibration.json`'s `model`), as written.
    pub calibration_model: Option<String>,
    /// The generator's truth, if any (used for error reports only).
    pub truth: Option<Truth>,
    /// What was wrong with optional files that were then left out (an unreadable
    /// `truth.json`: the frames are sensed unscored).
    pub warnings: Vec<String>,
}

pub(crate) fn file_err(path: &Path, e: impl std::fmt::Display) -> RecordingError {
    RecordingError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Reads a JSON file of a recording.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> RecordingResult<T> {
    let text = std::fs::read_to_string(path).map_err(|e| file_err(path, e))?;
    serde_json::from_str(&text).map_err(|e| file_err(path, e))
}

#[derive(serde::Deserialize)]
struct PoseFile {
    robot_from_camera: [[f64; 4]; 4],
    #[serde(default)]
    actuators: Option<Vec<ActuatorCalibration>>,
    #[serde(default)]
    model: Option<String>,
}

/// Reads `{"robot_from_camera": 4x4}` from `path` (the pose of `camera_pose.json`,
/// `calibration.json` or a `--pose` file), refusing a matrix that is not rigid.
pub fn read_pose(path: &Path) -> RecordingResult<Pose> {
    Ok(read_pose_file(path)?.0)
}

fn read_pose_file(path: &Path) -> RecordingResult<(Pose, PoseFile)> {
    let file: PoseFile = read_json(path)?;
    // A scale or shear in the pose would put every point somewhere else.
    let pose = Pose::from_matrix(&file.robot_from_camera).map_err(|e| {
        let PoseError::NotRigid { reason } = e;
        file_err(
            path,
            format!("robot_from_camera is not a rigid transform: {reason}"),
        )
    })?;
    Ok((pose, file))
}

impl Recording {
    /// Opens a recording folder: finds its frames and camera files, and reads the pose
    /// (`calibration.json` if present, else `camera_pose.json`, else none) and the optional
    /// `inputs.json`, `actuators.json` and `truth.json`.
    pub fn open(dir: &Path) -> RecordingResult<Self> {
        let (layout, mut files) = list_frames(dir)?;
        files.sort_by_key(|f| f.number);
        let mut cameras: Vec<CameraModel> = Vec::with_capacity(files.len());
        for (i, f) in files.iter().enumerate() {
            let shared = i > 0 && files[i - 1].camera == f.camera;
            let camera = match shared {
                true => cameras[i - 1],
                false => read_camera_model(&f.camera)?,
            };
            cameras.push(camera);
        }
        let opt = |name: &str| Some(dir.join(name)).filter(|p| p.exists());
        let pose_file = opt("calibration.json").or_else(|| opt("camera_pose.json"));
        let (robot_from_camera, pose) = match &pose_file {
            Some(p) => {
                let (pose, file) = read_pose_file(p)?;
                (Some(pose), Some(file))
            }
            None => (None, None),
        };
        let (calibrated, calibration_model) = pose.map_or((None, None), |p| (p.actuators, p.model));
        let mut warnings = Vec::new();
        // The truth only scores the estimates: a broken one costs the scores, not the run.
        let truth = match opt("truth.json").map(|p| read_json(&p)).transpose() {
            Ok(t) => t,
            Err(e) => {
                warnings.push(format!("{e}: left out, the frames are not scored"));
                None
            }
        };
        let recorded = match (opt("inputs.json"), opt("actuators.json")) {
            (Some(p), _) => Some(RecordedInputs::read(&p, InputsFile::Inputs)?),
            (None, Some(p)) => Some(RecordedInputs::read(&p, InputsFile::Actuators)?),
            (None, None) => None,
        };
        let frames: Vec<usize> = files.iter().map(|f| f.number).collect();
        warnings.extend(recorded.as_ref().and_then(|r| r.coverage_warning(&frames)));
        Ok(Self {
            dir: dir.to_path_buf(),
            layout,
            camera: cameras[0],
            robot_from_camera,
            pose_file,
            frames,
            files,
            cameras,
            recorded,
            calibrated,
            calibration_model,
            truth,
            warnings,
        })
    }

    /// The recording with the camera pose read from `path` (a `--pose` file) instead of
    /// the folder's.
    pub fn with_pose_file(mut self, path: &Path) -> RecordingResult<Self> {
        self.robot_from_camera = Some(read_pose(path)?);
        self.pose_file = Some(path.to_path_buf());
        Ok(self)
    }

    /// The recording with `robot_from_camera` as its camera pose, named as from `source`.
    pub fn with_pose(mut self, robot_from_camera: Pose, source: PathBuf) -> Self {
        self.robot_from_camera = Some(robot_from_camera);
        self.pose_file = Some(source);
        self
    }

    /// The recording's frames `frames` only (frame numbers not in it are errors).
    pub fn select(mut self, frames: &[usize]) -> RecordingResult<Self> {
        for &f in frames {
            self.index_of(f)?;
        }
        self.frames = frames.to_vec();
        Ok(self)
    }

    fn index_of(&self, frame: usize) -> RecordingResult<usize> {
        self.files
            .binary_search_by_key(&frame, |f| f.number)
            .map_err(|_| RecordingError::NoSuchFrame {
                frame,
                first: self.files[0].number,
                last: self.files[self.files.len() - 1].number,
            })
    }

    /// The files of `frame`.
    pub fn files_of(&self, frame: usize) -> RecordingResult<&FrameFiles> {
        Ok(&self.files[self.index_of(frame)?])
    }

    /// The camera of `frame` (intrinsics and depth units).
    pub fn camera_of(&self, frame: usize) -> RecordingResult<&CameraModel> {
        Ok(&self.cameras[self.index_of(frame)?])
    }

    /// Reads `frame` as a cloud in the camera frame (organized, coloured when the frame
    /// has a colour image).
    pub fn read_frame(&self, frame: usize) -> RecordingResult<crate::cloud::PointCloud> {
        let i = self.index_of(frame)?;
        let f = &self.files[i];
        Ok(crate::io::rgbd::read_frame(
            &f.depth,
            f.color.as_deref(),
            &self.cameras[i],
        )?)
    }

    /// The model file named by the truth (generated scenes), else by the calibration, if
    /// any (see [`Recording::model_named_by`]). A relative path is taken from the
    /// recording's folder; if nothing is there, as it is (older recordings name it from the
    /// directory `scene generate` ran in).
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
        let pose_file = || self.pose_file.clone().unwrap_or_default();
        match (truth, calibration) {
            (Some(t), Some(c)) if !t.exists() && c.exists() => Some((c, pose_file())),
            (Some(t), _) => Some((t, self.dir.join("truth.json"))),
            (None, Some(c)) => Some((c, pose_file())),
            (None, None) => None,
        }
    }

    /// The recorded inputs of `frame`: its entry of `inputs.json`, else its cables'
    /// commanded inputs from `actuators.json` (no known loads), else `None` (also for an
    /// entry that cannot be used: [`Recording::input_problem`]).
    pub fn inputs_of(&self, frame: usize) -> Option<FrameInput> {
        self.recorded.as_ref()?.get(frame).cloned()
    }

    /// Why `frame`'s recorded inputs cannot be used (a NaN, a missing field), if so.
    pub fn input_problem(&self, frame: usize) -> Option<String> {
        self.recorded.as_ref()?.problem(frame)
    }

    /// The truth of `frame`, if any.
    pub fn truth_of(&self, frame: usize) -> Option<&FrameTruth> {
        self.truth
            .as_ref()
            .and_then(|t| t.frames.iter().find(|f| f.frame == frame))
    }
}

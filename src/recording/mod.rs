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
//! A folder of several cameras keeps each camera's frames, camera file and pose in its own
//! sub-folder and the other files at the top: [`Rig`]. Marker track files (a motion-capture
//! system's, or `markers detect`'s) are read and written by [`tracks`].
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

pub mod import;
mod inputs;
mod layout;
mod rig;
pub mod schema;
pub mod tracks;
mod write;

pub use inputs::{EntryProblem, InputsFile, RecordedInputs};
pub use layout::{list_frames, FrameFiles, Layout};
pub use rig::{Rig, RigCamera};
pub use schema::{
    ActuatorCalibration, ActuatorTruth, CableInput, Calibration, CavityInput, FrameInput,
    FrameTruth, Truth,
};
pub use write::{write_json, RecordingWriter};

use crate::camera::Lens;
use crate::io::intrinsics::{read_camera_file, CameraModel};
use crate::io::IoError;
use crate::math::pose::{Pose, PoseError};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of reading a recording folder.
#[derive(Debug, Error)]
pub enum RecordingError {
    /// An output file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
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
    /// A recording path that is a file or is not there.
    #[error("{path}: {problem}")]
    NotAFolder {
        /// The path given as the recording.
        path: PathBuf,
        /// What it is instead, and what to give.
        problem: String,
    },
    /// A folder whose frames are in camera sub-folders, given where one camera's are read.
    #[error(
        "{path} is a {n}-camera recording (cameras {names}): this reads one-camera \
         recordings only, a folder with frames of its own",
        n = cameras.len(),
        names = cameras.join(", ")
    )]
    SeveralCameras {
        /// The folder.
        path: PathBuf,
        /// The cameras' names (sub-folder names).
        cameras: Vec<String>,
    },
    /// A camera of a rig could not be read.
    #[error("camera {name}: {source}")]
    Camera {
        /// The camera's name (its sub-folder).
        name: String,
        /// What went wrong.
        source: Box<RecordingError>,
    },
    /// A pose at the top of a rig's folder, where it would not say which camera it is.
    #[error(
        "{path}: robot_from_camera at the top of a {cameras}-camera recording: each \
         camera's pose goes in its own folder (NAME/calibration.json or NAME/camera_pose.json)"
    )]
    RigPose {
        /// The file.
        path: PathBuf,
        /// How many cameras the rig has.
        cameras: usize,
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
    /// A pose file given for a folder of several cameras.
    #[error(
        "a pose file is for a one-camera folder; {path} has cameras {cameras}, each with its \
         own pose (camera_pose.json or calibration.json in its folder)"
    )]
    PoseForRig {
        /// The rig's folder.
        path: PathBuf,
        /// The rig's camera names.
        cameras: String,
    },
    /// A camera name the rig does not have.
    #[error("no camera {name:?} in the recording (its cameras: {cameras})")]
    NoSuchCamera {
        /// The name asked for.
        name: String,
        /// The rig's camera names.
        cameras: String,
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
    // The lens of each frame's camera file, beside `cameras`.
    lenses: Vec<Lens>,
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
    /// The file `calibrated` and `calibration_model` came from.
    calibration_file: Option<PathBuf>,
    /// Where the shared files (`truth.json`, inputs) are: `dir`, or a rig's top folder.
    shared_dir: PathBuf,
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

/// One camera's folder: its frames, camera files and pose.
struct CameraFolder {
    layout: Layout,
    files: Vec<FrameFiles>,
    cameras: Vec<CameraModel>,
    lenses: Vec<Lens>,
    robot_from_camera: Option<Pose>,
    pose_file: Option<PathBuf>,
    calibration: Option<CalibrationFrom>,
}

/// What a calibration file adds beside a pose: the calibrated cable inputs and the model,
/// with the file it came from (a model named there resolves against its folder).
#[derive(Clone, Debug)]
struct CalibrationFrom {
    file: PathBuf,
    actuators: Option<Vec<ActuatorCalibration>>,
    model: Option<String>,
}

/// The files every camera of a recording shares (a one-camera folder's own; the top of a
/// rig's folder): recorded inputs and truth.
#[derive(Clone, Debug)]
struct Shared {
    dir: PathBuf,
    recorded: Option<RecordedInputs>,
    truth: Option<Truth>,
    warnings: Vec<String>,
}

fn existing(dir: &Path, name: &str) -> Option<PathBuf> {
    Some(dir.join(name)).filter(|p| p.exists())
}

impl CameraFolder {
    /// Reads the camera files of `files` (listed in `dir`) and the folder's pose
    /// (`calibration.json` if present, else `camera_pose.json`, else none).
    fn read(dir: &Path, layout: Layout, mut files: Vec<FrameFiles>) -> RecordingResult<Self> {
        files.sort_by_key(|f| f.number);
        let mut cameras: Vec<CameraModel> = Vec::with_capacity(files.len());
        let mut lenses: Vec<Lens> = Vec::with_capacity(files.len());
        for (i, f) in files.iter().enumerate() {
            let shared = i > 0 && files[i - 1].camera == f.camera;
            let (camera, lens) = match shared {
                // A ray table is shared, not copied.
                true => (cameras[i - 1], lenses[i - 1].clone()),
                false => read_camera_file(&f.camera)?,
            };
            cameras.push(camera);
            lenses.push(lens);
        }
        let pose_file =
            existing(dir, "calibration.json").or_else(|| existing(dir, "camera_pose.json"));
        let (robot_from_camera, calibration) = match &pose_file {
            Some(p) => {
                let (pose, file) = read_pose_file(p)?;
                let calibration = CalibrationFrom {
                    file: p.clone(),
                    actuators: file.actuators,
                    model: file.model,
                };
                (Some(pose), Some(calibration))
            }
            None => (None, None),
        };
        Ok(Self {
            layout,
            files,
            cameras,
            lenses,
            robot_from_camera,
            pose_file,
            calibration,
        })
    }
}

impl Shared {
    /// Reads the optional `inputs.json`, `actuators.json` and `truth.json` of `dir`.
    fn read(dir: &Path) -> RecordingResult<Self> {
        let mut warnings = Vec::new();
        // The truth only scores the estimates: a broken one costs the scores, not the run.
        let truth = match existing(dir, "truth.json")
            .map(|p| read_json(&p))
            .transpose()
        {
            Ok(t) => t,
            Err(e) => {
                warnings.push(format!("{e}: left out, the frames are not scored"));
                None
            }
        };
        let recorded = match (
            existing(dir, "inputs.json"),
            existing(dir, "actuators.json"),
        ) {
            (Some(p), _) => Some(RecordedInputs::read(&p, InputsFile::Inputs)?),
            (None, Some(p)) => Some(RecordedInputs::read(&p, InputsFile::Actuators)?),
            (None, None) => None,
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            recorded,
            truth,
            warnings,
        })
    }
}

impl Recording {
    /// Opens a one-camera recording folder: finds its frames and camera files, and reads
    /// the pose (`calibration.json` if present, else `camera_pose.json`, else none) and the
    /// optional `inputs.json`, `actuators.json` and `truth.json`. A folder whose frames are
    /// in camera sub-folders is refused ([`RecordingError::SeveralCameras`]): open it with
    /// [`Rig::open`].
    pub fn open(dir: &Path) -> RecordingResult<Self> {
        Self::open_with_camera(dir, None)
    }

    /// As [`Recording::open`], with `camera` (if given) in place of the folder's shared
    /// camera file (`intrinsics.json`): a recording read in place, whose folder has none.
    pub fn open_with_camera(dir: &Path, camera: Option<&Path>) -> RecordingResult<Self> {
        let (layout, files) = match layout::list_frames_with(dir, camera) {
            Err(RecordingError::NoFrames { path }) => {
                let (cameras, _) = rig::camera_folders(dir)?;
                return Err(match cameras.is_empty() {
                    true => RecordingError::NoFrames { path },
                    false => RecordingError::SeveralCameras {
                        path,
                        cameras: cameras.into_iter().map(|(name, _)| name).collect(),
                    },
                });
            }
            listed => listed?,
        };
        let folder = CameraFolder::read(dir, layout, files)?;
        let mut shared = Shared::read(dir)?;
        let frames: Vec<usize> = folder.files.iter().map(|f| f.number).collect();
        let coverage = shared.recorded.as_ref();
        let coverage = coverage.and_then(|r| r.coverage_warning(&frames));
        shared.warnings.extend(coverage);
        let calibration = folder.calibration.clone();
        Ok(Self::assemble(dir, folder, shared, calibration))
    }

    /// The recording of the camera folder `dir` with the shared files `shared` and the
    /// calibration `calibration` (cable inputs and model).
    fn assemble(
        dir: &Path,
        folder: CameraFolder,
        shared: Shared,
        calibration: Option<CalibrationFrom>,
    ) -> Self {
        let frames: Vec<usize> = folder.files.iter().map(|f| f.number).collect();
        let (calibrated, calibration_model) = calibration
            .as_ref()
            .map_or((None, None), |c| (c.actuators.clone(), c.model.clone()));
        Self {
            dir: dir.to_path_buf(),
            layout: folder.layout,
            camera: folder.cameras[0],
            robot_from_camera: folder.robot_from_camera,
            pose_file: folder.pose_file,
            frames,
            files: folder.files,
            cameras: folder.cameras,
            lenses: folder.lenses,
            recorded: shared.recorded,
            calibrated,
            calibration_model,
            calibration_file: calibration.map(|c| c.file),
            shared_dir: shared.dir,
            truth: shared.truth,
            warnings: shared.warnings,
        }
    }

    /// The file the calibrated cable inputs and model came from, if any.
    pub fn calibration_file(&self) -> Option<&Path> {
        self.calibration_file.as_deref()
    }

    /// The recording with the camera pose read from `path` (a `--pose` file) instead of
    /// the folder's.
    pub fn with_pose_file(mut self, path: &Path) -> RecordingResult<Self> {
        self.robot_from_camera = Some(read_pose(path)?);
        self.pose_file = Some(path.to_path_buf());
        Ok(self)
    }

    /// The recording with its recorded inputs read from `path` (an `inputs.json` kept
    /// elsewhere) instead of the folder's.
    pub fn with_inputs_file(mut self, path: &Path) -> RecordingResult<Self> {
        let recorded = RecordedInputs::read(path, InputsFile::Inputs)?;
        self.warnings
            .extend(recorded.coverage_warning(&self.frames));
        self.recorded = Some(recorded);
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

    /// Whether the folder has frame `frame` (whether or not [`Recording::select`] kept it).
    pub fn has_frame(&self, frame: usize) -> bool {
        self.index_of(frame).is_ok()
    }

    /// The files of `frame`.
    pub fn files_of(&self, frame: usize) -> RecordingResult<&FrameFiles> {
        Ok(&self.files[self.index_of(frame)?])
    }

    /// The camera of `frame` (intrinsics and depth units).
    pub fn camera_of(&self, frame: usize) -> RecordingResult<&CameraModel> {
        Ok(&self.cameras[self.index_of(frame)?])
    }

    /// The lens of `frame`'s camera file (the pinhole unless it gives distortion or rays).
    pub fn lens_of(&self, frame: usize) -> RecordingResult<&Lens> {
        Ok(&self.lenses[self.index_of(frame)?])
    }

    /// Reads `frame` as a cloud in the camera frame (organized, coloured when the frame
    /// has a colour image), through its camera file's lens.
    pub fn read_frame(&self, frame: usize) -> RecordingResult<crate::cloud::PointCloud> {
        let i = self.index_of(frame)?;
        let f = &self.files[i];
        Ok(crate::io::rgbd::read_frame_through(
            &f.depth,
            f.color.as_deref(),
            &self.cameras[i],
            &self.lenses[i],
        )?)
    }

    /// The model file named by the truth (generated scenes), else by the calibration, if
    /// any (see [`Recording::model_named_by`]). A relative path is taken from the folder
    /// of the file that names it; if nothing is there, as it is (older recordings name it from the
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
        let resolve = |named: &str, dir: &Path| {
            let named = PathBuf::from(named);
            let in_dir = dir.join(&named);
            if named.is_relative() && in_dir.exists() {
                in_dir
            } else {
                named
            }
        };
        let truth = (self.truth.as_ref()).map(|t| resolve(&t.model_path, &self.shared_dir));
        let calibration_file = self.calibration_file.clone().unwrap_or_default();
        let calibration_dir = calibration_file.parent().unwrap_or(&self.dir);
        let calibration = (self.calibration_model.as_deref()).map(|m| resolve(m, calibration_dir));
        match (truth, calibration) {
            (Some(t), Some(c)) if !t.exists() && c.exists() => Some((c, calibration_file)),
            (Some(t), _) => Some((t, self.shared_dir.join("truth.json"))),
            (None, Some(c)) => Some((c, calibration_file)),
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

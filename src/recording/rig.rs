//! Several cameras on one robot: a recording folder whose top has no frames of its own
//! holds one camera per sub-folder with frames, each read as a one-camera folder (its own
//! layout, camera files and pose), while the recorded inputs, the truth and the calibration
//! stay at the top. A folder with frames of its own is a rig of one camera.
//!
//! Frames of different cameras are tied by frame number (`depth_0003.png` of every camera
//! is frame 3). A camera may lack a frame the others have: [`RigCamera::has_frame`].
//!
//! ```
//! use softsense::recording::Rig;
//! let rig = Rig::open("clouds/scenes/tip_weight".as_ref()).unwrap();
//! assert_eq!(rig.cameras.len(), 1);
//! assert!(rig.is_one_folder());
//! assert!(rig.cameras[0].has_frame(rig.frames[0]));
//! ```

use super::{
    existing, list_frames, read_json, CalibrationFrom, CameraFolder, FrameFiles, Layout, Recording,
    RecordingError, RecordingResult, Shared,
};
use crate::recording::ActuatorCalibration;
use std::path::{Path, PathBuf};

/// One camera of a [`Rig`].
#[derive(Clone, Debug)]
pub struct RigCamera {
    /// The camera's name: its sub-folder's name, or `camera` for a one-camera folder.
    pub name: String,
    /// The camera's frames, camera files and pose (from its folder), with the rig's shared
    /// recorded inputs, truth and calibration.
    pub recording: Recording,
}

impl RigCamera {
    /// Whether the camera's folder has frame `frame` (a camera may miss frames the others
    /// have).
    pub fn has_frame(&self, frame: usize) -> bool {
        self.recording.has_frame(frame)
    }
}

/// A recording of any number of cameras (see the module docs).
#[derive(Clone, Debug)]
pub struct Rig {
    /// The top folder.
    pub dir: PathBuf,
    /// The cameras, in name order (one for a folder with frames of its own).
    pub cameras: Vec<RigCamera>,
    /// Every frame number any camera has, ascending.
    pub frames: Vec<usize>,
    /// What was wrong with optional shared files that were then left out, and which frames
    /// have no recorded inputs.
    pub warnings: Vec<String>,
}

/// The top's `calibration.json` in a rig: the cable inputs and model; a pose there is
/// refused (it would not say which camera it is).
#[derive(serde::Deserialize)]
struct SharedCalibration {
    #[serde(default)]
    robot_from_camera: Option<serde_json::Value>,
    #[serde(default)]
    actuators: Option<Vec<ActuatorCalibration>>,
    #[serde(default)]
    model: Option<String>,
}

/// A camera's sub-folder name, with its layout and frame files.
type CameraListing = (String, (Layout, Vec<FrameFiles>));

/// The sub-folders of `dir` with frames, by name (sorted), each with its layout and frame
/// files, and a warning per sub-folder left out as another's folder. A sub-folder with
/// frames that cannot be listed (no camera file, two layouts) is an error naming the
/// camera; one without any frames is not a camera. Hidden folders (`.name`) are skipped.
/// Sub-folders that resolve to the same folder (a symlink to another camera's) are one
/// camera: read as several, the same pixels would count as independent views.
pub(super) fn camera_folders(dir: &Path) -> RecordingResult<(Vec<CameraListing>, Vec<String>)> {
    let entries = std::fs::read_dir(dir).map_err(|source| crate::io::IoError::Os {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut subs: Vec<(String, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .filter_map(|e| Some((e.file_name().to_str()?.to_string(), e.path())))
        .filter(|(name, _)| !name.starts_with('.'))
        .collect();
    subs.sort();
    let (subs, warnings) = one_per_folder(subs);
    let mut out = Vec::new();
    for (name, path) in subs {
        match list_frames(&path) {
            Ok(listed) => out.push((name, listed)),
            Err(RecordingError::NoFrames { .. }) => {}
            Err(e) => return Err(camera_error(&name, e)),
        }
    }
    Ok((out, warnings))
}

/// `subs` (name, path; sorted by name) with one entry per folder they resolve to: the one
/// that is not a symlink, else the first by name; a warning for each left out.
fn one_per_folder(subs: Vec<(String, PathBuf)>) -> (Vec<(String, PathBuf)>, Vec<String>) {
    let real = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let linked = |p: &Path| std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_symlink());
    let resolved: Vec<PathBuf> = subs.iter().map(|(_, p)| real(p)).collect();
    let mut keep = vec![true; subs.len()];
    let mut warnings = Vec::new();
    for i in 0..subs.len() {
        let same: Vec<usize> = (0..subs.len())
            .filter(|&j| resolved[j] == resolved[i])
            .collect();
        if same.len() < 2 || same[0] != i {
            continue;
        }
        let kept = *same
            .iter()
            .find(|&&j| !linked(&subs[j].1))
            .unwrap_or(&same[0]);
        for &j in same.iter().filter(|&&j| j != kept) {
            keep[j] = false;
            warnings.push(format!(
                "cameras {} and {} are the same folder ({}): read once, as camera {}",
                subs[kept].0,
                subs[j].0,
                resolved[j].display(),
                subs[kept].0
            ));
        }
    }
    let subs = (subs.into_iter().zip(keep))
        .filter_map(|(s, k)| k.then_some(s))
        .collect();
    (subs, warnings)
}

fn camera_error(name: &str, e: RecordingError) -> RecordingError {
    RecordingError::Camera {
        name: name.to_string(),
        source: Box::new(e),
    }
}

impl Rig {
    /// Opens a recording of any number of cameras: a folder with frames of its own as a rig
    /// of one camera named `camera` (exactly as [`Recording::open`] reads it), else each
    /// sub-folder with frames as one camera, with `inputs.json`/`actuators.json`,
    /// `truth.json` and `calibration.json` (cable inputs and model; no pose) read from the
    /// top. No camera anywhere is [`RecordingError::NoFrames`]; a camera that cannot be
    /// read is [`RecordingError::Camera`], naming it. Sub-folders that resolve to the same
    /// folder (symlinks) are one camera, with a warning.
    pub fn open(dir: &Path) -> RecordingResult<Self> {
        let listed = match list_frames(dir) {
            Err(RecordingError::NoFrames { path }) => {
                let cameras = camera_folders(dir)?;
                if cameras.0.is_empty() {
                    return Err(RecordingError::NoFrames { path });
                }
                cameras
            }
            _ => return Self::one_folder(dir),
        };
        let (listed, same_folder) = listed;
        let mut shared = Shared::read(dir)?;
        shared.warnings.extend(same_folder);
        let calibration = shared_calibration(dir, listed.len())?;
        let mut cameras = Vec::with_capacity(listed.len());
        for (name, (layout, files)) in listed {
            let sub = dir.join(&name);
            let folder =
                CameraFolder::read(&sub, layout, files).map_err(|e| camera_error(&name, e))?;
            // The camera's own calibration file wins for the cable inputs and the model.
            let own = folder.calibration.clone();
            let own = own.filter(|c| c.actuators.is_some() || c.model.is_some());
            let calibration = own.or_else(|| calibration.clone());
            let mut camera_shared = shared.clone();
            camera_shared.warnings.clear();
            let recording = Recording::assemble(&sub, folder, camera_shared, calibration);
            cameras.push(RigCamera { name, recording });
        }
        let mut frames: Vec<usize> = (cameras.iter())
            .flat_map(|c| c.recording.frames.iter().copied())
            .collect();
        frames.sort_unstable();
        frames.dedup();
        let coverage = shared.recorded.as_ref();
        shared
            .warnings
            .extend(coverage.and_then(|r| r.coverage_warning(&frames)));
        Ok(Self {
            dir: dir.to_path_buf(),
            cameras,
            frames,
            warnings: shared.warnings,
        })
    }

    fn one_folder(dir: &Path) -> RecordingResult<Self> {
        let mut recording = Recording::open(dir)?;
        let warnings = std::mem::take(&mut recording.warnings);
        Ok(Self {
            dir: dir.to_path_buf(),
            frames: recording.frames.clone(),
            cameras: vec![RigCamera {
                name: "camera".into(),
                recording,
            }],
            warnings,
        })
    }

    /// Whether the rig is a one-camera folder (frames of its own, no camera sub-folders).
    pub fn is_one_folder(&self) -> bool {
        self.cameras.len() == 1 && self.cameras[0].recording.dir == self.dir
    }

    /// The camera named `name`, if any.
    pub fn camera(&self, name: &str) -> Option<&RigCamera> {
        self.cameras.iter().find(|c| c.name == name)
    }

    /// The cameras that have frame `frame`.
    pub fn cameras_with(&self, frame: usize) -> impl Iterator<Item = &RigCamera> {
        self.cameras.iter().filter(move |c| c.has_frame(frame))
    }

    /// The rig's frames `frames` only: each camera keeps those it has. A frame no camera
    /// has is an error.
    pub fn select(mut self, frames: &[usize]) -> RecordingResult<Self> {
        for &frame in frames {
            if self.frames.binary_search(&frame).is_err() {
                return Err(RecordingError::NoSuchFrame {
                    frame,
                    first: self.frames[0],
                    last: self.frames[self.frames.len() - 1],
                });
            }
        }
        for c in &mut self.cameras {
            let own: Vec<usize> = (frames.iter().copied())
                .filter(|&f| c.has_frame(f))
                .collect();
            c.recording.frames = own;
        }
        self.frames = frames.to_vec();
        Ok(self)
    }

    /// The one-camera rig with its camera's pose read from `path` (a `--pose` file)
    /// instead of the folder's; a rig of several cameras is
    /// [`RecordingError::PoseForRig`].
    pub fn with_pose_file(mut self, path: &Path) -> RecordingResult<Self> {
        if !self.is_one_folder() {
            return Err(RecordingError::PoseForRig {
                path: self.dir.clone(),
                cameras: self.camera_names().join(", "),
            });
        }
        let camera = &mut self.cameras[0];
        camera.recording = camera.recording.clone().with_pose_file(path)?;
        Ok(self)
    }

    /// The cameras' names, in order.
    pub fn camera_names(&self) -> Vec<String> {
        self.cameras.iter().map(|c| c.name.clone()).collect()
    }

    /// The rig with only the cameras named in `names`, in the rig's order; the frames are
    /// those any of them has. An unknown name is [`RecordingError::NoSuchCamera`].
    pub fn keep_cameras(mut self, names: &[String]) -> RecordingResult<Self> {
        if let Some(name) = names.iter().find(|n| self.camera(n).is_none()) {
            return Err(RecordingError::NoSuchCamera {
                name: name.clone(),
                cameras: self.camera_names().join(", "),
            });
        }
        self.cameras.retain(|c| names.contains(&c.name));
        self.frames = (self.cameras.iter())
            .flat_map(|c| c.recording.frames.iter().copied())
            .collect();
        self.frames.sort_unstable();
        self.frames.dedup();
        Ok(self)
    }

    /// The shared files' view of the rig (recorded inputs, truth, model): the first
    /// camera's recording, which holds them like every other camera's.
    pub fn shared(&self) -> &Recording {
        &self.cameras[0].recording
    }
}

/// The top's `calibration.json` of a rig of `cameras` cameras, if any.
fn shared_calibration(dir: &Path, cameras: usize) -> RecordingResult<Option<CalibrationFrom>> {
    let Some(path) = existing(dir, "calibration.json") else {
        return Ok(None);
    };
    let file: SharedCalibration = read_json(&path)?;
    if file.robot_from_camera.is_some() {
        return Err(RecordingError::RigPose { path, cameras });
    }
    Ok(Some(CalibrationFrom {
        file: path,
        actuators: file.actuators,
        model: file.model,
    }))
}

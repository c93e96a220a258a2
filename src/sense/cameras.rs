//! The cameras a [`Sensor`] looks through, and what each saw of a frame: one camera for a
//! [`Recording`], any number for a [`Rig`] ([`CameraFrames`]). All cameras' robot points,
//! in the robot frame, are registered together, each dense row with its own camera's ray
//! and depth noise; contacts come from the union of their points (so two cameras seeing one
//! contact give one contact); a camera without the frame, or whose frame cannot be read,
//! is left out of that frame ([`CameraReport`]) while the others are sensed, and so is a
//! camera that shows no robot point (a wrong pose: [`CameraState::NoRobot`]).

use super::{Recording, SenseError, SenseResult, Sensor};
use crate::math::pose::Pose;
use crate::recording::{FrameInput, Rig};
use serde::{Deserialize, Serialize};

/// What to check when a camera puts no point in the box around the robot (one camera's
/// frames, or one camera of a rig).
pub const POSE_HINT: &str = "check the camera pose (robot_from_camera maps camera coordinates \
     to the robot's, in metres; not its inverse)";

/// What to check when the box around the robot holds points but none of the robot's colour.
pub const COLOUR_HINT: &str = "check --robot-color";

/// One camera of a [`Sensor`].
#[derive(Clone, Debug)]
pub struct SensorCamera {
    /// The camera's name (its folder's in a rig; `camera` for a one-camera recording).
    pub name: String,
    /// The camera's pose in the robot frame.
    pub robot_from_camera: Pose,
    /// The camera centre in the robot frame (m).
    pub eye: [f64; 3],
}

impl SensorCamera {
    /// The camera `name` at `robot_from_camera`.
    pub fn new(name: &str, robot_from_camera: Pose) -> Self {
        Self {
            name: name.to_string(),
            eye: robot_from_camera.origin(),
            robot_from_camera,
        }
    }
}

/// Frames seen by one or more cameras, in the sensor's camera order: a [`Recording`] (one
/// camera) or a [`Rig`].
pub trait CameraFrames: Sync {
    /// How many cameras.
    fn camera_count(&self) -> usize;
    /// Camera `k`'s recording (its frames, camera files and pose, and the shared inputs).
    fn camera_recording(&self, k: usize) -> &Recording;
    /// Camera `k`'s name.
    fn camera_name(&self, k: usize) -> &str;
    /// The recorded cable inputs of `frame` (shared by all cameras).
    fn inputs_of(&self, frame: usize) -> Option<FrameInput> {
        self.camera_recording(0).inputs_of(frame)
    }
}

impl CameraFrames for Recording {
    fn camera_count(&self) -> usize {
        1
    }
    fn camera_recording(&self, _: usize) -> &Recording {
        self
    }
    fn camera_name(&self, _: usize) -> &str {
        "camera"
    }
}

impl CameraFrames for Rig {
    fn camera_count(&self) -> usize {
        self.cameras.len()
    }
    fn camera_recording(&self, k: usize) -> &Recording {
        &self.cameras[k].recording
    }
    fn camera_name(&self, k: usize) -> &str {
        &self.cameras[k].name
    }
}

/// What one camera gave a frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum CameraState {
    /// Read and used.
    Seen {
        /// Its robot points in the crop.
        robot_points: usize,
        /// Its object points in the crop.
        object_points: usize,
    },
    /// Read, but with no robot point in the box around the robot: its pose (or the robot's
    /// colour) is wrong for it. Left out of the frame, with its points: a pose that misses
    /// the robot would put the objects it sees in the wrong place too.
    NoRobot {
        /// Its points in the box around the robot, none of the robot's colour.
        object_points: usize,
    },
    /// The camera has no such frame.
    Missing,
    /// The frame's files could not be read (the message says why).
    Unreadable {
        /// What went wrong.
        message: String,
    },
}

/// One camera's part in a frame of a several-camera recording.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraReport {
    /// The camera's name.
    pub name: String,
    /// What it gave the frame.
    #[serde(flatten)]
    pub state: CameraState,
}

impl CameraReport {
    /// Whether the camera's frame was read and used.
    pub fn is_seen(&self) -> bool {
        matches!(self.state, CameraState::Seen { .. })
    }
}

impl std::fmt::Display for CameraReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.state {
            CameraState::Seen {
                robot_points,
                object_points,
            } => write!(
                f,
                "{}: robot {robot_points} pts, objects {object_points} pts",
                self.name
            ),
            CameraState::NoRobot { object_points: 0 } => write!(
                f,
                "{}: no point in the box around the robot: {}",
                self.name, POSE_HINT
            ),
            CameraState::NoRobot { object_points } => write!(
                f,
                "{}: none of its {object_points} points in the box around the robot is of the robot's colour: {COLOUR_HINT}, or {POSE_HINT}",
                self.name
            ),
            CameraState::Missing => write!(f, "{}: no such frame", self.name),
            CameraState::Unreadable { message } => write!(f, "{}: {message}", self.name),
        }
    }
}

/// Each camera's part in a frame, `; `-separated.
pub(super) fn joined(cameras: &[CameraReport]) -> String {
    let each: Vec<String> = cameras.iter().map(ToString::to_string).collect();
    each.join("; ")
}

impl Sensor {
    /// A sensor for every camera of `rig`, each at its folder's pose
    /// ([`Sensor::with_cameras`]); a camera without one is [`SenseError::NoPose`].
    pub fn for_rig(
        model: crate::fem::model::Model,
        rig: &Rig,
        params: super::SenseParams,
    ) -> SenseResult<Self> {
        let mut cameras = Vec::with_capacity(rig.cameras.len());
        for c in &rig.cameras {
            let pose = c
                .recording
                .robot_from_camera
                .ok_or_else(|| SenseError::NoPose {
                    dir: c.recording.dir.clone(),
                })?;
            cameras.push(SensorCamera::new(&c.name, pose));
        }
        Ok(Self::with_cameras(model, cameras, params))
    }

    /// Checks that `source` has the sensor's cameras, by count and name.
    pub fn check_cameras(&self, source: &impl CameraFrames) -> SenseResult<()> {
        let names: Vec<String> = (0..source.camera_count())
            .map(|k| source.camera_name(k).to_string())
            .collect();
        let mine: Vec<String> = self.cameras.iter().map(|c| c.name.clone()).collect();
        // A one-camera sensor reads any one-camera recording, whatever its name.
        if names.len() == mine.len() && (mine.len() == 1 || names == mine) {
            return Ok(());
        }
        Err(SenseError::Cameras {
            sensor: mine,
            recording: names,
        })
    }
}

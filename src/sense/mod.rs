//! Marker-free force sensing, frame by frame (thesis 4.5, Algorithms 4.1-4.2): an RGB-D
//! frame in, "touched here, this hard" out.
//!
//! Per frame: depth + colour → points in the camera frame → the robot frame
//! (`robot_from_camera`) → crop to the robot's working box above the table → robot points by
//! a colour model (hue and chroma in CIELAB, robust to shading) and object points (the rest)
//! → KD-tree contact detection and Euclidean grouping ([`crate::contact`]) → location mapping
//! (each contact to the nearest surface node of the FE model at the actuated state, refined at
//! the estimated state) → registration of the surface features along their normal lines
//! ([`crate::register`]) → the intensity QP with FE updates ([`crate::inverse::estimate`]).
//! Where no contact is seen (a weight hanging by a thin string), the model's declared force
//! points are the candidates and the one that explains the frame best is reported.
//!
//! A recording is a folder read by [`crate::recording`] ([`Recording`]). Without recorded
//! inputs, the model's are used: the model file's, or the calibration's after
//! [`Sensor::use_calibrated_inputs`] (`rec.calibrated`), as `softsense sense` does.
//!
//! The API: [`Sensor::observe`] reads a frame, [`Sensor::sense`] senses it alone and
//! [`Sensor::track`] as the next frame of a stream; [`Sensor::sense_frames`] senses many
//! frames side by side and [`Sensor::track_frames`] one after the other as a stream.
//!
//! ```no_run
//! use softsense::sense::{Recording, SenseParams, Sensor};
//! let rec = Recording::open("clouds/scenes/tip_weight".as_ref()).unwrap();
//! let model = softsense::fem::model::Model::load(&rec.model_path().unwrap(), None).unwrap();
//! let sensor = Sensor::new(model, rec.robot_from_camera.unwrap(), SenseParams::default());
//! for &frame in &rec.frames {
//!     let obs = sensor.observe(&rec, frame).unwrap();
//!     let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
//!     println!("{:?}", report.forces);
//! }
//! ```

mod blend;
mod cameras;
mod estimate;
mod free;
mod hold;
mod locate;
pub mod membrane;
mod modulus;
mod observe;
mod params;
mod reference;
mod report;
mod sag;
pub mod score;
mod stream;
mod timings;
mod track;

pub use crate::recording::{Recording, Rig};
pub use blend::{largest_sigma, LocationAlternative};
pub use cameras::{CameraFrames, CameraReport, CameraState, SensorCamera, COLOUR_HINT, POSE_HINT};
pub use free::SAME_INPUT;
pub use hold::{HeldForce, Hold, HoldParams};
pub use modulus::{KnownLoadProblem, ModulusFit, ModulusParams, ModulusRound};
pub use observe::{Observation, View};
pub use params::{Registration, SenseParams, CHI2_3DOF_95};
pub use report::{compare, ForceEstimate, FrameReport, FrameStatus, LoadError, MIN_SCORED_FORCE};
pub use sag::{SagFit, SagRound};
pub use stream::default_window;
pub use timings::{median_timings, StageTimings};
pub use track::Track;

use crate::fem::mesh::Surface;
use crate::fem::model::Model;
use crate::fem::solve::CableControl;
use crate::fem::solve::{apply_cable_inputs, apply_cavity_inputs};
use crate::math::pose::Pose;
use crate::recording::{ActuatorCalibration, FrameInput};
use crate::register::{surface_features, FeatureParams, SurfaceFeature};
use free::FreeSolves;
use serde::Serialize;
use std::path::PathBuf;
use thiserror::Error;

/// Errors of the sensing stage (per recording; per-frame failures are [`FrameStatus`]es).
#[derive(Debug, Error)]
pub enum SenseError {
    /// The recording could not be read.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
    /// Image or intrinsics reading failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The frame's entry of the recorded inputs cannot be used.
    #[error("recorded inputs: {path}: frame {frame}: {problem}")]
    Inputs {
        /// The recorded inputs file (`inputs.json` or `actuators.json`).
        path: PathBuf,
        /// The frame.
        frame: usize,
        /// Why its entry cannot be used.
        #[source]
        problem: crate::recording::EntryProblem,
    },
    /// A frame's recorded cable inputs do not fit the model: a cable it does not have, or
    /// not exactly one of shorten and force.
    #[error("recorded inputs: {0}")]
    CableInputs(#[source] crate::fem::FemError),
    /// A calibrated cable input names a cable the model does not have: the calibration is
    /// of another model.
    #[error(
        "calibrated cable inputs: the model has no cable named {cable:?} (its cables: {})",
        model_cables.join(", ")
    )]
    UnknownCalibratedCable {
        /// The calibration's cable.
        cable: String,
        /// The model's cables.
        model_cables: Vec<String>,
    },
    /// A calibrated cable input that is not finite.
    #[error(
        "calibrated cable inputs: cable {cable:?}: tension {tension} N, shortening {shortening} m: \
         not finite"
    )]
    NonFiniteCalibratedCable {
        /// The cable.
        cable: String,
        /// Its calibrated tension (N).
        tension: f64,
        /// Its calibrated shortening (m).
        shortening: f64,
    },
    /// The recording's cameras are not the sensor's.
    #[error(
        "the sensor has cameras [{}], the recording [{}]",
        sensor.join(", "),
        recording.join(", ")
    )]
    Cameras {
        /// The sensor's camera names.
        sensor: Vec<String>,
        /// The recording's camera names.
        recording: Vec<String>,
    },
    /// A camera without a pose (the folder has neither calibration.json nor
    /// camera_pose.json).
    #[error("{dir} has no camera pose (calibration.json or camera_pose.json)")]
    NoPose {
        /// The camera's folder.
        dir: PathBuf,
    },
    /// A reference frame in which a contact is seen: a reference must show the body
    /// unloaded.
    #[error("reference frame {frame}: {contacts} contact(s) seen; a reference frame must show the body unloaded")]
    LoadedReference {
        /// The frame.
        frame: usize,
        /// Contacts seen in it.
        contacts: usize,
    },
    /// The model's unloaded state at a reference frame's inputs could not be solved.
    #[error("reference frame {frame}: the unloaded model: {source}")]
    Reference {
        /// The frame.
        frame: usize,
        /// Why.
        source: crate::fem::FemError,
    },
    /// No robot point of the reference frames met the model's surface within reach.
    #[error("reference frames {frames:?}: no robot point lies on the model's unloaded surface (within the reference's max_offset): is the camera pose right?")]
    EmptyReference {
        /// The frames.
        frames: Vec<usize>,
    },
    /// A frame given with a known load could not calibrate the modulus.
    #[error("known load on frame {frame}: {why}")]
    KnownLoad {
        /// The frame.
        frame: usize,
        /// Why.
        why: KnownLoadProblem,
    },
    /// A modulus that is not a material's.
    #[error("the model's modulus: {0}")]
    Modulus(#[source] crate::fem::FemError),
    /// No camera could read the frame.
    #[error("no camera could read the frame: {}", self::cameras::joined(cameras))]
    NoCamera {
        /// Each camera's part: missing, or unreadable and why.
        cameras: Vec<CameraReport>,
    },
}

/// `Result` of the sensing stage.
pub type SenseResult<T> = std::result::Result<T, SenseError>;

/// The per-recording state: the model and its features.
pub struct Sensor {
    /// The FE model (its cable controls are replaced per frame by recorded inputs).
    pub model: Model,
    /// Feature points on the surface.
    pub features: Vec<SurfaceFeature>,
    /// Parameters.
    pub params: SenseParams,
    /// A dense pool of features (same rules), from which those near a seen contact join
    /// the frame's features.
    pub local_pool: Vec<SurfaceFeature>,
    /// The cameras, in the order of the recordings sensed (one for a [`Recording`]).
    pub cameras: Vec<SensorCamera>,
    /// Crop box in the robot frame (m).
    pub bounds: [[f64; 3]; 2],
    /// The model's surface (triangles and nodes), computed once.
    pub surface: Surface,
    /// Free solves of the latest distinct actuator inputs (a stream repeats them).
    free: FreeSolves,
    /// Where the model's own cable inputs (used for frames without recorded ones) come
    /// from.
    model_inputs: ModelInputs,
    /// The reference of unloaded frames, if taken ([`Sensor::take_reference`]).
    tare: Option<crate::inverse::Tare>,
    /// The frames the reference was taken from (their reports say so).
    reference_frames: Vec<usize>,
}

/// Where the cable inputs of a frame without recorded ones come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelInputs {
    /// The model file's `[[cables]]`.
    #[default]
    ModelFile,
    /// A calibration's ([`Sensor::use_calibrated_inputs`]).
    Calibration,
}

impl Sensor {
    /// Prepares the features (flat patches the camera at `robot_from_camera` sees) for a
    /// one-camera [`Recording`].
    pub fn new(model: Model, robot_from_camera: Pose, params: SenseParams) -> Self {
        Self::with_cameras(
            model,
            vec![SensorCamera::new("camera", robot_from_camera)],
            params,
        )
    }

    /// Prepares the features (flat patches any of `cameras` sees) for frames of these
    /// cameras, in this order ([`Rig`]: [`SensorCamera`]s named as its cameras).
    pub fn with_cameras(model: Model, cameras: Vec<SensorCamera>, mut params: SenseParams) -> Self {
        params.features.eyes = cameras.iter().map(|c| c.eye).collect();
        let surface = model.problem.mesh.surface();
        let features = surface_features(
            &model.problem.mesh.nodes_in_rest,
            &surface,
            &params.features,
        );
        let local_pool = if params.local_features_radius > 0.0 {
            surface_features(
                &model.problem.mesh.nodes_in_rest,
                &surface,
                &FeatureParams {
                    count: params.local_feature_pool,
                    ..params.features.clone()
                },
            )
        } else {
            Vec::new()
        };
        // The pool's farthest-point sampling starts like the global one's, so it holds the
        // global features too: near a contact they are registered twice, and count twice.
        // Kept on purpose: dropping the repeats lowered the residual spread of frames whose
        // force sits a node off enough to pass the fit check (see docs/sensing.md).
        let [lo, hi] = model.problem.mesh.bbox();
        let m = params.crop_margin;
        let bounds = [
            [lo[0] - m, lo[1] - m, lo[2] + params.table_clearance],
            [hi[0] + m, hi[1] + m, hi[2] + m],
        ];
        Self {
            model,
            features,
            params,
            local_pool,
            cameras,
            bounds,
            surface,
            free: FreeSolves::default(),
            model_inputs: ModelInputs::ModelFile,
            tare: None,
            reference_frames: Vec::new(),
        }
    }

    /// Where the cable inputs of frames without recorded ones come from.
    pub fn model_inputs(&self) -> ModelInputs {
        self.model_inputs
    }

    /// Takes the cable inputs a calibration found (thesis 3.3: the camera pose and the
    /// initial actuator inputs) as the model's own, for frames without recorded inputs:
    /// each cable keeps the model file's control and takes the calibrated value of it (a
    /// displacement-controlled cable its shortening, a force-controlled one its tension).
    /// Recorded inputs ([`Recording::inputs_of`]) still take precedence. A calibrated
    /// cable the model does not have, or a value that is not finite, is refused: the
    /// calibration is of another model.
    pub fn use_calibrated_inputs(&mut self, calibrated: &[ActuatorCalibration]) -> SenseResult<()> {
        let mut cables = self.model.problem.cables.clone();
        for a in calibrated {
            let c = cables
                .iter_mut()
                .find(|c| c.name == a.name)
                .ok_or_else(|| SenseError::UnknownCalibratedCable {
                    cable: a.name.clone(),
                    model_cables: (self.model.problem.cables.iter())
                        .map(|c| c.name.clone())
                        .collect(),
                })?;
            if !(a.tension.is_finite() && a.shortening.is_finite()) {
                return Err(SenseError::NonFiniteCalibratedCable {
                    cable: a.name.clone(),
                    tension: a.tension,
                    shortening: a.shortening,
                });
            }
            c.control = match c.control {
                CableControl::Displacement(_) => CableControl::Displacement(a.shortening),
                CableControl::Force(_) => CableControl::Force(a.tension),
            };
        }
        self.model.problem.cables = cables;
        // The free solves were of the old inputs.
        self.free = FreeSolves::default();
        self.model_inputs = ModelInputs::Calibration;
        Ok(())
    }

    /// The model with the cable inputs of `inputs` as its cable controls (its loads are what
    /// sensing estimates, so they are not applied); the error names a cable input that does
    /// not fit the model.
    fn actuated(&self, inputs: Option<&FrameInput>) -> SenseResult<Model> {
        let mut model = self.model.clone();
        model.problem.loads.clear();
        if let Some(inputs) = inputs {
            apply_cable_inputs(&mut model.problem.cables, &inputs.cables)
                .map_err(SenseError::CableInputs)?;
            apply_cavity_inputs(&mut model.problem.cavities, &inputs.cavities)
                .map_err(SenseError::CableInputs)?;
        }
        Ok(model)
    }

    /// Takes the cable inputs `rec` provides for frames without recorded ones, as
    /// `softsense sense` does: with `actuators.json` every frame has all its cables, so
    /// nothing is taken; otherwise the calibration's inputs, when `rec` has a
    /// `calibration.json` ([`Sensor::use_calibrated_inputs`]). Returns whether the
    /// calibration's were taken.
    pub fn use_recording_inputs(&mut self, rec: &Recording) -> SenseResult<bool> {
        use crate::recording::InputsFile;
        let all_recorded = rec
            .recorded
            .as_ref()
            .is_some_and(|r| r.kind == InputsFile::Actuators);
        match (&rec.calibrated, all_recorded) {
            (Some(cal), false) => self.use_calibrated_inputs(cal).map(|()| true),
            _ => Ok(false),
        }
    }

    /// Senses one frame. Never fails: problems are in the report's status.
    pub fn sense(
        &self,
        frame: usize,
        obs: &Observation,
        inputs: Option<&FrameInput>,
    ) -> FrameReport {
        self.sense_frame(frame, obs, inputs, None, false).0
    }

    /// [`Sensor::sense`] as a frame of a stream, starting from `prev`, what the previous
    /// frame left, when the cable inputs are the same and its contacts are seen again (each
    /// within [`SenseParams::track_radius`]): the previous locations and forces start the
    /// loop, while the location choice is made at the previous state; if it keeps the
    /// locations the estimate stands (else it is made again at the estimated state, and a
    /// new location is estimated as in an untracked frame). A frame without contacts after
    /// one without contacts resumes each declared force point's loop. Returns the report
    /// ([`FrameReport::tracked`] says whether it started from `prev`) and what this frame
    /// leaves for the next (`None` when it failed or was flagged unreliable).
    pub fn track(
        &self,
        frame: usize,
        obs: &Observation,
        inputs: Option<&FrameInput>,
        prev: Option<&Track>,
    ) -> (FrameReport, Option<Track>) {
        self.sense_frame(frame, obs, inputs, prev, true)
    }
}

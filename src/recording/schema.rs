//! The files of a recording folder, as JSON types: recorded inputs (`inputs.json`,
//! `actuators.json`), the generator's truth (`truth.json`) and the calibration
//! (`calibration.json`). See `docs/recording-format.md`.

use serde::{Deserialize, Serialize};

/// What kind of load.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LoadKind {
    /// A spherical probe pressing on the surface (rendered).
    Probe,
    /// A weight hanging from a point by a string (not rendered: the string is thin).
    Weight,
}

/// One load of a frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadInput {
    /// Probe or weight.
    pub kind: LoadKind,
    /// Point in the robot frame (m): a probe presses on the nearest surface node of the rest
    /// mesh, a weight hangs from this point itself (located in the mesh; else the node).
    /// `scene generate` refuses one more than 20 mm from every surface node.
    pub at: [f64; 3],
    /// Force vector (N).
    pub force: [f64; 3],
    /// Probe radius (m).
    #[serde(default = "default_radius")]
    pub radius: f64,
}

fn default_radius() -> f64 {
    0.008
}

/// One cable's input for a frame (exactly one of the two).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CableInput {
    /// Cable name in the model.
    pub name: String,
    /// Shortening (m).
    pub shorten: Option<f64>,
    /// Tension (N).
    pub force: Option<f64>,
}

/// One pressure cavity's input for a frame (exactly one of the two).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CavityInput {
    /// Cavity name in the model.
    pub name: String,
    /// Pressure (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pressure: Option<f64>,
    /// Volume change from rest (m^3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<f64>,
}

/// One frame: actuator inputs (unlisted cables and cavities keep the model's) and loads.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrameInput {
    /// Cable inputs.
    pub cables: Vec<CableInput>,
    /// Pressure cavity inputs.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cavities: Vec<CavityInput>,
    /// Loads.
    pub loads: Vec<LoadInput>,
}

/// The truth of one load, as applied.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LoadTruth {
    /// Probe or weight.
    pub kind: LoadKind,
    /// The nearest surface node (a probe acts on it; a weight acts at `at_rest` exactly).
    pub node: usize,
    /// The node's rest position (m).
    pub at_rest: [f64; 3],
    /// The node's deformed position (m).
    pub at_deformed: [f64; 3],
    /// Force vector (N).
    pub force: [f64; 3],
    /// Force magnitude (N).
    pub magnitude: f64,
    /// Probe centre (m) when rendered.
    pub probe_center: Option<[f64; 3]>,
    /// Probe radius (m).
    pub radius: f64,
}

/// The truth of one actuator in a frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ActuatorTruth {
    /// Cable name.
    pub name: String,
    /// Whether the input was a shortening (true) or a tension (false).
    pub displacement_controlled: bool,
    /// Shortening at equilibrium (m).
    pub shortening: f64,
    /// Tension at equilibrium (N).
    pub tension: f64,
}

impl ActuatorTruth {
    /// The input that was commanded: the shortening of a displacement-controlled cable,
    /// else the tension.
    pub fn commanded(&self) -> CableInput {
        let (shorten, force) = match self.displacement_controlled {
            true => (Some(self.shortening), None),
            false => (None, Some(self.tension)),
        };
        CableInput {
            name: self.name.clone(),
            shorten,
            force,
        }
    }
}

/// The truth of one frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameTruth {
    /// Frame index.
    pub frame: usize,
    /// Loads.
    pub loads: Vec<LoadTruth>,
    /// Actuators.
    pub actuators: Vec<ActuatorTruth>,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Pixels that hit the robot / probe / table (before holes).
    pub pixels: [usize; 3],
    /// Pixels where an occluder hides the robot (not counted in `pixels`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub occluded: usize,
    /// Per camera of a scene with several (`[[cameras]]`), in the scene's order; `pixels`
    /// and `occluded` are then the sums over the cameras. Empty for one camera.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub views: Vec<ViewTruth>,
}

/// What one camera of several saw in a frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ViewTruth {
    /// The camera's name.
    pub camera: String,
    /// Pixels that hit the robot / probe / table (before holes).
    pub pixels: [usize; 3],
    /// Pixels where an occluder hides the robot (not counted in `pixels`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub occluded: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Everything a scene folder's `truth.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Truth<Spec = serde_json::Value> {
    /// The scene spec that was used (sensor, camera, colours, seed, frames): `scene generate`
    /// writes its scene spec; readers that do not need it keep the JSON.
    pub scene: Spec,
    /// The model file. A relative path is relative to the recording's folder (where
    /// `truth.json` is); older recordings have it relative to the directory `scene generate`
    /// ran in ([`super::Recording::model_path`] reads both).
    pub model_path: String,
    /// Young's modulus (Pa) and Poisson ratio of the model (the scene's `young` applied).
    pub material: [f64; 2],
    /// The body the frames were rendered from, when the scene's `[truth]` made it differ
    /// from the model; absent when the truth is the model. What the scene was, for reports:
    /// the estimator never reads it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth_model: Option<TruthModel>,
    /// Per frame.
    pub frames: Vec<FrameTruth>,
}

/// The body a scene's frames were rendered from, when it is not the model (`[truth]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TruthModel {
    /// Its Young's modulus over the model's.
    pub young_factor: f64,
    /// Its Young's modulus (Pa).
    pub young: f64,
    /// Its Poisson ratio.
    pub poisson: f64,
    /// Its element law: "corotational", "small-strain" or "neo-hookean".
    pub formulation: String,
    /// Its mesh file (relative to the recording's folder when it can be), or the model's.
    pub mesh: String,
    /// Its base's total stiffness (N/m, each axis) when compliant; absent: clamped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_stiffness: Option<f64>,
}

/// How the calibration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CalibrationStatus {
    /// Pose and tensions settled within the tolerances.
    Converged,
    /// `max_iterations` outer iterations were done first.
    MaxIterations,
    /// The model has no cables: only the pose was fitted (and it settled).
    PoseOnly,
    /// It settled, but the final residual RMS exceeds `max_residual_rms`: a wrong local
    /// minimum (start too far off) or a model that does not match the robot.
    PoorFit,
}

/// The calibrated input of one cable.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ActuatorCalibration {
    /// Cable name.
    pub name: String,
    /// Tension λ_a (N), the QP unknown.
    pub tension: f64,
    /// The cable's shortening at the calibrated FE state (m).
    pub shortening: f64,
}

/// One outer iteration, for progress and the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IterationReport {
    /// RMS point-to-surface distance after the rigid fit (m).
    pub residual_rms: f64,
    /// Points matched (after trimming).
    pub matched: usize,
    /// How far the pose moved in this iteration (m).
    pub translation_change: f64,
    /// How far the pose turned in this iteration (rad).
    pub rotation_change: f64,
    /// Largest tension change (N).
    pub tension_change: f64,
}

/// The calibration result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Calibration {
    /// Robot-from-camera transform, row-major 4x4 (metres): p_robot = T p_camera.
    pub robot_from_camera: [[f64; 4]; 4],
    /// Calibrated input of each cable, in model order.
    pub actuators: Vec<ActuatorCalibration>,
    /// Outer iterations done.
    pub iterations: usize,
    /// RMS point-to-surface distance at the end, over the matched points (m).
    pub residual_rms: f64,
    /// Measured points used.
    pub points: usize,
    /// How it ended.
    pub status: CalibrationStatus,
    /// Per outer iteration.
    pub history: Vec<IterationReport>,
}

//! The calibration result as written to `calibration.json` (and read back by `sense`).

use serde::{Deserialize, Serialize};

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

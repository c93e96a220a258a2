//! Calibration without markers (thesis 3.3.2, Algorithm 3.1): the camera-to-robot
//! transform and the initial actuator inputs of the FE model, by sequential optimisation
//! from the robot segment of one RGB-D frame and a rough pose.
//!
//! Each outer iteration
//! 1. matches every measured robot point (camera frame, mapped to the robot frame by the
//!    current pose) to its exact closest point on the FE surface triangles at the current FE
//!    state (a KD-tree over triangle centroids finds the candidates; the closest point on
//!    each candidate triangle is exact, so there is no bias from faceted vertex normals);
//! 2. fits the rigid transform (3.15) by point-to-plane Gauss-Newton ICP, with re-matching,
//!    until the pose settles for this FE state;
//! 3. solves the actuator QP (3.17)-(3.18) on clarabel: the cable tensions λ ≥ 0 that move
//!    the FE surface points onto the measured points along the face normals, with
//!    `W_ea = H_e K⁻¹ H_aᵀ` at the current state;
//! 4. re-solves the FE model with the new tensions,
//!
//! and stops when both the pose and the tensions settle. A first, coarse stage runs
//! untrimmed ICP from the rough start and from six turned copies of it and keeps the best.
//!
//! The package: [`params`] (options), [`pose`] (pose matrices and files), [`crate::geometry::rigid`]
//! (Kabsch and point-to-plane steps), [`surface`] (exact closest points on the FE
//! surface), [`observe`] (robot pixels of a frame), `icp` (matching and rigid ICP),
//! [`solve`] (Algorithm 3.1: the actuator QP and the outer loop), [`schema`] (the
//! calibration file). With markers (known feature-point correspondences) instead of a
//! cloud: [`feature`] (the sequential method, Algorithm 3.1 with Kabsch) and [`pso`] (the
//! simultaneous method by particle swarm optimisation, 3.3.1).
//!
//! ```
//! use softsense::calibrate::{kabsch, pose_from_matrix, pose_to_matrix};
//! use softsense::math::{Iso3, Vec3};
//! let truth = Iso3::new(Vec3::new(0.1, -0.2, 0.3), Vec3::new(0.2, 0.1, -0.3));
//! let src = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
//! let dst: Vec<[f64; 3]> = src.iter().map(|p| {
//!     let q = truth * softsense::math::Point3::from(*p);
//!     [q.x, q.y, q.z]
//! }).collect();
//! let fit = kabsch(&src, &dst).unwrap();
//! assert!((fit.translation.vector - truth.translation.vector).norm() < 1e-12);
//! let back = pose_from_matrix(&pose_to_matrix(&fit)).unwrap();
//! assert!(back.rotation.angle_to(&truth.rotation) < 1e-12);
//! ```

pub mod agreement;
pub mod feature;
mod icp;
pub mod observe;
pub mod params;
pub mod pose;
pub mod pso;
pub mod schema;
pub mod solve;
pub mod surface;

pub use crate::geometry::rigid::{kabsch, point_to_plane_step};
pub use agreement::{camera_agreement, Agreement};
pub use feature::{
    calibrate_sequential, observe_features, surface_features, FeatureCalibration, FeatureStatus,
    ROBOT_MARKERS,
};
pub use observe::{read_scene_robot_points, recording_robot_points, robot_points};
pub use params::CalibrateParams;
pub use pose::{pose_difference, pose_from_matrix, pose_to_matrix, read_pose};
pub use pso::{calibrate_pso, PsoParams};
pub use schema::{ActuatorCalibration, Calibration, CalibrationStatus, IterationReport};
pub use solve::calibrate;
pub use surface::{SurfaceIndex, SurfaceMatch};

use crate::fem::FemError;
use crate::inverse::InverseError;
use thiserror::Error;

/// Errors of the calibration.
#[derive(Debug, Error)]
pub enum CalibrateError {
    /// Too few measured robot points to fit anything.
    #[error("only {found} robot points in the frame (need at least {needed}); is the robot colour right?")]
    TooFewPoints {
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
    /// The FE model has no surface triangles.
    #[error("the FE mesh has no surface")]
    NoSurface,
    /// Too few measured points lie near the FE surface: the start pose is too far off.
    #[error(
        "only {matched} of {total} points matched the FE surface: the start pose is too far off"
    )]
    LostTrack {
        /// Matched points.
        matched: usize,
        /// Points used.
        total: usize,
    },
    /// A pose file or matrix is malformed (not a rigid 4x4 transform).
    #[error("pose: {0}")]
    Pose(String),
    /// A recording or pose file could not be read.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A parameter is out of range.
    #[error("invalid parameter: {0}")]
    Param(String),
    /// The FE model failed (load, solve, factorization).
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The actuator QP failed.
    #[error(transparent)]
    Inverse(#[from] InverseError),
    /// Reading the frame failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

/// `Result` of the calibration.
pub type CalibrateResult<T> = std::result::Result<T, CalibrateError>;

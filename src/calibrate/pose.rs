//! Rigid poses as 4x4 row-major matrices and pose files.

use super::{CalibrateError, CalibrateResult};
use crate::math::pose::Pose;
use crate::math::Iso3;
use std::path::Path;

/// A 4x4 row-major matrix from a rigid transform.
pub fn pose_to_matrix(p: &Iso3) -> [[f64; 4]; 4] {
    Pose::from_iso(p).to_matrix()
}

/// A rigid transform from a 4x4 row-major matrix ([`Pose::from_matrix`]'s checks).
pub fn pose_from_matrix(m: &[[f64; 4]; 4]) -> CalibrateResult<Iso3> {
    Pose::from_matrix(m)
        .map(|p| p.to_iso())
        .map_err(|e| CalibrateError::Pose(e.to_string()))
}

/// Reads `{"robot_from_camera": 4x4}` (the format of `camera_pose.json` and
/// `calibration.json`; [`crate::recording::read_pose`]).
pub fn read_pose(path: &Path) -> CalibrateResult<Iso3> {
    Ok(crate::recording::read_pose(path)?.to_iso())
}

/// Translation distance (m) and rotation angle (rad) between two poses.
pub fn pose_difference(a: &Iso3, b: &Iso3) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

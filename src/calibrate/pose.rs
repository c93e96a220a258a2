//! Rigid poses as 4x4 row-major matrices and pose files.

use super::{CalibrateError, CalibrateResult};
use crate::math::{Iso3, Mat3};
use nalgebra::{Rotation3, Translation3, UnitQuaternion};
use serde::Deserialize;
use std::path::Path;

/// A 4x4 row-major matrix from a rigid transform.
pub fn pose_to_matrix(p: &Iso3) -> [[f64; 4]; 4] {
    let m = p.to_homogeneous();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// A rigid transform from a 4x4 row-major matrix; errors unless the upper-left block is a
/// rotation (orthonormal, det +1, to 1e-6) and the last row is (0, 0, 0, 1).
pub fn pose_from_matrix(m: &[[f64; 4]; 4]) -> CalibrateResult<Iso3> {
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(CalibrateError::Pose("non-finite entry".into()));
    }
    let r = Mat3::from_fn(|i, j| m[i][j]);
    let off = (r.transpose() * r - Mat3::identity()).amax();
    if off > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(CalibrateError::Pose(
            "the 3x3 block is not a rotation (orthonormal, det +1)".into(),
        ));
    }
    if (m[3][0], m[3][1], m[3][2], m[3][3]) != (0.0, 0.0, 0.0, 1.0) {
        return Err(CalibrateError::Pose("last row must be 0 0 0 1".into()));
    }
    let rot = Rotation3::from_matrix(&r);
    Ok(Iso3::from_parts(
        Translation3::new(m[0][3], m[1][3], m[2][3]),
        UnitQuaternion::from_rotation_matrix(&rot),
    ))
}

/// Reads `{"robot_from_camera": 4x4}` (the format of `camera_pose.json` and
/// `calibration.json`).
pub fn read_pose(path: &Path) -> CalibrateResult<Iso3> {
    #[derive(Deserialize)]
    struct PoseFile {
        robot_from_camera: [[f64; 4]; 4],
    }
    let file_err = |message: String| CalibrateError::File {
        path: path.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_err(e.to_string()))?;
    let p: PoseFile = serde_json::from_str(&text).map_err(|e| file_err(e.to_string()))?;
    pose_from_matrix(&p.robot_from_camera).map_err(|e| file_err(e.to_string()))
}

/// Translation distance (m) and rotation angle (rad) between two poses.
pub fn pose_difference(a: &Iso3, b: &Iso3) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

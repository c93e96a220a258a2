//! The one rigid pose type: a rotation and a translation, `x_to = R · x_from + t` (metres).
//!
//! Name a pose by the frames it maps between, target first: `robot_from_camera` takes
//! camera-frame points into the robot frame. Rigidity is checked where a pose is built from
//! a matrix (files, user input), never later. In JSON a pose is a row-major 4x4 homogeneous
//! matrix, as in `camera_pose.json` and `calibration.json`.
//!
//! ```
//! use softsense::math::pose::Pose;
//! let robot_from_camera = Pose::from_matrix(&[
//!     [0.0, -1.0, 0.0, 0.1],
//!     [1.0, 0.0, 0.0, 0.0],
//!     [0.0, 0.0, 1.0, 0.5],
//!     [0.0, 0.0, 0.0, 1.0],
//! ])?;
//! assert_eq!(robot_from_camera.apply([1.0, 0.0, 0.0]), [0.1, 1.0, 0.5]);
//! let camera_from_robot = robot_from_camera.inverse();
//! assert_eq!(camera_from_robot.apply([0.1, 1.0, 0.5]), [1.0, 0.0, 0.0]);
//! assert!(Pose::from_matrix(&[[2.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0],
//!     [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]).is_err());
//! # Ok::<(), softsense::math::pose::PoseError>(())
//! ```

use super::Iso3;
use serde::{Deserialize, Serialize};

/// Orthonormality tolerance of [`Pose::from_matrix`] (largest entry of RᵀR − I, and
/// |det R − 1|).
pub const RIGID_TOLERANCE: f64 = 1e-6;

/// Errors building a pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// A 4x4 matrix is not a rigid transform.
    #[error("not a rigid transform: {reason}")]
    NotRigid {
        /// What is wrong.
        reason: String,
    },
}

/// A rigid transform `x_to = rotation · x_from + translation` (metres).
///
/// The rotation is kept as the matrix it was given (not as a quaternion), so that a pose
/// read from a file maps points exactly as the file's matrix does.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "[[f64; 4]; 4]", into = "[[f64; 4]; 4]")]
pub struct Pose {
    /// Rotation matrix, row-major, orthonormal with determinant +1.
    pub rotation: [[f64; 3]; 3],
    /// Translation (m).
    pub translation: [f64; 3],
}

impl Default for Pose {
    fn default() -> Self {
        Self::identity()
    }
}

impl TryFrom<[[f64; 4]; 4]> for Pose {
    type Error = PoseError;
    fn try_from(m: [[f64; 4]; 4]) -> Result<Self, PoseError> {
        Pose::from_matrix(&m)
    }
}

impl From<Pose> for [[f64; 4]; 4] {
    fn from(p: Pose) -> Self {
        p.to_matrix()
    }
}

impl Pose {
    /// The identity.
    pub fn identity() -> Self {
        Pose {
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
        }
    }

    /// Reads a row-major 4x4 homogeneous matrix; errors unless it is finite, its last row is
    /// `0 0 0 1` and its rotation block is orthonormal with determinant +1 (within
    /// [`RIGID_TOLERANCE`]).
    pub fn from_matrix(m: &[[f64; 4]; 4]) -> Result<Self, PoseError> {
        let not_rigid = |reason: String| PoseError::NotRigid { reason };
        if !m.iter().flatten().all(|v| v.is_finite()) {
            return Err(not_rigid("an entry is not finite".into()));
        }
        if m[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(not_rigid(format!(
                "last row is {:?}, not [0, 0, 0, 1]",
                m[3]
            )));
        }
        let r = [0, 1, 2].map(|i| [m[i][0], m[i][1], m[i][2]]);
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                if (dot - want).abs() > RIGID_TOLERANCE {
                    return Err(not_rigid(format!(
                        "rotation columns {i}, {j} have dot product {dot}, want {want}"
                    )));
                }
            }
        }
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
            - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        if (det - 1.0).abs() > RIGID_TOLERANCE {
            return Err(not_rigid(format!("rotation determinant is {det}, want 1")));
        }
        Ok(Pose {
            rotation: r,
            translation: [m[0][3], m[1][3], m[2][3]],
        })
    }

    /// The row-major 4x4 homogeneous matrix.
    pub fn to_matrix(&self) -> [[f64; 4]; 4] {
        let r = &self.rotation;
        let t = self.translation;
        [
            [r[0][0], r[0][1], r[0][2], t[0]],
            [r[1][0], r[1][1], r[1][2], t[1]],
            [r[2][0], r[2][1], r[2][2], t[2]],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    /// The nalgebra isometry (the rotation as a unit quaternion, for optimisation).
    pub fn to_iso(&self) -> Iso3 {
        let r = super::Mat3::from_fn(|i, j| self.rotation[i][j]);
        Iso3::from_parts(
            nalgebra::Translation3::from(nalgebra::Vector3::from(self.translation)),
            nalgebra::UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix(&r)),
        )
    }

    /// The pose of a nalgebra isometry.
    pub fn from_iso(iso: &Iso3) -> Self {
        let m = iso.to_homogeneous();
        Pose {
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
            translation: std::array::from_fn(|i| m[(i, 3)]),
        }
    }

    /// The inverse transform: `Rᵀ`, `−Rᵀ t`.
    pub fn inverse(&self) -> Self {
        let r = &self.rotation;
        let rt = [0, 1, 2].map(|i| [r[0][i], r[1][i], r[2][i]]);
        let t = self.translation;
        let ti = [0, 1, 2].map(|i| -(rt[i][0] * t[0] + rt[i][1] * t[1] + rt[i][2] * t[2]));
        Pose {
            rotation: rt,
            translation: ti,
        }
    }

    /// Rotates a direction (no translation).
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
    }

    /// Transforms a point.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let q = self.rotate(p);
        [0, 1, 2].map(|i| q[i] + self.translation[i])
    }

    /// The origin of the source frame in the target frame (for `robot_from_camera`: the
    /// camera centre in the robot frame).
    pub fn origin(&self) -> [f64; 3] {
        self.translation
    }

    /// Column `k` of the rotation: the source frame's axis `k` in the target frame.
    pub fn axis(&self, k: usize) -> [f64; 3] {
        [0, 1, 2].map(|i| self.rotation[i][k])
    }
}

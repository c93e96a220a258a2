//! Pinhole projection for pictures. The camera and pose types are the crate's one
//! [`crate::camera::Camera`] and [`crate::math::pose::Pose`].

use super::RenderError;
use crate::camera::PinholeIntrinsics;

pub use crate::camera::NEAR_Z;
pub use crate::math::pose::{Pose, RIGID_TOLERANCE};

/// Projects a point in the camera frame to pixel coordinates `[u, v]`:
/// `u = fx·x/z + cx`, `v = fy·y/z + cy`. `None` when the point is behind or on the camera
/// plane (`z <= NEAR_Z`) or anything is not finite.
pub fn project(point_in_camera: [f64; 3], fx: f64, fy: f64, cx: f64, cy: f64) -> Option<[f64; 2]> {
    let k = PinholeIntrinsics {
        width: 0,
        height: 0,
        fx,
        fy,
        cx,
        cy,
    };
    crate::camera::project(point_in_camera, &k)
}

/// [`project`] with the parameters of `intrinsics`.
pub fn project_with(intrinsics: &PinholeIntrinsics, point_in_camera: [f64; 3]) -> Option<[f64; 2]> {
    crate::camera::project(point_in_camera, intrinsics)
}

/// The camera-from-robot pose from the `robot_from_camera` matrix a scene writes
/// (`camera_pose.json`).
pub fn camera_from_robot(robot_from_camera: &[[f64; 4]; 4]) -> Result<Pose, RenderError> {
    Ok(Pose::from_matrix(robot_from_camera)?.inverse())
}

pub(crate) use crate::camera::cross;

pub(crate) use crate::camera::normalize;

//! The one pinhole camera: intrinsics plus its pose in the robot frame. What a real lens
//! adds to the pinhole (distortion, a per-pixel ray table) is [`lens`].
//!
//! Camera frame: OpenCV convention (x right, y down, z forward); a point in front of the
//! camera has `z > 0`. Pixels are 0-based: `u = fx·x/z + cx`, `v = fy·y/z + cy`, no skew.
//! Every workflow that looks at the robot through a camera (scene generation, sensing,
//! calibration, the discrepancy workflow, pictures) uses this type.
//!
//! ```
//! use softsense::camera::{Camera, PinholeIntrinsics};
//! let k = PinholeIntrinsics { width: 640, height: 480, fx: 600.0, fy: 600.0, cx: 319.5, cy: 239.5 };
//! // 0.5 m in front of the robot's origin, looking along robot +y, robot +z up.
//! let cam = Camera::look_at(k, [0.0, -0.5, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
//! let (uv, depth) = cam.project_robot([0.0, 0.0, 0.0]).unwrap();
//! assert_eq!((uv, depth), ([319.5, 239.5], 0.5));
//! let p = cam.backproject(uv[0], uv[1], depth);
//! assert!(p.iter().all(|c| c.abs() < 1e-12));
//! ```

// `!(a < b)` is meant: a NaN must fail these checks, which `a >= b` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod lens;

use crate::math::pose::{Pose, PoseError};
use serde::{Deserialize, Serialize};

pub use lens::{Distortion, DistortionModel, Lens, LensError, RayTable};

/// A pinhole camera: `u = fx·x/z + cx`, `v = fy·y/z + cy`, pixels 0-based, no skew.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PinholeIntrinsics {
    /// Image width in pixels; 0 when the source does not say (PCL's XML), in which case
    /// the RGB-D reader takes the depth image's width.
    pub width: u32,
    /// Image height in pixels; 0 when the source does not say (see `width`).
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x (column), pixels.
    pub cx: f64,
    /// Principal point y (row), pixels.
    pub cy: f64,
}

impl PinholeIntrinsics {
    /// Open3D's `PrimeSenseDefault`: 640x480, f = 525, c = (319.5, 239.5).
    pub fn prime_sense_default() -> Self {
        PinholeIntrinsics {
            width: 640,
            height: 480,
            fx: 525.0,
            fy: 525.0,
            cx: 319.5,
            cy: 239.5,
        }
    }
}

impl Default for PinholeIntrinsics {
    /// [`PinholeIntrinsics::prime_sense_default`], as Open3D's default camera.
    fn default() -> Self {
        Self::prime_sense_default()
    }
}

/// Points closer to the camera plane than this (m) do not project.
pub const NEAR_Z: f64 = 1e-6;

/// Projects a camera-frame point to pixel coordinates `[u, v]`; `None` when it is behind or
/// on the camera plane (`z <= NEAR_Z`) or anything is not finite.
pub fn project(point_in_camera: [f64; 3], k: &PinholeIntrinsics) -> Option<[f64; 2]> {
    let [x, y, z] = point_in_camera;
    if !(z > NEAR_Z) {
        return None;
    }
    let uv = [k.fx * x / z + k.cx, k.fy * y / z + k.cy];
    (uv[0].is_finite() && uv[1].is_finite()).then_some(uv)
}

/// A pinhole camera placed in the robot frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The pinhole model (its width and height are the image size).
    pub intrinsics: PinholeIntrinsics,
    robot_from_camera: Pose,
    // Kept beside its inverse so that both directions map exactly as they were built.
    camera_from_robot: Pose,
}

impl Camera {
    /// A camera at `robot_from_camera` (as read from `camera_pose.json` or a calibration).
    pub fn new(intrinsics: PinholeIntrinsics, robot_from_camera: Pose) -> Self {
        Camera {
            intrinsics,
            robot_from_camera,
            camera_from_robot: robot_from_camera.inverse(),
        }
    }

    /// A camera from the row-major 4x4 `robot_from_camera` matrix; errors unless it is rigid.
    pub fn from_matrix(
        intrinsics: PinholeIntrinsics,
        robot_from_camera: &[[f64; 4]; 4],
    ) -> Result<Self, PoseError> {
        Ok(Self::new(intrinsics, Pose::from_matrix(robot_from_camera)?))
    }

    /// A camera given by the pose that maps robot-frame points into the camera frame.
    pub fn from_camera_from_robot(intrinsics: PinholeIntrinsics, camera_from_robot: Pose) -> Self {
        Camera {
            intrinsics,
            robot_from_camera: camera_from_robot.inverse(),
            camera_from_robot,
        }
    }

    /// A camera at `eye` looking at `target` (robot frame, m) with image y pointing against
    /// `up`; `None` when eye = target, up is parallel to the view direction, or the
    /// focal lengths or the image size are not positive.
    pub fn look_at(
        intrinsics: PinholeIntrinsics,
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
    ) -> Option<Self> {
        let k = &intrinsics;
        let ok = k.fx > 0.0 && k.fy > 0.0 && k.width > 0 && k.height > 0;
        let z = unit([0, 1, 2].map(|i| target[i] - eye[i]))?;
        let x = unit(cross(z, up))?;
        let y = cross(z, x);
        // Columns of the rotation are the camera axes in the robot frame.
        let rotation = [0, 1, 2].map(|i| [x[i], y[i], z[i]]);
        let robot_from_camera = Pose {
            rotation,
            translation: eye,
        };
        ok.then(|| Self::new(intrinsics, robot_from_camera))
    }

    /// The pose taking camera-frame points into the robot frame.
    pub fn robot_from_camera(&self) -> &Pose {
        &self.robot_from_camera
    }

    /// The pose taking robot-frame points into the camera frame.
    pub fn camera_from_robot(&self) -> &Pose {
        &self.camera_from_robot
    }

    /// The camera centre in the robot frame (m).
    pub fn eye(&self) -> [f64; 3] {
        self.robot_from_camera.origin()
    }

    /// The optical axis (camera z) in the robot frame.
    pub fn axis_z(&self) -> [f64; 3] {
        self.robot_from_camera.axis(2)
    }

    /// Depth (along the optical axis, m) of a robot-frame point.
    pub fn depth_of(&self, point_in_robot: [f64; 3]) -> f64 {
        let (e, a) = (self.eye(), self.axis_z());
        (0..3).map(|k| (point_in_robot[k] - e[k]) * a[k]).sum()
    }

    /// Projects a robot-frame point: pixel `[u, v]` and depth `z` (m), or `None` when it is
    /// behind the camera.
    pub fn project_robot(&self, point_in_robot: [f64; 3]) -> Option<([f64; 2], f64)> {
        let p = self.camera_from_robot.apply(point_in_robot);
        project(p, &self.intrinsics).map(|uv| (uv, p[2]))
    }

    /// Ray direction in the robot frame through pixel (u, v), scaled so that its camera-z
    /// component is 1 (the ray parameter is then the depth).
    pub fn ray(&self, u: f64, v: f64) -> [f64; 3] {
        let k = &self.intrinsics;
        self.robot_from_camera
            .rotate([(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0])
    }

    /// The camera-frame point seen at pixel (u, v) at depth z (m).
    pub fn point_in_camera(&self, u: f64, v: f64, z: f64) -> [f64; 3] {
        let k = &self.intrinsics;
        [(u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z]
    }

    /// Back-projects pixel (u, v) at depth z (m) into the robot frame along the pixel's
    /// ray from the eye (the ray caster's form of `robot_from_camera · point_in_camera`).
    pub fn backproject(&self, u: f64, v: f64, z: f64) -> [f64; 3] {
        let d = self.ray(u, v);
        let e = self.eye();
        [0, 1, 2].map(|k| e[k] + z * d[k])
    }

    /// A camera that frames all finite `points_in_robot` in a `width` x `height` picture,
    /// looking at their bounding-box centre from `azimuth_deg` (about +z, from +x towards
    /// +y) and `elevation_deg` (above the x-y plane), robot +z up in the image, a 50°
    /// horizontal field of view, from the nearest distance at which every point is in the
    /// picture with a 5% margin. `None` when there is no finite point, a size is 0, or the
    /// elevation is ±90° (up would be ambiguous).
    pub fn orbit(
        points_in_robot: &[[f64; 3]],
        azimuth_deg: f64,
        elevation_deg: f64,
        width: u32,
        height: u32,
    ) -> Option<Camera> {
        if width == 0 || height == 0 || !(elevation_deg.abs() < 89.9) || !azimuth_deg.is_finite() {
            return None;
        }
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        // Direction from the centre to the eye.
        let back = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
        let fx = 0.5 * f64::from(width) / (25f64.to_radians()).tan();
        // Every point inside the picture less a 5% margin.
        let tan = [0.45 * f64::from(width) / fx, 0.45 * f64::from(height) / fx];
        let ([x, y, z], eye) = framing(points_in_robot, back, [0.0, 0.0, 1.0], tan)?;
        // Rows of camera_from_robot's rotation are the camera axes in the robot frame.
        let rotation = [x, y, z];
        let translation = [0, 1, 2].map(|i| {
            -(rotation[i][0] * eye[0] + rotation[i][1] * eye[1] + rotation[i][2] * eye[2])
        });
        let intrinsics = PinholeIntrinsics {
            width,
            height,
            fx,
            fy: fx,
            cx: (f64::from(width) - 1.0) * 0.5,
            cy: (f64::from(height) - 1.0) * 0.5,
        };
        Some(Self::from_camera_from_robot(
            intrinsics,
            Pose {
                rotation,
                translation,
            },
        ))
    }

    /// Open3D `PinholeCameraIntrinsic` JSON (column-major intrinsic matrix).
    pub fn open3d_intrinsics(&self) -> serde_json::Value {
        let k = &self.intrinsics;
        serde_json::json!({
            "width": k.width,
            "height": k.height,
            "intrinsic_matrix": [k.fx, 0.0, 0.0, 0.0, k.fy, 0.0, k.cx, k.cy, 1.0],
        })
    }
}

/// The camera axes (x, y, z: image right, image down, view) and the eye of a camera looking
/// at the bounding-box centre of all finite `points` from direction `back` (centre to
/// eye), image y against `up`, from the nearest distance at which every point is within
/// `tan` (tangents of the half-angles across x and y) of the optical axis. `None` when
/// there is no finite point or `up` is parallel to `back`.
pub fn framing(
    points: &[[f64; 3]],
    back: [f64; 3],
    up: [f64; 3],
    tan: [f64; 2],
) -> Option<([[f64; 3]; 3], [f64; 3])> {
    let finite = || points.iter().filter(|p| p.iter().all(|c| c.is_finite()));
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in finite() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0] <= hi[0]) {
        return None;
    }
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let radius = (0..3)
        .map(|k| (hi[k] - lo[k]).powi(2))
        .sum::<f64>()
        .sqrt()
        .max(1e-9)
        * 0.5;
    let back = normalize(back)?;
    let z = back.map(|c| -c);
    let x = normalize(cross(z, up))?;
    let y = cross(z, x);
    // A point q (from the centre) sits at depth z·q + d and needs |x·q| <= tan_x (z·q + d),
    // likewise for y.
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut dist = radius * 1e-3;
    for p in finite() {
        let q = [0, 1, 2].map(|k| p[k] - centre[k]);
        let (qx, qy, qz) = (dot(x, q), dot(y, q), dot(z, q));
        dist = dist
            .max(qx.abs() / tan[0] - qz)
            .max(qy.abs() / tan[1] - qz)
            .max(radius * 1e-3 - qz);
    }
    Some(([x, y, z], [0, 1, 2].map(|k| centre[k] + dist * back[k])))
}

/// `a × b`.
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    crate::math::cross(a, b)
}

/// `a / |a|`, or `None` for a (near-)zero or non-finite vector.
pub(crate) fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (l > 1e-300 && l.is_finite()).then(|| a.map(|c| c / l))
}

// `look_at`'s stricter cut-off than `normalize`: an eye on its target, or an up vector
// nearly along the view, is a mistake in the scene file.
fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (l > 1e-12 && l.is_finite()).then(|| a.map(|c| c / l))
}

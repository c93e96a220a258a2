//! Pinhole projection and rigid camera poses.
//!
//! Camera frame: OpenCV convention (x right, y down, z forward), as in
//! [`crate::scene::camera`]; a point in front of the camera has `z > 0`.

use super::RenderError;
use crate::io::intrinsics::PinholeIntrinsics;

/// Points closer to the camera plane than this (m) do not project.
pub const NEAR_Z: f64 = 1e-6;

/// Projects a point in the camera frame to pixel coordinates `[u, v]`:
/// `u = fx·x/z + cx`, `v = fy·y/z + cy`. `None` when the point is behind or on the camera
/// plane (`z <= NEAR_Z`) or anything is not finite.
pub fn project(point_in_camera: [f64; 3], fx: f64, fy: f64, cx: f64, cy: f64) -> Option<[f64; 2]> {
    let [x, y, z] = point_in_camera;
    if !(z > NEAR_Z) {
        return None;
    }
    let uv = [fx * x / z + cx, fy * y / z + cy];
    (uv[0].is_finite() && uv[1].is_finite()).then_some(uv)
}

/// [`project`] with the parameters of `intrinsics`.
pub fn project_with(intrinsics: &PinholeIntrinsics, point_in_camera: [f64; 3]) -> Option<[f64; 2]> {
    let k = intrinsics;
    project(point_in_camera, k.fx, k.fy, k.cx, k.cy)
}

/// A rigid transform `x_to = rotation · x_from + translation` (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation matrix, row-major, orthonormal with determinant +1.
    pub rotation: [[f64; 3]; 3],
    /// Translation.
    pub translation: [f64; 3],
}

/// Orthonormality tolerance of [`Pose::from_matrix`] (largest entry of RᵀR − I, and
/// |det R − 1|).
pub const RIGID_TOLERANCE: f64 = 1e-6;

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
    pub fn from_matrix(m: &[[f64; 4]; 4]) -> Result<Self, RenderError> {
        let not_rigid = |reason: String| RenderError::NotRigid { reason };
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
}

/// The camera-from-robot pose from the `robot_from_camera` matrix a scene writes
/// (`camera_pose.json`, [`crate::scene::camera::Camera::robot_from_camera`]).
pub fn camera_from_robot(robot_from_camera: &[[f64; 4]; 4]) -> Result<Pose, RenderError> {
    Ok(Pose::from_matrix(robot_from_camera)?.inverse())
}

/// A camera looking at the robot: pose plus intrinsics (whose width and height give the
/// picture size).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Maps robot-frame points into the camera frame.
    pub camera_from_robot: Pose,
    /// The pinhole model; `width` and `height` must be > 0.
    pub intrinsics: PinholeIntrinsics,
}

impl View {
    /// The view of a recording: its `robot_from_camera` matrix (as in `camera_pose.json`)
    /// and the camera's intrinsics. Errors when the matrix is not rigid.
    pub fn from_robot_from_camera(
        robot_from_camera: &[[f64; 4]; 4],
        intrinsics: PinholeIntrinsics,
    ) -> Result<View, RenderError> {
        Ok(View {
            camera_from_robot: camera_from_robot(robot_from_camera)?,
            intrinsics,
        })
    }

    /// Projects a robot-frame point: pixel `[u, v]` and depth `z` (m), or `None` when it is
    /// behind the camera.
    pub fn project_robot(&self, point_in_robot: [f64; 3]) -> Option<([f64; 2], f64)> {
        let p = self.camera_from_robot.apply(point_in_robot);
        project_with(&self.intrinsics, p).map(|uv| (uv, p[2]))
    }

    /// A camera that frames all finite `points_in_robot` in a `width` x `height` picture,
    /// looking at their bounding-box centre from `azimuth_deg` (about +z, from +x towards
    /// +y) and `elevation_deg` (above the x-y plane), with robot +z up in the image and a
    /// 50° horizontal field of view, from the nearest distance at which every point is in
    /// the picture with a 5% margin. `None` when there is no finite point, a size is 0, or
    /// the elevation is ±90° (up would be ambiguous).
    pub fn orbit(
        points_in_robot: &[[f64; 3]],
        azimuth_deg: f64,
        elevation_deg: f64,
        width: u32,
        height: u32,
    ) -> Option<View> {
        if width == 0 || height == 0 || !(elevation_deg.abs() < 89.9) || !azimuth_deg.is_finite() {
            return None;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points_in_robot
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
        {
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
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        // Direction from the centre to the eye.
        let back = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
        let fx = 0.5 * f64::from(width) / (25f64.to_radians()).tan();
        let z = back.map(|c| -c);
        let up = [0.0, 0.0, 1.0];
        let x = normalize(cross(z, up))?;
        let y = cross(z, x);
        // The nearest eye distance that keeps every point inside the picture less a 5%
        // margin: a point q (from the centre) sits at depth z·q + d and needs
        // |x·q| <= tan_x (z·q + d), likewise for y.
        let tan_x = 0.45 * f64::from(width) / fx;
        let tan_y = 0.45 * f64::from(height) / fx;
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut dist = radius * 1e-3;
        for p in points_in_robot
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
        {
            let q = [0, 1, 2].map(|k| p[k] - centre[k]);
            let (qx, qy, qz) = (dot(x, q), dot(y, q), dot(z, q));
            dist = dist
                .max(qx.abs() / tan_x - qz)
                .max(qy.abs() / tan_y - qz)
                .max(radius * 1e-3 - qz);
        }
        let eye = [0, 1, 2].map(|k| centre[k] + dist * back[k]);
        // Rows of camera_from_robot's rotation are the camera axes in the robot frame.
        let rotation = [x, y, z];
        let ti = [0, 1, 2].map(|i| {
            -(rotation[i][0] * eye[0] + rotation[i][1] * eye[1] + rotation[i][2] * eye[2])
        });
        Some(View {
            camera_from_robot: Pose {
                rotation,
                translation: ti,
            },
            intrinsics: PinholeIntrinsics {
                width,
                height,
                fx,
                fy: fx,
                cx: (f64::from(width) - 1.0) * 0.5,
                cy: (f64::from(height) - 1.0) * 0.5,
            },
        })
    }
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (l > 1e-300 && l.is_finite()).then(|| a.map(|c| c / l))
}

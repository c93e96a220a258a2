//! The virtual pinhole camera (OpenCV convention: x right, y down, z forward) and its pose.

use serde::{Deserialize, Serialize};

/// Camera intrinsics and pose, as written in a scene file (metres, robot frame).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSpec {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// Camera centre in the robot frame (m).
    pub eye: [f64; 3],
    /// Point the camera looks at (m).
    pub target: [f64; 3],
    /// Up direction in the robot frame (image y points against it).
    pub up: [f64; 3],
}

impl Default for CameraSpec {
    /// A RealSense D415-like 640x480 depth stream, 0.5 m from the robot, looking down at 30°.
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            fx: 615.0,
            fy: 615.0,
            cx: 319.5,
            cy: 239.5,
            eye: [0.0, -0.433, 0.31],
            target: [0.0, 0.0, 0.06],
            up: [0.0, 0.0, 1.0],
        }
    }
}

impl CameraSpec {
    /// The same D415-like camera and pose as [`CameraSpec::default`] at its 1280x720 stream:
    /// the same vertical field of view (fy = 922.5 px, 1.5 times the 640x480 stream's 615) and
    /// a wider 16:9 horizontal one, so a surface patch gets about 2.25 times the pixels.
    /// Its depth noise is smaller too (the same disparity noise at a longer focal length:
    /// [`crate::scene::sensor::SensorModel::for_camera`]). In a scene file:
    ///
    /// ```toml
    /// [camera]
    /// width = 1280
    /// height = 720
    /// fx = 922.5
    /// fy = 922.5
    /// cx = 639.5
    /// cy = 359.5
    /// ```
    ///
    /// ```
    /// use softsense::scene::camera::{Camera, CameraSpec};
    /// let (sd, hd) = (CameraSpec::default(), CameraSpec::d415_1280x720());
    /// assert_eq!((hd.width, hd.height), (1280, 720));
    /// // A pixel row of the 640x480 stream is 1.5 rows of the 1280x720 one.
    /// let (a, b) = (Camera::new(sd).unwrap(), Camera::new(hd).unwrap());
    /// let (ra, rb) = (a.ray(319.5, 0.0), b.ray(639.5, 359.5 - 1.5 * 239.5));
    /// assert!((0..3).all(|k| (ra[k] - rb[k]).abs() < 1e-12));
    /// ```
    pub fn d415_1280x720() -> Self {
        let sd = Self::default();
        let scale = 1.5;
        Self {
            width: 1280,
            height: 720,
            fx: sd.fx * scale,
            fy: sd.fy * scale,
            cx: 639.5,
            cy: 359.5,
            ..sd
        }
    }
}

/// A camera ready for ray casting: rotation columns are the camera axes in the robot frame.
#[derive(Clone, Debug, Serialize)]
pub struct Camera {
    /// The spec it was made from.
    pub spec: CameraSpec,
    /// Camera x, y, z axes in the robot frame.
    pub axes: [[f64; 3]; 3],
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (l > 1e-12 && l.is_finite()).then(|| a.map(|c| c / l))
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl Camera {
    /// Builds the pose; None when eye = target or up is parallel to the view direction,
    /// or the intrinsics are not positive.
    pub fn new(spec: CameraSpec) -> Option<Self> {
        let ok = spec.fx > 0.0 && spec.fy > 0.0 && spec.width > 0 && spec.height > 0;
        let z = unit([0, 1, 2].map(|k| spec.target[k] - spec.eye[k]))?;
        let x = unit(cross(z, spec.up))?;
        let y = cross(z, x);
        ok.then_some(Self {
            spec,
            axes: [x, y, z],
        })
    }

    /// Ray direction in the robot frame for pixel (u, v), scaled so that its camera-z
    /// component is 1 (the ray parameter is then the depth z).
    pub fn ray(&self, u: f64, v: f64) -> [f64; 3] {
        let s = &self.spec;
        let c = [(u - s.cx) / s.fx, (v - s.cy) / s.fy, 1.0];
        [0, 1, 2].map(|k| c[0] * self.axes[0][k] + c[1] * self.axes[1][k] + c[2] * self.axes[2][k])
    }

    /// Back-projects pixel (u, v) at depth z (m) into the robot frame.
    pub fn backproject(&self, u: f64, v: f64, z: f64) -> [f64; 3] {
        let d = self.ray(u, v);
        [0, 1, 2].map(|k| self.spec.eye[k] + z * d[k])
    }

    /// The 4x4 robot_from_camera transform, row-major.
    pub fn robot_from_camera(&self) -> [[f64; 4]; 4] {
        let a = &self.axes;
        let e = self.spec.eye;
        [
            [a[0][0], a[1][0], a[2][0], e[0]],
            [a[0][1], a[1][1], a[2][1], e[1]],
            [a[0][2], a[1][2], a[2][2], e[2]],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    /// Open3D `PinholeCameraIntrinsic` JSON (column-major intrinsic matrix).
    pub fn open3d_intrinsics(&self) -> serde_json::Value {
        let s = &self.spec;
        serde_json::json!({
            "width": s.width,
            "height": s.height,
            "intrinsic_matrix": [s.fx, 0.0, 0.0, 0.0, s.fy, 0.0, s.cx, s.cy, 1.0],
        })
    }
}

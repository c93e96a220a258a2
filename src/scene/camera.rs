//! A scene file's camera: intrinsics and a look-at pose, made into the crate's
//! [`Camera`] by [`CameraSpec::camera`].

use crate::camera::{Camera, PinholeIntrinsics};
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
    /// use softsense::scene::camera::CameraSpec;
    /// let (sd, hd) = (CameraSpec::default(), CameraSpec::d415_1280x720());
    /// assert_eq!((hd.width, hd.height), (1280, 720));
    /// // A pixel row of the 640x480 stream is 1.5 rows of the 1280x720 one.
    /// let (a, b) = (sd.camera().unwrap(), hd.camera().unwrap());
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

    /// The pinhole part of the spec.
    pub fn intrinsics(&self) -> PinholeIntrinsics {
        PinholeIntrinsics {
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
        }
    }

    /// Which fault keeps [`camera`](Self::camera) from making a camera, in words naming
    /// the field; `Ok` when it can.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if v == 0 {
                return Err(format!("camera.{name} is 0"));
            }
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "camera.{name} must be a finite number > 0, got {v}"
                ));
            }
        }
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(format!("camera.{name} must be finite, got {v}"));
            }
        }
        for (name, v) in [("eye", self.eye), ("target", self.target), ("up", self.up)] {
            if !v.iter().all(|c| c.is_finite()) {
                return Err(format!("camera.{name} must be finite, got {v:?}"));
            }
        }
        let view = [0, 1, 2].map(|i| self.target[i] - self.eye[i]);
        let norm = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        if norm(view) <= 1e-12 {
            return Err("camera.eye and camera.target are the same point".into());
        }
        if norm(self.up) <= 1e-12 {
            return Err("camera.up is a zero vector".into());
        }
        let c = crate::camera::cross(view, self.up);
        if norm(c) <= 1e-12 * norm(view) * norm(self.up) {
            return Err("camera.up is parallel to the view direction (target - eye)".into());
        }
        self.intrinsics()
            .check_plausible()
            .map_err(|e| format!("camera: {e}"))?;
        if self.camera().is_none() {
            return Err("camera: no camera can be made from the spec".into());
        }
        Ok(())
    }

    /// The camera this spec describes ([`Camera::look_at`]); `None` when eye = target, up
    /// is parallel to the view direction, or the intrinsics are not positive.
    pub fn camera(&self) -> Option<Camera> {
        Camera::look_at(self.intrinsics(), self.eye, self.target, self.up)
    }
}

/// One camera of a scene with several (`[[cameras]]`): a name, which is also the folder
/// its frames are written to, and the fields of `[camera]` with the same defaults.
#[derive(Clone, Debug, Serialize)]
pub struct NamedCameraSpec {
    /// The camera's name: letters, digits, `-` and `_` (its sub-folder in the recording).
    pub name: String,
    /// Its intrinsics and pose.
    #[serde(flatten)]
    pub camera: CameraSpec,
}

// By hand: serde's `flatten` would let a misspelt camera field through silently.
impl<'de> Deserialize<'de> for NamedCameraSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut table = toml::Table::deserialize(d)?;
        let name = match table.remove("name") {
            Some(toml::Value::String(name)) => name,
            Some(other) => {
                return Err(D::Error::custom(format!(
                    "cameras: name must be a string, got {}",
                    other.type_str()
                )))
            }
            None => return Err(D::Error::custom("cameras: every camera needs a name")),
        };
        let camera = toml::Value::Table(table)
            .try_into::<CameraSpec>()
            .map_err(|e| D::Error::custom(format!("camera {name}: {}", e.message())))?;
        Ok(Self { name, camera })
    }
}

impl NamedCameraSpec {
    /// Which fault keeps the name from being a folder name, in words; `Ok` when it can be.
    pub fn check_name(&self) -> Result<(), String> {
        let ok = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
        if self.name.is_empty() || !self.name.chars().all(ok) {
            return Err(format!(
                "camera name {:?} must be letters, digits, '-' and '_' (it names the camera's folder)",
                self.name
            ));
        }
        Ok(())
    }
}

//! A recorded frames folder: depth and colour PNGs, intrinsics, camera pose, sensor model
//! and the recorded inputs (cable inputs and known loads) per frame.
//!
//! Layout (what [`super::generate`] writes and [`load_frames`] reads):
//! `depth_NNNN.png` (16-bit), `color_NNNN.png`, `intrinsics.json` (Open3D),
//! `camera_pose.json` (`robot_from_camera`, 4x4 row-major), `sensor.json`
//! ([`SensorModel`]), `inputs.json` (one [`FrameInput`] per frame).

use super::{DiscrepancyError, DiscrepancyResult};
use crate::scene::sensor::SensorModel;
use crate::scene::FrameInput;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Largest accepted number of frames in a folder.
pub const MAX_FRAMES: usize = 1000;
/// Largest accepted image side (pixels).
pub const MAX_SIDE: u32 = 4096;

/// The recorded camera: intrinsics and its pose in the robot frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Focal lengths and principal point (pixels): fx, fy, cx, cy.
    pub intrinsics: [f64; 4],
    /// robot_from_camera, row-major 4x4.
    pub robot_from_camera: [[f64; 4]; 4],
}

impl CameraInfo {
    /// Camera centre in the robot frame.
    pub fn eye(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| self.robot_from_camera[k][3])
    }

    /// Optical axis (camera z) in the robot frame.
    pub fn axis_z(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| self.robot_from_camera[k][2])
    }

    /// Camera depth (along the optical axis) of a robot-frame point.
    pub fn depth_of(&self, p: [f64; 3]) -> f64 {
        let e = self.eye();
        let a = self.axis_z();
        (0..3).map(|k| (p[k] - e[k]) * a[k]).sum()
    }

    /// Back-projects pixel (u, v) at depth z into the robot frame.
    pub fn backproject(&self, u: f64, v: f64, z: f64) -> [f64; 3] {
        let [fx, fy, cx, cy] = self.intrinsics;
        let c = [(u - cx) / fx * z, (v - cy) / fy * z, z];
        let m = &self.robot_from_camera;
        [0, 1, 2].map(|k| m[k][0] * c[0] + m[k][1] * c[1] + m[k][2] * c[2] + m[k][3])
    }
}

/// One recorded frame.
#[derive(Clone, Debug)]
pub struct RecordedFrame {
    /// Robot points (robot frame, m), picked by colour.
    pub points: Vec<[f64; 3]>,
    /// The recorded inputs.
    pub input: FrameInput,
}

/// A recorded frames folder.
#[derive(Clone, Debug)]
pub struct Recording {
    /// The camera.
    pub camera: CameraInfo,
    /// The sensor's noise model (known from the sensor, not fitted).
    pub sensor: SensorModel,
    /// Frames in order.
    pub frames: Vec<RecordedFrame>,
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> DiscrepancyResult<T> {
    let text = std::fs::read_to_string(path).map_err(|e| DiscrepancyError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    serde_json::from_str(&text)
        .map_err(|e| DiscrepancyError::Data(format!("{}: {e}", path.display())))
}

/// Whether a colour is the robot's (green dominant), the colour segmentation used here.
pub fn is_robot_color(c: [u8; 3]) -> bool {
    let [r, g, b] = c.map(i32::from);
    g > r + 40 && g > b + 40
}

/// Reads a frames folder (see the module docs).
pub fn load_frames(dir: &Path) -> DiscrepancyResult<Recording> {
    let intr: serde_json::Value = read_json(&dir.join("intrinsics.json"))?;
    let m: Vec<f64> = intr["intrinsic_matrix"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_f64()).collect())
        .unwrap_or_default();
    if m.len() != 9 || m[0] <= 0.0 || m[4] <= 0.0 {
        return Err(DiscrepancyError::Data(
            "intrinsics.json: bad intrinsic_matrix".into(),
        ));
    }
    let pose: serde_json::Value = read_json(&dir.join("camera_pose.json"))?;
    let robot_from_camera: [[f64; 4]; 4] =
        serde_json::from_value(pose["robot_from_camera"].clone())
            .map_err(|e| DiscrepancyError::Data(format!("camera_pose.json: {e}")))?;
    let camera = CameraInfo {
        intrinsics: [m[0], m[4], m[6], m[7]],
        robot_from_camera,
    };
    let sensor: SensorModel = read_json(&dir.join("sensor.json"))?;
    let inputs: Vec<FrameInput> = read_json(&dir.join("inputs.json"))?;
    if inputs.is_empty() || inputs.len() > MAX_FRAMES {
        return Err(DiscrepancyError::Data(format!(
            "inputs.json: needs 1..={MAX_FRAMES} frames, has {}",
            inputs.len()
        )));
    }
    let mut frames = Vec::with_capacity(inputs.len());
    for (i, input) in inputs.into_iter().enumerate() {
        let dp = dir.join(format!("depth_{i:04}.png"));
        let cp = dir.join(format!("color_{i:04}.png"));
        let open = |p: &Path| {
            image::open(p).map_err(|e| DiscrepancyError::File {
                path: p.display().to_string(),
                message: e.to_string(),
            })
        };
        let depth = open(&dp)?.into_luma16();
        let color = open(&cp)?.into_rgb8();
        if depth.dimensions() != color.dimensions()
            || depth.width() > MAX_SIDE
            || depth.height() > MAX_SIDE
        {
            return Err(DiscrepancyError::Data(format!(
                "frame {i}: depth and colour sizes differ or are too large"
            )));
        }
        let mut points = Vec::new();
        for (u, v, d) in depth.enumerate_pixels() {
            let z = d.0[0] as f64 * sensor.depth_unit;
            if z > 0.0 && is_robot_color(color.get_pixel(u, v).0) {
                points.push(camera.backproject(u as f64, v as f64, z));
            }
        }
        frames.push(RecordedFrame { points, input });
    }
    Ok(Recording {
        camera,
        sensor,
        frames,
    })
}

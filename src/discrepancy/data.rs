//! A recorded frames folder: depth and colour PNGs, intrinsics, camera pose, sensor model
//! and the recorded inputs (cable inputs and known loads) per frame.
//!
//! Layout (what [`super::generate`] writes and [`load_frames`] reads):
//! `depth_NNNN.png` (16-bit), `color_NNNN.png`, `intrinsics.json` (Open3D),
//! `camera_pose.json` (`robot_from_camera`, 4x4 row-major), `sensor.json`
//! ([`SensorModel`]), `inputs.json` (one [`FrameInput`] per frame).

use super::{DiscrepancyError, DiscrepancyResult};
use crate::camera::Camera;
use crate::io::intrinsics::read_camera_model;
use crate::io::rgbd::{read_color_image, read_depth_image};
use crate::scene::sensor::SensorModel;
use crate::scene::FrameInput;
use std::path::Path;

/// Largest accepted number of frames in a folder.
pub const MAX_FRAMES: usize = 1000;
/// Largest accepted image side (pixels).
pub const MAX_SIDE: u32 = 4096;

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
    pub camera: Camera,
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
    let file_err = |path: &Path, e: &dyn std::fmt::Display| DiscrepancyError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let intrinsics_path = dir.join("intrinsics.json");
    let intrinsics = read_camera_model(&intrinsics_path)
        .map_err(|e| file_err(&intrinsics_path, &e))?
        .intrinsics;
    let pose_path = dir.join("camera_pose.json");
    let pose: serde_json::Value = read_json(&pose_path)?;
    let robot_from_camera: [[f64; 4]; 4] =
        serde_json::from_value(pose["robot_from_camera"].clone())
            .map_err(|e| DiscrepancyError::Data(format!("camera_pose.json: {e}")))?;
    let camera = Camera::from_matrix(intrinsics, &robot_from_camera)
        .map_err(|e| file_err(&pose_path, &e))?;
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
        let depth = read_depth_image(&dp).map_err(|e| file_err(&dp, &e))?;
        let color = read_color_image(&cp).map_err(|e| file_err(&cp, &e))?;
        if (depth.width, depth.height) != (color.width, color.height)
            || depth.width > MAX_SIDE
            || depth.height > MAX_SIDE
        {
            return Err(DiscrepancyError::Data(format!(
                "frame {i}: depth and colour sizes differ or are too large"
            )));
        }
        let mut points = Vec::new();
        let robot_from_camera = camera.robot_from_camera();
        for (pixel, (&d, &c)) in depth.data.iter().zip(&color.data).enumerate() {
            let z = d as f64 * sensor.depth_unit;
            if z > 0.0 && is_robot_color(c) {
                let (u, v) = (pixel % depth.width as usize, pixel / depth.width as usize);
                let p = camera.point_in_camera(u as f64, v as f64, z);
                points.push(robot_from_camera.apply(p));
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

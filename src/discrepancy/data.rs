//! The frames of a recording folder ([`crate::recording`]) as robot points with their
//! recorded inputs (cable inputs and known loads), for `explain`.
//!
//! Besides the frames, intrinsics and camera pose it needs each frame's recorded inputs
//! (`inputs.json`, or `actuators.json` for cable inputs without known loads) and reads the
//! sensor's noise model from `sensor.json` if there is one ([`SensorModel`]; else the
//! default D415-like model). [`super::generate`] writes all of them.

use super::{DiscrepancyError, DiscrepancyResult};
use crate::camera::Camera;
use crate::io::rgbd::{read_color_image, read_depth_image};
use crate::recording::FrameInput;
use crate::scene::sensor::SensorModel;
use crate::segment::robot_color::RobotColorModel;
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

/// A recording folder as `explain` reads it: the camera, its noise model, and each
/// frame's robot points with its recorded inputs.
#[derive(Clone, Debug)]
pub struct RobotFrames {
    /// The camera.
    pub camera: Camera,
    /// The sensor's noise model (known from the sensor, not fitted).
    pub sensor: SensorModel,
    /// Frames in order.
    pub frames: Vec<RecordedFrame>,
}

/// The sensor model of a folder's `sensor.json`, if it has one.
fn sensor_file(dir: &Path) -> DiscrepancyResult<Option<SensorModel>> {
    let path = dir.join("sensor.json");
    Ok(path
        .exists()
        .then(|| crate::recording::read_json(&path))
        .transpose()?)
}

/// Reads a recording folder (see the module docs) and picks each frame's robot points
/// with `color`.
pub fn load_frames(dir: &Path, color: &RobotColorModel) -> DiscrepancyResult<RobotFrames> {
    let rec = crate::recording::Recording::open(dir)?;
    let robot_from_camera = rec.robot_from_camera.ok_or_else(|| {
        DiscrepancyError::Data(format!(
            "{}: no camera pose (camera_pose.json or calibration.json)",
            dir.display()
        ))
    })?;
    let camera = Camera::new(rec.camera.intrinsics, robot_from_camera);
    let sensor_file = sensor_file(dir)?;
    // One depth unit: the camera file's. A sensor.json that says otherwise would have the
    // noise floor and the points disagree.
    let depth_unit = 1.0 / rec.camera.params.depth_scale;
    if let Some(sensor) = sensor_file
        .as_ref()
        .filter(|s| (s.depth_unit - depth_unit).abs() > 1e-9 * depth_unit.abs())
    {
        return Err(DiscrepancyError::Data(format!(
            "{}: sensor.json's depth_unit {} m and intrinsics.json's depth_scale {} (a unit of \
             {depth_unit} m) disagree",
            dir.display(),
            sensor.depth_unit,
            rec.camera.params.depth_scale
        )));
    }
    if rec.frames.len() > MAX_FRAMES {
        return Err(DiscrepancyError::Data(format!(
            "{}: needs 1..={MAX_FRAMES} frames, has {}",
            dir.display(),
            rec.frames.len()
        )));
    }
    let mut frames = Vec::with_capacity(rec.frames.len());
    let mut is_robot = color.classifier();
    for &f in &rec.frames {
        // explain fits the model to every frame: one without its inputs would mislead it.
        if let Some(problem) = rec.input_problem(f) {
            return Err(DiscrepancyError::Data(problem));
        }
        let input = rec.inputs_of(f).ok_or_else(|| {
            DiscrepancyError::Data(format!(
                "{}: no recorded inputs for frame {f} (inputs.json or actuators.json)",
                dir.display()
            ))
        })?;
        let files = rec.files_of(f)?;
        let depth = read_depth_image(&files.depth)?;
        let Some(color_path) = &files.color else {
            return Err(DiscrepancyError::Data(format!(
                "{}: frame {f} has no colour image",
                dir.display()
            )));
        };
        let color = read_color_image(color_path)?;
        if (depth.width, depth.height) != (color.width, color.height)
            || depth.width > MAX_SIDE
            || depth.height > MAX_SIDE
        {
            return Err(DiscrepancyError::Data(format!(
                "frame {f}: depth and colour sizes differ or are too large"
            )));
        }
        let depth_unit = 1.0 / rec.camera_of(f)?.params.depth_scale;
        let mut points = Vec::new();
        for (pixel, (&d, &c)) in depth.data.iter().zip(&color.data).enumerate() {
            let z = d as f64 * depth_unit;
            if z > 0.0 && is_robot.is_robot(c) {
                let (u, v) = (pixel % depth.width as usize, pixel / depth.width as usize);
                let p = camera.point_in_camera(u as f64, v as f64, z);
                points.push(robot_from_camera.apply(p));
            }
        }
        if points.is_empty() {
            return Err(DiscrepancyError::Data(format!(
                "{}: frame {f} has no robot point (no valid depth, or no pixel of the robot's \
                 colour: check --robot-color)",
                dir.display()
            )));
        }
        frames.push(RecordedFrame { points, input });
    }
    Ok(RobotFrames {
        camera,
        // Without a sensor.json: the default D415-like model.
        sensor: sensor_file.unwrap_or_default(),
        frames,
    })
}

//! The measured robot points: robot-coloured pixels of a colour-and-depth frame.

use super::{CalibrateParams, CalibrateResult};
use crate::recording::Recording;
use crate::segment::robot_color::RobotColorModel;
use std::path::Path;

/// The robot points of a colour-and-depth cloud (camera frame, m): finite points whose
/// colour `color` calls the robot's. Clouds without colour give no points.
pub fn robot_points(cloud: &crate::cloud::PointCloud, color: &RobotColorModel) -> Vec<[f64; 3]> {
    let Some(colors) = cloud.colors.as_ref() else {
        return Vec::new();
    };
    let mut is_robot = color.classifier();
    cloud
        .positions
        .iter()
        .zip(colors)
        .filter(|&(p, &c)| p.iter().all(|v| v.is_finite()) && is_robot.is_robot(c))
        .map(|(p, _)| p.map(f64::from))
        .collect()
}

/// Reads frame `frame` of a recording folder (any [`crate::recording::Layout`]) and
/// returns its robot points (camera frame).
pub fn read_scene_robot_points(
    dir: &Path,
    frame: usize,
    params: &CalibrateParams,
) -> CalibrateResult<Vec<[f64; 3]>> {
    recording_robot_points(&Recording::open(dir)?, frame, params)
}

/// The robot points (camera frame) of `frame` of an opened recording.
pub fn recording_robot_points(
    rec: &Recording,
    frame: usize,
    params: &CalibrateParams,
) -> CalibrateResult<Vec<[f64; 3]>> {
    Ok(robot_points(&rec.read_frame(frame)?, &params.color))
}

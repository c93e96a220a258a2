//! The measured robot points: robot-coloured pixels of a colour-and-depth frame.

use super::{CalibrateParams, CalibrateResult};
use std::path::Path;

/// The robot points of a colour-and-depth cloud (camera frame, m): finite points whose
/// colour is within `min_color_cosine` of `robot_color` as RGB direction (so shading does
/// not matter). Clouds without colour give no points.
pub fn robot_points(
    cloud: &crate::cloud::PointCloud,
    robot_color: [u8; 3],
    min_color_cosine: f64,
) -> Vec<[f64; 3]> {
    let Some(colors) = cloud.colors.as_ref() else {
        return Vec::new();
    };
    let r = robot_color.map(f64::from);
    let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    cloud
        .positions
        .iter()
        .zip(colors)
        .filter(|(p, c)| {
            let c = c.map(f64::from);
            let cn = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            p.iter().all(|v| v.is_finite())
                && cn > 0.0
                && rn > 0.0
                && (c[0] * r[0] + c[1] * r[1] + c[2] * r[2]) / (cn * rn) >= min_color_cosine
        })
        .map(|(p, _)| p.map(f64::from))
        .collect()
}

/// Reads frame `frame` of a scene folder (`depth_NNNN.png`, `color_NNNN.png`,
/// `intrinsics.json`, depth in millimetres) and returns its robot points (camera frame).
pub fn read_scene_robot_points(
    dir: &Path,
    frame: usize,
    params: &CalibrateParams,
) -> CalibrateResult<Vec<[f64; 3]>> {
    let camera = crate::io::intrinsics::read_camera_model(dir.join("intrinsics.json"))?;
    let color = dir.join(format!("color_{frame:04}.png"));
    let cloud = crate::io::rgbd::read_frame(
        dir.join(format!("depth_{frame:04}.png")),
        Some(&color),
        &camera,
    )?;
    Ok(robot_points(
        &cloud,
        params.robot_color,
        params.min_color_cosine,
    ))
}

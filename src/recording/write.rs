//! The one writer of a recording folder (softsense layout): what `scene generate` and
//! `hidden` write.

use super::{RecordingError, RecordingResult};
use crate::camera::Camera;
use serde::Serialize;
use std::path::{Path, PathBuf};

fn write_err(path: &Path, e: impl std::fmt::Display) -> RecordingError {
    RecordingError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Writes `v` as pretty JSON to `path`.
pub fn write_json(path: &Path, v: &impl Serialize) -> RecordingResult<()> {
    let text = serde_json::to_string_pretty(v).map_err(|e| write_err(path, e))?;
    Ok(crate::io::atomic::write(path, text.as_bytes())?)
}

/// A recording folder being written.
#[derive(Clone, Debug)]
pub struct RecordingWriter {
    dir: PathBuf,
}

impl RecordingWriter {
    /// Creates `dir` (and its parents) for a recording.
    pub fn create(dir: &Path) -> RecordingResult<Self> {
        std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Writes `intrinsics.json` (Open3D format, with the depth images' unit as
    /// `depth_scale`: a reader assuming millimetres would put the robot elsewhere) and
    /// `camera_pose.json`.
    pub fn write_camera(&self, camera: &Camera, depth_unit: f64) -> RecordingResult<()> {
        let mut intrinsics = camera.open3d_intrinsics();
        intrinsics["depth_scale"] = serde_json::json!(1.0 / depth_unit);
        self.write_json("intrinsics.json", &intrinsics)?;
        self.write_json(
            "camera_pose.json",
            &serde_json::json!({ "robot_from_camera": camera.robot_from_camera() }),
        )
    }

    /// Writes `intrinsics.json` alone (Open3D format) for a `width x height` camera with
    /// focal lengths and principal point `[fx, fy, cx, cy]` in pixels, and depth images in
    /// units of `depth_unit` metres.
    pub fn write_intrinsics(
        &self,
        [width, height]: [u32; 2],
        [fx, fy, cx, cy]: [f64; 4],
        depth_unit: f64,
    ) -> RecordingResult<()> {
        let intrinsics = serde_json::json!({
            "width": width,
            "height": height,
            "intrinsic_matrix": [fx, 0.0, 0.0, 0.0, fy, 0.0, cx, cy, 1.0],
            "depth_scale": 1.0 / depth_unit,
        });
        self.write_json("intrinsics.json", &intrinsics)
    }

    /// Writes frame `i`: `depth_NNNN.png` (16-bit, row-major `width x height`) and
    /// `color_NNNN.png` (8-bit RGB).
    pub fn write_frame(
        &self,
        i: usize,
        size: [u32; 2],
        depth: Vec<u16>,
        color: &[[u8; 3]],
    ) -> RecordingResult<()> {
        self.write_depth(i, size, depth)?;
        use crate::io::atomic::write_png;
        let [width, height] = size;
        let cp = self.dir.join(format!("color_{i:04}.png"));
        let flat: Vec<u8> = color.iter().flatten().copied().collect();
        let color = image::RgbImage::from_raw(width, height, flat)
            .ok_or_else(|| write_err(&cp, "colour buffer size"))?;
        Ok(write_png(&cp, &image::DynamicImage::ImageRgb8(color))?)
    }

    /// Writes `depth_NNNN.png` of frame `i` alone (a depth-only recording).
    pub fn write_depth(
        &self,
        i: usize,
        [width, height]: [u32; 2],
        depth: Vec<u16>,
    ) -> RecordingResult<()> {
        use crate::io::atomic::write_png;
        use image::DynamicImage;
        let dp = self.dir.join(format!("depth_{i:04}.png"));
        let depth = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(width, height, depth)
            .ok_or_else(|| write_err(&dp, "depth buffer size"))?;
        Ok(write_png(&dp, &DynamicImage::ImageLuma16(depth))?)
    }

    /// Writes `name` in the folder as pretty JSON.
    pub fn write_json(&self, name: &str, v: &impl Serialize) -> RecordingResult<()> {
        write_json(&self.dir.join(name), v)
    }
}

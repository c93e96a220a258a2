//! The depth-camera sensor model: depth noise σ = k·z², millimetre quantisation, holes at
//! grazing angles and silhouette edges, colour noise. Every random draw is a hash of
//! (seed, frame, pixel, stream), so results do not depend on thread scheduling.

use super::camera::CameraSpec;
use crate::math::rand::{normal, uniform};
use serde::{Deserialize, Serialize};

/// Sensor-model parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorModel {
    /// Master switch: false gives exact depth (still quantised to the depth unit).
    pub enabled: bool,
    /// Depth noise coefficient k in σ = k·z² (1/m; 0.002 gives 0.5 mm at 0.5 m). It holds
    /// for one focal length: a camera with more pixels across the same view has a smaller k
    /// (see [`SensorModel::for_camera`]).
    pub depth_k: f64,
    /// Depth unit of the PNG (m); 0.001 = millimetres.
    pub depth_unit: f64,
    /// Rays meeting the surface at more than this angle from its normal give holes (degrees).
    pub grazing_deg: f64,
    /// A depth jump to a 4-neighbour above this (m) marks a silhouette edge.
    pub edge_jump: f64,
    /// Probability that a silhouette-edge pixel is a hole.
    pub edge_hole_probability: f64,
    /// Colour noise standard deviation per channel (0-255 units).
    pub color_sigma: f64,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self {
            enabled: true,
            depth_k: 0.002,
            depth_unit: 0.001,
            grazing_deg: 80.0,
            edge_jump: 0.02,
            edge_hole_probability: 0.5,
            color_sigma: 3.0,
        }
    }
}

impl SensorModel {
    /// The default model for a stereo depth camera with `camera`'s focal length: the same
    /// disparity noise as the default has at [`CameraSpec::default`]'s 615 px, so `depth_k`
    /// is 0.002 × 615 / fx (1/m). Everything else is the default's, millimetre depth unit
    /// included.
    ///
    /// A stereo camera measures the disparity d = fx·b/z (b its baseline), so a disparity
    /// noise of σ_d pixels is a depth noise of σ_z = z²·σ_d / (fx·b): at a fixed σ_d, k =
    /// σ_d / (fx·b) falls as the focal length in pixels grows. The default's k at 615 px is
    /// σ_d ≈ 0.068 px for a D415's 55 mm baseline. This is why Intel's tuning guide runs the
    /// D415 at 1280x720: lower resolutions degrade its depth precision.
    ///
    /// ```
    /// use softsense::scene::camera::CameraSpec;
    /// use softsense::scene::sensor::SensorModel;
    /// let sd = SensorModel::for_camera(&CameraSpec::default());
    /// assert_eq!(sd.depth_k, SensorModel::default().depth_k);
    /// // The 1280x720 stream: 1.5 times the focal length, two thirds of the depth noise
    /// // (0.33 mm at 0.5 m against 0.5 mm).
    /// let hd = SensorModel::for_camera(&CameraSpec::d415_1280x720());
    /// assert!((hd.depth_k - 0.002 / 1.5).abs() < 1e-12);
    /// assert_eq!(hd.depth_unit, 0.001);
    /// ```
    pub fn for_camera(camera: &CameraSpec) -> Self {
        let default = Self::default();
        Self {
            depth_k: default.depth_k * CameraSpec::default().fx / camera.fx,
            ..default
        }
    }

    /// Checks every field's range; the error names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        let checks = [
            ("depth_k", self.depth_k, self.depth_k >= 0.0, ">= 0"),
            ("depth_unit", self.depth_unit, self.depth_unit > 0.0, "> 0"),
            (
                "grazing_deg",
                self.grazing_deg,
                (0.0..=90.0).contains(&self.grazing_deg),
                "in 0..=90",
            ),
            ("edge_jump", self.edge_jump, self.edge_jump > 0.0, "> 0"),
            (
                "edge_hole_probability",
                self.edge_hole_probability,
                (0.0..=1.0).contains(&self.edge_hole_probability),
                "in 0..=1",
            ),
            (
                "color_sigma",
                self.color_sigma,
                self.color_sigma >= 0.0,
                ">= 0",
            ),
        ];
        for (name, value, ok, want) in checks {
            if !(value.is_finite() && ok) {
                return Err(format!("sensor.{name} must be {want}, got {value}"));
            }
        }
        Ok(())
    }

    /// Applies the model to an exact depth image (m, 0 = no return) with the cosine of the
    /// incidence angle per pixel; returns depth in PNG units (0 = hole).
    pub fn depth(
        &self,
        z: &[f64],
        cos_incidence: &[f64],
        width: usize,
        seed: u64,
        frame: u64,
    ) -> Vec<u16> {
        let height = z.len().checked_div(width).unwrap_or(0);
        let cos_graze = self.grazing_deg.to_radians().cos();
        (0..z.len())
            .map(|i| {
                let zi = z[i];
                if zi.is_nan() || zi <= 0.0 {
                    return 0;
                }
                let mut value = zi;
                if self.enabled {
                    if cos_incidence[i] < cos_graze {
                        return 0;
                    }
                    let (u, v) = (i % width, i / width);
                    let jump = [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
                        .iter()
                        .any(|(du, dv)| {
                            let (nu, nv) = (u as i64 + du, v as i64 + dv);
                            if nu < 0 || nv < 0 || nu >= width as i64 || nv >= height as i64 {
                                return false;
                            }
                            let zn = z[nv as usize * width + nu as usize];
                            zn.is_nan() || zn <= 0.0 || zn - zi > self.edge_jump
                        });
                    if jump && uniform(seed, frame, i as u64, 0) < self.edge_hole_probability {
                        return 0;
                    }
                    value += self.depth_k * zi * zi * normal(seed, frame, i as u64, 1);
                }
                let q = (value / self.depth_unit).round();
                if (1.0..=65535.0).contains(&q) {
                    q as u16
                } else {
                    0
                }
            })
            .collect()
    }

    /// Adds colour noise to one pixel.
    pub fn color(&self, rgb: [f64; 3], seed: u64, frame: u64, pixel: u64) -> [u8; 3] {
        let mut out = [0u8; 3];
        for k in 0..3 {
            let n = if self.enabled {
                self.color_sigma * normal(seed, frame, pixel, 10 + k as u64)
            } else {
                0.0
            };
            out[k] = (rgb[k] + n).round().clamp(0.0, 255.0) as u8;
        }
        out
    }
}

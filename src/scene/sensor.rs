//! The depth-camera sensor model: depth noise σ = (σ₀ + k·z²)·(1 + g·(1/cos θ − 1)),
//! quantisation to the depth unit (and, opted in, to a step growing as z²), holes at grazing
//! angles, at silhouette edges and at random, flying pixels at depth edges, colour noise.
//! Every random draw is a hash of (seed, frame, pixel, stream), so results do not depend on
//! thread scheduling. The artefacts beyond σ = k·z² are off by default, so a scene without
//! them renders as before; docs/sensing.md gives their values fitted on real frames.

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
    /// Depth noise floor σ₀ added to k·z² (m; default 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub depth_sigma_floor: f64,
    /// Incidence gain g: σ grows by the factor 1 + g·(1/cos θ − 1) (default 0: none).
    #[serde(skip_serializing_if = "is_zero")]
    pub depth_sigma_incidence: f64,
    /// Quantisation step growing with distance, step = max(depth_unit, c·z²), as a
    /// disparity camera's (c in 1/m; default 0: the depth unit only).
    #[serde(skip_serializing_if = "is_zero")]
    pub depth_step_k: f64,
    /// Probability that any pixel is a hole (random dropout; default 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub hole_probability: f64,
    /// Probability that a pixel at a depth edge (a 4-neighbour more than `edge_jump` nearer
    /// or farther) mixes its depth with that neighbour's: a flying pixel (default 0).
    #[serde(skip_serializing_if = "is_zero")]
    pub flying_probability: f64,
    /// Spread of a flying pixel's mixing fraction t about 1/2: t uniform in 1/2 ± spread/2
    /// (0-1; default 1: anywhere between the two depths).
    #[serde(skip_serializing_if = "is_one")]
    pub flying_spread: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

fn is_one(x: &f64) -> bool {
    *x == 1.0
}

/// Draw streams of the depth model (uniform streams; the noise's normal takes 2 and 3).
const EDGE_HOLE: u64 = 0;
const NOISE: u64 = 1;
const DROPOUT: u64 = 4;
const FLYING: u64 = 5;
const FLYING_T: u64 = 6;

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
            depth_sigma_floor: 0.0,
            depth_sigma_incidence: 0.0,
            depth_step_k: 0.0,
            hole_probability: 0.0,
            flying_probability: 0.0,
            flying_spread: 1.0,
        }
    }
}

impl SensorModel {
    /// The default model for a stereo depth camera with `camera`'s focal length: the same
    /// disparity noise as the default has at [`CameraSpec::default`]'s 615 px, so `depth_k`
    /// is 0.002 × 615 / fx (1/m), and so is `depth_step_k`. Everything else is the default's, millimetre depth unit
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
            depth_step_k: default.depth_step_k * CameraSpec::default().fx / camera.fx,
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
            (
                "depth_sigma_floor",
                self.depth_sigma_floor,
                self.depth_sigma_floor >= 0.0,
                ">= 0",
            ),
            (
                "depth_sigma_incidence",
                self.depth_sigma_incidence,
                self.depth_sigma_incidence >= 0.0,
                ">= 0",
            ),
            (
                "depth_step_k",
                self.depth_step_k,
                self.depth_step_k >= 0.0,
                ">= 0",
            ),
            (
                "hole_probability",
                self.hole_probability,
                (0.0..=1.0).contains(&self.hole_probability),
                "in 0..=1",
            ),
            (
                "flying_probability",
                self.flying_probability,
                (0.0..=1.0).contains(&self.flying_probability),
                "in 0..=1",
            ),
            (
                "flying_spread",
                self.flying_spread,
                (0.0..=1.0).contains(&self.flying_spread),
                "in 0..=1",
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
        let image = DepthImage {
            z,
            width,
            height: z.len().checked_div(width).unwrap_or(0),
        };
        let cos_graze = self.grazing_deg.to_radians().cos();
        (0..z.len())
            .map(|i| {
                let zi = z[i];
                if zi.is_nan() || zi <= 0.0 {
                    return 0;
                }
                let mut value = zi;
                if self.enabled {
                    let key = (seed, frame, i as u64);
                    match self.artefacts(&image, i, cos_incidence[i], cos_graze, key) {
                        Some(v) => value = v,
                        None => return 0,
                    }
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

    /// Pixel `i`'s measured depth (m) before the depth unit's rounding, or None for a hole.
    /// `key` is (seed, frame, pixel) of its draws.
    fn artefacts(
        &self,
        image: &DepthImage,
        i: usize,
        cos_incidence: f64,
        cos_graze: f64,
        key: (u64, u64, u64),
    ) -> Option<f64> {
        let (seed, frame, pixel) = key;
        let zi = image.z[i];
        if cos_incidence < cos_graze {
            return None;
        }
        let near_side = image
            .neighbours(i)
            .any(|zn| !valid(zn) || zn - zi > self.edge_jump);
        if near_side && uniform(seed, frame, pixel, EDGE_HOLE) < self.edge_hole_probability {
            return None;
        }
        // Each opted-in artefact draws only when on, so the default's draws are unchanged.
        if self.hole_probability > 0.0
            && uniform(seed, frame, pixel, DROPOUT) < self.hole_probability
        {
            return None;
        }
        let mut value = zi;
        if self.flying_probability > 0.0 {
            let across = (image.neighbours(i))
                .filter(|&zn| valid(zn) && (zn - zi).abs() > self.edge_jump)
                .max_by(|a, b| (a - zi).abs().total_cmp(&(b - zi).abs()));
            if let Some(zn) = across {
                if uniform(seed, frame, pixel, FLYING) < self.flying_probability {
                    let u = uniform(seed, frame, pixel, FLYING_T);
                    let t = 0.5 + self.flying_spread * (u - 0.5);
                    value += t * (zn - zi);
                }
            }
        }
        // Written as before the opt-in terms (σ₀ = 0, g = 0), to keep default draws bit-equal.
        let mut sigma = self.depth_sigma_floor + self.depth_k * zi * zi;
        if self.depth_sigma_incidence > 0.0 {
            sigma *= 1.0 + self.depth_sigma_incidence * (1.0 / cos_incidence.max(1e-6) - 1.0);
        }
        value += sigma * normal(seed, frame, pixel, NOISE);
        if self.depth_step_k > 0.0 {
            let step = self.depth_unit.max(self.depth_step_k * zi * zi);
            value = (value / step).round() * step;
        }
        Some(value)
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

fn valid(z: f64) -> bool {
    !z.is_nan() && z > 0.0
}

/// An exact depth image (m, 0 or NaN = no return), row-major.
struct DepthImage<'a> {
    z: &'a [f64],
    width: usize,
    height: usize,
}

impl DepthImage<'_> {
    /// The depths of pixel `i`'s 4-neighbours inside the image.
    fn neighbours(&self, i: usize) -> impl Iterator<Item = f64> + '_ {
        let (u, v) = ((i % self.width) as i64, (i / self.width) as i64);
        [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
            .into_iter()
            .filter_map(move |(du, dv)| {
                let (nu, nv) = (u + du, v + dv);
                let inside =
                    nu >= 0 && nv >= 0 && nu < self.width as i64 && nv < self.height as i64;
                inside.then(|| self.z[nv as usize * self.width + nu as usize])
            })
    }
}

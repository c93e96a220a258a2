//! The robot colour model: which pixel colours are the robot's.
//!
//! A colour is the robot's when its CIELAB hue is within a tolerance of the reference
//! colour's hue and its chroma is high enough for a hue to mean something. Hue, not RGB
//! distance, because shading on a curved silicone body changes lightness far more than
//! hue; the chroma floor keeps grey table and shadow pixels out, whose hue is noise.
//!
//! ```
//! use softsense::segment::robot_color::RobotColorModel;
//! let green = RobotColorModel::default();
//! assert!(green.is_robot([40, 200, 60]));
//! assert!(green.is_robot([20, 100, 30])); // the same green in shadow
//! assert!(!green.is_robot([128, 128, 128])); // grey: no hue
//! assert!(!green.is_robot([200, 40, 40])); // a red probe
//! ```

use super::color::rgb_to_lab;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::f64::consts::PI;

/// Tells robot colours from others by CIELAB hue and chroma.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotColorModel {
    /// The robot's colour, 8-bit sRGB. Default 40, 200, 60 (the bundled robots' green).
    pub reference: [u8; 3],
    /// Largest CIELAB hue difference from the reference counted as robot (degrees).
    /// Default 25.
    pub hue_tolerance_deg: f64,
    /// Smallest CIELAB chroma counted as robot. Default 12.
    pub min_chroma: f64,
}

impl Default for RobotColorModel {
    fn default() -> Self {
        Self {
            reference: [40, 200, 60],
            hue_tolerance_deg: 25.0,
            min_chroma: 12.0,
        }
    }
}

impl RobotColorModel {
    /// The model with another reference colour and the default tolerances.
    pub fn with_reference(reference: [u8; 3]) -> Self {
        Self {
            reference,
            ..Self::default()
        }
    }

    /// Whether `rgb` is a robot colour (for many pixels, [`RobotColorModel::classifier`]).
    pub fn is_robot(&self, rgb: [u8; 3]) -> bool {
        self.is_robot_lab(
            rgb,
            self.reference_hue(),
            self.hue_tolerance_deg.to_radians(),
        )
    }

    /// How far `rgb`'s CIELAB hue is from the reference's (degrees, 0-180); `None` when its
    /// chroma is below `min_chroma` (grey: no hue).
    pub fn hue_difference_deg(&self, rgb: [u8; 3]) -> Option<f64> {
        self.hue_gap(rgb, self.reference_hue()).map(f64::to_degrees)
    }

    /// `rgb`'s hue difference to `ref_hue` (rad), `None` below the chroma floor.
    fn hue_gap(&self, rgb: [u8; 3], ref_hue: f64) -> Option<f64> {
        let lab = rgb_to_lab(rgb);
        let chroma = (lab[1] * lab[1] + lab[2] * lab[2]).sqrt();
        let dh = (lab[2].atan2(lab[1]) - ref_hue + PI).rem_euclid(2.0 * PI) - PI;
        (chroma >= self.min_chroma).then_some(dh.abs())
    }

    /// The reference colour's CIELAB hue (rad).
    fn reference_hue(&self) -> f64 {
        let reference = rgb_to_lab(self.reference);
        reference[2].atan2(reference[1])
    }

    fn is_robot_lab(&self, rgb: [u8; 3], ref_hue: f64, tol: f64) -> bool {
        self.hue_gap(rgb, ref_hue).is_some_and(|dh| dh <= tol)
    }

    /// A classifier for one frame that decides each distinct colour once: a frame's tens
    /// of thousands of robot pixels share a few thousand colours, and a Lab conversion costs
    /// three cube roots.
    pub fn classifier(&self) -> RobotColorClassifier {
        RobotColorClassifier {
            model: *self,
            ref_hue: self.reference_hue(),
            tol: self.hue_tolerance_deg.to_radians(),
            seen: HashMap::new(),
        }
    }
}

/// [`RobotColorModel::classifier`]: the model with a memory of the colours it decided.
#[derive(Clone, Debug)]
pub struct RobotColorClassifier {
    model: RobotColorModel,
    ref_hue: f64,
    tol: f64,
    seen: HashMap<[u8; 3], bool>,
}

impl RobotColorClassifier {
    /// Whether `rgb` is a robot colour.
    pub fn is_robot(&mut self, rgb: [u8; 3]) -> bool {
        let (model, ref_hue, tol) = (&self.model, self.ref_hue, self.tol);
        *self
            .seen
            .entry(rgb)
            .or_insert_with(|| model.is_robot_lab(rgb, ref_hue, tol))
    }
}

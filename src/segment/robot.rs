//! Which segment is the robot: the one matching a reference colour in CIELAB, or the
//! largest segment (the thesis code's rule).
//!
//! ```
//! use softsense::segment::robot::{select_robot, RobotRule, ChosenBy};
//! use softsense::segment::Segment;
//! let seg = |n: usize, c: [f32; 3]| Segment { indices: (0..n).collect(), mean_color: c, min: [0.0; 3], max: [0.0; 3] };
//! let segs = vec![seg(50, [200.0, 30.0, 30.0]), seg(10, [20.0, 40.0, 220.0])];
//! let largest = select_robot(&segs, &RobotRule::Largest).unwrap();
//! assert_eq!((largest.segment, largest.chosen_by.clone()), (0, ChosenBy::Largest));
//! let blue = select_robot(&segs, &RobotRule::Color { rgb: [0, 0, 255], tolerance: 40.0 }).unwrap();
//! assert_eq!(blue.segment, 1);
//! ```

use super::color::{delta_e, rgb_f64_to_lab, rgb_to_lab};
use super::{Segment, SegmentError};

/// How to choose the robot segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum RobotRule {
    /// The largest segment whose mean colour is within `tolerance` (CIE76 ΔE) of `rgb`.
    Color {
        /// Reference colour, 8-bit sRGB.
        rgb: [u8; 3],
        /// Largest ΔE (CIELAB units) accepted.
        tolerance: f64,
    },
    /// The segment with the most points (first one on ties).
    Largest,
}

/// Which rule chose the robot. JSON: `{"rule": "color", "delta_e": ...}` or
/// `{"rule": "largest"}`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "rule", rename_all = "lowercase")]
pub enum ChosenBy {
    /// The colour rule, with the chosen segment's ΔE to the reference.
    Color {
        /// ΔE of the segment's mean colour to the reference.
        delta_e: f64,
    },
    /// The largest-segment rule.
    Largest,
}

/// The chosen robot segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RobotChoice {
    /// Index into the segment list.
    pub segment: usize,
    /// The rule that chose it.
    pub chosen_by: ChosenBy,
}

/// Chooses the robot among `segments` by `rule`; an error when there is no segment or no
/// segment is within the colour tolerance.
pub fn select_robot(segments: &[Segment], rule: &RobotRule) -> Result<RobotChoice, SegmentError> {
    match rule {
        RobotRule::Largest => {
            let mut best: Option<usize> = None;
            for (i, s) in segments.iter().enumerate() {
                if best.is_none_or(|b| s.len() > segments[b].len()) {
                    best = Some(i);
                }
            }
            best.map(|segment| RobotChoice {
                segment,
                chosen_by: ChosenBy::Largest,
            })
            .ok_or_else(|| SegmentError::NoRobot("no segments".into()))
        }
        RobotRule::Color { rgb, tolerance } => {
            let reference = rgb_to_lab(*rgb);
            let mut best: Option<(usize, f64)> = None;
            let mut nearest = f64::INFINITY;
            for (i, s) in segments.iter().enumerate() {
                let lab = rgb_f64_to_lab(s.mean_color.map(|c| c as f64 / 255.0));
                let de = delta_e(lab, reference);
                nearest = nearest.min(de);
                if de <= *tolerance && best.is_none_or(|(b, _)| s.len() > segments[b].len()) {
                    best = Some((i, de));
                }
            }
            best.map(|(segment, delta_e)| RobotChoice {
                segment,
                chosen_by: ChosenBy::Color { delta_e },
            })
            .ok_or_else(|| {
                SegmentError::NoRobot(format!(
                    "no segment within ΔE {tolerance} of {rgb:?} (nearest ΔE {nearest:.1})"
                ))
            })
        }
    }
}

//! Which segment is the robot: the largest whose mean colour the robot colour model
//! ([`RobotColorModel`]) calls the robot's, or the largest segment (the thesis code's rule).
//!
//! ```
//! use softsense::segment::robot::{select_robot, RobotRule, ChosenBy};
//! use softsense::segment::robot_color::RobotColorModel;
//! use softsense::segment::Segment;
//! let seg = |n: usize, c: [f32; 3]| Segment { indices: (0..n).collect(), mean_color: c, min: [0.0; 3], max: [0.0; 3] };
//! let segs = vec![seg(50, [200.0, 30.0, 30.0]), seg(10, [20.0, 40.0, 220.0])];
//! let largest = select_robot(&segs, &RobotRule::Largest).unwrap();
//! assert_eq!((largest.segment, largest.chosen_by.clone()), (0, ChosenBy::Largest));
//! let blue = RobotRule::Color(RobotColorModel::with_reference([0, 0, 255]));
//! let blue = select_robot(&segs, &blue).unwrap();
//! assert_eq!(blue.segment, 1);
//! ```

use super::robot_color::RobotColorModel;
use super::{Segment, SegmentError};

/// How to choose the robot segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum RobotRule {
    /// The largest segment whose mean colour the model calls the robot's.
    Color(RobotColorModel),
    /// The segment with the most points (first one on ties).
    Largest,
}

/// Which rule chose the robot. JSON: `{"rule": "color", "hue_difference_deg": ...}` or
/// `{"rule": "largest"}`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "rule", rename_all = "lowercase")]
pub enum ChosenBy {
    /// The colour rule, with the chosen segment's hue difference to the reference.
    Color {
        /// CIELAB hue difference of the segment's mean colour to the reference (degrees).
        hue_difference_deg: f64,
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
        RobotRule::Color(model) => {
            let tolerance = model.hue_tolerance_deg;
            let mut best: Option<(usize, f64)> = None;
            let mut nearest = f64::INFINITY;
            for (i, s) in segments.iter().enumerate() {
                let mean = s.mean_color.map(|c| c.round().clamp(0.0, 255.0) as u8);
                let Some(dh) = model.hue_difference_deg(mean) else {
                    continue;
                };
                nearest = nearest.min(dh);
                if dh <= tolerance && best.is_none_or(|(b, _)| s.len() > segments[b].len()) {
                    best = Some((i, dh));
                }
            }
            best.map(|(segment, hue_difference_deg)| RobotChoice {
                segment,
                chosen_by: ChosenBy::Color { hue_difference_deg },
            })
            .ok_or_else(|| {
                SegmentError::NoRobot(format!(
                    "no segment within {tolerance}° of the hue of {:?} (nearest {nearest:.1}°)",
                    model.reference
                ))
            })
        }
    }
}

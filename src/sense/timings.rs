//! Where the time of a frame went ([`StageTimings`]), stage by stage, and its medians over
//! frames.

use crate::inverse::LoopTimings;
use serde::Serialize;

/// Milliseconds of a duration.
pub(super) fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Where the time of one frame went (ms). Stage times add up the work done in each stage:
/// where candidate estimates run in parallel (rayon) they are summed over threads, so their
/// sum can exceed `total`, the wall time of the frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageTimings {
    /// Decoding the depth and colour PNGs and back-projecting depth into points.
    pub read: f64,
    /// Filter: transform to the robot frame and crop to the working box.
    pub crop: f64,
    /// Segment: the colour model splitting robot and object points.
    pub segment: f64,
    /// The free FE solve at the frame's actuator inputs (near zero when cached).
    pub free_solve: f64,
    /// Contact detection (KD-tree) and Euclidean grouping.
    pub contacts: f64,
    /// Location mapping: options per contact, their linearisation and the QPs choosing one.
    pub mapping: f64,
    /// Registration of the features along their normal lines (grid build included).
    pub register: f64,
    /// FE updates: Newton solves under the estimated forces.
    pub fe_update: f64,
    /// Compliance: tangent factorisation at the updated state and W = H K⁻¹ Hᵀ.
    pub compliance: f64,
    /// Intensity QPs (clarabel), identifiability and uncertainty included.
    pub qp: f64,
    /// Wall time of the whole frame: read to report.
    pub total: f64,
}

impl StageTimings {
    /// Stage names and values, in chain order (`total` last).
    pub fn named(&self) -> [(&'static str, f64); 11] {
        [
            ("read", self.read),
            ("crop", self.crop),
            ("segment", self.segment),
            ("free_solve", self.free_solve),
            ("contacts", self.contacts),
            ("mapping", self.mapping),
            ("register", self.register),
            ("fe_update", self.fe_update),
            ("compliance", self.compliance),
            ("qp", self.qp),
            ("total", self.total),
        ]
    }

    /// Adds the loop timings of one frame estimate.
    pub(super) fn add_loop(&mut self, t: &LoopTimings) {
        self.register += t.register;
        self.fe_update += t.fe_update;
        self.compliance += t.compliance;
        self.qp += t.qp;
    }
}

/// Per-stage medians over frames (ms), in [`StageTimings::named`] order.
pub fn median_timings(timings: &[StageTimings]) -> Vec<(&'static str, f64)> {
    let named: Vec<_> = timings.iter().map(|t| t.named()).collect();
    StageTimings::default()
        .named()
        .iter()
        .enumerate()
        .map(|(k, (name, _))| {
            let mut v: Vec<f64> = named.iter().map(|n| n[k].1).collect();
            (*name, crate::math::median(&mut v))
        })
        .collect()
}

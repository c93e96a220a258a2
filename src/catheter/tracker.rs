//! The tip tracker and its calibration to the robot (thesis 5.5.1-5.5.2): the tracker
//! measures the tip in its own frame with noise; seven feature points on the tube, known in
//! the robot's frame and measured by the tracker, give the tracker-to-robot transform by
//! the SVD fit (Kabsch) of `geometry::rigid`.

use super::tube::Tube;
use super::{CatheterError, CatheterResult};
use crate::geometry::rigid::kabsch;
use crate::math::rand::normal;
use crate::math::{Iso3, Point3};
use serde::Serialize;

/// Noise streams of the counter-based draws.
const TIP_STREAM: u64 = 0;
const FEATURE_STREAM: u64 = 1;

/// A simulated tracker with its calibration.
#[derive(Clone, Debug)]
pub struct Tracker {
    tracker_from_robot: Iso3,
    robot_from_tracker_estimate: Iso3,
    noise: f64,
    seed: u64,
    /// The calibration's quality.
    pub calibration: Calibration,
}

/// How well the feature-point calibration went.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Calibration {
    /// Feature points used.
    pub points: usize,
    /// RMS of the fit's residuals (m).
    pub rms: f64,
    /// Largest distance, over the feature points, between where the estimate and the truth
    /// put a tracker point in the robot's frame (m).
    pub error: f64,
}

/// `n` feature points on the tube's wall, spread along its length and round it (robot
/// frame): not collinear even on a straight tube.
pub fn feature_points(tube: &Tube, n: usize) -> Vec<[f64; 3]> {
    let length = tube.centreline.length();
    (0..n)
        .map(|i| {
            let c = tube
                .centreline
                .at(length * i as f64 / (n - 1).max(1) as f64);
            let (a, b) = crate::math::tangents(c.tangent);
            let angle = std::f64::consts::TAU * i as f64 / n as f64 * 3.0;
            let (s, co) = angle.sin_cos();
            std::array::from_fn(|k| c.point[k] + tube.radius * (co * a[k] + s * b[k]))
        })
        .collect()
}

impl Tracker {
    /// A tracker at `tracker_from_robot` with per-axis noise `noise` m (standard
    /// deviation), calibrated on `points` feature points of `tube` measured with noise
    /// `calibration_noise` m.
    pub fn calibrated(
        tracker_from_robot: Iso3,
        noise: f64,
        calibration_noise: f64,
        tube: &Tube,
        points: usize,
        seed: u64,
    ) -> CatheterResult<Self> {
        let robot = feature_points(tube, points);
        let measured: Vec<[f64; 3]> = (robot.iter().enumerate())
            .map(|(i, &p)| {
                noisy(
                    tracker_from_robot,
                    p,
                    calibration_noise,
                    seed,
                    i as u64,
                    FEATURE_STREAM,
                )
            })
            .collect();
        let estimate = kabsch(&measured, &robot).ok_or_else(|| {
            CatheterError::Path("the tracker calibration's feature points are degenerate".into())
        })?;
        let apply = |t: &Iso3, p: [f64; 3]| {
            let q = t * Point3::from(p);
            [q.x, q.y, q.z]
        };
        let rms = (robot.iter().zip(&measured))
            .map(|(r, m)| crate::math::dist(apply(&estimate, *m), *r).powi(2))
            .sum::<f64>()
            / robot.len() as f64;
        let truth = tracker_from_robot.inverse();
        let error = (measured.iter())
            .map(|m| crate::math::dist(apply(&estimate, *m), apply(&truth, *m)))
            .fold(0.0, f64::max);
        Ok(Self {
            tracker_from_robot,
            robot_from_tracker_estimate: estimate,
            noise,
            seed,
            calibration: Calibration {
                points,
                rms: rms.sqrt(),
                error,
            },
        })
    }

    /// The tip at `tip_in_robot` as the tracker reports it at step `k`, brought into the
    /// robot's frame by the calibration (m).
    pub fn measure(&self, tip_in_robot: [f64; 3], k: usize) -> [f64; 3] {
        let m = noisy(
            self.tracker_from_robot,
            tip_in_robot,
            self.noise,
            self.seed,
            k as u64,
            TIP_STREAM,
        );
        let q = self.robot_from_tracker_estimate * Point3::from(m);
        [q.x, q.y, q.z]
    }
}

/// `p` (robot frame) seen by the tracker, with Gaussian noise of `sigma` per axis.
fn noisy(
    tracker_from_robot: Iso3,
    p: [f64; 3],
    sigma: f64,
    seed: u64,
    key: u64,
    stream: u64,
) -> [f64; 3] {
    let q = tracker_from_robot * Point3::from(p);
    let q = [q.x, q.y, q.z];
    std::array::from_fn(|axis| q[axis] + sigma * normal(seed, key, axis as u64, stream))
}

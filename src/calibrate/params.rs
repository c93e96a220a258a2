//! Calibration options.

use super::{CalibrateError, CalibrateResult};
use crate::inverse::qp::QpParams;
use crate::segment::robot_color::RobotColorModel;

/// Calibration options.
#[derive(Clone, Debug)]
pub struct CalibrateParams {
    /// Which pixel colours are the robot's; default [`RobotColorModel::default`] (the
    /// bundled robots' green), as `sense` uses.
    pub color: RobotColorModel,
    /// At most this many measured points are used (evenly strided subsample); default 6000.
    pub max_points: usize,
    /// Fewest robot points accepted; default 50.
    pub min_points: usize,
    /// Outer iterations (I_1 of Algorithm 3.1); default 30.
    pub max_iterations: usize,
    /// Point-to-plane ICP iterations per outer iteration (rigid fit, re-matching each
    /// time); default 15.
    pub icp_iterations: usize,
    /// Point-to-point (SVD) ICP iterations of the coarse alignment from the rough start,
    /// before anything else; default 20.
    pub coarse_iterations: usize,
    /// Coarse restarts turned by ± this about each robot axis (degrees; 0 for none);
    /// default 15.
    pub coarse_turn_deg: f64,
    /// QP + FE updates per outer iteration (I_2 of Algorithm 3.1); default 1.
    pub fe_updates: usize,
    /// A match farther than `trim_factor` × the median match distance is dropped;
    /// default 3.
    pub trim_factor: f64,
    /// ... but the trim distance never goes below this (m); default 0.003.
    pub min_trim: f64,
    /// Stop when the pose moves less than this in an outer iteration (m); default 5e-5.
    pub translation_tol: f64,
    /// Stop when the pose turns less than this in an outer iteration (rad); default 5e-5.
    pub rotation_tol: f64,
    /// Stop when no tension changes by more than this (N); default 1e-3.
    pub tension_tol: f64,
    /// A settled fit with a larger final RMS point-to-surface distance is reported as
    /// [`CalibrationStatus::PoorFit`](super::CalibrationStatus::PoorFit) (m); default 0.001.
    pub max_residual_rms: f64,
    /// Fewest matched points, as a fraction of the points used, before giving up;
    /// default 0.3.
    pub min_matched_fraction: f64,
    /// Solve the rigid motion together with the tensions in the actuator QP (one
    /// Gauss-Newton step of 3.9) instead of holding the pose; default true.
    // Holding the pose (the thesis's alternation) crawls when a rigid tilt and a bend of
    // the legs look alike.
    pub joint: bool,
    /// QP solver options.
    pub qp: QpParams,
}

impl Default for CalibrateParams {
    fn default() -> Self {
        Self {
            color: RobotColorModel::default(),
            max_points: 6000,
            min_points: 50,
            max_iterations: 30,
            icp_iterations: 15,
            coarse_iterations: 20,
            coarse_turn_deg: 15.0,
            fe_updates: 1,
            trim_factor: 3.0,
            min_trim: 0.003,
            translation_tol: 5e-5,
            rotation_tol: 5e-5,
            tension_tol: 1e-3,
            min_matched_fraction: 0.3,
            max_residual_rms: 0.001,
            joint: true,
            qp: QpParams::default(),
        }
    }
}

/// Rejects options the calibration cannot run with.
pub(super) fn check_params(p: &CalibrateParams) -> CalibrateResult<()> {
    let bad = |s: &str| Err(CalibrateError::Param(s.into()));
    if p.max_points == 0 || p.max_iterations == 0 || p.icp_iterations == 0 {
        return bad("max_points, max_iterations and icp_iterations must be positive");
    }
    if !(p.trim_factor > 0.0 && p.min_trim > 0.0) {
        return bad("trim_factor and min_trim must be positive");
    }
    if !(0.0..=1.0).contains(&p.min_matched_fraction) {
        return bad("min_matched_fraction must be in [0, 1]");
    }
    Ok(())
}

//! The tracker-to-robot transform from markers (thesis 3.3 calibrates the sensor-robot
//! system with markers): the rigid fit of the markers' tracked rest positions (tracker
//! frame) onto their positions on the model (robot frame), by least squares
//! ([`crate::geometry::rigid::kabsch`]).

use super::{MarkersError, MarkersResult};
use crate::math::pose::Pose;
use crate::math::{Mat3, Vec3};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Points whose second principal spread is below this are collinear for the fit (m, RMS
/// distance from their best line): the rotation about that line would be free.
pub const MIN_SPREAD: f64 = 1e-4;

/// A marker calibration, as written to its JSON file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarkerCalibration {
    /// Takes tracker-frame points into the robot (model) frame.
    pub robot_from_tracker: Pose,
    /// RMS distance between the mapped tracks and the model positions (m).
    pub residual_rms_m: f64,
    /// Each marker's residual distance (m), in `markers` order.
    pub residuals_m: Vec<f64>,
    /// The markers fitted.
    pub markers: Vec<String>,
    /// Their model positions the fit matched (m, robot frame), in `markers` order.
    pub model_positions_m: Vec<[f64; 3]>,
    /// How many frames each tracked position averaged (the fit's noise is 1/N of a frame's).
    pub reference_frames: usize,
}

/// Fits `robot_from_tracker` to the pairs (tracker-frame position, model position), both
/// in metres. Needs at least 3 markers not on one line.
pub fn fit_robot_from_tracker(
    names: &[String],
    tracker: &[[f64; 3]],
    model: &[[f64; 3]],
) -> MarkersResult<MarkerCalibration> {
    assert_eq!(tracker.len(), model.len(), "one model position per track");
    assert_eq!(names.len(), model.len(), "one name per marker");
    if tracker.len() < 3 {
        return Err(MarkersError::CalibrationTooFew {
            markers: tracker.len(),
        });
    }
    let spread = second_spread(model).min(second_spread(tracker));
    if spread.is_nan() || spread < MIN_SPREAD {
        return Err(MarkersError::CalibrationOnALine {
            markers: tracker.len(),
            spread,
            min_spread: MIN_SPREAD,
        });
    }
    let iso =
        crate::geometry::rigid::kabsch(tracker, model).ok_or(MarkersError::CalibrationNonFinite)?;
    let pose = Pose::from_iso(&iso);
    let residuals: Vec<f64> = (tracker.iter().zip(model))
        .map(|(t, m)| (Vec3::from(pose.apply(*t)) - Vec3::from(*m)).norm())
        .collect();
    let rms = (residuals.iter().map(|r| r * r).sum::<f64>() / residuals.len() as f64).sqrt();
    Ok(MarkerCalibration {
        robot_from_tracker: pose,
        residual_rms_m: rms,
        residuals_m: residuals,
        markers: names.to_vec(),
        model_positions_m: model.to_vec(),
        reference_frames: 1,
    })
}

/// The covariance, in units of σ² (the tracker's noise per coordinate), of the offset a
/// rigid fit on `fitted` (each the mean of `frames` frames) leaves at the points `at`:
/// B_at (B_fᵀB_f)⁻¹ B_atᵀ / frames, B the small rigid motions [I | −[p − c]×] about the
/// fitted points' centroid c. The fit's error is one rigid motion, the same in every frame
/// mapped by it, so its share of the forces' σ does not average out over frames.
pub fn rigid_fit_covariance(fitted: &[[f64; 3]], at: &[[f64; 3]], frames: usize) -> DMatrix<f64> {
    let n = fitted.len().max(1) as f64;
    let c = fitted.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let basis = |ps: &[[f64; 3]]| {
        let mut b = DMatrix::zeros(3 * ps.len(), 6);
        for (j, p) in ps.iter().enumerate() {
            let d = Vec3::from(*p) - c;
            for a in 0..3 {
                b[(3 * j + a, a)] = 1.0;
            }
            // (ω × d) = −[d]× ω
            let cross = -d.cross_matrix();
            for a in 0..3 {
                for k in 0..3 {
                    b[(3 * j + a, 3 + k)] = cross[(a, k)];
                }
            }
        }
        b
    };
    let (bf, ba) = (basis(fitted), basis(at));
    let gram = bf.tr_mul(&bf);
    match gram.try_inverse() {
        Some(inv) => &ba * inv * ba.transpose() / frames.max(1) as f64,
        None => DMatrix::from_element(3 * at.len(), 3 * at.len(), f64::INFINITY),
    }
}

/// The RMS distance of `points` from their best-fitting line: the square root of the
/// second-largest eigenvalue of their scatter, per point.
fn second_spread(points: &[[f64; 3]]) -> f64 {
    let n = points.len() as f64;
    let c = points.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let mut s = Mat3::zeros();
    for p in points {
        let d = Vec3::from(*p) - c;
        s += d * d.transpose();
    }
    let mut e: Vec<f64> = s.symmetric_eigenvalues().iter().copied().collect();
    e.sort_by(|a, b| b.total_cmp(a));
    (e[1].max(0.0) / n).sqrt()
}

/// Writes `calibration` as pretty JSON (all or nothing).
pub fn write_calibration(path: &Path, calibration: &MarkerCalibration) -> MarkersResult<()> {
    let text = serde_json::to_string_pretty(calibration).expect("a calibration serialises") + "\n";
    Ok(crate::io::atomic::write(path, text.as_bytes())?)
}

/// Reads a calibration written by [`write_calibration`]; a matrix that is not rigid is
/// refused.
pub fn read_calibration(path: &Path) -> MarkersResult<MarkerCalibration> {
    let text = std::fs::read_to_string(path).map_err(|source| MarkersError::File {
        path: path.display().to_string(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|source| MarkersError::NotACalibration {
        path: path.display().to_string(),
        source,
    })
}

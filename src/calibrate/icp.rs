//! Matching measured points to the FE surface and rigid ICP against it: the fine fit
//! (trimmed, point-to-plane) and the coarse alignment from a rough start.

use super::surface::{SurfaceIndex, SurfaceMatch};
use super::{CalibrateError, CalibrateParams, CalibrateResult};
use crate::geometry::rigid::{kabsch, point_to_plane_step};
use crate::math::{Iso3, Point3, Vec3};
use nalgebra::{Translation3, UnitQuaternion};

/// Matched pairs at a pose: measured point in the robot frame, its surface match.
pub(super) struct Matches {
    /// Measured points in the robot frame.
    pub(super) src: Vec<[f64; 3]>,
    /// Their closest surface points.
    pub(super) hits: Vec<SurfaceMatch>,
    /// RMS match distance (m).
    pub(super) rms: f64,
}

/// Matches the points at `pose` to the surface, dropping matches farther than the trim
/// distance; errors when too few remain.
pub(super) fn match_points(
    index: &SurfaceIndex,
    camera_points: &[[f64; 3]],
    pose: &Iso3,
    params: &CalibrateParams,
) -> CalibrateResult<Matches> {
    let all: Vec<([f64; 3], SurfaceMatch)> = camera_points
        .iter()
        .filter_map(|p| {
            let q = pose * Point3::from(*p);
            let q = [q.x, q.y, q.z];
            index.closest(q).map(|m| (q, m))
        })
        .collect();
    let mut d: Vec<f64> = all.iter().map(|(_, m)| m.distance).collect();
    let median = if d.is_empty() {
        0.0
    } else {
        let k = d.len() / 2;
        *d.select_nth_unstable_by(k, f64::total_cmp).1
    };
    let trim = (params.trim_factor * median).max(params.min_trim);
    let (src, hits): (Vec<_>, Vec<_>) = all.into_iter().filter(|(_, m)| m.distance <= trim).unzip();
    let needed = (params.min_matched_fraction * camera_points.len() as f64).ceil() as usize;
    if src.len() < needed.max(6) {
        return Err(CalibrateError::LostTrack {
            matched: src.len(),
            total: camera_points.len(),
        });
    }
    let rms =
        (hits.iter().map(|m| m.distance * m.distance).sum::<f64>() / hits.len() as f64).sqrt();
    Ok(Matches { src, hits, rms })
}

/// ICP against a fixed surface, point-to-point by SVD ([`kabsch`], robust far from the
/// answer) or point-to-plane Gauss-Newton (fast and exact near it); returns the pose and
/// the last matches.
pub(super) fn fit_pose(
    index: &SurfaceIndex,
    camera_points: &[[f64; 3]],
    mut pose: Iso3,
    iterations: usize,
    point_to_point: bool,
    params: &CalibrateParams,
) -> CalibrateResult<(Iso3, Matches)> {
    for _ in 0..iterations {
        let m = match_points(index, camera_points, &pose, params)?;
        let dst: Vec<[f64; 3]> = m.hits.iter().map(|h| h.point).collect();
        let nrm: Vec<[f64; 3]> = m.hits.iter().map(|h| h.normal).collect();
        let step = if point_to_point {
            kabsch(&m.src, &dst)
        } else {
            point_to_plane_step(&m.src, &dst, &nrm)
        };
        let Some(step) = step else {
            break;
        };
        pose = step * pose;
        let (dt, dr) = (step.translation.vector.norm(), step.rotation.angle());
        if dt < 0.1 * params.translation_tol && dr < 0.1 * params.rotation_tol {
            break;
        }
    }
    let m = match_points(index, camera_points, &pose, params)?;
    Ok((pose, m))
}

/// Truncated RMS distance of the points at `pose` to the surface: each distance capped at
/// `cap`, so a pose that explains most points well beats one that explains all poorly.
fn truncated_rms(index: &SurfaceIndex, camera_points: &[[f64; 3]], pose: &Iso3, cap: f64) -> f64 {
    let sum: f64 = camera_points
        .iter()
        .map(|p| {
            let q = pose * Point3::from(*p);
            index
                .closest([q.x, q.y, q.z])
                .map_or(cap, |m| m.distance.min(cap))
                .powi(2)
        })
        .sum();
    (sum / camera_points.len().max(1) as f64).sqrt()
}

/// The coarse alignment: point-to-point then point-to-plane ICP from the start and from
/// the start turned by ± `coarse_turn_deg` about each robot axis (through the points'
/// centroid), keeping the result with the smallest truncated RMS; every point is matched
/// (no trimming). ICP alone falls into a wrong minimum from some 10° starts on a
/// four-legged robot; a handful of restarts finds the right basin.
pub(super) fn coarse_align(
    index: &SurfaceIndex,
    camera_points: &[[f64; 3]],
    start: &Iso3,
    params: &CalibrateParams,
) -> CalibrateResult<Iso3> {
    let n = camera_points.len() as f64;
    let c = camera_points
        .iter()
        .fold(Vec3::zeros(), |a, p| a + (start * Point3::from(*p)).coords)
        / n;
    let mut turns = vec![Vec3::zeros()];
    if params.coarse_turn_deg > 0.0 {
        for k in 0..3 {
            for s in [1.0, -1.0] {
                let mut a = Vec3::zeros();
                a[k] = s * params.coarse_turn_deg.to_radians();
                turns.push(a);
            }
        }
    }
    // No trimming here: from a far start the trimmed set is the part that already fits,
    // which pulls ICP into a wrong minimum (seen from -10° about x, -30 mm along z).
    let all = CalibrateParams {
        trim_factor: f64::INFINITY,
        ..params.clone()
    };
    let params = &all;
    let mut best: Option<(f64, Iso3)> = None;
    let mut last_err = None;
    for a in turns {
        let rot = UnitQuaternion::from_scaled_axis(a);
        let turn = Iso3::from_parts(Translation3::from(c - rot * c), rot);
        let fitted = fit_pose(
            index,
            camera_points,
            turn * start,
            params.coarse_iterations,
            true,
            params,
        )
        .and_then(|(p, _)| {
            fit_pose(
                index,
                camera_points,
                p,
                2 * params.icp_iterations,
                false,
                params,
            )
        });
        match fitted {
            Ok((pose, _)) => {
                let score = truncated_rms(index, camera_points, &pose, params.min_trim);
                if best.is_none_or(|b| score < b.0) {
                    best = Some((score, pose));
                }
            }
            Err(e) => last_err = Some(e),
        }
    }
    match (best, last_err) {
        (Some((_, pose)), _) => Ok(pose),
        (None, Some(e)) => Err(e),
        (None, None) => Ok(*start),
    }
}

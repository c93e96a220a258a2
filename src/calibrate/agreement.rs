//! How well two calibrated cameras agree on the robot's surface: each robot point of one
//! camera (in the robot frame, by its calibrated pose) against the surface the other camera
//! saw there (a plane fitted to its nearest points), over the part both cameras see.

use crate::features::pca_normal;
use crate::search::KdTree;
use serde::Serialize;

/// Neighbours of the other camera a plane is fitted to.
const PLANE_POINTS: usize = 10;

/// Two cameras' agreement on the robot's surface ([`camera_agreement`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Agreement {
    /// Points of the first camera over the second's surface (all their plane's points
    /// within `overlap_radius`).
    pub overlap_points: usize,
    /// Median distance from those points to the second camera's surface (m).
    pub median: f64,
    /// RMS of the same distances (m).
    pub rms: f64,
    /// 95th percentile (m).
    pub p95: f64,
}

/// Distances from the robot points `a` of one camera to the surface the robot points `b`
/// of another saw (both in the robot frame, m): for each point of `a` whose
/// 10 nearest points of `b` lie within `overlap_radius` (m), its distance
/// to the plane fitted to them. Every `stride`-th point of `a` is used. `None` when no
/// point of `a` is over `b`'s surface.
pub fn camera_agreement(
    a: &[[f64; 3]],
    b: &[[f64; 3]],
    overlap_radius: f64,
    stride: usize,
) -> Option<Agreement> {
    let b32: Vec<[f32; 3]> = b.iter().map(|p| p.map(|c| c as f32)).collect();
    let tree = KdTree::build(&b32);
    let mut d: Vec<f64> = (a.iter().step_by(stride.max(1)))
        .filter_map(|p| {
            let q = p.map(|c| c as f32);
            let near = tree.nearest_n_f64(&q, PLANE_POINTS);
            let far = near.last()?.squared_distance;
            if near.len() < PLANE_POINTS || far > overlap_radius * overlap_radius {
                return None;
            }
            let (n, _, degenerate, _) = pca_normal(&b32, near.iter().map(|n| n.index))?;
            if degenerate {
                return None;
            }
            let centre = (near.iter().map(|n| b[n.index]))
                .fold([0.0; 3], |s, x| [s[0] + x[0], s[1] + x[1], s[2] + x[2]])
                .map(|s| s / near.len() as f64);
            Some(
                (0..3)
                    .map(|k| f64::from(n[k]) * (p[k] - centre[k]))
                    .sum::<f64>()
                    .abs(),
            )
        })
        .collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let at = |q: f64| d[((d.len() - 1) as f64 * q).round() as usize];
    Some(Agreement {
        overlap_points: d.len(),
        median: at(0.5),
        rms: (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt(),
        p95: at(0.95),
    })
}

//! Dense registration: instead of the features' averaged normal-line offsets, one row per
//! (subsampled) robot point the camera sees, its offset from the deformed FE surface
//! along the ray from the camera ([`DenseInputs`], `dense_rows`), and the forces'
//! covariance from independent rows ([`FrameEstimate::use_independent_uncertainty`]).

use super::sensing::FrameEstimate;
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::solve::MappedPoint;
use crate::fem::FemResult;
use crate::geometry::raycast::Bvh;
use crate::geometry::triangle::closest_point_on_triangle_weights;
use crate::math::{dot, sub, unit};

/// Tunables of the dense rows.
#[derive(Clone, Copy, Debug)]
pub struct DenseParams {
    /// At most this many robot points make rows: every k-th of the frame's (4000).
    pub max_points: usize,
    /// A point farther than this from the surface along its normal makes no row (m, 0.004):
    /// a point of the probe taken for the robot, or one matched to the wrong side.
    // Near a contact the free state's offsets reach a few mm; the loop's later states take
    // them back in as the model follows the dent.
    pub max_offset: f64,
    /// A point whose ray meets the surface more obliquely than this (|cos| of the ray with
    /// the normal) makes no row (0.25): at grazing view the offset along the normal is
    /// mostly the silhouette's position.
    pub min_view_cos: f64,
}

impl Default for DenseParams {
    fn default() -> Self {
        Self {
            max_points: 4000,
            max_offset: 0.004,
            min_view_cos: 0.25,
        }
    }
}

/// What the dense rows need: the frame's (subsampled) robot points, the camera centre and
/// the model's surface.
#[derive(Clone, Copy, Debug)]
pub struct DenseInputs<'a> {
    /// Robot points (robot frame, m), already subsampled ([`subsample`]).
    pub points: &'a [[f64; 3]],
    /// Camera centre (robot frame, m).
    pub eye: [f64; 3],
    /// Surface triangles (volume node indices, oriented outward).
    pub triangles: &'a [[usize; 3]],
    /// Tunables.
    pub params: DenseParams,
}

/// Every k-th finite point of `points`, at most `max` (deterministic, in order).
pub fn subsample(points: &[[f64; 3]], max: usize) -> Vec<[f64; 3]> {
    let finite: Vec<[f64; 3]> = points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    let k = finite.len().div_ceil(max.max(1)).max(1);
    finite.into_iter().step_by(k).collect()
}

/// The dense rows at node positions `x`: for each point q, the ray from the eye through q
/// meets the surface (the first hit, facing the camera) at p on triangle t; the row
/// measures p (t's barycentric point) along t's outward normal n, and its measured value
/// is the row's value plus n·(q − p). Returns the rows and their measured values.
pub(crate) fn dense_rows(
    dense: &DenseInputs<'_>,
    x: &[[f64; 3]],
) -> FemResult<(Vec<ConstraintRow>, Vec<f64>)> {
    let bvh = Bvh::new(x, dense.triangles);
    let params = dense.params;
    let found = super::par_map(dense.points, |&q| {
        let to = sub(q, dense.eye);
        let range = dot(to, to).sqrt();
        let d = unit(to);
        let (hit, k) = bvh.cast_triangle(dense.eye, d)?;
        let cos = dot(hit.normal, d);
        if cos > -params.min_view_cos {
            return None;
        }
        let offset = cos * (range - hit.t);
        if offset.abs() > params.max_offset {
            return None;
        }
        let tri = dense.triangles[k];
        let p = [0, 1, 2].map(|c| dense.eye[c] + hit.t * d[c]);
        let (_, w) = closest_point_on_triangle_weights(p, x[tri[0]], x[tri[1]], x[tri[2]]);
        let at = MappedPoint {
            nodes: [tri[0], tri[1], tri[2], tri[0]],
            weights: [w[0], w[1], w[2], 0.0],
        };
        Some((at, hit.normal, offset))
    });
    let mut rows = Vec::new();
    let mut measured = Vec::new();
    for (at, n, offset) in found.into_iter().flatten() {
        let row = ConstraintRow::along(RowKind::Effector, &at, n)?;
        measured.push(row.value(x) + offset);
        rows.push(row);
    }
    Ok((rows, measured))
}

impl FrameEstimate {
    /// The forces' covariance from independent rows (one point each, the dense rows):
    /// each row's variance is the residuals' robust spread (1.4826 median |r|), scaled up
    /// to its own residual where that is larger (max(1, r² / s²)), plus the square of each
    /// force's last change in the loop (as [`FrameEstimate::use_shared_point_uncertainty`]).
    /// Returns whether the σ were replaced.
    pub fn use_independent_uncertainty(&mut self) -> bool {
        let e = &self.estimate;
        let Some(residuals) = self.problem.residuals(&e.actuator_forces, &e.forces) else {
            return false;
        };
        let mut abs: Vec<f64> = residuals.iter().map(|r| r.abs()).collect();
        if abs.is_empty() {
            return false;
        }
        let spread = 1.4826 * crate::math::median(&mut abs);
        let var = spread * spread;
        if !(var > 0.0 && var.is_finite()) {
            return false;
        }
        let row_var: Vec<f64> = residuals.iter().map(|r| (r * r).max(var)).collect();
        let Some(cov) = self.problem.force_covariance_with(|a| {
            let mut scaled = a.clone();
            for (j, v) in row_var.iter().enumerate() {
                scaled.column_mut(j).scale_mut(*v);
            }
            Some(&scaled * a.transpose())
        }) else {
            return false;
        };
        self.set_force_covariance(cov);
        true
    }
}

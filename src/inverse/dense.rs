//! Dense registration: instead of the features' averaged normal-line offsets, one row per
//! (subsampled) robot point the camera sees, its offset from the deformed FE surface
//! along the ray from the camera ([`DenseInputs`], `dense_rows`), and the forces'
//! covariance from independent rows ([`FrameEstimate::use_independent_uncertainty`]).

use super::intensity::RowNoise;
use super::sensing::FrameEstimate;
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::solve::MappedPoint;
use crate::fem::FemResult;
use crate::geometry::raycast::Bvh;
use crate::geometry::triangle::closest_point_on_triangle_weights;
use crate::math::{dot, sub, unit};
use std::borrow::Cow;
use std::sync::OnceLock;

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
    /// The camera's depth noise k in σ_z = k·z² (1/m, 0.002: 0.5 mm at 0.5 m, a D415-like
    /// camera at 615 px focal length; scale by 615 / fx for another resolution).
    pub depth_k: f64,
    /// The camera's depth step (m, 0.001): its rounding adds step / √12.
    pub depth_step: f64,
}

impl Default for DenseParams {
    fn default() -> Self {
        Self {
            max_points: 4000,
            max_offset: 0.004,
            min_view_cos: 0.25,
            depth_k: 0.002,
            depth_step: 0.001,
        }
    }
}

impl DenseParams {
    /// The expected noise of one row (m): the depth noise at depth `z` along a ray that
    /// meets the surface at |cos| = `cos` to its normal, seen along the normal.
    pub fn row_noise(&self, z: f64, cos: f64) -> f64 {
        let sz = self.depth_k * z * z;
        let sq = self.depth_step / 12f64.sqrt();
        cos.abs() * (sz * sz + sq * sq).sqrt()
    }
}

/// One camera's part of the dense rows: its (subsampled) robot points and where it looks
/// from.
#[derive(Clone, Debug)]
pub struct DenseView {
    /// Robot points this camera saw (robot frame, m), already subsampled ([`subsample`]).
    pub points: Vec<[f64; 3]>,
    /// Camera centre (robot frame, m).
    pub eye: [f64; 3],
    /// The camera's optical axis (robot frame, unit): a point's depth is along it.
    pub axis: [f64; 3],
}

/// What the dense rows need: each camera's robot points and pose, and the model's surface.
#[derive(Clone, Debug)]
pub struct DenseInputs<'a> {
    /// The cameras' points, one view per camera that saw the frame.
    pub views: &'a [DenseView],
    /// Surface triangles (volume node indices, oriented outward).
    pub triangles: &'a [[usize; 3]],
    /// The hierarchy over `triangles` for the ray casts: built at the first state the rows
    /// are taken at, and refitted to each later one ([`Bvh::refit`]) instead of rebuilt
    /// (a rebuild per linearisation was a fifth of the ray casting). Start it empty.
    pub surface: OnceLock<Bvh>,
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

/// The dense rows at node positions `x`: for each point q of a view, the ray from that
/// view's eye through q meets the surface (the first hit, facing the camera) at p on
/// triangle t; the row measures p (t's barycentric point) along t's outward normal n, and
/// its measured value is the row's value plus n·(q − p). Each row's noise is its own
/// camera's at its own depth. Returns the rows, their measured values and their noise:
/// expected ([`DenseParams::row_noise`]) and patch (t).
pub(crate) fn dense_rows(
    dense: &DenseInputs<'_>,
    x: &[[f64; 3]],
) -> FemResult<(Vec<ConstraintRow>, Vec<f64>, RowNoise)> {
    let mut built_here = false;
    let first = dense.surface.get_or_init(|| {
        built_here = true;
        Bvh::new(x, dense.triangles)
    });
    let bvh = if built_here {
        Cow::Borrowed(first)
    } else {
        let mut bvh = first.clone();
        if !bvh.refit(x) {
            bvh = Bvh::new(x, dense.triangles);
        }
        Cow::Owned(bvh)
    };
    let params = dense.params;
    let rays: Vec<(&DenseView, [f64; 3])> = (dense.views.iter())
        .flat_map(|v| v.points.iter().map(move |&q| (v, q)))
        .collect();
    let found = super::par_map(&rays, |&(view, q)| {
        let to = sub(q, view.eye);
        let range = dot(to, to).sqrt();
        let d = unit(to);
        let (hit, k) = bvh.cast_triangle(view.eye, d)?;
        let cos = dot(hit.normal, d);
        if cos > -params.min_view_cos {
            return None;
        }
        let offset = cos * (range - hit.t);
        if offset.abs() > params.max_offset {
            return None;
        }
        let tri = dense.triangles[k];
        let p = [0, 1, 2].map(|c| view.eye[c] + hit.t * d[c]);
        let (_, w) = closest_point_on_triangle_weights(p, x[tri[0]], x[tri[1]], x[tri[2]]);
        let at = MappedPoint {
            nodes: [tri[0], tri[1], tri[2], tri[0]],
            weights: [w[0], w[1], w[2], 0.0],
        };
        let noise = params.row_noise(dot(to, view.axis), cos);
        Some((at, hit.normal, offset, noise, k))
    });
    let mut rows = Vec::new();
    let mut measured = Vec::new();
    let mut noise = RowNoise::default();
    for (at, n, offset, s, k) in found.into_iter().flatten() {
        let row = ConstraintRow::along(RowKind::Effector, &at, n)?;
        measured.push(row.value(x) + offset);
        noise.sigma.push(s);
        noise.patch.push(k);
        rows.push(row);
    }
    Ok((rows, measured, noise))
}

impl FrameEstimate {
    /// The forces' covariance from the dense rows' residuals, cluster-robust over the FE
    /// triangles they meet ([`white_covariance`](super::intensity::IntensityProblem::white_covariance)): unbiased where the
    /// residuals are noise, and larger where the model misfits (near a contact, a
    /// silhouette) with the misfit's correlation within a triangle kept; plus the square of each force's last change in the
    /// loop (as [`FrameEstimate::use_shared_point_uncertainty`]). Also sets
    /// [`FrameEstimate::fit`]: the residuals' robust spread against the rows' expected
    /// noise. Returns whether the σ were replaced; if not, they are the Gauss-Markov σ
    /// of the rows' expected noise.
    pub fn use_independent_uncertainty(&mut self) -> bool {
        let noise = &self.problem.row_noise.sigma;
        let e = &self.estimate;
        let residuals = self.problem.residuals(&e.actuator_forces, &e.forces);
        let Some(residuals) = residuals.filter(|r| !r.is_empty() && r.len() == noise.len()) else {
            return false;
        };
        let expected = (noise.iter().map(|s| s * s).sum::<f64>() / noise.len() as f64).sqrt();
        let mut ratios: Vec<f64> = residuals
            .iter()
            .zip(noise)
            .map(|(r, s)| (r / s).abs())
            .filter(|v| v.is_finite())
            .collect();
        if !ratios.is_empty() {
            let (patches_off, worst_patch) = patches_off(&residuals, &self.problem.row_noise);
            self.fit = Some(NoiseFit {
                ratio: 1.4826 * crate::math::median(&mut ratios),
                expected,
                patches_off,
                worst_patch,
            });
        }
        match self
            .problem
            .white_covariance(&residuals, &self.problem.row_noise.patch)
        {
            Some(cov) => {
                self.set_force_covariance(cov);
                true
            }
            None => {
                self.estimate.force_sigma = self.problem.force_sigma(expected);
                false
            }
        }
    }
}

/// How well a frame's rows fit against their expected noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseFit {
    /// The robust spread (1.4826 median) of each row's residual over its expected noise.
    pub ratio: f64,
    /// The rows' expected noise, root mean square (m).
    pub expected: f64,
    /// Patches (FE triangles) whose rows' mean residual is more than [`PATCH_OFF`] times
    /// its expected noise off: a dent the model does not explain (a contact not seen, a
    /// wrong location) shows here while the median over all rows barely moves.
    pub patches_off: usize,
    /// The largest |mean residual| of a patch (m).
    pub worst_patch: f64,
}

/// A patch is off when its rows' mean residual exceeds this many times the mean's expected
/// noise: depth noise alone puts one of ~800 patches beyond 5σ once in ~2000 frames.
pub const PATCH_OFF: f64 = 5.0;

/// The patches whose rows' mean residual is beyond [`PATCH_OFF`] times its expected noise
/// (√Σσ_i² / n), and the largest |mean residual| of any patch.
fn patches_off(residuals: &[f64], noise: &RowNoise) -> (usize, f64) {
    let mut sums: std::collections::BTreeMap<usize, (f64, f64, usize)> = Default::default();
    for ((r, s), p) in residuals.iter().zip(&noise.sigma).zip(&noise.patch) {
        let e = sums.entry(*p).or_insert((0.0, 0.0, 0));
        e.0 += r;
        e.1 += s * s;
        e.2 += 1;
    }
    let off = sums
        .values()
        .filter(|(sum, var, _)| sum.abs() > PATCH_OFF * var.sqrt())
        .count();
    let worst = sums
        .values()
        .map(|(sum, _, n)| (sum / *n as f64).abs())
        .fold(0.0, f64::max);
    (off, worst)
}

//! Calibration without markers (thesis 3.3.2, Algorithm 3.1): the camera-to-robot
//! transform and the initial actuator inputs of the FE model, by sequential optimisation
//! from the robot segment of one RGB-D frame and a rough pose.
//!
//! Each outer iteration
//! 1. matches every measured robot point (camera frame, mapped to the robot frame by the
//!    current pose) to its exact closest point on the FE surface triangles at the current FE
//!    state (a KD-tree over triangle centroids finds the candidates; the closest point on
//!    each candidate triangle is exact, so there is no bias from faceted vertex normals);
//! 2. fits the rigid transform (3.15) by point-to-plane Gauss-Newton ICP, with re-matching,
//!    until the pose settles for this FE state;
//! 3. solves the actuator QP (3.17)-(3.18) on clarabel: the cable tensions λ ≥ 0 that move
//!    the FE surface points onto the measured points along the face normals, with
//!    `W_ea = H_e K⁻¹ H_aᵀ` at the current state;
//! 4. re-solves the FE model with the new tensions,
//!
//! and stops when both the pose and the tensions settle. A first, coarse stage runs
//! untrimmed ICP from the rough start and from six turned copies of it and keeps the best.
//!
//! On the noise-free scene `clouds/scenes/calib` (depth quantised to 1 mm) twelve starts
//! 10° / 30 mm off all end 0.55 mm / 0.07° from the true camera pose with tensions within
//! 0.6%. That remainder is the data's conditioning, not a bias: the RMS point-to-surface
//! distance there (0.20013 mm) equals the one at the true pose and inputs (0.20006 mm).
//!
//! ```
//! use softsense::calibrate::{kabsch, pose_from_matrix, pose_to_matrix};
//! use softsense::math::{Iso3, Vec3};
//! let truth = Iso3::new(Vec3::new(0.1, -0.2, 0.3), Vec3::new(0.2, 0.1, -0.3));
//! let src = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
//! let dst: Vec<[f64; 3]> = src.iter().map(|p| {
//!     let q = truth * softsense::math::Point3::from(*p);
//!     [q.x, q.y, q.z]
//! }).collect();
//! let fit = kabsch(&src, &dst).unwrap();
//! assert!((fit.translation.vector - truth.translation.vector).norm() < 1e-12);
//! let back = pose_from_matrix(&pose_to_matrix(&fit)).unwrap();
//! assert!(back.rotation.angle_to(&truth.rotation) < 1e-12);
//! ```

use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, Problem};
use crate::fem::FemError;
use crate::inverse::qp::{QpParams, QpProblem};
use crate::inverse::InverseError;
use crate::math::{Iso3, Mat3, Point3, Vec3};
use crate::register::closest_point_on_triangle_weights;
use kiddo::{KdTree, SquaredEuclidean};
use nalgebra::{Matrix6, Rotation3, Translation3, UnitQuaternion, Vector6};
use serde::{Deserialize, Serialize};
use std::path::Path;
use thiserror::Error;

/// Errors of the calibration.
#[derive(Debug, Error)]
pub enum CalibrateError {
    /// Too few measured robot points to fit anything.
    #[error("only {found} robot points in the frame (need at least {needed}); is the robot colour right?")]
    TooFewPoints {
        /// Points found.
        found: usize,
        /// Points needed.
        needed: usize,
    },
    /// The FE model has no surface triangles.
    #[error("the FE mesh has no surface")]
    NoSurface,
    /// Too few measured points lie near the FE surface: the start pose is too far off.
    #[error(
        "only {matched} of {total} points matched the FE surface: the start pose is too far off"
    )]
    LostTrack {
        /// Matched points.
        matched: usize,
        /// Points used.
        total: usize,
    },
    /// A pose file or matrix is malformed (not a rigid 4x4 transform).
    #[error("pose: {0}")]
    Pose(String),
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A parameter is out of range.
    #[error("invalid parameter: {0}")]
    Param(String),
    /// The FE model failed (load, solve, factorization).
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The actuator QP failed.
    #[error(transparent)]
    Inverse(#[from] InverseError),
    /// Reading the frame failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

/// `Result` of the calibration.
pub type CalibrateResult<T> = std::result::Result<T, CalibrateError>;

/// Calibration options.
#[derive(Clone, Debug)]
pub struct CalibrateParams {
    /// Colour of the robot in the colour image (0-255 RGB); pixels of this hue are robot.
    pub robot_color: [u8; 3],
    /// Smallest cosine between a pixel's RGB vector and `robot_color` to count as robot.
    pub min_color_cosine: f64,
    /// At most this many measured points are used (evenly strided subsample).
    pub max_points: usize,
    /// Fewest robot points accepted.
    pub min_points: usize,
    /// Outer iterations (I_1 of Algorithm 3.1).
    pub max_iterations: usize,
    /// Point-to-plane ICP iterations per outer iteration (rigid fit, re-matching each time).
    pub icp_iterations: usize,
    /// Point-to-point (SVD) ICP iterations on the model's own shape before anything else:
    /// the coarse alignment from a rough start.
    pub coarse_iterations: usize,
    /// Coarse restarts turned by ± this about each robot axis (degrees; 0 for none).
    pub coarse_turn_deg: f64,
    /// QP + FE updates per outer iteration (I_2 of Algorithm 3.1).
    pub fe_updates: usize,
    /// A match farther than `trim_factor` × the median match distance is dropped.
    pub trim_factor: f64,
    /// ... but the trim distance never goes below this (m).
    pub min_trim: f64,
    /// Stop when the pose moves less than this in an outer iteration (m).
    pub translation_tol: f64,
    /// Stop when the pose turns less than this in an outer iteration (rad).
    pub rotation_tol: f64,
    /// Stop when no tension changes by more than this (N).
    pub tension_tol: f64,
    /// A settled fit with a larger final RMS point-to-surface distance is reported as
    /// [`CalibrationStatus::PoorFit`] (m).
    pub max_residual_rms: f64,
    /// Fewest matched points, as a fraction of the points used, before giving up.
    pub min_matched_fraction: f64,
    /// Solve the rigid motion together with the tensions in the actuator QP (one
    /// Gauss-Newton step of 3.9) instead of holding the pose (the thesis's alternation,
    /// which crawls when a rigid tilt and a bend of the legs look alike).
    pub joint: bool,
    /// QP solver options.
    pub qp: QpParams,
}

impl Default for CalibrateParams {
    fn default() -> Self {
        Self {
            robot_color: crate::scene::Colors::default().robot,
            min_color_cosine: 0.99,
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

/// How the calibration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CalibrationStatus {
    /// Pose and tensions settled within the tolerances.
    Converged,
    /// `max_iterations` outer iterations were done first.
    MaxIterations,
    /// The model has no cables: only the pose was fitted (and it settled).
    PoseOnly,
    /// It settled, but the final residual RMS exceeds `max_residual_rms`: a wrong local
    /// minimum (start too far off) or a model that does not match the robot.
    PoorFit,
}

/// The calibrated input of one cable.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ActuatorCalibration {
    /// Cable name.
    pub name: String,
    /// Tension λ_a (N), the QP unknown.
    pub tension: f64,
    /// The cable's shortening at the calibrated FE state (m).
    pub shortening: f64,
}

/// One outer iteration, for progress and the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IterationReport {
    /// RMS point-to-surface distance after the rigid fit (m).
    pub residual_rms: f64,
    /// Points matched (after trimming).
    pub matched: usize,
    /// How far the pose moved in this iteration (m).
    pub translation_change: f64,
    /// How far the pose turned in this iteration (rad).
    pub rotation_change: f64,
    /// Largest tension change (N).
    pub tension_change: f64,
}

/// The calibration result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Calibration {
    /// Robot-from-camera transform, row-major 4x4 (metres): p_robot = T p_camera.
    pub robot_from_camera: [[f64; 4]; 4],
    /// Calibrated input of each cable, in model order.
    pub actuators: Vec<ActuatorCalibration>,
    /// Outer iterations done.
    pub iterations: usize,
    /// RMS point-to-surface distance at the end, over the matched points (m).
    pub residual_rms: f64,
    /// Measured points used.
    pub points: usize,
    /// How it ended.
    pub status: CalibrationStatus,
    /// Per outer iteration.
    pub history: Vec<IterationReport>,
}

// ---------------------------------------------------------------------------------------
// Poses.

/// A 4x4 row-major matrix from a rigid transform.
pub fn pose_to_matrix(p: &Iso3) -> [[f64; 4]; 4] {
    let m = p.to_homogeneous();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// A rigid transform from a 4x4 row-major matrix; errors unless the upper-left block is a
/// rotation (orthonormal, det +1, to 1e-6) and the last row is (0, 0, 0, 1).
pub fn pose_from_matrix(m: &[[f64; 4]; 4]) -> CalibrateResult<Iso3> {
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(CalibrateError::Pose("non-finite entry".into()));
    }
    let r = Mat3::from_fn(|i, j| m[i][j]);
    let off = (r.transpose() * r - Mat3::identity()).amax();
    if off > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(CalibrateError::Pose(
            "the 3x3 block is not a rotation (orthonormal, det +1)".into(),
        ));
    }
    if (m[3][0], m[3][1], m[3][2], m[3][3]) != (0.0, 0.0, 0.0, 1.0) {
        return Err(CalibrateError::Pose("last row must be 0 0 0 1".into()));
    }
    let rot = Rotation3::from_matrix(&r);
    Ok(Iso3::from_parts(
        Translation3::new(m[0][3], m[1][3], m[2][3]),
        UnitQuaternion::from_rotation_matrix(&rot),
    ))
}

/// Reads `{"robot_from_camera": 4x4}` (the format of `camera_pose.json` and
/// `calibration.json`).
pub fn read_pose(path: &Path) -> CalibrateResult<Iso3> {
    #[derive(Deserialize)]
    struct PoseFile {
        robot_from_camera: [[f64; 4]; 4],
    }
    let file_err = |message: String| CalibrateError::File {
        path: path.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_err(e.to_string()))?;
    let p: PoseFile = serde_json::from_str(&text).map_err(|e| file_err(e.to_string()))?;
    pose_from_matrix(&p.robot_from_camera).map_err(|e| file_err(e.to_string()))
}

/// Translation distance (m) and rotation angle (rad) between two poses.
pub fn pose_difference(a: &Iso3, b: &Iso3) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

// ---------------------------------------------------------------------------------------
// Rigid fits.

/// The rigid transform T minimising Σ‖T src_i − dst_i‖² (SVD, Kabsch/Umeyama without
/// scale; thesis 3.15). None for fewer than 3 pairs, unequal lengths or non-finite data.
pub fn kabsch(src: &[[f64; 3]], dst: &[[f64; 3]]) -> Option<Iso3> {
    if src.len() != dst.len() || src.len() < 3 {
        return None;
    }
    let n = src.len() as f64;
    let c = |ps: &[[f64; 3]]| ps.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let (cs, cd) = (c(src), c(dst));
    let mut h = Mat3::zeros();
    for (s, d) in src.iter().zip(dst) {
        h += (Vec3::from(*s) - cs) * (Vec3::from(*d) - cd).transpose();
    }
    if !h.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = Mat3::identity();
    if (vt.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = vt.transpose() * d * u.transpose();
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cd - rot * cs;
    Some(Iso3::from_parts(Translation3::from(t), rot))
}

/// One Gauss-Newton step of point-to-plane ICP: the small rigid motion D (about the
/// centroid of `src`) minimising Σ (n_i · (D src_i − dst_i))² to first order. The step is
/// returned as a proper rigid transform (rotation by the solved rotation vector). None when
/// the 6x6 normal matrix is singular (e.g. all normals parallel).
pub fn point_to_plane_step(
    src: &[[f64; 3]],
    dst: &[[f64; 3]],
    normals: &[[f64; 3]],
) -> Option<Iso3> {
    if src.len() != dst.len() || src.len() != normals.len() || src.len() < 6 {
        return None;
    }
    let n = src.len() as f64;
    let c = src.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let mut a = Matrix6::<f64>::zeros();
    let mut b = Vector6::<f64>::zeros();
    for ((s, d), nn) in src.iter().zip(dst).zip(normals) {
        let p = Vec3::from(*s) - c;
        let nv = Vec3::from(*nn);
        let r = nv.dot(&(Vec3::from(*s) - Vec3::from(*d)));
        let pn = p.cross(&nv);
        let j = Vector6::new(pn.x, pn.y, pn.z, nv.x, nv.y, nv.z);
        a += j * j.transpose();
        b -= j * r;
    }
    let x = a.cholesky()?.solve(&b);
    if !x.iter().all(|v| v.is_finite()) {
        return None;
    }
    let w = Vec3::new(x[0], x[1], x[2]);
    let t = Vec3::new(x[3], x[4], x[5]);
    let rot = UnitQuaternion::from_scaled_axis(w);
    // p' = c + R (p - c) + t
    Some(Iso3::from_parts(Translation3::from(c + t - rot * c), rot))
}

// ---------------------------------------------------------------------------------------
// Closest points on the FE surface.

/// The closest surface point to a query.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceMatch {
    /// Triangle index.
    pub triangle: usize,
    /// Barycentric weights on the triangle's nodes.
    pub weights: [f64; 3],
    /// The closest point (m).
    pub point: [f64; 3],
    /// The triangle's unit outward normal.
    pub normal: [f64; 3],
    /// Distance from the query (m).
    pub distance: f64,
}

/// Exact closest-point queries on a triangle surface at given node positions: a KD-tree
/// over triangle centroids gives a bound (the nearest centroid's distance) and every
/// triangle whose centroid lies within that bound plus the largest centroid-to-corner
/// distance is tested exactly.
pub struct SurfaceIndex {
    tree: KdTree<f64, 3>,
    tris: Vec<[Vec3; 3]>,
    normals: Vec<Vec3>,
    radius: f64,
}

impl SurfaceIndex {
    /// Indexes `triangles` at node positions `x` (degenerate triangles are skipped).
    pub fn new(x: &[[f64; 3]], triangles: &[[usize; 3]]) -> Self {
        let mut tree = KdTree::with_capacity(triangles.len().max(1));
        let mut tris = Vec::with_capacity(triangles.len());
        let mut normals = Vec::with_capacity(triangles.len());
        let mut radius: f64 = 0.0;
        for (i, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| Vec3::from(x[v]));
            let n = (b - a).cross(&(c - a));
            let l = n.norm();
            if !(l > 0.0 && l.is_finite()) {
                // Keep indices aligned: a far-away placeholder never wins.
                tris.push([Vec3::repeat(f64::MAX); 3]);
                normals.push(Vec3::zeros());
                continue;
            }
            let centroid = (a + b + c) / 3.0;
            radius = radius.max(
                [a, b, c]
                    .iter()
                    .map(|p| (p - centroid).norm())
                    .fold(0.0, f64::max),
            );
            tree.add(&[centroid.x, centroid.y, centroid.z], i as u64);
            tris.push([a, b, c]);
            normals.push(n / l);
        }
        Self {
            tree,
            tris,
            normals,
            radius,
        }
    }

    /// The exact closest point of the surface to `p`, or None for an empty surface.
    pub fn closest(&self, p: [f64; 3]) -> Option<SurfaceMatch> {
        if self.tree.size() == 0 {
            return None;
        }
        let nearest = self.tree.nearest_one::<SquaredEuclidean>(&p);
        let bound = nearest.distance.sqrt() + self.radius;
        let q = Vec3::from(p);
        let mut best: Option<SurfaceMatch> = None;
        for nb in self
            .tree
            .within_unsorted::<SquaredEuclidean>(&p, bound * bound)
        {
            let i = nb.item as usize;
            let [a, b, c] = self.tris[i];
            let (s, w) = closest_point_on_triangle_weights(p, a.into(), b.into(), c.into());
            let s = Vec3::from(s);
            let d = (q - s).norm();
            if best.is_none_or(|m| d < m.distance) {
                let n = self.normals[i];
                best = Some(SurfaceMatch {
                    triangle: i,
                    weights: w,
                    point: [s.x, s.y, s.z],
                    normal: [n.x, n.y, n.z],
                    distance: d,
                });
            }
        }
        best
    }
}

// ---------------------------------------------------------------------------------------
// Measured points.

/// The robot points of a colour-and-depth cloud (camera frame, m): finite points whose
/// colour is within `min_color_cosine` of `robot_color` as RGB direction (so shading does
/// not matter). Clouds without colour give no points.
pub fn robot_points(
    cloud: &crate::cloud::PointCloud,
    robot_color: [u8; 3],
    min_color_cosine: f64,
) -> Vec<[f64; 3]> {
    let Some(colors) = cloud.colors.as_ref() else {
        return Vec::new();
    };
    let r = robot_color.map(f64::from);
    let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    cloud
        .positions
        .iter()
        .zip(colors)
        .filter(|(p, c)| {
            let c = c.map(f64::from);
            let cn = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            p.iter().all(|v| v.is_finite())
                && cn > 0.0
                && rn > 0.0
                && (c[0] * r[0] + c[1] * r[1] + c[2] * r[2]) / (cn * rn) >= min_color_cosine
        })
        .map(|(p, _)| p.map(f64::from))
        .collect()
}

/// Reads frame `frame` of a scene folder (`depth_NNNN.png`, `color_NNNN.png`,
/// `intrinsics.json`, depth in millimetres) and returns its robot points (camera frame).
pub fn read_scene_robot_points(
    dir: &Path,
    frame: usize,
    params: &CalibrateParams,
) -> CalibrateResult<Vec<[f64; 3]>> {
    let camera = crate::io::intrinsics::read_camera_model(dir.join("intrinsics.json"))?;
    let color = dir.join(format!("color_{frame:04}.png"));
    let cloud = crate::io::rgbd::read_frame(
        dir.join(format!("depth_{frame:04}.png")),
        Some(&color),
        &camera,
    )?;
    Ok(robot_points(
        &cloud,
        params.robot_color,
        params.min_color_cosine,
    ))
}

// ---------------------------------------------------------------------------------------
// The calibration.

/// Matched pairs at a pose: measured point in the robot frame, its surface match.
struct Matches {
    src: Vec<[f64; 3]>,
    hits: Vec<SurfaceMatch>,
    rms: f64,
}

fn match_points(
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
fn fit_pose(
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

/// The coarse alignment: point-to-point then point-to-plane ICP from the start and from the start turned by
/// ± `coarse_turn_deg` about each robot axis (through the points' centroid), keeping the
/// result with the smallest truncated RMS; every point is matched (no trimming). ICP alone falls into a wrong minimum from some
/// 10° starts on a four-legged robot; a handful of restarts finds the right basin.
fn coarse_align(
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

/// The actuator QP (3.17)-(3.18) at FE state `x` with tensions `tensions`: effector rows
/// along the face normals of the matched surface points, targets the measured points.
/// With `joint`, the rigid motion (rotation vector about the matched points' centroid and
/// translation) is solved in the same least-squares problem (one Gauss-Newton step of
/// 3.9). Returns the new tensions and the pose step.
fn solve_step(
    problem: &Problem,
    x: &[[f64; 3]],
    tensions: &[f64],
    triangles: &[[usize; 3]],
    m: &Matches,
    joint: bool,
    params: &CalibrateParams,
) -> CalibrateResult<(Vec<f64>, Iso3)> {
    let na = problem.cables.len();
    let np = if joint { 6 } else { 0 };
    let mut solver = problem.solver()?;
    solver.factorize_with_cables(x, tensions)?;
    let nd = solver.ndof();
    // K⁻¹ H_aᵀ: one solve per cable; W_ea = H_e K⁻¹ H_aᵀ then costs a dot product per row.
    let mut b = faer::Mat::<f64>::zeros(nd, na);
    let mut col = vec![0.0; nd];
    for (j, c) in problem.cables.iter().enumerate() {
        col.iter_mut().for_each(|v| *v = 0.0);
        solver.row_to_dofs(&ConstraintRow::cable(c, x).entries, &mut col);
        for (i, v) in col.iter().enumerate() {
            b[(i, j)] = *v;
        }
    }
    solver.solve_in_place(&mut b)?;
    let rows = m.hits.len();
    let centroid = m.src.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / rows as f64;
    // Unknowns [ω, t, λ]: n·(q + ω×(q−c) + t) − (n·s + W (λ − λ_k)) = 0.
    let mut a = nalgebra::DMatrix::<f64>::zeros(rows, np + na);
    let mut target = vec![0.0; rows];
    for (i, (h, q)) in m.hits.iter().zip(&m.src).enumerate() {
        let t = triangles[h.triangle];
        let at = MappedPoint {
            nodes: [t[0], t[1], t[2], t[0]],
            weights: [h.weights[0], h.weights[1], h.weights[2], 0.0],
        };
        let row = ConstraintRow::along(RowKind::Effector, &at, h.normal)?;
        let mut w_lk = 0.0;
        for j in 0..na {
            let mut wij = 0.0;
            for (node, coef) in &row.entries {
                if let Some(d) = solver.dofs.node_dof.get(*node).copied().flatten() {
                    wij += (0..3).map(|k| coef[k] * b[(d + k, j)]).sum::<f64>();
                }
            }
            a[(i, np + j)] = -wij;
            w_lk += wij * tensions[j];
        }
        let n = Vec3::from(h.normal);
        let qv = Vec3::from(*q);
        if joint {
            let pn = (qv - centroid).cross(&n);
            for k in 0..3 {
                a[(i, k)] = pn[k];
                a[(i, 3 + k)] = n[k];
            }
        }
        target[i] = row.value(x) - n.dot(&qv) - w_lk;
    }
    // Column scaling to O(1): compliances are ~1e-3 m/N, lever arms ~0.1 m.
    let scales: Vec<f64> = (0..np + na)
        .map(|j| a.column(j).amax().max(f64::MIN_POSITIVE))
        .collect();
    for (j, s) in scales.iter().enumerate() {
        a.column_mut(j).scale_mut(1.0 / s);
    }
    let mut qp = QpProblem::least_squares(&a, &target)?;
    for j in np..np + na {
        qp.lower[j] = 0.0;
    }
    let sol = qp.solve(&params.qp)?;
    let y: Vec<f64> = sol
        .solution()?
        .iter()
        .zip(&scales)
        .map(|(v, s)| v / s)
        .collect();
    let step = if joint {
        let rot = UnitQuaternion::from_scaled_axis(Vec3::new(y[0], y[1], y[2]));
        let t = Vec3::new(y[3], y[4], y[5]);
        Iso3::from_parts(Translation3::from(centroid + t - rot * centroid), rot)
    } else {
        Iso3::identity()
    };
    Ok((y[np..].iter().map(|v| v.max(0.0)).collect(), step))
}

fn check_params(p: &CalibrateParams) -> CalibrateResult<()> {
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

/// Calibrates the robot-from-camera pose and the cable tensions from measured robot points
/// (camera frame, m) and a rough start pose. The model's own cable inputs give the first
/// FE state; from then on every cable is force-controlled by the calibrated tension.
/// `progress` is called after each outer iteration.
pub fn calibrate(
    model: &Model,
    camera_points: &[[f64; 3]],
    start: &Iso3,
    params: &CalibrateParams,
    mut progress: impl FnMut(usize, &IterationReport),
) -> CalibrateResult<Calibration> {
    check_params(params)?;
    let finite: Vec<[f64; 3]> = camera_points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    if finite.len() < params.min_points.max(6) {
        return Err(CalibrateError::TooFewPoints {
            found: finite.len(),
            needed: params.min_points.max(6),
        });
    }
    let stride = finite.len().div_ceil(params.max_points);
    let pts: Vec<[f64; 3]> = finite.iter().step_by(stride).copied().collect();
    let mut problem = model.problem.clone();
    let triangles = problem.mesh.surface().triangles;
    if triangles.is_empty() {
        return Err(CalibrateError::NoSurface);
    }
    // First FE state: the model file's own inputs.
    let sol = problem.solve_static(&model.newton)?;
    let mut x = sol.positions;
    let mut tensions = sol.cable_tension;
    let mut shortening = sol.cable_shortening;
    for (c, t) in problem.cables.iter_mut().zip(&tensions) {
        c.control = CableControl::Force(*t);
    }
    let mut pose = *start;
    let mut history = Vec::new();
    let mut status = CalibrationStatus::MaxIterations;
    let mut residual_rms = f64::NAN;
    for it in 0..params.max_iterations {
        let before = pose;
        let index = SurfaceIndex::new(&x, &triangles);
        if it == 0 && params.coarse_iterations > 0 {
            pose = coarse_align(&index, &pts, &pose, params)?;
        }
        let (p, mut m) = fit_pose(&index, &pts, pose, params.icp_iterations, false, params)?;
        pose = p;
        residual_rms = m.rms;
        let matched = m.hits.len();
        let old = tensions.clone();
        if !problem.cables.is_empty() {
            for u in 0..params.fe_updates {
                if u > 0 {
                    let index = SurfaceIndex::new(&x, &triangles);
                    m = match_points(&index, &pts, &pose, params)?;
                }
                let (t, step) = solve_step(
                    &problem,
                    &x,
                    &tensions,
                    &triangles,
                    &m,
                    params.joint,
                    params,
                )?;
                tensions = t;
                pose = step * pose;
                for (c, t) in problem.cables.iter_mut().zip(&tensions) {
                    c.control = CableControl::Force(*t);
                }
                let sol = problem.solve_static(&model.newton)?;
                x = sol.positions;
                shortening = sol.cable_shortening;
            }
        }
        let (dt, dr) = pose_difference(&pose, &before);
        let dl = tensions
            .iter()
            .zip(&old)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let report = IterationReport {
            residual_rms,
            matched,
            translation_change: dt,
            rotation_change: dr,
            tension_change: dl,
        };
        progress(it + 1, &report);
        history.push(report);
        if dt < params.translation_tol && dr < params.rotation_tol && dl < params.tension_tol {
            status = if problem.cables.is_empty() {
                CalibrationStatus::PoseOnly
            } else {
                CalibrationStatus::Converged
            };
            break;
        }
    }
    // Final residual at the final pose and FE state.
    let index = SurfaceIndex::new(&x, &triangles);
    if let Ok(m) = match_points(&index, &pts, &pose, params) {
        residual_rms = m.rms;
    }
    if residual_rms.is_nan() || residual_rms > params.max_residual_rms {
        status = CalibrationStatus::PoorFit;
    }
    Ok(Calibration {
        robot_from_camera: pose_to_matrix(&pose),
        actuators: problem
            .cables
            .iter()
            .zip(tensions.iter().zip(&shortening))
            .map(|(c, (t, s))| ActuatorCalibration {
                name: c.name.clone(),
                tension: *t,
                shortening: *s,
            })
            .collect(),
        iterations: history.len(),
        residual_rms,
        points: pts.len(),
        status,
        history,
    })
}

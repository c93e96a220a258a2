//! Calibration with known feature-point correspondences (thesis 3.3, markers on the robot):
//! the FE model linearised at its current state, δ_e = W_ea λ_a + δ_e^free (3.1), and the
//! sequential method (3.3.2, Algorithm 3.1) that alternates Kabsch (3.15) with the
//! actuator QP (3.17)-(3.18). The simultaneous method is in [`super::pso`].

use super::params::check_params;
use super::pose::pose_difference;
use super::solve::{solve_scaled, split_solution};
use super::{kabsch, CalibrateError, CalibrateParams, CalibrateResult};
use crate::fem::bind::bind_markers;
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::mesh::TetMesh;
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, Problem, Solution};
use crate::math::rand::normal;
use crate::math::{Iso3, Point3, Vec3};
use nalgebra::DMatrix;
use serde::Serialize;

/// How a feature-point calibration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum FeatureStatus {
    /// The error stopped dropping (PSO) or pose and tensions settled (sequential).
    Converged,
    /// The set number of FE updates ran out first.
    MaxUpdates,
}

/// The result of a feature-point calibration, simultaneous or sequential.
#[derive(Clone, Debug)]
pub struct FeatureCalibration {
    /// Maps camera-frame points into the robot (FE model) frame: R δ_cam + T (3.9).
    pub robot_from_camera: Iso3,
    /// Cable tensions λ_a (N), in the model's cable order.
    pub tensions: Vec<f64>,
    /// RMS distance (m) between the mapped feature points and the FE feature points, with
    /// the FE model solved at `tensions`.
    pub residual_rms: f64,
    /// FE re-solves done after the first.
    pub fe_updates: usize,
    /// Objective evaluations (PSO) or actuator QPs solved (sequential).
    pub evaluations: usize,
    /// How it ended.
    pub status: FeatureStatus,
    /// `residual_rms` after each FE update (m).
    pub history: Vec<f64>,
}

/// Nine marker places (model frame, m) on the bundled four-legged robot
/// (meshes/models/robot.toml), as many as the thesis's larger set: the tip and a corner
/// of the top platform, the four knees, three corners of the fixed base.
// Three base markers, not two: two leave a turn about the line through them that a bend
// of the legs mimics (noise-free PSO stopped 0.3 mm and 1.4% off with two, exact with three).
pub const ROBOT_MARKERS: [[f64; 3]; 9] = [
    [0.0, 0.0, 0.125],
    [0.028, 0.028, 0.125],
    [0.105, 0.0, 0.045],
    [-0.105, 0.0, 0.045],
    [0.0, 0.105, 0.045],
    [0.0, -0.105, 0.045],
    [0.015, 0.015, 0.012],
    [-0.015, 0.015, 0.012],
    [0.015, -0.015, 0.012],
];

impl FeatureCalibration {
    /// Its errors against a known truth: translation (m) and rotation (rad) of the pose,
    /// and the largest tension error relative to that cable's truth tension.
    pub fn errors(&self, truth: &Iso3, truth_tensions: &[f64]) -> (f64, f64, f64) {
        let (dt, dr) = pose_difference(&self.robot_from_camera, truth);
        let dl = self
            .tensions
            .iter()
            .zip(truth_tensions)
            .map(|(a, b)| (a - b).abs() / b)
            .fold(0.0, f64::max);
        (dt, dr, dl)
    }
}

/// Feature points on the FE surface: each point of `near` (model frame, m, rest shape)
/// bound to the nearest point of the surface, as tracked markers are
/// ([`crate::fem::bind::bind_markers`]); a point farther than `max_distance` (m) is an error.
pub fn surface_features(
    mesh: &TetMesh,
    near: &[[f64; 3]],
    max_distance: f64,
) -> CalibrateResult<Vec<MappedPoint>> {
    let names: Vec<String> = (0..near.len()).map(|i| format!("feature {i}")).collect();
    let bound = bind_markers(
        &mesh.nodes_in_rest,
        &mesh.surface(),
        &names,
        near,
        max_distance,
    )?;
    Ok(bound.into_iter().map(|b| b.at).collect())
}

/// Synthetic measurements: the feature points of the model solved at `tensions` (N),
/// seen from a camera at `robot_from_camera`, with Gaussian noise of `sigma` (m) on each
/// coordinate from the seeded hash generator (the same numbers on any machine).
pub fn observe_features(
    model: &Model,
    features: &[MappedPoint],
    robot_from_camera: &Iso3,
    tensions: &[f64],
    sigma: f64,
    seed: u64,
) -> CalibrateResult<Vec<[f64; 3]>> {
    let fe = FeatureModel::new(model, features, tensions)?;
    let inv = robot_from_camera.inverse();
    Ok(fe
        .positions()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = inv * Point3::from(*p);
            [0, 1, 2].map(|k| q[k] + sigma * normal(seed, 31, i as u64, k as u64))
        })
        .collect())
}

/// RMS distance (m) between `pose` applied to `camera` and `robot`.
pub fn rms_distance(pose: &Iso3, camera: &[[f64; 3]], robot: &[[f64; 3]]) -> f64 {
    let s: f64 = camera
        .iter()
        .zip(robot)
        .map(|(c, r)| (pose * Point3::from(*c) - Point3::from(*r)).norm_squared())
        .sum();
    (s / camera.len().max(1) as f64).sqrt()
}

/// The FE model linearised at one state: feature positions W λ + δ^free (3.1).
pub(super) struct Linear {
    /// W_ea (3n x cables), m/N: rows x, y, z of each feature point.
    pub w: DMatrix<f64>,
    /// δ_e^free (3n), m.
    pub delta_free: Vec<f64>,
}

/// The FE model during a feature-point calibration: every cable force-controlled.
pub(super) struct FeatureModel<'m> {
    model: &'m Model,
    problem: Problem,
    features: &'m [MappedPoint],
    solution: Solution,
}

impl<'m> FeatureModel<'m> {
    /// The model solved at `tensions` (one per cable, N).
    pub fn new(
        model: &'m Model,
        features: &'m [MappedPoint],
        tensions: &[f64],
    ) -> CalibrateResult<Self> {
        let na = model.problem.cables.len();
        if tensions.len() != na {
            return Err(CalibrateError::Param(format!(
                "{} start tensions for {na} cables",
                tensions.len()
            )));
        }
        let mut problem = model.problem.clone();
        set_tensions(&mut problem, tensions);
        let solution = problem.solve_static(&model.newton)?;
        Ok(Self {
            model,
            problem,
            features,
            solution,
        })
    }

    /// Re-solves at new tensions, warm-started from the current state.
    pub fn resolve(&mut self, tensions: &[f64]) -> CalibrateResult<()> {
        set_tensions(&mut self.problem, tensions);
        self.solution = self
            .problem
            .solve_static_from(&self.model.newton, &self.solution)?;
        Ok(())
    }

    /// The FE feature points at the current state (m).
    pub fn positions(&self) -> Vec<[f64; 3]> {
        let x = &self.solution.positions;
        self.features.iter().map(|f| f.position(x)).collect()
    }

    /// The tensions the current state was solved at (N).
    pub fn tensions(&self) -> &[f64] {
        &self.solution.cable_tension
    }

    /// W_ea and δ_e^free at the current state, from the tangent stiffness there.
    pub fn linearise(&self) -> CalibrateResult<Linear> {
        let x = &self.solution.positions;
        let mut rows: Vec<ConstraintRow> = self
            .features
            .iter()
            .flat_map(|f| ConstraintRow::point3(RowKind::Effector, f))
            .collect();
        let ne = rows.len();
        rows.extend(
            self.problem
                .cables
                .iter()
                .map(|c| ConstraintRow::cable(c, x)),
        );
        let c = self.problem.solver()?.compliance_at(x, &rows)?;
        let a: Vec<usize> = (ne..rows.len()).collect();
        let e: Vec<usize> = (0..ne).collect();
        Ok(Linear {
            w: c.block(&e, &a),
            delta_free: c.delta_free[..ne].to_vec(),
        })
    }
}

fn set_tensions(problem: &mut Problem, tensions: &[f64]) {
    for (c, t) in problem.cables.iter_mut().zip(tensions) {
        c.control = CableControl::Force(t.max(0.0));
    }
}

/// Checks the measured points against the features: one finite point each, at least 3.
pub(super) fn check_points(
    features: &[MappedPoint],
    camera_points: &[[f64; 3]],
) -> CalibrateResult<()> {
    if camera_points.len() != features.len() {
        return Err(CalibrateError::Param(format!(
            "{} measured points for {} feature points",
            camera_points.len(),
            features.len()
        )));
    }
    let finite = camera_points.iter().flatten().all(|v| v.is_finite());
    if !finite || camera_points.len() < 3 {
        return Err(CalibrateError::TooFewPoints {
            found: camera_points.len(),
            needed: 3,
        });
    }
    Ok(())
}

/// Algorithm 3.1 with known correspondences: each of at most `params.max_iterations` (I_1)
/// iterations fits the pose by Kabsch to the FE feature points (3.15), maps the measured
/// points (3.16) and runs `params.fe_updates` (I_2) actuator QPs (3.17)-(3.18) with
/// λ ≥ 0, each followed by an FE re-solve. With `params.joint` (the default) each QP also
/// moves the pose (as [`super::calibrate`] does); without, it is the thesis's plain
/// alternation, which crawls where a tilt and a bend of the legs look alike. Stops when
/// the pose and tensions settle within `params`' tolerances. Needs no start pose: Kabsch
/// is closed-form.
pub fn calibrate_sequential(
    model: &Model,
    features: &[MappedPoint],
    camera_points: &[[f64; 3]],
    start_tensions: &[f64],
    params: &CalibrateParams,
) -> CalibrateResult<FeatureCalibration> {
    check_params(params)?;
    check_points(features, camera_points)?;
    let mut fe = FeatureModel::new(model, features, start_tensions)?;
    let mut pose = Iso3::identity();
    let (mut status, mut updates, mut evaluations) = (FeatureStatus::MaxUpdates, 0, 0);
    let mut history = Vec::new();
    let fit = |fe: &FeatureModel| {
        kabsch(camera_points, &fe.positions())
            .ok_or_else(|| CalibrateError::Pose("Kabsch failed on the feature points".into()))
    };
    for it in 0..params.max_iterations {
        let before = (pose, fe.tensions().to_vec());
        pose = fit(&fe)?;
        for _ in 0..params.fe_updates.max(1) {
            let (lambda, step) = actuator_step(&fe.linearise()?, camera_points, &pose, params)?;
            pose = step * pose;
            evaluations += 1;
            fe.resolve(&lambda)?;
            updates += 1;
        }
        history.push(rms_distance(&pose, camera_points, &fe.positions()));
        let (dt, dr) = pose_difference(&pose, &before.0);
        let dl = max_abs_difference(fe.tensions(), &before.1);
        if it > 0
            && dt < params.translation_tol
            && dr < params.rotation_tol
            && dl < params.tension_tol
        {
            status = FeatureStatus::Converged;
            break;
        }
    }
    // The final pose for the final FE state.
    pose = fit(&fe)?;
    Ok(FeatureCalibration {
        robot_from_camera: pose,
        tensions: fe.tensions().to_vec(),
        residual_rms: rms_distance(&pose, camera_points, &fe.positions()),
        fe_updates: updates,
        evaluations,
        status,
        history,
    })
}

/// The actuator QP (3.17)-(3.18) on the mapped points δ_tran = pose δ_cam (3.16): the
/// tensions λ ≥ 0 minimising ‖W_ea λ + δ_e^free − δ_tran‖². With `params.joint`, a small
/// rigid motion of δ_tran (rotation vector about their centroid, translation) is solved
/// with λ, one Gauss-Newton step of (3.9); it is returned as a pose step.
fn actuator_step(
    lin: &Linear,
    camera_points: &[[f64; 3]],
    pose: &Iso3,
    params: &CalibrateParams,
) -> CalibrateResult<(Vec<f64>, Iso3)> {
    let na = lin.w.ncols();
    let np = if params.joint { 6 } else { 0 };
    let p: Vec<Vec3> = camera_points
        .iter()
        .map(|c| (pose * Point3::from(*c)).coords)
        .collect();
    let centroid = p.iter().fold(Vec3::zeros(), |a, q| a + q) / p.len() as f64;
    let mut a = DMatrix::<f64>::zeros(3 * p.len(), np + na);
    let mut target = vec![0.0; 3 * p.len()];
    for (i, q) in p.iter().enumerate() {
        for k in 0..3 {
            let row = 3 * i + k;
            if params.joint {
                // Row k of ω × (q − c) + t.
                for j in 0..3 {
                    a[(row, j)] = Vec3::ith(j, 1.0).cross(&(q - centroid))[k];
                    a[(row, 3 + j)] = if j == k { 1.0 } else { 0.0 };
                }
            }
            for j in 0..na {
                a[(row, np + j)] = -lin.w[(row, j)];
            }
            target[row] = lin.delta_free[row] - q[k];
        }
    }
    let y = solve_scaled(a, &target, np, &params.qp)?;
    Ok(split_solution(&y, np, centroid))
}

/// The largest |a_i − b_i|.
pub(super) fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

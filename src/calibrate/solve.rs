//! Algorithm 3.1: the actuator QP step (3.17)-(3.18) with the optional joint rigid motion,
//! and the outer loop that alternates it with the rigid fit until pose and tensions settle.

use super::icp::{coarse_align, fit_pose, match_points, Matches};
use super::params::check_params;
use super::pose::{pose_difference, pose_to_matrix};
use super::schema::{ActuatorCalibration, Calibration, CalibrationStatus, IterationReport};
use super::surface::SurfaceIndex;
use super::{CalibrateError, CalibrateParams, CalibrateResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, Problem, Solver};
use crate::inverse::qp::{QpParams, QpProblem};
use crate::math::{Iso3, Vec3};
use nalgebra::{DMatrix, Translation3, UnitQuaternion};

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
    let b = cable_responses(&solver, problem, x)?;
    let rows = m.hits.len();
    let centroid = m.src.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / rows as f64;
    // Unknowns [ω, t, λ]: n·(q + ω×(q−c) + t) − (n·s + W (λ − λ_k)) = 0.
    let mut a = DMatrix::<f64>::zeros(rows, np + na);
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
    let y = solve_scaled(a, &target, np, &params.qp)?;
    Ok(split_solution(&y, np, centroid))
}

/// The tensions (clipped at 0) and the pose step of a solved [ω, t, λ] (`np` = 6: the
/// rotation vector ω turns about `centroid`) or [λ] (`np` = 0: no step).
pub(super) fn split_solution(y: &[f64], np: usize, centroid: Vec3) -> (Vec<f64>, Iso3) {
    let step = if np == 6 {
        let rot = UnitQuaternion::from_scaled_axis(Vec3::new(y[0], y[1], y[2]));
        let t = Vec3::new(y[3], y[4], y[5]);
        Iso3::from_parts(Translation3::from(centroid + t - rot * centroid), rot)
    } else {
        Iso3::identity()
    };
    (y[np..].iter().map(|v| v.max(0.0)).collect(), step)
}

/// K⁻¹ H_aᵀ at the factorized state: one solve per cable, so that W_ea = H_e K⁻¹ H_aᵀ
/// then costs a dot product per effector row.
fn cable_responses(
    solver: &Solver<'_>,
    problem: &Problem,
    x: &[[f64; 3]],
) -> CalibrateResult<faer::Mat<f64>> {
    let nd = solver.ndof();
    let mut b = faer::Mat::<f64>::zeros(nd, problem.cables.len());
    let mut col = vec![0.0; nd];
    for (j, c) in problem.cables.iter().enumerate() {
        col.iter_mut().for_each(|v| *v = 0.0);
        solver.row_to_dofs(&ConstraintRow::cable(c, x).entries, &mut col);
        for (i, v) in col.iter().enumerate() {
            b[(i, j)] = *v;
        }
    }
    solver.solve_in_place(&mut b)?;
    Ok(b)
}

/// Least squares ‖a y − target‖² with y ≥ 0 beyond the first `np` unknowns, columns
/// scaled to O(1) for the solver: the unscaled solution. Also the actuator QP of the
/// feature-point calibration ([`super::feature`]), with `np` = 0.
pub(super) fn solve_scaled(
    mut a: DMatrix<f64>,
    target: &[f64],
    np: usize,
    qp_params: &QpParams,
) -> CalibrateResult<Vec<f64>> {
    // Compliances are ~1e-3 m/N, lever arms ~0.1 m.
    let scales: Vec<f64> = (0..a.ncols())
        .map(|j| a.column(j).amax().max(f64::MIN_POSITIVE))
        .collect();
    for (j, s) in scales.iter().enumerate() {
        a.column_mut(j).scale_mut(1.0 / s);
    }
    let mut qp = QpProblem::least_squares(&a, target)?;
    for j in np..a.ncols() {
        qp.lower[j] = 0.0;
    }
    let sol = qp.solve(qp_params)?;
    Ok(sol
        .solution()?
        .iter()
        .zip(&scales)
        .map(|(v, s)| v / s)
        .collect())
}

/// The finite points, strided down to at most `max_points`; errors when too few.
fn usable_points(
    camera_points: &[[f64; 3]],
    params: &CalibrateParams,
) -> CalibrateResult<Vec<[f64; 3]>> {
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
    Ok(finite.iter().step_by(stride).copied().collect())
}

/// The FE model during the calibration: its problem (cables force-controlled by the
/// current tensions), node positions and cable state.
struct FeState<'m> {
    model: &'m Model,
    problem: Problem,
    triangles: Vec<[usize; 3]>,
    x: Vec<[f64; 3]>,
    tensions: Vec<f64>,
    shortening: Vec<f64>,
}

impl<'m> FeState<'m> {
    /// The first FE state: the model file's own inputs; from then on every cable is
    /// force-controlled by its tension.
    fn new(model: &'m Model) -> CalibrateResult<Self> {
        let mut problem = model.problem.clone();
        let triangles = problem.mesh.surface().triangles;
        if triangles.is_empty() {
            return Err(CalibrateError::NoSurface);
        }
        let sol = problem.solve_static(&model.newton)?;
        for (c, t) in problem.cables.iter_mut().zip(&sol.cable_tension) {
            c.control = CableControl::Force(*t);
        }
        Ok(Self {
            model,
            problem,
            triangles,
            x: sol.positions,
            tensions: sol.cable_tension,
            shortening: sol.cable_shortening,
        })
    }

    fn index(&self) -> SurfaceIndex {
        SurfaceIndex::new(&self.x, &self.triangles)
    }

    /// `fe_updates` actuator QP steps, each followed by an FE re-solve with the new
    /// tensions, starting from the matches `m`; returns the pose moved by the joint steps.
    fn update_actuators(
        &mut self,
        pts: &[[f64; 3]],
        mut pose: Iso3,
        mut m: Matches,
        params: &CalibrateParams,
    ) -> CalibrateResult<Iso3> {
        for u in 0..params.fe_updates {
            if u > 0 {
                m = match_points(&self.index(), pts, &pose, params)?;
            }
            let (t, step) = solve_step(
                &self.problem,
                &self.x,
                &self.tensions,
                &self.triangles,
                &m,
                params.joint,
                params,
            )?;
            self.tensions = t;
            pose = step * pose;
            for (c, t) in self.problem.cables.iter_mut().zip(&self.tensions) {
                c.control = CableControl::Force(*t);
            }
            let sol = self.problem.solve_static(&self.model.newton)?;
            self.x = sol.positions;
            self.shortening = sol.cable_shortening;
        }
        Ok(pose)
    }

    /// Each cable's calibrated input at the current state.
    fn actuators(&self) -> Vec<ActuatorCalibration> {
        self.problem
            .cables
            .iter()
            .zip(self.tensions.iter().zip(&self.shortening))
            .map(|(c, (t, s))| ActuatorCalibration {
                name: c.name.clone(),
                tension: *t,
                shortening: *s,
            })
            .collect()
    }
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
    let pts = usable_points(camera_points, params)?;
    let mut fe = FeState::new(model)?;
    let mut pose = *start;
    let mut history = Vec::new();
    let mut status = CalibrationStatus::MaxIterations;
    let mut residual_rms = f64::NAN;
    for it in 0..params.max_iterations {
        let before = pose;
        let index = fe.index();
        if it == 0 && params.coarse_iterations > 0 {
            pose = coarse_align(&index, &pts, &pose, params)?;
        }
        let (p, m) = fit_pose(&index, &pts, pose, params.icp_iterations, false, params)?;
        pose = p;
        residual_rms = m.rms;
        let matched = m.hits.len();
        let old = fe.tensions.clone();
        if !fe.problem.cables.is_empty() {
            pose = fe.update_actuators(&pts, pose, m, params)?;
        }
        let (dt, dr) = pose_difference(&pose, &before);
        let dl = fe
            .tensions
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
            status = if fe.problem.cables.is_empty() {
                CalibrationStatus::PoseOnly
            } else {
                CalibrationStatus::Converged
            };
            break;
        }
    }
    // Final residual at the final pose and FE state.
    if let Ok(m) = match_points(&fe.index(), &pts, &pose, params) {
        residual_rms = m.rms;
    }
    if residual_rms.is_nan() || residual_rms > params.max_residual_rms {
        status = CalibrationStatus::PoorFit;
    }
    Ok(Calibration {
        robot_from_camera: pose_to_matrix(&pose),
        actuators: fe.actuators(),
        iterations: history.len(),
        residual_rms,
        points: pts.len(),
        status,
        history,
    })
}

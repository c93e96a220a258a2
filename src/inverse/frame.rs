//! One frame of force sensing on the FE model (thesis 4.5.2): register the features at the
//! current FE state, build the normal-space compliance rows, solve the intensity QP, update
//! the FE state with the solved forces, and repeat until the forces settle.

use super::intensity::{ActuatorInput, IntensityEstimate, IntensityParams, IntensityProblem};
use super::{InverseError, InverseResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, PointLoad};
use crate::register::{RegisterParams, Registrar, SurfaceFeature};

/// A candidate force: a point on the mesh and the force direction (unit after normalising).
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// Where the force acts.
    pub at: MappedPoint,
    /// Direction of a positive intensity.
    pub direction: [f64; 3],
    /// Whether the intensity is bounded below by zero (a push, or a hanging weight).
    pub push_only: bool,
}

impl Candidate {
    /// A pushing-only force on node `node` along `direction`.
    pub fn at_node(node: usize, direction: [f64; 3]) -> Self {
        Self {
            at: MappedPoint::node(node),
            direction,
            push_only: true,
        }
    }
}

/// Options of the per-frame loop.
#[derive(Clone, Debug)]
pub struct FrameParams {
    /// Registration.
    pub register: RegisterParams,
    /// Intensity QP.
    pub intensity: IntensityParams,
    /// Maximum FE updates within the frame.
    pub max_updates: usize,
    /// Stop when the largest force change is below this (N).
    pub force_tol: f64,
}

impl Default for FrameParams {
    fn default() -> Self {
        Self {
            register: RegisterParams::default(),
            intensity: IntensityParams::default(),
            max_updates: 6,
            force_tol: 1e-4,
        }
    }
}

/// The result of one frame.
#[derive(Clone, Debug)]
pub struct FrameEstimate {
    /// The last intensity QP.
    pub estimate: IntensityEstimate,
    /// Visible features in the last registration.
    pub visible: usize,
    /// FE updates done.
    pub updates: usize,
    /// Final node positions (m).
    pub positions: Vec<[f64; 3]>,
}

/// Estimates the candidate forces from measured robot points (robot frame, m). The model's
/// cable controls are the actuator inputs; `features` are points on flat surface patches
/// (see [`crate::register::surface_features`]), matched along their patch normals at each FE
/// state, so a measured surface equal to the model's gives zero offsets.
pub fn estimate(
    model: &Model,
    points: &[[f64; 3]],
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    let base = {
        let mut p = model.problem.clone();
        p.loads.clear();
        p
    };
    let rest = base.mesh.nodes_in_rest.clone();
    let registrar = Registrar::new(points);
    let mut forces = vec![0.0; candidates.len()];
    let mut last: Option<(IntensityEstimate, usize)> = None;
    let mut x = rest.clone();
    let mut updates = 0;
    for _ in 0..params.max_updates {
        // FE state under the current forces.
        let mut problem = base.clone();
        for (c, f) in candidates.iter().zip(&forces) {
            problem.loads.push(PointLoad {
                at: c.at,
                force: crate::math::unit(c.direction).map(|d| d * f),
            });
        }
        let sol = problem.solve_static(&model.newton)?;
        x = sol.positions;
        updates += 1;
        // Register at the current state.
        let mut rows = Vec::new();
        let mut measured = Vec::new();
        for f in features {
            let (p, n) = (f.position(&x), f.normal(&x));
            if n == [0.0; 3] {
                continue;
            }
            if let Some(m) = registrar.match_feature(p, n, &params.register) {
                let row = ConstraintRow::along(RowKind::Effector, &f.mapped(), n)?;
                measured.push(row.value(&x) + m.offset);
                rows.push(row);
            }
        }
        let visible = rows.len();
        let ne = rows.len();
        let mut inputs = Vec::new();
        for c in &base.cables {
            let row = ConstraintRow::cable(c, &x);
            inputs.push(match c.control {
                CableControl::Force(f) => ActuatorInput::Force(f),
                CableControl::Displacement(s) => {
                    // Target in row units: value(x) + (s_target - s(x)).
                    let s_now = c.length(&rest) - c.length(&x);
                    ActuatorInput::Displacement(row.value(&x) + s - s_now)
                }
            });
            rows.push(row);
        }
        let na = base.cables.len();
        for c in candidates {
            rows.push(ConstraintRow::along(RowKind::Force, &c.at, c.direction)?);
        }
        let nf = candidates.len();
        let mut solver = base.solver()?;
        solver.tangent_at(&x, Default::default())?;
        let mut full = base.external_forces();
        for (f, fi) in full.iter_mut().zip(&solver.internal_force) {
            *f -= fi;
        }
        let r = solver.dofs.gather(&full);
        let comp = solver.compliance(&rows, &x, &r)?;
        let e: Vec<usize> = (0..ne).collect();
        let a: Vec<usize> = (ne..ne + na).collect();
        let fo: Vec<usize> = (ne + na..ne + na + nf).collect();
        let prob = IntensityProblem {
            w_ea: comp.block(&e, &a),
            w_ef: comp.block(&e, &fo),
            delta_free_e: comp.delta_free[..ne].to_vec(),
            delta_measured: measured,
            w_aa: comp.block(&a, &a),
            w_af: comp.block(&a, &fo),
            delta_free_a: comp.delta_free[ne..ne + na].to_vec(),
            actuators: inputs,
            push_only: candidates.iter().map(|c| c.push_only).collect(),
        };
        if ne == 0 {
            return Err(InverseError::Intensity("no visible feature point".into()));
        }
        let est = prob.solve(&params.intensity)?;
        if !est.status.is_solution() {
            return Err(InverseError::NotSolved(est.status));
        }
        let change = est
            .forces
            .iter()
            .zip(&forces)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        forces = est.forces.clone();
        last = Some((est, visible));
        if change < params.force_tol {
            break;
        }
    }
    let (estimate, visible) =
        last.ok_or_else(|| InverseError::Intensity("max_updates is zero".into()))?;
    Ok(FrameEstimate {
        estimate,
        visible,
        updates,
        positions: x,
    })
}

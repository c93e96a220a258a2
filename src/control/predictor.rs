//! The FE model as a predictor (thesis 3.2, 3.4): its effector position and Jacobian at
//! the state a set of actuator inputs gives, and the allocation of a wanted effector
//! motion to input changes within the actuators' limits.

use super::scenario::Actuation;
use super::{ControlError, ControlResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, CavityControl, Solution, SolverState};
use crate::inverse::qp::{QpParams, QpProblem};
use nalgebra::{DMatrix, DVector};

/// The kinematic model at one state (3.4, 3.5, 3.8).
#[derive(Debug, Clone)]
pub struct Kinematics {
    /// Effector position (m).
    pub position: [f64; 3],
    /// J: effector motion per input change (m per m of shortening, or m/N).
    pub j: DMatrix<f64>,
    /// W_aa (m/N): cable shortening per tension.
    pub w_aa: DMatrix<f64>,
    /// Cable tensions (N), or cavity pressures (Pa) with pressure actuation.
    pub tension: Vec<f64>,
    /// How the inputs drive the cables.
    pub actuation: Actuation,
}

/// An allocated input change.
#[derive(Debug, Clone)]
pub struct Allocation {
    /// Change of every input (m or N).
    pub delta: Vec<f64>,
    /// The pseudo-inverse would have broken a limit or made a tension negative, and the
    /// bounded QP gave `delta` instead.
    pub bounded: bool,
}

/// Sets every cable of `model` to `inputs` (m of shortening or N of tension), or with
/// pressure actuation every cavity (Pa).
pub fn drive(model: &mut Model, actuation: Actuation, inputs: &[f64]) {
    if actuation == Actuation::Pressure {
        for (c, &u) in model.problem.cavities.iter_mut().zip(inputs) {
            c.control = CavityControl::Pressure(u);
        }
        return;
    }
    for (c, &u) in model.problem.cables.iter_mut().zip(inputs) {
        c.control = match actuation {
            Actuation::Force => CableControl::Force(u),
            _ => CableControl::Displacement(u),
        };
    }
}

/// Relative residual at which a control step's static solve has converged.
pub const CONTROL_REL_TOL: f64 = 1e-6;
/// Gap (m) at which a displacement-controlled cable has reached its shortening.
pub const CONTROL_GAP_TOL: f64 = 1e-9;

/// Load steps of the last attempt at a control step's static solve.
const FALLBACK_LOAD_STEPS: usize = 8;

/// Static equilibrium of `model` under its current controls, warm-started from `prev`
/// (a cold solve if the warm one fails); `state` carries the solver's buffers over.
pub fn equilibrium(
    model: &Model,
    prev: Option<&Solution>,
    state: &mut Option<SolverState>,
) -> ControlResult<Solution> {
    let mut solver = match state.take() {
        Some(s) => model.problem.solver_from(s)?,
        None => model.problem.solver()?,
    };
    // A control step needs the effector to a micrometre, not to round-off: the model's
    // 1e-10 relative residual and sub-picometre cable gaps stall Newton near slack cables.
    // A residual of 1e-6 of the applied forces moves the robot's effector by nanometres
    // (its compliance is about 0.02 m/N).
    let mut params = model.newton.clone();
    params.rel_tol = params.rel_tol.max(CONTROL_REL_TOL);
    params.gap_tol = params.gap_tol.max(CONTROL_GAP_TOL);
    let warm = prev.map(|p| solver.solve_static_from(&params, Some(p)));
    let sol = match warm {
        Some(Ok(s)) if s.converged => s,
        _ => match solver.solve_static(&params) {
            Ok(s) => s,
            // Near a cable going slack, the full load at once can stall Newton; load
            // steps get there.
            Err(_) => {
                params.load_steps = params.load_steps.max(FALLBACK_LOAD_STEPS);
                params.max_iterations = params.max_iterations.max(100);
                solver.solve_static(&params)?
            }
        },
    };
    *state = Some(solver.into_state());
    if !sol.converged {
        return Err(ControlError::NotConverged {
            residual: sol.residuals.last().copied().unwrap_or(f64::NAN),
        });
    }
    Ok(sol)
}

/// The controller's FE model and its last state.
#[derive(Debug)]
pub struct Predictor {
    model: Model,
    effector: usize,
    actuation: Actuation,
    solution: Option<Solution>,
    state: Option<SolverState>,
}

/// The index of the effector named `name` (the first when `None`).
pub fn effector_index(model: &Model, name: Option<&str>) -> ControlResult<usize> {
    let i = match name {
        Some(n) => model.effectors.iter().position(|e| e.name == n),
        None => (!model.effectors.is_empty()).then_some(0),
    };
    let i = i.ok_or_else(|| ControlError::NoEffector {
        name: name.map(str::to_string),
        available: model.effectors.iter().map(|e| e.name.clone()).collect(),
    })?;
    if model.effectors[i].rows.len() != 3 {
        return Err(ControlError::NotAPoint {
            effector: model.effectors[i].name.clone(),
            rows: model.effectors[i].rows.len(),
        });
    }
    Ok(i)
}

impl Predictor {
    /// The predictor of `model`'s effector `effector` (its first when `None`).
    pub fn new(model: Model, effector: Option<&str>, actuation: Actuation) -> ControlResult<Self> {
        let effector = effector_index(&model, effector)?;
        match actuation {
            Actuation::Pressure if model.problem.cavities.is_empty() => {
                return Err(ControlError::NoCavities);
            }
            Actuation::Displacement | Actuation::Force if model.problem.cables.is_empty() => {
                return Err(ControlError::NoCables);
            }
            _ => {}
        }
        Ok(Self {
            model,
            effector,
            actuation,
            solution: None,
            state: None,
        })
    }

    /// Number of actuators (cables, or cavities with pressure actuation).
    pub fn actuators(&self) -> usize {
        match self.actuation {
            Actuation::Pressure => self.model.problem.cavities.len(),
            _ => self.model.problem.cables.len(),
        }
    }

    /// The model's last equilibrium.
    pub fn solution(&self) -> Option<&Solution> {
        self.solution.as_ref()
    }

    /// Drives the model to `inputs`, solves it and returns its kinematics there: J from
    /// the compliance of the effector and cable rows at the new state (3.8).
    pub fn update(&mut self, inputs: &[f64]) -> ControlResult<Kinematics> {
        drive(&mut self.model, self.actuation, inputs);
        let sol = equilibrium(&self.model, self.solution.as_ref(), &mut self.state)?;
        let kin = kinematics_at(
            &self.model,
            self.effector,
            self.actuation,
            &sol,
            &mut self.state,
        )?;
        self.solution = Some(sol);
        Ok(kin)
    }
}

/// The kinematics of `model`'s effector `effector` at the equilibrium `sol`: J from the
/// compliance of the effector and cable rows there (3.8).
pub fn kinematics_at(
    model: &Model,
    effector: usize,
    actuation: Actuation,
    sol: &Solution,
    state: &mut Option<SolverState>,
) -> ControlResult<Kinematics> {
    let x = &sol.positions;
    let eff = &model.effectors[effector];
    let mut rows: Vec<ConstraintRow> = eff.rows.clone();
    match actuation {
        Actuation::Pressure => {
            rows.extend((model.problem.cavities.iter()).map(|c| ConstraintRow::cavity(c, x)))
        }
        _ => rows.extend((model.problem.cables.iter()).map(|c| ConstraintRow::cable(c, x))),
    }
    let mut solver = match state.take() {
        Some(s) => model.problem.solver_from(s)?,
        None => model.problem.solver()?,
    };
    let c = solver.compliance_at(x, &rows);
    *state = Some(solver.into_state());
    let c = c?;
    let e = c.rows_of(RowKind::Effector);
    let a = c.rows_of(RowKind::Actuator);
    let w_ea = c.block(&e, &a);
    let w_aa = c.block(&a, &a);
    let j = match actuation {
        Actuation::Force | Actuation::Pressure => w_ea,
        Actuation::Displacement => c.jacobian()?,
    };
    let tension = match actuation {
        Actuation::Pressure => sol.cavity_pressure.clone(),
        _ => sol.cable_tension.clone(),
    };
    Ok(Kinematics {
        position: eff.point.position(x),
        j,
        w_aa,
        tension,
        actuation,
    })
}

/// Relative slack on the limits before the bounded QP is used.
const LIMIT_TOL: f64 = 1e-9;

impl Kinematics {
    /// The input change that moves the effector by `wanted` (m): the minimum-norm
    /// pseudo-inverse solution (3.27) when it keeps every input in `limits` and every cable
    /// tension non-negative; otherwise the closest motion that does, from a small QP
    /// (min ½‖J Δ − wanted‖² + ½ε‖Δ‖², the ε term picking the smallest change among
    /// equals). With displacement inputs the tensions change by W_aa⁻¹ Δ (3.5).
    pub fn allocate(
        &self,
        wanted: [f64; 3],
        inputs: &[f64],
        limits: [f64; 2],
    ) -> ControlResult<Allocation> {
        let n = inputs.len();
        let u = DVector::from_column_slice(&wanted);
        let pinv = self
            .j
            .clone()
            .pseudo_inverse(1e-12 * self.j.norm().max(f64::MIN_POSITIVE))
            .map_err(|_| ControlError::Singular { what: "J" })?;
        let delta: Vec<f64> = (&pinv * &u).iter().copied().collect();
        let tension_step = self.tension_per_input()?;
        if self.admissible(&delta, inputs, limits, &tension_step) {
            return Ok(Allocation {
                delta,
                bounded: false,
            });
        }
        let jtj = self.j.transpose() * &self.j;
        let eps = 1e-6 * jtj.trace() / n as f64;
        let mut qp = QpProblem::least_squares(&self.j, &wanted)?;
        qp.p += DMatrix::identity(n, n) * eps;
        qp.lower = inputs.iter().map(|v| limits[0] - v).collect();
        qp.upper = inputs.iter().map(|v| limits[1] - v).collect();
        qp.a_le = -&tension_step;
        qp.b_le = self.tension.iter().map(|t| t.max(0.0)).collect();
        let sol = qp.solve(&QpParams::default())?;
        let delta = sol.solution()?.to_vec();
        Ok(Allocation {
            delta,
            bounded: true,
        })
    }

    /// d tension / d input: W_aa⁻¹ for displacement inputs, I for tensions; none for
    /// pressures, which may take either sign (their limits bound them).
    fn tension_per_input(&self) -> ControlResult<DMatrix<f64>> {
        let n = self.tension.len();
        match self.actuation {
            Actuation::Force => Ok(DMatrix::identity(n, n)),
            Actuation::Pressure => Ok(DMatrix::zeros(n, n)),
            Actuation::Displacement => self
                .w_aa
                .clone()
                .try_inverse()
                .ok_or(ControlError::Singular { what: "W_aa" }),
        }
    }

    fn admissible(
        &self,
        delta: &[f64],
        inputs: &[f64],
        limits: [f64; 2],
        tension_step: &DMatrix<f64>,
    ) -> bool {
        let span = (limits[1] - limits[0]).abs();
        let inside = delta.iter().zip(inputs).all(|(d, v)| {
            let w = v + d;
            w >= limits[0] - LIMIT_TOL * span && w <= limits[1] + LIMIT_TOL * span
        });
        let dt = tension_step * DVector::from_column_slice(delta);
        let scale = self.tension.iter().fold(1e-9f64, |m, t| m.max(t.abs()));
        let taut =
            (self.tension.iter().zip(dt.iter())).all(|(t, d)| t.max(0.0) + d >= -LIMIT_TOL * scale);
        inside && taut
    }
}

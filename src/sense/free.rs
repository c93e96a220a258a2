//! The free equilibria (no loads) of the actuator inputs a stream uses, solved once each and
//! cached: every frame's sensing loop starts from one.

use crate::fem::model::Model;
use crate::fem::solve::{CableControl, CavityControl, Solution, SolverState};
use crate::inverse::linearise::factorize_loop_tangent;
use std::sync::{Arc, Mutex, OnceLock};

/// Free solves kept: one per distinct actuator input, the latest ones.
const FREE_CACHE: usize = 8;

/// Cable inputs closer than this (m or N) are the same input for the free-solve cache: far
/// below what moves the FE state by more than the Newton tolerance.
pub const SAME_INPUT: f64 = 1e-12;

/// The free equilibrium of one actuator input, and a solver state there (elements
/// evaluated, tangent with the cables factorized; `None` if that failed): every frame's
/// sensing loop starts from it, so its first FE update costs neither (see
/// [`crate::inverse::Start::Unloaded`]).
pub(crate) struct FreeState {
    pub(crate) solution: Solution,
    pub(crate) solver: Option<SolverState>,
}

/// A frame's actuator inputs: cables (same within [`SAME_INPUT`]), then cavities (same
/// when equal: recorded pressures carry no round-off from frame to frame).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ActuatorInputs {
    pub(crate) cables: Vec<CableControl>,
    pub(crate) cavities: Vec<CavityControl>,
}

impl ActuatorInputs {
    /// The inputs `model` is actuated with.
    pub(crate) fn of(model: &Model) -> Self {
        Self {
            cables: model.problem.cables.iter().map(|c| c.control).collect(),
            cavities: model.problem.cavities.iter().map(|c| c.control).collect(),
        }
    }
}

/// Free solves of the latest distinct actuator inputs (a stream repeats them).
#[derive(Default)]
pub(crate) struct FreeSolves {
    cache: Mutex<Vec<(ActuatorInputs, Arc<FreeState>)>>,
    /// The free solve at the model file's own inputs (`None`: it failed), solved once: new
    /// inputs are solved warm from it, so a free solve does not depend on which frames came
    /// before it (or ran beside it).
    base: OnceLock<Option<Solution>>,
}

/// Whether two frames' actuator inputs are the same: cables within [`SAME_INPUT`],
/// cavities equal.
pub(crate) fn same_inputs(a: &ActuatorInputs, b: &ActuatorInputs) -> bool {
    a.cavities == b.cavities
        && a.cables.len() == b.cables.len()
        && a.cables.iter().zip(&b.cables).all(|(a, b)| match (a, b) {
            (CableControl::Force(a), CableControl::Force(b))
            | (CableControl::Displacement(a), CableControl::Displacement(b)) => {
                (a - b).abs() <= SAME_INPUT
            }
            _ => false,
        })
}

impl FreeSolves {
    /// The free solve (no loads) of `model`, `own` being the model with its file's inputs.
    /// Inputs equal within [`SAME_INPUT`] share a solve (recorded shortenings differ by
    /// round-off from frame to frame); a new input is solved warm from `own`'s.
    pub(crate) fn solve(
        &self,
        own: &Model,
        model: &Model,
    ) -> crate::fem::FemResult<Arc<FreeState>> {
        let key = ActuatorInputs::of(model);
        let same = |a: &ActuatorInputs| same_inputs(a, &key);
        let hit = match self.cache.lock() {
            Ok(cache) => cache.iter().find(|e| same(&e.0)).map(|e| e.1.clone()),
            Err(_) => None,
        };
        if let Some(s) = hit {
            return Ok(s);
        }
        let base = self.base.get_or_init(|| {
            own.problem
                .solve_static(&own.newton)
                .ok()
                .filter(|s| s.converged)
        });
        let s = match base {
            Some(start) => model.problem.solve_static_from(&model.newton, start)?,
            None => model.problem.solve_static(&model.newton)?,
        };
        let s = Arc::new(FreeState {
            solver: free_solver_state(model, &s),
            solution: s,
        });
        if let Ok(mut cache) = self.cache.lock() {
            // Frames sensed side by side may both have solved this input.
            if !cache.iter().any(|e| same(&e.0)) {
                if cache.len() >= FREE_CACHE {
                    cache.remove(0);
                }
                cache.push((key, Arc::clone(&s)));
            }
        }
        Ok(s)
    }
}

/// A solver state at the free equilibrium `free` of `model` (without loads): elements
/// evaluated and the tangent with the cables' geometric stiffness factorized, as the
/// sensing loop's first FE update leaves it. `None` if either fails (the loop then does
/// both itself, and fails or falls back as it does without the state).
fn free_solver_state(model: &Model, free: &Solution) -> Option<SolverState> {
    let base = model.problem.without_loads();
    let mut solver = base.solver().ok()?;
    let x = &free.positions;
    solver.assemble(x, model.newton.tangent).ok()?;
    let forces = free.actuator_forces();
    factorize_loop_tangent(&mut solver, x, &forces, model.newton.tangent).ok()?;
    Some(solver.into_state())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: tracking compared cable inputs only, so a frame whose cavity pressure
    /// changed (cables unchanged) resumed from the previous frame's state.
    #[test]
    fn frames_with_other_cavity_pressures_do_not_have_the_same_inputs() {
        let at = |p: f64| ActuatorInputs {
            cables: vec![CableControl::Displacement(0.001)],
            cavities: vec![CavityControl::Pressure(p)],
        };
        assert!(same_inputs(&at(1e4), &at(1e4)));
        assert!(!same_inputs(&at(1e4), &at(2e4)));
        let mut nudged = at(1e4);
        nudged.cables[0] = CableControl::Displacement(0.001 + 0.5 * SAME_INPUT);
        assert!(same_inputs(&at(1e4), &nudged), "cables within SAME_INPUT");
    }
}

//! The sensing loop of one frame (thesis 4.5.2): register the features at the current FE
//! state, build the normal-space compliance rows, solve the intensity QP, update the FE
//! state with the solved forces, and repeat until the forces settle. One entry,
//! [`estimate`]: what the loop works on ([`FrameInputs`]) and where it starts ([`Start`]).

use super::candidate::{loads_of, Candidate};
use super::intensity::{IntensityEstimate, IntensityParams, IntensityProblem};
use super::linearise::{factorize_loop_tangent, linearise};
use super::locations::LocationChoice;
use super::{InverseError, InverseResult};
use crate::fem::model::Model;
use crate::fem::solve::{
    norm_vec, NewtonParams, PointLoad, Problem, Solution, Solver, SolverState,
};
use crate::fem::FemError;
use crate::register::{FeatureMatches, RegisterParams, Registrar, SurfaceFeature};

/// Options of the per-frame loop.
#[derive(Clone, Debug)]
pub struct FrameParams {
    /// Registration.
    pub register: RegisterParams,
    /// Intensity QP.
    pub intensity: IntensityParams,
    /// Maximum FE updates within the frame (6).
    pub max_updates: usize,
    /// Stop when the largest force change is below this (N, 1e-4).
    pub force_tol: f64,
    /// Newton's relative residual tolerance in the FE updates (1e-8; `None`: the model's
    /// own, 1e-10 by default).
    // At 1e-8 the state is off by ~1e-9 m on a 0.5 kg robot, far below the depth noise,
    // and an update often saves its last Newton iteration.
    pub fe_rel_tol: Option<f64>,
    /// Forcing term of inexact FE updates: an update whose loads moved by at most `s` N
    /// stops Newton once the residual is below `fe_forcing * s` (N) (0.2; 0: off).
    // The residual left is not lost: the linearisation's free motion includes it.
    pub fe_forcing: f64,
    /// The loop also stops once every force's change is below this fraction of its
    /// Gauss-Markov σ (0.25; 0: `force_tol` alone).
    // Near the fixed point a weakly identified component can cycle within its noise; at
    // 0.25 a stop adds about 3% to the spread (√(1 + 0.25²)).
    pub sigma_tol: f64,
    /// Halvings, in all, of force steps whose FE update fails before the frame fails (6; 0:
    /// the first failure fails the frame).
    // The first QP is linearised at the unloaded state and can ask for more force than
    // one Newton solve can follow; the step is then halved from the last good state.
    pub max_halvings: usize,
    /// Newton iterations an FE update may take before its step is halved (25; the model's
    /// own limit if lower).
    pub fe_max_iterations: usize,
    /// Stop on the *predicted* error once the iteration contracts by at most this factor
    /// per update (0.5; 0: off).
    // The distance of G(f_k) to the fixed point is about g / (1 - g) times the last force
    // change, g measured by the secant over the last two updates.
    pub settle_contraction: f64,
}

impl Default for FrameParams {
    fn default() -> Self {
        Self {
            register: RegisterParams::default(),
            intensity: IntensityParams::default(),
            max_updates: 6,
            force_tol: 1e-4,
            fe_rel_tol: Some(1e-8),
            fe_forcing: 0.2,
            sigma_tol: 0.25,
            max_halvings: 6,
            fe_max_iterations: 25,
            settle_contraction: 0.5,
        }
    }
}

/// Time spent in the stages of [`estimate`]'s loop (ms, summed over its FE updates).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopTimings {
    /// Registration (normal-line matches; the grid is built once per frame).
    pub register: f64,
    /// Newton solves under the current forces.
    pub fe_update: f64,
    /// Tangent factorisation and compliance rows at the updated state.
    pub compliance: f64,
    /// Intensity QPs.
    pub qp: f64,
}

pub(crate) fn ms_since(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The result of one frame.
#[derive(Clone, Debug)]
pub struct FrameEstimate {
    /// The last intensity QP.
    pub estimate: IntensityEstimate,
    /// The problem it solved (linearised at `positions`).
    pub problem: IntensityProblem,
    /// Visible features in the last registration.
    pub visible: usize,
    /// FE updates done.
    pub updates: usize,
    /// Whether the forces settled (`force_tol` or `sigma_tol`) before `max_updates`.
    pub settled: bool,
    /// Force steps halved because their FE update failed (see `FrameParams::max_halvings`).
    pub halvings: usize,
    /// Final node positions (m).
    pub positions: Vec<[f64; 3]>,
    /// The frame's features as the last linearisation registered them at `positions` (none
    /// matched under dense rows): its feature rows are the matched ones, in order.
    pub matches: FeatureMatches,
    /// The last linearisation's solver state: elements evaluated at `positions`, the
    /// tangent with the cables factorized there (for
    /// [`choose_locations`](super::choose_locations) at `positions`).
    pub solver: Option<SolverState>,
    /// The FE state at `positions` (the equilibrium under `applied`), to warm-start the
    /// next frame's loop from ([`Start::Resume`]).
    pub solution: Option<Solution>,
    /// The candidate forces of that state (N): the loop's last iterate, of which
    /// `estimate.forces` is the QP's answer at `positions`.
    pub applied: Vec<f64>,
    /// How much each of `estimate.forces` moved in the loop's last update (N): the QP's
    /// answer at `positions` against the forces that made them. The answer depends on the
    /// state it is linearised at by about this much (a weakly identified component keeps
    /// cycling by it). Empty when no QP was solved.
    pub last_change: Vec<f64>,
    /// The rows' fit against their expected noise, where the rows know it (the dense rows,
    /// [`FrameEstimate::use_independent_uncertainty`]).
    pub fit: Option<super::dense::NoiseFit>,
    /// Where the time went.
    pub timings: LoopTimings,
}

/// What a frame's estimates share: the model (its cable controls are the actuator inputs),
/// the measured robot points, the features matched on them, and the loop's parameters.
#[derive(Clone, Copy)]
pub struct FrameInputs<'a> {
    /// The FE model with the frame's actuator inputs.
    pub model: &'a Model,
    /// The frame's robot points (robot frame, m), ready for matching.
    pub registrar: &'a Registrar,
    /// Points on flat surface patches (see [`crate::register::surface_features`]), matched
    /// along their patch normals at each FE state: a measured surface equal to the model's
    /// gives zero offsets.
    pub features: &'a [SurfaceFeature],
    /// The loop's parameters.
    pub params: &'a FrameParams,
    /// Dense registration: rows of the robot points themselves instead of the features'
    /// (`None`: the features').
    pub dense: Option<&'a super::dense::DenseInputs<'a>>,
}

/// Where [`estimate`]'s loop starts.
#[derive(Debug)]
pub enum Start<'a> {
    /// From zero forces. `near`: a nearby equilibrium of the same model (e.g. without the
    /// candidate forces) to warm-start Newton. `state`: a solver state left at `near`'s
    /// positions by a solver of the same model without loads (see
    /// [`crate::fem::solve::Problem::solver_from`]), ideally with the tangent and the
    /// cables' geometric stiffness factorized there: the first FE update (at zero forces,
    /// so at `near` itself) then neither evaluates the elements nor factorizes. Any other
    /// state only costs that reuse, never the result.
    Unloaded {
        /// A nearby equilibrium.
        near: Option<&'a Solution>,
        /// A solver state at `near`.
        state: Option<SolverState>,
    },
    /// From `forces` (one per candidate), e.g. the `applied` forces of the previous frame's
    /// [`FrameEstimate`] with its `solution` and `solver`. With all three the loop
    /// *resumes*: `solution` is taken as the first FE update's state as it is (no Newton
    /// step, the tangent factorized there reused), so on a stream whose load changes little
    /// the loop settles in one or two updates. The fixed point is the same.
    Resume {
        /// The equilibrium under `forces` (or a nearby one).
        solution: Option<&'a Solution>,
        /// A solver state at `solution`.
        state: Option<SolverState>,
        /// The starting forces (N).
        forces: &'a [f64],
    },
    /// Goes on with a loop that stopped before its forces settled (e.g. a short first try):
    /// its next FE update is under the forces of its last QP, warm-started at its last
    /// state (only the relaxation starts afresh). The updates count on from its own:
    /// `params.max_updates` bounds the total. Errors if the candidates are not the loop's.
    Onwards {
        /// The loop that stopped.
        from: &'a FrameEstimate,
        /// Its solver state ([`FrameEstimate::solver`], if taken out).
        state: Option<SolverState>,
    },
    /// The candidates of a location `choice` made at `at` (its linearisation point): the
    /// choice's QP is the loop's first update there, so the loop goes on from its forces
    /// (Newton warm-started at `at`) and counts it as one update. Errors if the candidates
    /// are not the choice's.
    AfterChoice {
        /// The equilibrium the choice linearised at.
        at: &'a Solution,
        /// A solver state at `at`, as for [`Start::Unloaded`].
        state: Option<SolverState>,
        /// The choice.
        choice: &'a LocationChoice,
    },
}

/// Estimates the forces of `candidates` from the frame's `inputs`, starting at `start`.
pub fn estimate(
    inputs: &FrameInputs<'_>,
    candidates: &[Candidate],
    start: Start<'_>,
) -> InverseResult<FrameEstimate> {
    let mut state = LoopState::new(inputs, candidates, start)?;
    // The model without its point loads: the candidates' loads go to each update's solver.
    let model = &inputs.model.problem;
    let base = if model.loads.is_empty() {
        std::borrow::Cow::Borrowed(model)
    } else {
        std::borrow::Cow::Owned(model.without_loads())
    };
    while state.updates < inputs.params.max_updates {
        let loads = loads_of(candidates, &state.forces);
        let Some(solver) = state.fe_update(&base, loads, inputs.params)? else {
            continue;
        };
        let (prob, visible) = state.linearise(solver, inputs, candidates)?;
        let clock = std::time::Instant::now();
        let est = prob.solve(&inputs.params.intensity)?;
        state.timings.qp += ms_since(clock);
        if !est.status.is_solution() {
            return Err(InverseError::NotSolved(est.status));
        }
        if state.relax(est, visible, prob, inputs.params) {
            break;
        }
    }
    state.finish()
}

/// The loop's iterate and what it keeps between FE updates.
struct LoopState<'a> {
    /// The caller's equilibrium (warm start of the first update).
    start: Option<&'a Solution>,
    /// Whether the first update takes `start` as it is.
    resume: bool,
    newton: NewtonParams,
    /// The model's own absolute Newton tolerance.
    abs_tol: f64,
    /// The current forces (one per candidate).
    forces: Vec<f64>,
    /// The forces of the last good FE state (`prev`, else `start`), from which a failed step
    /// is halved.
    applied: Vec<f64>,
    /// Largest load change (N) applied since the last FE state: the forcing term's scale.
    step: f64,
    /// Largest cable self-compliance W_aa (m/N) of the last linearisation.
    cable_compliance: f64,
    /// Aitken's relaxation factor.
    omega: f64,
    /// The last QP's change of the forces.
    r_prev: Option<Vec<f64>>,
    /// The previous update's solver state (before the first, the caller's): its last
    /// element evaluation is at `x`, where the next Newton solve starts.
    carry: Option<SolverState>,
    /// The last FE state.
    prev: Option<Solution>,
    /// Its node positions (rest before the first).
    x: Vec<[f64; 3]>,
    updates: usize,
    halvings: usize,
    settled: bool,
    /// The last QP's change of each force (N).
    last_change: Vec<f64>,
    last: Option<(IntensityEstimate, usize, IntensityProblem)>,
    /// The features registered at `x` by the last linearisation.
    matches: FeatureMatches,
    timings: LoopTimings,
}

/// Largest diagonal entry (a cable's self-compliance W_aa, m/N).
fn max_diagonal(w: &nalgebra::DMatrix<f64>) -> f64 {
    (0..w.nrows()).fold(0.0f64, |m, i| m.max(w[(i, i)]))
}

impl<'a> LoopState<'a> {
    fn new(
        inputs: &FrameInputs<'_>,
        candidates: &[Candidate],
        start: Start<'a>,
    ) -> InverseResult<Self> {
        let (near, carry, forces, onwards) = starting_point(start, candidates.len())?;
        let model = inputs.model;
        let params = inputs.params;
        let mut newton = model.newton.clone();
        if let Some(tol) = params.fe_rel_tol {
            newton.rel_tol = tol;
        }
        // Starting forces with a state and a solver state: the previous loop's end, taken as
        // the first FE update's state.
        let resume =
            matches!(onwards, Onwards::No) && forces.is_some() && near.is_some() && carry.is_some();
        let forces = forces.map_or_else(|| vec![0.0; candidates.len()], <[f64]>::to_vec);
        let abs_tol = newton.abs_tol;
        newton.max_iterations = newton.max_iterations.min(params.fe_max_iterations);
        let applied = match onwards {
            Onwards::No => forces.clone(),
            Onwards::Loop(o) => o.applied.clone(),
            Onwards::Choice(_) => vec![0.0; forces.len()],
        };
        let step = match onwards {
            Onwards::No => 0.0f64,
            _ => applied
                .iter()
                .zip(&forces)
                .fold(0.0f64, |m, (a, f)| m.max((f - a).abs())),
        };
        Ok(Self {
            start: near,
            resume,
            newton,
            abs_tol,
            // After a choice's QP (the first update, from zero forces), its forces are the
            // change.
            r_prev: match onwards {
                Onwards::Choice(_) => Some(forces.clone()),
                _ => None,
            },
            forces,
            applied,
            step,
            cable_compliance: match onwards {
                Onwards::No => 0.0,
                Onwards::Loop(o) => max_diagonal(&o.problem.w_aa),
                Onwards::Choice(c) => max_diagonal(&c.problem.w_aa),
            },
            omega: 1.0,
            carry,
            prev: None,
            x: model.problem.mesh.nodes_in_rest.clone(),
            updates: match onwards {
                Onwards::No => 0,
                Onwards::Loop(o) => o.updates,
                Onwards::Choice(_) => 1,
            },
            halvings: 0,
            settled: false,
            last_change: Vec::new(),
            last: None,
            matches: FeatureMatches::default(),
            timings: LoopTimings::default(),
        })
    }

    /// The FE state of `problem` under the current forces' `loads`, warm-started from the
    /// previous state (or the caller's). `None`: it failed and the step was halved.
    fn fe_update<'p>(
        &mut self,
        problem: &'p Problem,
        loads: Vec<PointLoad>,
        params: &FrameParams,
    ) -> InverseResult<Option<Solver<'p>>> {
        let clock = std::time::Instant::now();
        let solver = match self.carry.take() {
            Some(state) => problem.solver_from(state)?,
            None => problem.solver()?,
        };
        let mut solver = solver.with_loads(loads)?;
        let newton = &mut self.newton;
        newton.abs_tol = self.abs_tol.max(params.fe_forcing * self.step);
        // A cable gap g is a tension error of about g / W_aa.
        newton.gap_tol = params.fe_forcing * self.step * self.cable_compliance;
        let resume = &mut self.resume;
        let solved = match self.start.filter(|_| std::mem::take(resume)) {
            // Resuming: `start` is the equilibrium under the starting forces, to the
            // tolerance of the loop that left it; only the tangent is assembled there.
            Some(s) => solver
                .assemble(&s.positions, newton.tangent)
                .map(|()| s.clone()),
            None => solver.solve_static_from(newton, self.prev.as_ref().or(self.start)),
        };
        let sol = match solved {
            Ok(sol) => sol,
            Err(
                e @ (FemError::InvertedElement { .. }
                | FemError::Singular(_)
                | FemError::NotPositiveDefinite { .. }
                | FemError::NoConvergence { .. }),
            ) => {
                if self.halvings >= params.max_halvings || self.forces == self.applied {
                    return Err(e.into());
                }
                self.halve();
                self.timings.fe_update += ms_since(clock);
                return Ok(None);
            }
            Err(e) => return Err(e.into()),
        };
        self.applied.clone_from(&self.forces);
        self.x = sol.positions.clone();
        self.prev = Some(sol);
        self.updates += 1;
        self.timings.fe_update += ms_since(clock);
        Ok(Some(solver))
    }

    /// The step overshot what the FE model can follow: halve it, from the last good state
    /// (a fresh solver: the failed one's element states are gone).
    fn halve(&mut self) {
        self.halvings += 1;
        for (f, a) in self.forces.iter_mut().zip(&self.applied) {
            *f = a + 0.5 * (*f - a);
        }
        self.step *= 0.5;
        self.omega = (0.5 * self.omega).max(0.1);
        self.r_prev = None;
    }

    /// The intensity problem at the new FE state, and its visible features; keeps the
    /// solver's state for the next update, and the features' registration there.
    fn linearise(
        &mut self,
        mut solver: Solver<'_>,
        inputs: &FrameInputs<'_>,
        candidates: &[Candidate],
    ) -> InverseResult<(IntensityProblem, usize)> {
        // The linearisation's tangent is Newton's own at x: the material tangent of the
        // solver's last assembly (loads do not enter K) plus the cables' geometric stiffness
        // under the solved tensions. Without the cables the consistent tangent is indefinite
        // at the sensed states, and the rotated fallback is a poorer linearisation: the loop
        // then needs up to twice the FE updates.
        let clock = std::time::Instant::now();
        let tensions = self
            .prev
            .as_ref()
            .map_or(Vec::new(), |s| s.actuator_forces());
        factorize_loop_tangent(&mut solver, &self.x, &tensions, self.newton.tangent)?;
        self.timings.compliance += ms_since(clock);
        let (prob, visible, matches) =
            linearise(&solver, &self.x, inputs, candidates, &mut self.timings)?;
        self.matches = matches;
        self.carry = Some(solver.into_state());
        self.cable_compliance = max_diagonal(&prob.w_aa);
        Ok((prob, visible))
    }

    /// Takes the QP `est` at the current state: whether the forces settled, else the next
    /// forces. Fixed point forces = QP(state(forces)), with Aitken's dynamic relaxation: the
    /// linearisation at a loaded state is not exact, and plain substitution oscillates
    /// (seen: period-2 in the tangential components, damped by only ~0.85 per update).
    fn relax(
        &mut self,
        est: IntensityEstimate,
        visible: usize,
        prob: IntensityProblem,
        params: &FrameParams,
    ) -> bool {
        let r: Vec<f64> = est
            .forces
            .iter()
            .zip(&self.forces)
            .map(|(a, b)| a - b)
            .collect();
        // Error factor of this estimate: g / (1 - g) for a measured contraction g (see
        // `settle_contraction`), else 1 (the last change itself, as without the prediction).
        let mut factor = 1.0;
        if let Some(rp) = &self.r_prev {
            // The last step was f_k - f_{k-1} = ω r_{k-1}, so r_k ≈ ((1 - ω) + ω G') r_{k-1}:
            // the secant along r_{k-1}. With several forces it sees G' in one direction
            // only, so the plain ratio |r_k| / |r_{k-1}| bounds it from below.
            let omega = self.omega;
            let rn = norm_vec(rp);
            let along: Vec<f64> = r
                .iter()
                .zip(rp)
                .map(|(a, b)| a - (1.0 - omega) * b)
                .collect();
            let g = (norm_vec(&along) / (omega * rn)).max(norm_vec(&r) / rn);
            if g.is_finite() && g <= params.settle_contraction {
                factor = g / (1.0 - g);
            }
            let dr: Vec<f64> = r.iter().zip(rp).map(|(a, b)| a - b).collect();
            let dd: f64 = dr.iter().map(|v| v * v).sum();
            if dd > 0.0 {
                let num: f64 = rp.iter().zip(&dr).map(|(a, b)| a * b).sum();
                self.omega = (-omega * num / dd).clamp(0.1, 1.5);
            }
        }
        // Settled: every force is (predicted to be) within `force_tol` of the fixed point,
        // or within `sigma_tol` of its own noise spread (further updates only move it within
        // its noise).
        self.last_change = r.iter().map(|v| v.abs()).collect();
        self.settled = r.iter().enumerate().all(|(i, v)| {
            let s = est.force_sigma.get(i).copied().filter(|s| s.is_finite());
            let tol = params.force_tol.max(params.sigma_tol * s.unwrap_or(0.0));
            v.abs() < tol || factor * v.abs() < tol
        });
        self.last = Some((est, visible, prob));
        if self.settled {
            return true;
        }
        let omega = self.omega;
        for (f, rk) in self.forces.iter_mut().zip(&r) {
            *f += omega * rk;
        }
        self.step = r.iter().fold(0.0f64, |m, v| m.max((omega * v).abs()));
        self.r_prev = Some(r);
        false
    }

    fn finish(self) -> InverseResult<FrameEstimate> {
        let (estimate, visible, problem) = self.last.ok_or(InverseError::NoUpdates)?;
        Ok(FrameEstimate {
            solution: self.prev,
            estimate,
            problem,
            visible,
            updates: self.updates,
            settled: self.settled,
            halvings: self.halvings,
            applied: self.applied,
            last_change: self.last_change,
            fit: None,
            positions: self.x,
            matches: self.matches,
            solver: self.carry,
            timings: self.timings,
        })
    }
}

/// A loop's start, for `n` candidates: the equilibrium to start at, a solver state there,
/// the starting forces, and the loop gone on from.
type StartingPoint<'a> = (
    Option<&'a Solution>,
    Option<SolverState>,
    Option<&'a [f64]>,
    Onwards<'a>,
);

/// What `start` starts a loop of `n` candidates from (checked).
fn starting_point(start: Start<'_>, n: usize) -> InverseResult<StartingPoint<'_>> {
    let (near, carry, forces, onwards) = match start {
        Start::Unloaded { near, state } => (near, state, None, Onwards::No),
        Start::Resume {
            solution,
            state,
            forces,
        } => (solution, state, Some(forces), Onwards::No),
        Start::Onwards { from, state } => {
            // (The QP forces are checked below.)
            if from.applied.len() != n {
                return Err(InverseError::OnwardsCandidates {
                    from: from.applied.len(),
                    candidates: n,
                });
            }
            let forces = Some(&from.estimate.forces[..]);
            (from.solution.as_ref(), state, forces, Onwards::Loop(from))
        }
        Start::AfterChoice { at, state, choice } => {
            let forces = Some(&choice.estimate.forces[..]);
            (Some(at), state, forces, Onwards::Choice(choice))
        }
    };
    if let Some(f) = forces {
        if f.len() != n || f.iter().any(|v| !v.is_finite()) {
            return Err(InverseError::StartingForces {
                forces: f.len(),
                candidates: n,
            });
        }
    }
    Ok((near, carry, forces, onwards))
}

/// Where the loop goes on from.
#[derive(Clone, Copy)]
enum Onwards<'a> {
    /// Nowhere: from zero forces, or resuming a previous loop's end.
    No,
    /// A loop stopped early ([`Start::Onwards`]).
    Loop(&'a FrameEstimate),
    /// A location choice's QP at `start` ([`Start::AfterChoice`]).
    Choice(&'a LocationChoice),
}

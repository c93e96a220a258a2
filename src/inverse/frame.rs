//! One frame of force sensing on the FE model (thesis 4.5.2): register the features at the
//! current FE state, build the normal-space compliance rows, solve the intensity QP, update
//! the FE state with the solved forces, and repeat until the forces settle.

use super::intensity::{ActuatorInput, IntensityEstimate, IntensityParams, IntensityProblem};
use super::{par_map, InverseError, InverseResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{
    norm_vec, CableControl, MappedPoint, PointLoad, Solution, Solver, SolverState,
};
use crate::fem::tet4::Tangent;
use crate::fem::FemError;
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
    /// Newton's relative residual tolerance in the FE updates (1e-8 of the force scale;
    /// `None`: the model's own, 1e-10 by default). At 1e-8 the state is off by ~1e-9 m on
    /// a 0.5 kg robot, far below the 0.5 mm depth noise, and an update saves the last
    /// Newton iteration about half the time.
    pub fe_rel_tol: Option<f64>,
    /// Inexact FE updates (a forcing term, as in inexact Newton methods): an update whose
    /// loads moved by at most `s` newtons from the last state stops Newton once the residual
    /// is below `fe_forcing * s` (N), if that is looser than `fe_rel_tol`. Early updates,
    /// whose forces are still far from the fixed point, then take 1-2 Newton iterations
    /// instead of 4-5; as the forces settle, the tolerance tightens with them. The residual
    /// left is not lost: the linearisation's free motion includes it, so the QP at that
    /// state predicts the features after it is balanced. 0: every update to `fe_rel_tol`.
    /// Default 0.2 (0.01 until 2026-11-25): on 56 held-out and test probe frames and 24
    /// two-probe frames the same loads come out within 5% and located, the forces move by
    /// 0.2 mN (median; at most 1.9 of their σ, on a two-probe frame with σ 96 mN), and the
    /// frames take a third less time.
    pub fe_forcing: f64,
    /// The loop also stops once every force's change is below this fraction of its
    /// Gauss-Markov σ (`IntensityEstimate::force_sigma`): near the fixed point a weakly
    /// identified (tangential) component can cycle by a fraction of its noise as the
    /// registration's matched points change, and more updates cannot settle it. At 0.25 a
    /// stop adds about 3% to the spread (√(1 + 0.25²)). 0: `force_tol` alone.
    pub sigma_tol: f64,
    /// Halvings, in all, of force steps whose FE update fails (an inverted element, an
    /// indefinite tangent, Newton not converging) before the frame fails (6). The first intensity QP is
    /// linearised at the unloaded state; where a load bends a leg by centimetres that
    /// linearisation can ask for several times the real force, more than the FE model can
    /// follow in one Newton solve. The step is then halved, from the last good state, until
    /// it can. 0: the first failure fails the frame.
    pub max_halvings: usize,
    /// Newton iterations an FE update may take before its step is halved (25; the
    /// model's own limit if lower). Warm-started updates take 2-6.
    pub fe_max_iterations: usize,
    /// The loop also stops when the *predicted* error of the last estimate is below the
    /// tolerances above, once the iteration is seen to contract by at most this factor per
    /// update (0.5; 0: off). The estimate returned is the QP at the last state, G(f_k);
    /// its distance to the fixed point f* = G(f*) is about g / (1 - g) times the last
    /// force change, where g, the contraction of G, is measured by the secant over the
    /// last two updates (with the relaxation factor taken out). Where the first update
    /// already lands within a few mN, as on the hanging-weight frames (g ≈ 0.02), this
    /// saves the update that only confirmed it.
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

fn ms_since(t: std::time::Instant) -> f64 {
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
    /// The last linearisation's solver state: elements evaluated at `positions`, the
    /// tangent with the cables factorized there (for [`choose_locations`] at `positions`).
    pub solver: Option<SolverState>,
    /// The FE state at `positions` (the equilibrium under `applied`), to warm-start the
    /// next frame's loop from ([`estimate_from`]).
    pub solution: Option<Solution>,
    /// The candidate forces of that state (N): the loop's last iterate, of which
    /// `estimate.forces` is the QP's answer at `positions`.
    pub applied: Vec<f64>,
    /// Where the time went.
    pub timings: LoopTimings,
}

impl FrameEstimate {
    /// Replaces the forces' Gauss-Markov σ (independent feature rows, the loop's) with their
    /// covariance from the points the rows share ([`SharedPoints`] at `positions`):
    /// neighbouring features average some of the same points, so their offsets' errors are
    /// correlated, and near a contact, where the force is decided, they overlap most. A row
    /// whose residual is larger than its spread from the points' noise has its errors
    /// scaled up to its residual (the rows' correlations kept): what the noise model leaves
    /// out (e.g. a bias in how the points near the probe's edge are selected) shows in the
    /// residuals, and the σ then cover it. The forces do not change. `registrar` and
    /// `features` must be the estimate's own. Returns whether the σ were replaced (not when
    /// a match is the single nearest point or the forces are not identifiable).
    pub fn use_shared_point_uncertainty(
        &mut self,
        registrar: &Registrar,
        features: &[SurfaceFeature],
        params: &RegisterParams,
    ) -> bool {
        let Some(shared) = SharedPoints::register(registrar, features, &self.positions, params)
        else {
            return false;
        };
        let e = &self.estimate;
        let Some(residuals) = self.problem.residuals(&e.actuator_forces, &e.forces) else {
            return false;
        };
        if residuals.len() != shared.rows.len() {
            return false;
        }
        // sqrt(max(1, r_i² / C_ii)): never below the noise model.
        let scale: Vec<f64> = residuals
            .iter()
            .enumerate()
            .map(|(i, r)| (r * r / shared.row_variance(i)).max(1.0).sqrt())
            .map(|s| if s.is_finite() { s } else { 1.0 })
            .collect();
        let Some(cov) = self
            .problem
            .force_covariance_with(|a| shared.sandwich_scaled(a, &scale))
        else {
            return false;
        };
        self.estimate.force_sigma = (0..cov.nrows())
            .map(|i| cov[(i, i)].max(0.0).sqrt())
            .collect();
        self.estimate.force_covariance = Some(cov);
        true
    }
}

/// Estimates the candidate forces from measured robot points (robot frame, m). The model's
/// cable controls are the actuator inputs; `features` are points on flat surface patches
/// (see [`crate::register::surface_features`]), matched along their patch normals at each FE
/// state, so a measured surface equal to the model's gives zero offsets. `start`: a nearby
/// equilibrium of the same model (e.g. without the candidate forces) to warm-start Newton.
/// `state`: a solver state left at `start`'s positions by a solver of the same model
/// without loads (see [`crate::fem::solve::Problem::solver_from`]), ideally with the
/// tangent and the cables' geometric stiffness factorized there: the first FE update (at
/// zero forces, so at `start` itself) then neither evaluates the elements nor factorizes.
/// Any other state only costs that reuse, never the result.
pub fn estimate(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    start: Option<&Solution>,
    state: Option<SolverState>,
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    estimate_from(
        model, registrar, features, candidates, start, state, None, params,
    )
}

/// [`estimate`] with the loop's forces starting at `forces` (one per candidate; `None`:
/// zero), e.g. the `applied` forces of the previous frame's [`FrameEstimate`], with its
/// `solution` as `start` and its `solver` as `state`. With all three the loop *resumes*:
/// `start` is taken as the first FE update's state as it is (the equilibrium under
/// `forces` to the tolerance of the loop that left it; no Newton step, and the tangent
/// factorized there is reused), so on a stream whose load changes little from frame to
/// frame the loop settles in one or two updates, the first almost free, instead of two
/// to six from zero. The fixed point, and so the answer within the loop's tolerances, is
/// the same.
#[allow(clippy::too_many_arguments)]
pub fn estimate_from(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    start: Option<&Solution>,
    state: Option<SolverState>,
    forces: Option<&[f64]>,
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    sensing_loop(
        model,
        registrar,
        features,
        candidates,
        start,
        state,
        forces,
        Onwards::No,
        params,
    )
}

/// Goes on with a loop that stopped before its forces settled (at `params.max_updates`,
/// e.g. a short first try): its next FE update is under the forces of its last QP,
/// Newton warm-started at its last state, as the loop itself would have gone on (only the
/// relaxation starts afresh). `state`: its solver state ([`FrameEstimate::solver`], if
/// taken out). The updates count on from its own: `params.max_updates` bounds the total.
/// Errors if `candidates` are not the loop's.
pub fn estimate_onwards(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    from: &FrameEstimate,
    state: Option<SolverState>,
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    // (The QP forces are checked against `candidates` by the loop.)
    if from.applied.len() != candidates.len() {
        return Err(InverseError::Intensity(format!(
            "a loop of {} candidates cannot go on with {}",
            from.applied.len(),
            candidates.len()
        )));
    }
    sensing_loop(
        model,
        registrar,
        features,
        candidates,
        from.solution.as_ref(),
        state,
        Some(&from.estimate.forces),
        Onwards::Loop(from),
        params,
    )
}

/// [`estimate`] for the candidates of a location `choice` made at `start` (its
/// linearisation point: positions and tensions of `start`): the choice's QP is the loop's
/// first update there, so the loop goes on from its forces (the first FE update is under
/// them, Newton warm-started at `start`) and counts it as one update. `state`: a solver
/// state at `start`, as for [`estimate`]. Errors if `candidates` are not the choice's.
#[allow(clippy::too_many_arguments)]
pub fn estimate_after_choice(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    start: &Solution,
    state: Option<SolverState>,
    choice: &LocationChoice,
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    sensing_loop(
        model,
        registrar,
        features,
        candidates,
        Some(start),
        state,
        Some(&choice.estimate.forces),
        Onwards::Choice(choice),
        params,
    )
}

/// Where [`sensing_loop`] goes on from.
#[derive(Clone, Copy)]
enum Onwards<'a> {
    /// Nowhere: from zero forces, or resuming a previous loop's end (see [`estimate_from`]).
    No,
    /// A loop stopped early ([`estimate_onwards`]).
    Loop(&'a FrameEstimate),
    /// A location choice's QP at `start` ([`estimate_after_choice`]).
    Choice(&'a LocationChoice),
}

/// The loop of [`estimate_from`], [`estimate_onwards`] or [`estimate_after_choice`]
/// (`onwards`; for the last two `forces` are the last QP's and `start` its state).
#[allow(clippy::too_many_arguments)]
fn sensing_loop(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    start: Option<&Solution>,
    state: Option<SolverState>,
    forces: Option<&[f64]>,
    onwards: Onwards<'_>,
    params: &FrameParams,
) -> InverseResult<FrameEstimate> {
    if let Some(f) = forces {
        if f.len() != candidates.len() || f.iter().any(|v| !v.is_finite()) {
            return Err(InverseError::Intensity(format!(
                "{} starting forces for {} candidates (or not finite)",
                f.len(),
                candidates.len()
            )));
        }
    }
    let base = model.problem.without_loads();
    let rest = base.mesh.nodes_in_rest.clone();
    let mut timings = LoopTimings::default();
    let mut newton = model.newton.clone();
    if let Some(tol) = params.fe_rel_tol {
        newton.rel_tol = tol;
    }
    // Starting forces with a state and a solver state: the previous loop's end, taken as
    // the first FE update's state.
    let mut resume =
        matches!(onwards, Onwards::No) && forces.is_some() && start.is_some() && state.is_some();
    let mut forces = forces.map_or_else(|| vec![0.0; candidates.len()], <[f64]>::to_vec);
    let mut last: Option<(IntensityEstimate, usize, IntensityProblem)> = None;
    let mut x = rest.clone();
    let mut updates = match onwards {
        Onwards::No => 0,
        Onwards::Loop(o) => o.updates,
        Onwards::Choice(_) => 1,
    };
    let mut prev: Option<Solution> = None;
    let mut omega = 1.0f64;
    // After a choice's QP (the first update, from zero forces), its forces are the change.
    let mut r_prev: Option<Vec<f64>> = match onwards {
        Onwards::Choice(_) => Some(forces.clone()),
        _ => None,
    };
    // The previous update's solver state (before the first, the caller's): its last
    // element evaluation is at `x`, where the next Newton solve starts.
    let mut carry = state;
    let abs_tol = newton.abs_tol;
    newton.max_iterations = newton.max_iterations.min(params.fe_max_iterations);
    // Largest load change (N) applied since the last FE state: the forcing term's scale.
    // The forces of the last good FE state (`prev`, else `start`), from which a failed
    // step is halved.
    let mut applied = match onwards {
        Onwards::No => forces.clone(),
        Onwards::Loop(o) => o.applied.clone(),
        Onwards::Choice(_) => vec![0.0; forces.len()],
    };
    let mut step = match onwards {
        Onwards::No => 0.0f64,
        _ => applied
            .iter()
            .zip(&forces)
            .fold(0.0f64, |m, (a, f)| m.max((f - a).abs())),
    };
    // Largest cable self-compliance W_aa (m/N) of the last linearisation.
    let max_diagonal =
        |w: &nalgebra::DMatrix<f64>| (0..w.nrows()).fold(0.0f64, |m, i| m.max(w[(i, i)]));
    let mut cable_compliance = match onwards {
        Onwards::No => 0.0,
        Onwards::Loop(o) => max_diagonal(&o.problem.w_aa),
        Onwards::Choice(c) => max_diagonal(&c.problem.w_aa),
    };
    let mut halvings = 0;
    let mut settled = false;
    while updates < params.max_updates {
        // FE state under the current forces.
        let mut problem = base.clone();
        for (c, f) in candidates.iter().zip(&forces) {
            problem.loads.push(PointLoad {
                at: c.at,
                force: crate::math::unit(c.direction).map(|d| d * f),
            });
        }
        // Warm start from the previous state (or the caller's), from rest otherwise.
        let clock = std::time::Instant::now();
        let mut solver = match carry.take() {
            Some(state) => problem.solver_from(state)?,
            None => problem.solver()?,
        };
        newton.abs_tol = abs_tol.max(params.fe_forcing * step);
        // A cable gap g is a tension error of about g / W_aa.
        newton.gap_tol = params.fe_forcing * step * cable_compliance;
        let solved = match start.filter(|_| std::mem::take(&mut resume)) {
            // Resuming: `start` is the equilibrium under the starting forces, to the
            // tolerance of the loop that left it; only the tangent is assembled there.
            Some(s) => solver
                .assemble(&s.positions, newton.tangent)
                .map(|()| s.clone()),
            None => solver.solve_static_from(&newton, prev.as_ref().or(start)),
        };
        let sol = match solved {
            Ok(sol) => sol,
            Err(
                e @ (FemError::InvertedElement { .. }
                | FemError::Singular(_)
                | FemError::NotPositiveDefinite { .. }
                | FemError::NoConvergence { .. }),
            ) => {
                if halvings >= params.max_halvings || forces == applied {
                    return Err(e.into());
                }
                // The step overshot what the FE model can follow: halve it, from the last
                // good state (a fresh solver: the failed one's element states are gone).
                halvings += 1;
                for (f, a) in forces.iter_mut().zip(&applied) {
                    *f = a + 0.5 * (*f - a);
                }
                step *= 0.5;
                omega = (0.5 * omega).max(0.1);
                r_prev = None;
                timings.fe_update += ms_since(clock);
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        applied.clone_from(&forces);
        x = sol.positions.clone();
        prev = Some(sol);
        updates += 1;
        timings.fe_update += ms_since(clock);
        // The linearisation's tangent is Newton's own at x: the material tangent of the
        // solver's last assembly (loads do not enter K) plus the cables' geometric stiffness
        // under the solved tensions. Without the cables the consistent tangent is indefinite
        // at the sensed states, and the rotated fallback is a poorer linearisation: the loop
        // then needs up to twice the FE updates.
        let clock = std::time::Instant::now();
        let tensions = prev.as_ref().map_or(&[][..], |s| &s.cable_tension[..]);
        factorize_loop_tangent(&mut solver, &x, tensions, newton.tangent)?;
        timings.compliance += ms_since(clock);
        let (prob, visible) = linearise(
            &solver,
            &x,
            registrar,
            features,
            candidates,
            params,
            &mut timings,
        )?;
        carry = Some(solver.into_state());
        cable_compliance = max_diagonal(&prob.w_aa);
        let clock = std::time::Instant::now();
        let est = prob.solve(&params.intensity)?;
        timings.qp += ms_since(clock);
        if !est.status.is_solution() {
            return Err(InverseError::NotSolved(est.status));
        }
        // Fixed point forces = QP(state(forces)), with Aitken's dynamic relaxation: the
        // linearisation at a loaded state is not exact, and plain substitution oscillates
        // (seen: period-2 in the tangential components, damped by only ~0.85 per update).
        let r: Vec<f64> = est.forces.iter().zip(&forces).map(|(a, b)| a - b).collect();
        // Error factor of this estimate: g / (1 - g) for a measured contraction g (see
        // `settle_contraction`), else 1 (the last change itself, as without the prediction).
        let mut factor = 1.0;
        if let Some(rp) = &r_prev {
            // The last step was f_k - f_{k-1} = ω r_{k-1}, so r_k ≈ ((1 - ω) + ω G') r_{k-1}:
            // the secant along r_{k-1}. With several forces it sees G' in one direction
            // only, so the plain ratio |r_k| / |r_{k-1}| bounds it from below.
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
                omega = (-omega * num / dd).clamp(0.1, 1.5);
            }
        }
        // Settled: every force is (predicted to be) within `force_tol` of the fixed point,
        // or within `sigma_tol` of its own noise spread (further updates only move it within
        // its noise).
        settled = r.iter().enumerate().all(|(i, v)| {
            let s = est.force_sigma.get(i).copied().filter(|s| s.is_finite());
            let tol = params.force_tol.max(params.sigma_tol * s.unwrap_or(0.0));
            v.abs() < tol || factor * v.abs() < tol
        });
        last = Some((est, visible, prob));
        if settled {
            break;
        }
        for (f, rk) in forces.iter_mut().zip(&r) {
            *f += omega * rk;
        }
        step = r.iter().fold(0.0f64, |m, v| m.max((omega * v).abs()));
        r_prev = Some(r);
    }
    let (estimate, visible, problem) =
        last.ok_or_else(|| InverseError::Intensity("max_updates is zero".into()))?;
    Ok(FrameEstimate {
        solution: prev,
        estimate,
        problem,
        visible,
        updates,
        settled,
        halvings,
        applied,
        positions: x,
        solver: carry,
        timings,
    })
}

/// The points behind the offsets of the features visible at node positions `x` (the rows
/// of the sensing loop's linearised problem, in its order): row i's offset is the mean of its n_i points,
/// so with independent points of variance s² the covariance of rows i and j is
/// s² n_ij / (n_i n_j), n_ij the points they share. s² is the median, over the rows, of the
/// points' scatter about their offset.
#[derive(Clone, Debug)]
pub struct SharedPoints {
    /// Each row's points (indices into the registrar's finite points, ascending).
    pub rows: Vec<Vec<u32>>,
    /// Per-point variance along the line, s² (m²).
    pub point_variance: f64,
}

impl SharedPoints {
    /// Registers `features` at `x` as the sensing loop's linearisation does. `None` unless the matches average
    /// (`params.average`) and some row has two points or more.
    pub fn register(
        registrar: &Registrar,
        features: &[SurfaceFeature],
        x: &[[f64; 3]],
        params: &RegisterParams,
    ) -> Option<Self> {
        if !params.average {
            return None;
        }
        let mut rows = Vec::new();
        let mut variances = Vec::new();
        for f in features {
            let (p, n) = (f.position(x), f.normal(x));
            if n == [0.0; 3] {
                continue;
            }
            // The same matches as `linearise` (visible there exactly when here).
            let Some((m, pts, scatter)) = registrar.match_feature_points(p, n, params) else {
                continue;
            };
            if m.points > 1 {
                variances.push(scatter / (m.points - 1) as f64);
            }
            rows.push(pts);
        }
        if variances.is_empty() {
            return None;
        }
        let point_variance = crate::math::median(&mut variances);
        Some(Self {
            rows,
            point_variance,
        })
    }

    /// The covariance of the rows' offsets (m², rows x rows).
    pub fn matrix(&self) -> nalgebra::DMatrix<f64> {
        let m = self.rows.len();
        let mut c = nalgebra::DMatrix::<f64>::zeros(m, m);
        for (_, owners) in self.owners() {
            for &a in &owners {
                for &b in &owners {
                    c[(a, b)] += 1.0;
                }
            }
        }
        let n: Vec<f64> = self.rows.iter().map(|r| r.len() as f64).collect();
        for i in 0..m {
            for j in 0..m {
                c[(i, j)] *= self.point_variance / (n[i] * n[j]);
            }
        }
        c
    }

    /// B C Bᵀ for the rows' covariance C ([`SharedPoints::matrix`]) and `b` (k x rows),
    /// without forming C: s² Σ_points v vᵀ, v = Σ over the rows holding the point of
    /// b's column / n_row.
    pub fn sandwich(&self, b: &nalgebra::DMatrix<f64>) -> Option<nalgebra::DMatrix<f64>> {
        self.sandwich_scaled(b, &vec![1.0; self.rows.len()])
    }

    /// Row i's variance in [`SharedPoints::matrix`], s² / n_i (m²).
    pub fn row_variance(&self, i: usize) -> f64 {
        self.point_variance / self.rows[i].len() as f64
    }

    /// [`SharedPoints::sandwich`] with row i's errors scaled by `scale[i]`: B D C D Bᵀ, D =
    /// diag(scale), the rows' correlations unchanged. `None` when a length does not fit.
    pub fn sandwich_scaled(
        &self,
        b: &nalgebra::DMatrix<f64>,
        scale: &[f64],
    ) -> Option<nalgebra::DMatrix<f64>> {
        if b.ncols() != self.rows.len() || scale.len() != self.rows.len() {
            return None;
        }
        let k = b.nrows();
        let mut out = nalgebra::DMatrix::<f64>::zeros(k, k);
        let mut v = nalgebra::DVector::<f64>::zeros(k);
        for (_, owners) in self.owners() {
            v.fill(0.0);
            for &i in &owners {
                let w = scale[i] / self.rows[i].len() as f64;
                v.axpy(w, &b.column(i), 1.0);
            }
            out.ger(self.point_variance, &v, &v, 1.0);
        }
        Some(out)
    }

    /// Each point used, with the rows holding it (ascending), in point order.
    fn owners(&self) -> Vec<(u32, Vec<usize>)> {
        let mut pairs: Vec<(u32, usize)> = self
            .rows
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.iter().map(move |&q| (q, i)))
            .collect();
        pairs.sort_unstable();
        let mut out: Vec<(u32, Vec<usize>)> = Vec::new();
        for (q, i) in pairs {
            match out.last_mut() {
                Some((p, rows)) if *p == q => rows.push(i),
                _ => out.push((q, vec![i])),
            }
        }
        out
    }
}

/// Factorizes the sensing loop's linearisation at `x`, an equilibrium the solver's Newton
/// solve (with `tangent`) just reached: the material tangent of its last assembly plus the
/// cables' geometric stiffness under `tensions` (see [`estimate`]).
pub(crate) fn factorize_loop_tangent(
    solver: &mut Solver<'_>,
    x: &[[f64; 3]],
    tensions: &[f64],
    tangent: Tangent,
) -> crate::fem::FemResult<()> {
    if tangent == Tangent::default() {
        solver.factorize_assembled_with_cables(x, tensions)
    } else {
        solver.factorize_with_cables(x, tensions)
    }
}

/// The intensity problem linearised at node positions `x` (an equilibrium of the solver's
/// problem without its point loads, plus some candidate loads; the solver holds the tangent
/// factorised at `x`): features registered at `x`, compliance of the feature, actuator and
/// candidate rows. Returns the problem and the number of visible features.
fn linearise(
    solver: &Solver<'_>,
    x: &[[f64; 3]],
    registrar: &Registrar,
    features: &[SurfaceFeature],
    candidates: &[Candidate],
    params: &FrameParams,
    timings: &mut LoopTimings,
) -> InverseResult<(IntensityProblem, usize)> {
    let base = solver.problem;
    let rest = &base.mesh.nodes_in_rest;
    let clock = std::time::Instant::now();
    // Register at the current state.
    let mut rows = Vec::new();
    let mut measured = Vec::new();
    let matches = registrar.match_features(features, x, &params.register);
    for (f, m) in features.iter().zip(matches) {
        if let Some(m) = m {
            let row = ConstraintRow::along(RowKind::Effector, &f.mapped(), f.normal(x))?;
            measured.push(row.value(x) + m.offset);
            rows.push(row);
        }
    }
    let visible = rows.len();
    timings.register += ms_since(clock);
    let clock = std::time::Instant::now();
    let ne = rows.len();
    let mut inputs = Vec::new();
    for c in &base.cables {
        let row = ConstraintRow::cable(c, x);
        inputs.push(match c.control {
            CableControl::Force(f) => ActuatorInput::Force(f),
            CableControl::Displacement(s) => {
                // Target in row units: value(x) + (s_target - s(x)).
                let s_now = c.length(rest) - c.length(x);
                ActuatorInput::Displacement(row.value(x) + s - s_now)
            }
        });
        rows.push(row);
    }
    let na = base.cables.len();
    for c in candidates {
        rows.push(ConstraintRow::along(RowKind::Force, &c.at, c.direction)?);
    }
    let nf = candidates.len();
    // Loads enter only as candidate rows: the free residual has the body forces alone.
    let mut full = solver.body_forces();
    for (f, fi) in full.iter_mut().zip(&solver.internal_force) {
        *f -= fi;
    }
    let r = solver.dofs.gather(&full);
    // W_ee is not used: skip the products among the feature rows.
    let comp = solver.compliance_skipping(&rows, x, &r, ne)?;
    timings.compliance += ms_since(clock);
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
    Ok((prob, visible))
}

/// Where [`choose_locations`] linearises.
#[derive(Debug)]
pub struct LinearisationPoint<'a> {
    /// Node positions of an equilibrium of the model (m): its free equilibrium, or one under
    /// a previous estimate's loads (point loads do not enter the tangent).
    pub positions: &'a [[f64; 3]],
    /// The cable tensions of that equilibrium (N, one per cable): the choice linearises on
    /// Newton's own matrix there, the material tangent plus the cables' geometric stiffness
    /// under these tensions, as the sensing loop does ([`estimate`]).
    pub tensions: &'a [f64],
    /// A solver state of the same model whose elements were evaluated at `positions` (e.g.
    /// [`FrameEstimate::solver`]) saves evaluating them, and one that holds the choice's
    /// very tangent factorized (bit for bit; e.g. an estimate's, which ends factorized
    /// there) saves factorizing it; any other state only costs that reuse, never the
    /// choice. `None`: both are done.
    pub state: Option<SolverState>,
}

/// Combinations whose QPs [`choose_locations`] solves at a time (in parallel), in order of
/// their lower bounds: usually the first is the winner and prunes the rest. Fixed, so the
/// work done does not depend on the thread count (the choice never does).
const PRUNE_BATCH: usize = 2;

/// Relative margin by which a lower bound must exceed the best QP residual before its
/// combination is skipped: far above the rounding of either.
const PRUNE_MARGIN: f64 = 1e-6;

/// Location mapping by the data: for each seen contact, a list of options (each option the
/// candidate forces of one location, e.g. three directions at one surface node). Linearised
/// once at the equilibrium `at` (on Newton's matrix, as the sensing loop: see
/// [`LinearisationPoint::tensions`]), with the compliance of every
/// option's rows in one computation; every combination of one option per contact is solved
/// as an intensity QP and the combination with the smallest residual wins. Returns the
/// chosen option per contact, with its QP. More than `max_combinations` combinations: coordinate descent
/// from the first options instead. Combinations in `excluded` (one option index per
/// contact, e.g. ones whose estimate failed) are never chosen; an error if nothing else is
/// left.
#[allow(clippy::too_many_arguments)]
pub fn choose_locations(
    model: &Model,
    registrar: &Registrar,
    features: &[SurfaceFeature],
    options: &[Vec<Vec<Candidate>>],
    at: LinearisationPoint<'_>,
    params: &FrameParams,
    max_combinations: usize,
    excluded: &[Vec<usize>],
) -> InverseResult<LocationChoice> {
    let every_excluded =
        || InverseError::Intensity("every combination of location options was excluded".into());
    if options.iter().any(|o| o.is_empty()) {
        return Err(InverseError::Intensity(
            "a contact has no location option".into(),
        ));
    }
    let base = model.problem.without_loads();
    // Columns of each option in the joint candidate list.
    let mut all = Vec::new();
    let mut cols: Vec<Vec<Vec<usize>>> = Vec::new();
    for group in options {
        let mut g = Vec::new();
        for opt in group {
            g.push((all.len()..all.len() + opt.len()).collect());
            all.extend_from_slice(opt);
        }
        cols.push(g);
    }
    let LinearisationPoint {
        positions: at,
        tensions,
        state,
    } = at;
    if tensions.len() != model.problem.cables.len() {
        return Err(InverseError::Intensity(format!(
            "{} cable tensions for {} cables",
            tensions.len(),
            model.problem.cables.len()
        )));
    }
    let mut solver = match state {
        Some(s) => base.solver_from(s)?,
        None => base.solver()?,
    };
    // The loop's linearisation: on the material tangent alone the choice ranked the
    // options by a poorer model of how the state moves under a load (indefinite at sensed
    // states, so the rotated fallback), and at the free state it then picked another node
    // than at the estimated state on 5 of 5 probe_side frames, each costing a second
    // estimate; on Newton's matrix, 2 of 5.
    let newton_tangent = model.newton.tangent;
    solver.assemble(at, newton_tangent)?;
    factorize_loop_tangent(&mut solver, at, tensions, newton_tangent)?;
    let (joint, _) = linearise(
        &solver,
        at,
        registrar,
        features,
        &all,
        params,
        &mut LoopTimings::default(),
    )?;
    let sub_problem = |choice: &[usize]| -> IntensityProblem {
        let idx: Vec<usize> = choice
            .iter()
            .zip(&cols)
            .flat_map(|(&c, g)| g[c].iter().copied())
            .collect();
        IntensityProblem {
            w_ef: joint.w_ef.select_columns(idx.iter()),
            w_af: joint.w_af.select_columns(idx.iter()),
            push_only: idx.iter().map(|&i| joint.push_only[i]).collect(),
            ..joint.clone()
        }
    };
    let residual = |choice: &[usize]| -> f64 {
        if excluded.iter().any(|e| e == choice) {
            return f64::INFINITY;
        }
        match sub_problem(choice).solve(&params.intensity) {
            Ok(e) if e.status.is_solution() => e.residual_rms,
            _ => f64::INFINITY,
        }
    };
    let total: usize = options
        .iter()
        .map(|o| o.len())
        .try_fold(1usize, |a, b| a.checked_mul(b))
        .unwrap_or(usize::MAX);
    let mut best = vec![0; options.len()];
    if total <= max_combinations {
        // Every combination (odometer order); the first smallest wins.
        let mut all = Vec::with_capacity(total);
        let mut choice = vec![0; options.len()];
        'odometer: loop {
            all.push(choice.clone());
            let mut k = 0;
            loop {
                if k == choice.len() {
                    break 'odometer;
                }
                choice[k] += 1;
                if choice[k] < options[k].len() {
                    break;
                }
                choice[k] = 0;
                k += 1;
            }
        }
        all.retain(|c| !excluded.contains(c));
        if all.is_empty() {
            return Err(every_excluded());
        }
        // Branch and bound: without its push-only bounds a combination's problem is a least
        // squares in closed form that never fits worse than its QP, so once a QP has fitted
        // better than a combination's bound (with a margin far above rounding), that
        // combination cannot win. The QPs run in order of their bounds, a batch at a time
        // in parallel, and stop at the first batch whose bounds all lose. The choice is the
        // exhaustive search's: the smallest QP residual, the first in odometer order on a tie.
        // (With a regularization the QP's objective is not the residual: no bounds.)
        let bounds: Vec<f64> = if params.intensity.regularization > 0.0 {
            vec![0.0; all.len()]
        } else {
            par_map(&all, |c| {
                sub_problem(c)
                    .unbounded_residual_rms()
                    .filter(|b| b.is_finite())
                    .unwrap_or(0.0)
            })
        };
        let mut order: Vec<usize> = (0..all.len()).collect();
        order.sort_by(|&i, &j| bounds[i].total_cmp(&bounds[j]).then(i.cmp(&j)));
        let mut won = (f64::INFINITY, 0usize);
        for batch in order.chunks(PRUNE_BATCH) {
            let live: Vec<usize> = batch
                .iter()
                .copied()
                .filter(|&i| bounds[i] <= won.0 * (1.0 + PRUNE_MARGIN))
                .collect();
            if live.is_empty() {
                break;
            }
            let rs = par_map(&live, |&i| residual(&all[i]));
            for (i, r) in live.into_iter().zip(rs) {
                if r < won.0 || (r == won.0 && i < won.1) {
                    won = (r, i);
                }
            }
        }
        best = all.swap_remove(won.1);
    } else {
        // Coordinate descent from the first options.
        let mut best_r = residual(&best);
        for _sweep in 0..3 {
            let mut improved = false;
            for g in 0..options.len() {
                // The trials of group g differ from `best` in entry g only, whatever the loop
                // below has accepted so far: solve them together, accept in order.
                let trials: Vec<Vec<usize>> = (0..options[g].len())
                    .map(|c| {
                        let mut trial = best.clone();
                        trial[g] = c;
                        trial
                    })
                    .collect();
                let rs = par_map(&trials, |t| residual(t));
                for (trial, r) in trials.into_iter().zip(rs) {
                    if r < best_r {
                        best_r = r;
                        best = trial;
                        improved = true;
                    }
                }
            }
            if !improved {
                break;
            }
        }
        if excluded.contains(&best) {
            return Err(every_excluded());
        }
    }
    // The winner's QP, solved once more to keep it.
    let problem = sub_problem(&best);
    let estimate = problem.solve(&params.intensity)?;
    if !estimate.status.is_solution() {
        return Err(InverseError::NotSolved(estimate.status));
    }
    Ok(LocationChoice {
        pick: best,
        problem,
        estimate,
    })
}

/// What [`choose_locations`] chose.
#[derive(Clone, Debug)]
pub struct LocationChoice {
    /// The chosen option per contact.
    pub pick: Vec<usize>,
    /// Its intensity problem at the linearisation point (the candidates of the chosen
    /// options, in contact order).
    pub problem: IntensityProblem,
    /// Its QP's solution there: the forces a sensing loop started at that point would get
    /// from its first FE update ([`estimate_after_choice`]).
    pub estimate: IntensityEstimate,
}

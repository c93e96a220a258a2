//! The sensing loop's linearisation: the tangent the loop factorizes at an equilibrium, and
//! the intensity problem of the candidate forces ([`Candidate`]) linearised there.

use super::candidate::Candidate;
use super::intensity::{ActuatorInput, IntensityProblem};
use super::sensing::{ms_since, FrameInputs, LoopTimings};
use super::{InverseError, InverseResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::solve::{CableControl, CavityControl, Solver, SolverState};
use crate::fem::tet4::Tangent;
use crate::register::FeatureMatches;

/// Where [`choose_locations`](super::choose_locations) linearises.
#[derive(Debug)]
pub struct LinearisationPoint<'a> {
    /// Node positions of an equilibrium of the model (m): its free equilibrium, or one under
    /// a previous estimate's loads (point loads do not enter the tangent).
    pub positions: &'a [[f64; 3]],
    /// The cable tensions of that equilibrium (N, one per cable): the choice linearises on
    /// Newton's own matrix there, the material tangent plus the cables' geometric stiffness
    /// under these tensions, as the sensing loop does ([`estimate`](super::estimate)).
    pub tensions: &'a [f64],
    /// A solver state of the same model whose elements were evaluated at `positions` (e.g.
    /// [`FrameEstimate::solver`](super::FrameEstimate::solver)) saves evaluating them, and one that holds the choice's
    /// very tangent factorized (bit for bit; e.g. an estimate's, which ends factorized
    /// there) saves factorizing it; any other state only costs that reuse, never the
    /// choice. `None`: both are done.
    pub state: Option<SolverState>,
}

/// Factorizes the sensing loop's linearisation at `x`, an equilibrium the solver's Newton
/// solve (with `tangent`) just reached: the material tangent of its last assembly plus the
/// cables' geometric stiffness under `tensions` (see [`estimate`](super::estimate)).
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

/// The features' rows at node positions `x`: each matched feature along its normal, its
/// measured value the row's plus the match's offset; and the matches they came from.
fn feature_rows(
    inputs: &FrameInputs<'_>,
    x: &[[f64; 3]],
) -> InverseResult<(Vec<ConstraintRow>, Vec<f64>, FeatureMatches)> {
    let (registrar, features, params) = (inputs.registrar, inputs.features, inputs.params);
    let mut rows = Vec::new();
    let mut measured = Vec::new();
    let matches = registrar.match_features(features, x, &params.register);
    for (f, m) in matches.iter() {
        if let Some(m) = m {
            let row = ConstraintRow::along(RowKind::Effector, &f.mapped(), f.normal(x))?;
            measured.push(row.value(x) + m.offset);
            rows.push(row);
        }
    }
    Ok((rows, measured, matches))
}

/// The intensity problem linearised at node positions `x` (an equilibrium of the solver's
/// problem without its point loads, plus some candidate loads; the solver holds the tangent
/// factorised at `x`): the frame's features registered at `x`, compliance of the feature,
/// actuator and candidate rows. Returns the problem, the number of visible features (or
/// dense rows) and the features' matches at `x` (none matched under dense rows).
pub(crate) fn linearise(
    solver: &Solver<'_>,
    x: &[[f64; 3]],
    inputs: &FrameInputs<'_>,
    candidates: &[Candidate],
    timings: &mut LoopTimings,
) -> InverseResult<(IntensityProblem, usize, FeatureMatches)> {
    let base = solver.problem;
    let rest = &base.mesh.nodes_in_rest;
    let clock = std::time::Instant::now();
    // Register at the current state.
    let (mut rows, measured, row_noise, matches) = match inputs.dense {
        Some(dense) => {
            let (rows, measured, noise) = super::dense::dense_rows(dense, x)?;
            (
                rows,
                measured,
                noise,
                FeatureMatches::unmatched(inputs.features),
            )
        }
        None => {
            let (rows, measured, matches) = feature_rows(inputs, x)?;
            (rows, measured, Default::default(), matches)
        }
    };
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
    for c in &base.cavities {
        let row = ConstraintRow::cavity(c, x);
        inputs.push(match c.control {
            CavityControl::Pressure(p) => ActuatorInput::Force(p),
            // Target in row units, as a cable's: value(x) + (ΔV_target − ΔV(x)).
            CavityControl::Volume(v) => {
                ActuatorInput::Displacement(row.value(x) + v - c.volume_change(x))
            }
        });
        rows.push(row);
    }
    let na = base.cables.len() + base.cavities.len();
    for c in candidates {
        rows.push(c.row()?);
    }
    let nf = candidates.len();
    // Loads enter only as candidate rows: the free residual has the body forces alone.
    let mut full = solver.body_forces();
    for (f, fi) in full.iter_mut().zip(&solver.internal_force) {
        *f -= fi;
    }
    let r = solver.dofs.gather(&full);
    // W_ee is not used: only the columns of the actuator and force rows.
    let (cols, delta_free) = solver.compliance_columns(&rows, x, &r, ne)?;
    timings.compliance += ms_since(clock);
    let block = |r0: usize, nr: usize, c0: usize, nc: usize| {
        cols.view((r0, c0 - ne), (nr, nc)).clone_owned()
    };
    let prob = IntensityProblem {
        w_ea: block(0, ne, ne, na),
        w_ef: block(0, ne, ne + na, nf),
        delta_free_e: delta_free[..ne].to_vec(),
        delta_measured: measured,
        w_aa: block(ne, na, ne, na),
        w_af: block(ne, na, ne + na, nf),
        delta_free_a: delta_free[ne..ne + na].to_vec(),
        actuators: inputs,
        push_only: candidates.iter().map(|c| c.push_only).collect(),
        row_noise,
    };
    if ne == 0 {
        return Err(InverseError::NoVisibleRows);
    }
    Ok((prob, visible, matches))
}

//! Location mapping by the data ([`choose_locations`]): for each seen contact a few options
//! (surface nodes near it), and the combination whose intensity QP fits the frame best.

use super::candidate::Candidate;
use super::intensity::{IntensityEstimate, IntensityProblem};
use super::linearise::{factorize_loop_tangent, linearise, LinearisationPoint};
use super::sensing::{FrameInputs, FrameParams, LoopTimings};
use super::{par_map, InverseError, InverseResult};

/// Combinations whose QPs [`choose_locations`] solves at a time (in parallel), in order of
/// their lower bounds: usually the first is the winner and prunes the rest. Fixed, so the
/// work done does not depend on the thread count (the choice never does).
const PRUNE_BATCH: usize = 2;

/// Relative margin by which a lower bound must exceed the best QP residual before its
/// combination is skipped: far above the rounding of either.
const PRUNE_MARGIN: f64 = 1e-6;

/// What [`choose_locations`] chose.
#[derive(Clone, Debug)]
pub struct LocationChoice {
    /// The chosen option per contact.
    pub pick: Vec<usize>,
    /// Its intensity problem at the linearisation point (the candidates of the chosen
    /// options, in contact order).
    pub problem: IntensityProblem,
    /// Its QP's solution there: the forces a sensing loop started at that point would get
    /// from its first FE update ([`Start::AfterChoice`](super::Start::AfterChoice)).
    pub estimate: IntensityEstimate,
    /// Every option's intensity problem, linearised together.
    joint: IntensityProblem,
    /// Columns of each option in `joint`, per contact.
    cols: Vec<Vec<Vec<usize>>>,
    /// The combinations that were never to be chosen.
    excluded: Vec<Vec<usize>>,
}

impl LocationChoice {
    /// Per contact, the other options that fit nearly as well: the chosen combination with
    /// that contact's option swapped, when its misfit ([`Alternative::misfit`]) is at most
    /// `window`, best first. Solves the QPs of those that may be (`params.intensity`).
    pub fn alternatives(&self, params: &FrameParams, window: f64) -> Vec<Vec<Alternative>> {
        let combinations = Combinations {
            joint: &self.joint,
            cols: &self.cols,
            excluded: &self.excluded,
            params,
        };
        combinations.alternatives(&self.pick, &self.problem, &self.estimate, window)
    }
}

/// A location a contact could have instead of the chosen one, and the fit it gives.
#[derive(Clone, Debug)]
pub struct Alternative {
    /// The option (an index into the contact's options).
    pub option: usize,
    /// How much worse it fits, in units of the rows' noise variance: (RSS − RSS₀) / s²,
    /// with RSS the QP's residual sum of squares, RSS₀ the chosen one's and s² = RSS₀ /
    /// (rows − unknowns) the noise the chosen fit leaves. With Gaussian rows the fit
    /// difference of two equally good locations of k force unknowns is about χ²_k.
    pub misfit: f64,
    /// The intensities of this option's candidates in that QP (N).
    pub forces: Vec<f64>,
}

/// Location mapping by the data: for each seen contact, a list of options (each option the
/// candidate forces of one location, e.g. three directions at one surface node). Linearised
/// once at the equilibrium `at` (on Newton's matrix, as the sensing loop: see
/// [`LinearisationPoint::tensions`]), with the compliance of every option's rows in one
/// computation; every combination of one option per contact is solved as an intensity QP
/// and the combination with the smallest residual wins. Returns the chosen option per
/// contact, with its QP. More than `max_combinations` combinations: coordinate descent from
/// the first options instead. Combinations in `excluded` (one option index per contact,
/// e.g. ones whose estimate failed) are never chosen; an error if nothing else is left.
/// `inputs.candidates` are not used.
pub fn choose_locations(
    inputs: &FrameInputs<'_>,
    options: &[Vec<Vec<Candidate>>],
    at: LinearisationPoint<'_>,
    max_combinations: usize,
    excluded: &[Vec<usize>],
) -> InverseResult<LocationChoice> {
    if let Some(contact) = options.iter().position(|o| o.is_empty()) {
        return Err(InverseError::NoLocationOption { contact });
    }
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
    let joint = joint_problem(inputs, &all, at)?;
    let combinations = Combinations {
        joint: &joint,
        cols: &cols,
        excluded,
        params: inputs.params,
    };
    let sizes: Vec<usize> = options.iter().map(|o| o.len()).collect();
    let total: usize = sizes
        .iter()
        .copied()
        .try_fold(1usize, |a, b| a.checked_mul(b))
        .unwrap_or(usize::MAX);
    let best = if total <= max_combinations {
        combinations.exhaustive(&sizes, total)?
    } else {
        combinations.descent(&sizes)?
    };
    // The winner's QP, solved once more to keep it.
    let problem = combinations.sub_problem(&best);
    let estimate = problem.solve(&inputs.params.intensity)?;
    if !estimate.status.is_solution() {
        return Err(InverseError::NotSolved(estimate.status));
    }
    Ok(LocationChoice {
        pick: best,
        problem,
        estimate,
        joint,
        cols,
        excluded: excluded.to_vec(),
    })
}

/// The intensity problem of every option's candidates `all` at once, linearised at `at`.
fn joint_problem(
    inputs: &FrameInputs<'_>,
    all: &[Candidate],
    at: LinearisationPoint<'_>,
) -> InverseResult<IntensityProblem> {
    let model = inputs.model;
    let base = model.problem.without_loads();
    let LinearisationPoint {
        positions: at,
        tensions,
        state,
    } = at;
    let actuators = model.problem.cables.len() + model.problem.cavities.len();
    if tensions.len() != actuators {
        return Err(InverseError::CableTensions {
            tensions: tensions.len(),
            cables: actuators,
        });
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
    let (joint, ..) = linearise(&solver, at, inputs, all, &mut LoopTimings::default())?;
    Ok(joint)
}

fn every_excluded() -> InverseError {
    InverseError::AllLocationsExcluded
}

/// The combinations of one option per contact, as sub-problems of the joint one.
struct Combinations<'a> {
    /// Every option's candidates, linearised together.
    joint: &'a IntensityProblem,
    /// Columns of each option in `joint`, per contact.
    cols: &'a [Vec<Vec<usize>>],
    /// Combinations never chosen.
    excluded: &'a [Vec<usize>],
    params: &'a FrameParams,
}

impl Combinations<'_> {
    /// The intensity problem of one option per contact (`choice`).
    fn sub_problem(&self, choice: &[usize]) -> IntensityProblem {
        let joint = self.joint;
        let idx: Vec<usize> = choice
            .iter()
            .zip(self.cols)
            .flat_map(|(&c, g)| g[c].iter().copied())
            .collect();
        // Field by field: `..joint.clone()` would copy the joint candidate columns, every
        // option's (thousands of dense rows each), only to drop them.
        IntensityProblem {
            w_ea: joint.w_ea.clone(),
            w_ef: joint.w_ef.select_columns(idx.iter()),
            delta_free_e: joint.delta_free_e.clone(),
            delta_measured: joint.delta_measured.clone(),
            w_aa: joint.w_aa.clone(),
            w_af: joint.w_af.select_columns(idx.iter()),
            delta_free_a: joint.delta_free_a.clone(),
            actuators: joint.actuators.clone(),
            push_only: idx.iter().map(|&i| joint.push_only[i]).collect(),
            row_noise: joint.row_noise.clone(),
        }
    }

    /// Per contact, the options whose misfit is within `window` when swapped into the
    /// winner `best` alone (its `problem`, solved as `estimate`), best first. Only QPs whose
    /// closed-form bound is inside the window are solved: most options are far outside it.
    fn alternatives(
        &self,
        best: &[usize],
        problem: &IntensityProblem,
        estimate: &IntensityEstimate,
        window: f64,
    ) -> Vec<Vec<Alternative>> {
        let rows = problem.w_ef.nrows();
        let unknowns = problem.w_ef.ncols() + problem.w_ea.ncols();
        let rss0 = estimate.residual_rms.powi(2) * rows as f64;
        // The noise variance the chosen fit leaves, per row.
        let s2 = rss0 / rows.saturating_sub(unknowns).max(1) as f64;
        let misfit = |rms: f64| (rms * rms * rows as f64 - rss0) / s2;
        if !(s2 > 0.0 && s2.is_finite()) {
            return vec![Vec::new(); self.cols.len()];
        }
        let mut trials = Vec::new();
        for (k, group) in self.cols.iter().enumerate() {
            for o in (0..group.len()).filter(|&o| o != best[k]) {
                let mut t = best.to_vec();
                t[k] = o;
                if !self.excluded.contains(&t) {
                    trials.push((k, t));
                }
            }
        }
        let fits = par_map(&trials, |(k, t)| {
            let problem = self.sub_problem(t);
            let bound = problem.unbounded_residual_rms().unwrap_or(0.0);
            if misfit(bound) > window {
                return None;
            }
            let e = problem.solve(&self.params.intensity).ok()?;
            if !e.status.is_solution() || misfit(e.residual_rms) > window {
                return None;
            }
            // This contact's columns in the trial's problem.
            let start: usize = (0..*k).map(|j| self.cols[j][t[j]].len()).sum();
            let len = self.cols[*k][t[*k]].len();
            Some(Alternative {
                option: t[*k],
                misfit: misfit(e.residual_rms).max(0.0),
                forces: e.forces[start..start + len].to_vec(),
            })
        });
        let mut out = vec![Vec::new(); self.cols.len()];
        for ((k, _), fit) in trials.iter().zip(fits) {
            if let Some(a) = fit {
                out[*k].push(a);
            }
        }
        for group in &mut out {
            group.sort_by(|a, b| a.misfit.total_cmp(&b.misfit));
        }
        out
    }

    /// The QP residual of `choice` (infinite when excluded or not solved).
    fn residual(&self, choice: &[usize]) -> f64 {
        if self.excluded.iter().any(|e| e == choice) {
            return f64::INFINITY;
        }
        match self.sub_problem(choice).solve(&self.params.intensity) {
            Ok(e) if e.status.is_solution() => e.residual_rms,
            _ => f64::INFINITY,
        }
    }

    /// The best of every combination (`total` of them, contact k having `sizes[k]` options).
    fn exhaustive(&self, sizes: &[usize], total: usize) -> InverseResult<Vec<usize>> {
        // Every combination (odometer order); the first smallest wins.
        let mut all = Vec::with_capacity(total);
        let mut choice = vec![0; sizes.len()];
        'odometer: loop {
            all.push(choice.clone());
            let mut k = 0;
            loop {
                if k == choice.len() {
                    break 'odometer;
                }
                choice[k] += 1;
                if choice[k] < sizes[k] {
                    break;
                }
                choice[k] = 0;
                k += 1;
            }
        }
        all.retain(|c| !self.excluded.contains(c));
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
        let bounds: Vec<f64> = if self.params.intensity.regularization > 0.0 {
            vec![0.0; all.len()]
        } else {
            par_map(&all, |c| {
                self.sub_problem(c)
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
            let rs = par_map(&live, |&i| self.residual(&all[i]));
            for (i, r) in live.into_iter().zip(rs) {
                if r < won.0 || (r == won.0 && i < won.1) {
                    won = (r, i);
                }
            }
        }
        Ok(all.swap_remove(won.1))
    }

    /// Coordinate descent from the first options (contact k having `sizes[k]` options).
    fn descent(&self, sizes: &[usize]) -> InverseResult<Vec<usize>> {
        let mut best = vec![0; sizes.len()];
        let mut best_r = self.residual(&best);
        for _sweep in 0..3 {
            let mut improved = false;
            for (g, &size) in sizes.iter().enumerate() {
                // The trials of group g differ from `best` in entry g only, whatever the loop
                // below has accepted so far: solve them together, accept in order.
                let trials: Vec<Vec<usize>> = (0..size)
                    .map(|c| {
                        let mut trial = best.clone();
                        trial[g] = c;
                        trial
                    })
                    .collect();
                let rs = par_map(&trials, |t| self.residual(t));
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
        if self.excluded.contains(&best) {
            return Err(every_excluded());
        }
        Ok(best)
    }
}

#[cfg(test)]
mod tests {
    use super::{Combinations, IntensityProblem};
    use crate::inverse::sensing::FrameParams;
    use nalgebra::DMatrix;

    /// A joint problem of two contacts with three options each (one push-only column per
    /// option, no actuators): rows of a smooth response, and data made by option 1 of
    /// contact 0 and option 2 of contact 1, plus a deterministic ripple for noise.
    fn joint() -> IntensityProblem {
        let m = 40;
        let centres = [0.2, 0.3, 0.45, 0.6, 0.7, 0.85];
        let w_ef = DMatrix::from_fn(m, 6, |i, j| {
            let t = i as f64 / m as f64 - centres[j];
            1e-3 * (-t * t / 0.02).exp()
        });
        let truth = [0.0, 0.5, 0.0, 0.0, 0.0, 0.8];
        let measured: Vec<f64> = (0..m)
            .map(|i| {
                let clean: f64 = (0..6).map(|j| w_ef[(i, j)] * truth[j]).sum();
                clean + 2e-6 * ((i * 7 % 11) as f64 - 5.0)
            })
            .collect();
        IntensityProblem {
            w_ea: DMatrix::zeros(m, 0),
            w_ef,
            delta_free_e: vec![0.0; m],
            delta_measured: measured,
            w_aa: DMatrix::zeros(0, 0),
            w_af: DMatrix::zeros(0, 6),
            delta_free_a: Vec::new(),
            actuators: Vec::new(),
            push_only: vec![true; 6],
            row_noise: Default::default(),
        }
    }

    #[test]
    fn each_alternatives_misfit_is_its_own_qps_loss_of_fit_over_the_noise_left() {
        let params = FrameParams::default();
        let excluded: Vec<Vec<usize>> = Vec::new();
        let joint = joint();
        let cols = vec![
            vec![vec![0], vec![1], vec![2]],
            vec![vec![3], vec![4], vec![5]],
        ];
        let combinations = Combinations {
            joint: &joint,
            cols: &cols,
            excluded: &excluded,
            params: &params,
        };
        let best = combinations.exhaustive(&[3, 3], 9).unwrap();
        assert_eq!(best, vec![1, 2]);
        let problem = combinations.sub_problem(&best);
        let estimate = problem.solve(&params.intensity).unwrap();
        let alternatives = combinations.alternatives(&best, &problem, &estimate, f64::INFINITY);
        // Brute force: every single swap solved on its own.
        let (m, n) = (40.0, 2.0);
        let rss0 = estimate.residual_rms.powi(2) * m;
        let s2 = rss0 / (m - n);
        for (k, alts) in alternatives.iter().enumerate() {
            assert_eq!(
                alts.len(),
                2,
                "contact {k}: every other option with no window"
            );
            for pair in alts.windows(2) {
                assert!(pair[0].misfit <= pair[1].misfit, "best first");
            }
            for a in alts {
                let mut swap = best.clone();
                swap[k] = a.option;
                let e = combinations
                    .sub_problem(&swap)
                    .solve(&params.intensity)
                    .unwrap();
                let misfit = (e.residual_rms.powi(2) * m - rss0) / s2;
                assert!((a.misfit - misfit).abs() <= 1e-6 * misfit.abs().max(1.0));
                assert!(a.misfit > 0.0, "the winner fits best");
                assert_eq!(a.forces.len(), 1);
            }
        }
        // A window keeps exactly those within it.
        let cut = alternatives[0][0].misfit;
        let within = combinations.alternatives(&best, &problem, &estimate, cut * (1.0 + 1e-9));
        assert_eq!(within[0].len(), 1);
        assert!(within[1].iter().all(|a| a.misfit <= cut * (1.0 + 1e-9)));
    }
}

//! The model selection: which candidate effects explain the residual. Forward steps add
//! the best candidate by BIC on training frames, confirmed on held-out frames; prunes drop
//! effects a later one made redundant; swaps replace a kept effect; pairs restart the path
//! from two effects fitted jointly.

use super::explanation::{CandidateScore, RegionStats, Residual, Step};
use super::fit::add_increments;
use super::workflow::{Kept, Workflow};
use super::DiscrepancyResult;
use nalgebra::DMatrix;

/// The best refined trial so far: its BIC, effects and covariance.
pub(super) type Best = Option<(f64, Kept, DMatrix<f64>)>;
/// A candidate of a step: what it adds, its score and its linear-fit increments.
type Scored<T> = (T, CandidateScore, Vec<f64>);

/// The effects kept so far with their covariance and the residuals of all frames.
pub(super) struct State {
    pub(super) kept: Kept,
    pub(super) cov: DMatrix<f64>,
    pub(super) res: Vec<Vec<Residual>>,
}

/// The model selection: BIC on training frames, confirmation on held-out frames.
pub(super) struct Search<'w, 'a> {
    pub(super) wf: &'w Workflow<'a>,
    pub(super) train: &'w [usize],
    pub(super) hold: &'w [usize],
    /// ln of the number of training rows (the BIC's penalty per parameter).
    pub(super) ln_n: f64,
}

/// Regions above the significance threshold `z`, most significant first (the last entry
/// of `stats`, all regions, left out).
pub(super) fn significant(stats: &[RegionStats], z: f64) -> Vec<String> {
    let mut v: Vec<&RegionStats> = stats[..stats.len().saturating_sub(1)]
        .iter()
        .filter(|s| s.n > 0 && s.z > z)
        .collect();
    v.sort_by(|a, b| b.z.total_cmp(&a.z));
    v.into_iter().map(|s| s.region.clone()).collect()
}

impl Search<'_, '_> {
    /// The selected effects from no effect (`res0`: residuals of all frames without one):
    /// the forward path, then, when it ends above the noise floor or with more than two
    /// effects, a restart from the best pair if that does better. Every step goes to
    /// `steps`.
    pub(super) fn select(
        &self,
        res0: &[Vec<Residual>],
        steps: &mut Vec<Step>,
    ) -> DiscrepancyResult<State> {
        let mut state = State {
            kept: Vec::new(),
            cov: DMatrix::<f64>::zeros(0, 0),
            res: res0.to_vec(),
        };
        if !self.at_floor(res0) {
            state = self.greedy(state, steps)?;
            // Two effects at once can defeat the forward path (its first pick fits
            // neither); more than two effects is a sign that it pieced the answer together.
            let params = self.wf.params;
            if params.pair_candidates > 0 && (state.kept.len() > 2 || !self.at_floor(&state.res)) {
                let (step, accepted) = self.try_pairs(&state, res0)?;
                steps.push(step);
                if let Some(next) = accepted {
                    state = self.greedy(next, steps)?;
                }
            }
        }
        Ok(state)
    }

    /// Penalised parameters of a set of effects (a load's location counts as one more).
    pub(super) fn k_of(&self, kept: &[(usize, Vec<f64>)]) -> usize {
        kept.iter()
            .map(|(c, p)| p.len() + self.wf.kinds[*c].choice_params())
            .sum()
    }

    /// BIC = χ² + k ln n of a set of effects.
    pub(super) fn bic(&self, chi2: f64, kept: &[(usize, Vec<f64>)]) -> f64 {
        chi2 + self.k_of(kept) as f64 * self.ln_n
    }

    /// A step not yet decided: its candidates and the state's held-out χ².
    pub(super) fn step(
        &self,
        action: String,
        bic_current: f64,
        candidates: impl IntoIterator<Item = CandidateScore>,
        state: &State,
    ) -> Step {
        Step {
            action,
            bic_current,
            candidates: candidates.into_iter().collect(),
            holdout_chi2: [self.wf.chi2(&state.res, self.hold).0, f64::NAN],
            accepted: false,
        }
    }

    /// The state with `trial` (residuals of all frames, covariance scaled by the
    /// training χ² per degree of freedom when above 1).
    pub(super) fn state_of(&self, trial: Kept, cov: DMatrix<f64>) -> DiscrepancyResult<State> {
        let res = self.wf.all_residuals(&self.wf.effects_of(&trial))?;
        let (chi_t, n_t) = self.wf.chi2(&res, self.train);
        let scale = (chi_t / (n_t.saturating_sub(cov.nrows()).max(1)) as f64).max(1.0);
        Ok(State {
            kept: trial,
            cov: cov * scale,
            res,
        })
    }

    /// Whether the residuals of all frames are at the noise floor (no significant region,
    /// overall z below the threshold).
    pub(super) fn at_floor(&self, res: &[Vec<Residual>]) -> bool {
        let all: Vec<usize> = (0..self.wf.frames.len()).collect();
        let s = self.wf.stats(res, &all);
        let z = self.wf.params.z_significant;
        significant(&s, z).is_empty() && s.last().is_some_and(|a| a.z <= z)
    }

    /// Forward selection then swaps from `state`. Forward: add the best candidate
    /// (refitted jointly with the kept ones) while it lowers the BIC and the held-out χ²;
    /// after each addition drop kept effects the new one made redundant (a wrong first
    /// pick that absorbed part of two effects). Swap: replace a kept effect by another
    /// candidate when that lowers the BIC (the forward order can lock in an effect that
    /// only mimics the missing one).
    pub(super) fn greedy(
        &self,
        mut state: State,
        steps: &mut Vec<Step>,
    ) -> DiscrepancyResult<State> {
        let max = self.wf.params.max_effects;
        while state.kept.len() < max && !self.at_floor(&state.res) {
            let (step, accepted) = self.try_add(&state, None)?;
            steps.push(step);
            let Some(next) = accepted else { break };
            state = next;
            self.prune(&mut state, steps)?;
        }
        let mut rounds = 0;
        while state.kept.len() >= 2 && rounds < max {
            rounds += 1;
            let mut swapped = false;
            for j in 0..state.kept.len() {
                let (step, accepted) = self.try_add(&state, Some(j))?;
                steps.push(step);
                if let Some(next) = accepted {
                    state = next;
                    self.prune(&mut state, steps)?;
                    swapped = true;
                    break;
                }
            }
            if !swapped {
                break;
            }
        }
        Ok(state)
    }

    /// Drops kept effects whose removal (the others refitted) lowers the BIC without
    /// raising the held-out χ² by more than the holdout gain.
    fn prune(&self, state: &mut State, steps: &mut Vec<Step>) -> DiscrepancyResult<()> {
        let wf = self.wf;
        while state.kept.len() >= 2 {
            let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
            let mut scores = Vec::new();
            let mut best: Best = None;
            for j in 0..state.kept.len() {
                let mut trial = state.kept.clone();
                let (c, _) = trial.remove(j);
                let Ok((chi2, cov)) = self.refine(&mut trial) else {
                    continue;
                };
                let bic = self.bic(chi2, &trial);
                scores.push(CandidateScore {
                    name: format!("without {}", wf.kinds[c].name()),
                    k: self.k_of(&trial),
                    chi2,
                    bic,
                    refined: true,
                });
                if best.as_ref().is_none_or(|b| bic < b.0) {
                    best = Some((bic, trial, cov));
                }
            }
            scores.sort_by(|a, b| a.bic.total_cmp(&b.bic));
            let mut step = self.step("drop".into(), bic_current, scores, state);
            let Some((_, trial, cov)) = best.filter(|b| b.0 < bic_current) else {
                steps.push(step);
                return Ok(());
            };
            let Ok(next) = self.state_of(trial, cov) else {
                steps.push(step);
                return Ok(());
            };
            let (h_new, accepted) = self.holdout_tolerates(state, &next.res);
            step.holdout_chi2[1] = h_new;
            step.accepted = accepted;
            steps.push(step);
            if !accepted {
                return Ok(());
            }
            *state = next;
        }
        Ok(())
    }

    /// One step: add the best candidate to the kept effects (or, with `replace`, to the
    /// kept effects without that one: a swap), all refitted jointly. The linear fits rank
    /// the candidates; the best few are refined exactly and the choice is made on their
    /// exact χ². Returns the step and the new state when the step is accepted (BIC lower
    /// by the margin and held-out χ² lower).
    fn try_add(
        &self,
        state: &State,
        replace: Option<usize>,
    ) -> DiscrepancyResult<(Step, Option<State>)> {
        let wf = self.wf;
        let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
        let mut base = state.kept.clone();
        let (action, base_res) = match replace {
            None => ("add".to_string(), None),
            Some(j) => {
                let (c, _) = base.remove(j);
                // The others alone may not solve (they compensated the one taken out).
                let Ok(res) = wf.some_residuals(self.train, &wf.effects_of(&base)) else {
                    let step = self.step(
                        format!("swap out {}", wf.kinds[c].name()),
                        bic_current,
                        [],
                        state,
                    );
                    return Ok((step, None));
                };
                (format!("swap out {}", wf.kinds[c].name()), Some((c, res)))
            }
        };
        let res = base_res.as_ref().map_or(&state.res, |(_, r)| r);
        let removed = base_res.as_ref().map(|(c, _)| *c);
        let mut cands = self.linear_candidates(&base, res, removed);
        let best = self.refine_chosen(&base, &mut cands);
        cands.sort_by(|a, b| {
            b.1.refined
                .cmp(&a.1.refined)
                .then(a.1.bic.total_cmp(&b.1.bic))
        });
        let mut step = self.step(
            action,
            bic_current,
            cands.iter().map(|c| c.1.clone()),
            state,
        );
        let Some((best_bic, trial, cov)) = best else {
            return Ok((step, None));
        };
        if best_bic > bic_current - wf.params.bic_margin {
            return Ok((step, None));
        }
        // Effects the FE model cannot solve on the held-out frames are not confirmed.
        let Ok(next) = self.state_of(trial, cov) else {
            return Ok((step, None));
        };
        let (_, h_new, ok) = self.holdout_gain(state, &next.res);
        step.holdout_chi2[1] = h_new;
        step.accepted = ok;
        Ok((step, ok.then_some(next)))
    }

    /// Every candidate not in `base` (nor `removed`) fitted linearly with the effects of
    /// `base` on the residuals `res`, best BIC first.
    fn linear_candidates(
        &self,
        base: &Kept,
        res: &[Vec<Residual>],
        removed: Option<usize>,
    ) -> Vec<Scored<usize>> {
        let wf = self.wf;
        let mut cands: Vec<Scored<usize>> = Vec::new();
        for c in 0..wf.kinds.len() {
            if base.iter().any(|(k, _)| *k == c) || removed == Some(c) {
                continue;
            }
            let mut idx: Vec<usize> = base.iter().map(|(k, _)| *k).collect();
            idx.push(c);
            if let Some((theta, chi2, _, _)) = wf.fit(res, self.train, &idx, None) {
                let kind = wf.kinds[c];
                let k = self.k_of(base)
                    + kind.n_params(super::effects::actuator_count(&wf.model.problem))
                    + kind.choice_params();
                cands.push((
                    c,
                    CandidateScore {
                        name: wf.kinds[c].name(),
                        k,
                        chi2,
                        bic: chi2 + k as f64 * self.ln_n,
                        refined: false,
                    },
                    theta,
                ));
            }
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        cands
    }

    /// Refines exactly the best few candidates by the linear fit and the best of every
    /// effect type (each added to `base`), scoring them in place; returns the best.
    fn refine_chosen(&self, base: &Kept, cands: &mut [Scored<usize>]) -> Best {
        let wf = self.wf;
        // The best of every type too: the linearisation about the nominal solution can
        // rank a right effect low once a large kept effect has moved the robot, e.g.
        // cable offsets after +40 % weight.
        let mut seen = Vec::new();
        let chosen: Vec<bool> = cands
            .iter()
            .enumerate()
            .map(|(i, (c, _, _))| {
                let kind = std::mem::discriminant(&wf.kinds[*c]);
                let first = !seen.contains(&kind);
                if first {
                    seen.push(kind);
                }
                i < wf.params.refine_candidates || first
            })
            .collect();
        let mut best: Best = None;
        for ((c, score, theta), _) in cands.iter_mut().zip(&chosen).filter(|&(_, &ch)| ch) {
            let mut trial = base.clone();
            trial.push((
                *c,
                vec![0.0; wf.kinds[*c].n_params(super::effects::actuator_count(&wf.model.problem))],
            ));
            add_increments(&mut trial, theta);
            self.refine_scored(score, trial, &mut best);
        }
        best
    }

    /// Every pair of candidates fitted jointly from the nominal model (`res0`: residuals
    /// with no effect): the forward path can start from a wrong first pick when two
    /// effects combine (one effect alone fits neither). The linear fits rank the pairs; the
    /// best few are refined exactly. The best pair replaces the state when it has a lower
    /// BIC (by the margin unless it has fewer parameters) and, on held-out frames, a lower
    /// χ² (by the holdout gain; with fewer parameters: not higher by more than it).
    fn try_pairs(
        &self,
        state: &State,
        res0: &[Vec<Residual>],
    ) -> DiscrepancyResult<(Step, Option<State>)> {
        let wf = self.wf;
        let params = wf.params;
        let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
        let mut cands = self.pair_candidates(res0);
        let mut best: Best = None;
        for (trial, score, theta) in cands.iter_mut() {
            let mut trial = trial.clone();
            add_increments(&mut trial, theta);
            self.refine_scored(score, trial, &mut best);
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        let candidates = cands.iter().map(|c| c.1.clone());
        let mut step = self.step("pair".into(), bic_current, candidates, state);
        let Some((best_bic, trial, cov)) = best else {
            return Ok((step, None));
        };
        let simpler = self.k_of(&trial) < self.k_of(&state.kept);
        let margin = if simpler { 0.0 } else { params.bic_margin };
        if best_bic >= bic_current - margin {
            return Ok((step, None));
        }
        // Effects the FE model cannot solve on the held-out frames are not confirmed.
        let Ok(next) = self.state_of(trial, cov) else {
            return Ok((step, None));
        };
        let (h_new, ok) = if simpler {
            self.holdout_tolerates(state, &next.res)
        } else {
            let (_, h_new, ok) = self.holdout_gain(state, &next.res);
            (h_new, ok)
        };
        step.holdout_chi2[1] = h_new;
        step.accepted = ok;
        Ok((step, ok.then_some(next)))
    }

    /// The `pair_candidates` best pairs of candidates by their joint linear fit on `res0`.
    fn pair_candidates(&self, res0: &[Vec<Residual>]) -> Vec<Scored<Kept>> {
        let wf = self.wf;
        let nc = super::effects::actuator_count(&wf.model.problem);
        let mut cands: Vec<Scored<Kept>> = Vec::new();
        for a in 0..wf.kinds.len() {
            for b in a + 1..wf.kinds.len() {
                let Some((theta, chi2, _, _)) = wf.fit(res0, self.train, &[a, b], None) else {
                    continue;
                };
                let trial: Kept = [a, b]
                    .iter()
                    .map(|&c| (c, vec![0.0; wf.kinds[c].n_params(nc)]))
                    .collect();
                let k = self.k_of(&trial);
                let name = format!("{} + {}", wf.kinds[a].name(), wf.kinds[b].name());
                let score = CandidateScore {
                    name,
                    k,
                    chi2,
                    bic: chi2 + k as f64 * self.ln_n,
                    refined: false,
                };
                cands.push((trial, score, theta));
            }
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        cands.truncate(wf.params.pair_candidates);
        cands
    }
}

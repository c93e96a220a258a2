//! Fitting effect parameters: linear least squares on the sensitivity rows (Huber
//! reweighted), then chord iterations with exact FE re-solves.

use super::effects::EffectKind;
use super::explanation::{CandidateScore, Residual};
use super::frame::Sens;
use super::select::{Best, Search};
use super::workflow::{Kept, Workflow};
use super::DiscrepancyResult;
use nalgebra::{DMatrix, DVector};

/// A linear fit: parameter increments, plain χ² after, covariance, rows.
pub(super) type LinearFit = (Vec<f64>, f64, DMatrix<f64>, usize);

impl Workflow<'_> {
    /// Linear least squares over `frames` for the parameter increments of `kinds`
    /// (candidate indices), with Huber reweighting (threshold `params.huber` in units of
    /// σ) against rows the linearisation does not hold for (a face sliding past an edge):
    /// returns (increments, plain χ² after, covariance, rows).
    pub(super) fn fit(
        &self,
        res: &[Vec<Residual>],
        frames: &[usize],
        kinds: &[usize],
        over: Option<&[Sens]>,
    ) -> Option<LinearFit> {
        let (k, rows, ys) = self.design(res, frames, kinds, over);
        let n = ys.len();
        if n <= k || k == 0 {
            return None;
        }
        let mut w = vec![1.0; n];
        let mut out = None;
        let passes = if self.params.huber > 0.0 { 5 } else { 1 };
        for _ in 0..passes {
            let (theta, chi2, cov) = huber_pass(&rows, &ys, &mut w, k, self.params.huber)?;
            out = Some((theta, chi2, cov, n));
        }
        out
    }

    /// The normalised least-squares problem: parameters k, rows (row-major, k per
    /// residual, sensitivities over σ) and right-hand sides (residuals over σ). `over`
    /// replaces a frame's sensitivity rows per kept effect.
    fn design(
        &self,
        res: &[Vec<Residual>],
        frames: &[usize],
        kinds: &[usize],
        over: Option<&[Sens]>,
    ) -> (usize, Vec<f64>, Vec<f64>) {
        let k: usize = kinds
            .iter()
            .map(|&c| self.frames[0].sens[c].first().map_or(0, |r| r.len()))
            .sum();
        let mut rows: Vec<f64> = Vec::new();
        let mut ys: Vec<f64> = Vec::new();
        for &i in frames {
            for r in &res[i] {
                for (j, &c) in kinds.iter().enumerate() {
                    let s = over
                        .and_then(|o| o.get(i)?.get(j)?.as_ref())
                        .unwrap_or(&self.frames[i].sens[c]);
                    rows.extend(s[r.feature].iter().map(|v| v / r.sigma));
                }
                ys.push(r.r / r.sigma);
            }
        }
        (k, rows, ys)
    }
}

/// One weighted least-squares solve (weights `w`), then the plain χ² and the Huber
/// weights for the next pass (threshold `huber`): returns (increments, χ², covariance).
fn huber_pass(
    rows: &[f64],
    ys: &[f64],
    w: &mut [f64],
    k: usize,
    huber: f64,
) -> Option<(Vec<f64>, f64, DMatrix<f64>)> {
    let mut a = DMatrix::<f64>::zeros(k, k);
    let mut b = DVector::<f64>::zeros(k);
    for (j, (&y, &wj)) in ys.iter().zip(w.iter()).enumerate() {
        let row = &rows[j * k..(j + 1) * k];
        for p in 0..k {
            b[p] += wj * row[p] * y;
            for q in 0..k {
                a[(p, q)] += wj * row[p] * row[q];
            }
        }
    }
    // Scale for conditioning, then a tiny ridge.
    let d: Vec<f64> = (0..k).map(|p| a[(p, p)].max(1e-300).sqrt()).collect();
    let mut sa = a.clone();
    for p in 0..k {
        for q in 0..k {
            sa[(p, q)] /= d[p] * d[q];
        }
        sa[(p, p)] += 1e-10;
    }
    let inv = sa.try_inverse()?;
    let bs = DVector::from_fn(k, |p, _| b[p] / d[p]);
    let ts = &inv * &bs;
    let theta: Vec<f64> = (0..k).map(|p| ts[p] / d[p]).collect();
    let mut chi2 = 0.0;
    for (j, &y) in ys.iter().enumerate() {
        let row = &rows[j * k..(j + 1) * k];
        let e = y - row.iter().zip(&theta).map(|(a, t)| a * t).sum::<f64>();
        chi2 += e * e;
        let c = huber;
        w[j] = if c > 0.0 && e.abs() > c {
            c / e.abs()
        } else {
            1.0
        };
    }
    let cov = DMatrix::from_fn(k, k, |p, q| inv[(p, q)] / (d[p] * d[q]));
    Some((theta, chi2, cov))
}

/// Adds the increments `d` (in parameter order) to the effects' parameters.
pub(super) fn add_increments(effects: &mut [(usize, Vec<f64>)], d: &[f64]) {
    let mut o = 0;
    for (_, p) in effects.iter_mut() {
        for v in p.iter_mut() {
            *v += d.get(o).copied().unwrap_or(0.0);
            o += 1;
        }
    }
}

impl Search<'_, '_> {
    /// Chord iterations (fixed-Jacobian Gauss-Newton with exact FE re-solves and
    /// re-registration; point loads' rows re-linearised at every iterate) of all parameters
    /// of `trial` on the training frames, keeping the best iterate (a step can overshoot):
    /// returns its χ² and the covariance.
    pub(super) fn refine(&self, trial: &mut Kept) -> DiscrepancyResult<(f64, DMatrix<f64>)> {
        let wf = self.wf;
        let idx: Vec<usize> = trial.iter().map(|(k, _)| *k).collect();
        let mut res_t = wf.some_residuals(self.train, &wf.effects_of(trial))?;
        let mut cov = DMatrix::zeros(0, 0);
        let mut best_chi = wf.chi2(&res_t, self.train).0;
        for _ in 0..wf.params.refine_iterations {
            let over = self.load_sens_over(trial);
            let Some((d, _, cv, _)) = wf.fit(&res_t, self.train, &idx, over.as_deref()) else {
                break;
            };
            cov = cv;
            let Some((next, res_n, chi)) = self.chord_step(trial, &d, best_chi) else {
                break;
            };
            // Chord steps converge linearly: stop once they no longer pay (a strongly
            // nonlinear effect such as a Poisson ratio far below the nominal one needs
            // several; most candidates stop after one or two).
            let small = best_chi - chi < 2e-3 * best_chi;
            best_chi = chi;
            *trial = next;
            res_t = res_n;
            if small {
                break;
            }
        }
        Ok((best_chi, cov))
    }

    /// Point loads away from zero: their sensitivity rows at the current estimate on the
    /// training frames (None when there are none, or when a frame does not solve).
    fn load_sens_over(&self, trial: &Kept) -> Option<Vec<Sens>> {
        let wf = self.wf;
        let moved = trial.iter().any(|(c, p)| {
            matches!(wf.kinds[*c], EffectKind::PointLoad { .. }) && p.iter().any(|v| *v != 0.0)
        });
        if !moved {
            return None;
        }
        (0..wf.frames.len())
            .map(|i| {
                if self.train.contains(&i) {
                    wf.load_sens_at(i, trial)
                } else {
                    Ok(Vec::new())
                }
            })
            .collect::<DiscrepancyResult<_>>()
            .ok()
    }

    /// The chord step `d` from `trial`, halved up to twice when it does not lower the
    /// training χ² below `best_chi`: the new effects, their residuals and χ².
    fn chord_step(
        &self,
        trial: &Kept,
        d: &[f64],
        best_chi: f64,
    ) -> Option<(Kept, Vec<Vec<Residual>>, f64)> {
        let wf = self.wf;
        // A chord step can overshoot where the effect is strongly nonlinear (a large
        // load bending a leg): halve it before giving up. A step the FE model cannot
        // solve counts as an overshoot (the start solved).
        let mut scale = 1.0;
        for _ in 0..3 {
            let mut next = trial.clone();
            add_increments(&mut next, &d.iter().map(|v| v * scale).collect::<Vec<_>>());
            let res_n = match wf.some_residuals(self.train, &wf.effects_of(&next)) {
                Ok(r) => r,
                Err(_) => {
                    scale *= 0.5;
                    continue;
                }
            };
            let chi = wf.chi2(&res_n, self.train).0;
            if std::env::var_os("SOFTSENSE_DEBUG").is_some() {
                eprintln!("refine {next:?} scale {scale} chi2 {chi:.1}");
            }
            if chi < best_chi {
                return Some((next, res_n, chi));
            }
            scale *= 0.5;
        }
        None
    }

    /// Refines `trial` exactly, records its χ² and BIC in `score` and keeps it in `best`
    /// when its BIC is the lowest so far. A trial the FE model cannot solve (absurd
    /// parameters) is not a candidate: its score becomes infinite.
    pub(super) fn refine_scored(
        &self,
        score: &mut CandidateScore,
        mut trial: Kept,
        best: &mut Best,
    ) {
        score.refined = true;
        let Ok((chi2, cov)) = self.refine(&mut trial) else {
            score.chi2 = f64::INFINITY;
            score.bic = f64::INFINITY;
            return;
        };
        score.chi2 = chi2;
        score.bic = chi2 + score.k as f64 * self.ln_n;
        if best.as_ref().is_none_or(|b| score.bic < b.0) {
            *best = Some((score.bic, trial, cov));
        }
    }
}

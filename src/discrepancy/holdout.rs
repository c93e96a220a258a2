//! Held-out frames: the split, and the confirmation of a step on the frames it never saw.

use super::explanation::Residual;
use super::select::{Search, State};

/// Holdout frame indices: every k-th frame (k = round(1/fraction)), at least one, and at
/// least one training frame.
pub fn split_frames(n: usize, fraction: f64) -> [Vec<usize>; 2] {
    if n < 2 || fraction.is_nan() || fraction <= 0.0 {
        return [(0..n).collect(), Vec::new()];
    }
    let k = (1.0 / fraction.min(0.5)).round().max(2.0) as usize;
    let hold: Vec<usize> = (0..n).filter(|i| i % k == k - 1).collect();
    let hold = if hold.is_empty() { vec![n - 1] } else { hold };
    let train = (0..n).filter(|i| !hold.contains(i)).collect();
    [train, hold]
}

impl Search<'_, '_> {
    /// Whether the held-out χ² of `res` is lower than the state's by the required gain:
    /// (χ² of the state, χ² of `res`, whether it is).
    pub(super) fn holdout_gain(&self, state: &State, res: &[Vec<Residual>]) -> (f64, f64, bool) {
        let (h_cur, n_hold) = self.wf.chi2(&state.res, self.hold);
        let (h_new, _) = self.wf.chi2(res, self.hold);
        let ok =
            self.hold.is_empty() || h_cur - h_new > self.wf.params.holdout_gain * n_hold as f64;
        (h_cur, h_new, ok)
    }

    /// For a simpler set of effects: the held-out χ² of `res` and whether it is not higher
    /// than the state's by more than the holdout gain.
    pub(super) fn holdout_tolerates(&self, state: &State, res: &[Vec<Residual>]) -> (f64, bool) {
        let (h_cur, h_new, _) = self.holdout_gain(state, res);
        let (_, n_hold) = self.wf.chi2(&state.res, self.hold);
        let ok = h_new <= h_cur + self.wf.params.holdout_gain * n_hold as f64;
        (h_new, ok)
    }
}

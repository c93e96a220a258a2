//! Where a marker is expected in a new frame: its last accepted position moved by the
//! displacement its neighbours accepted in this frame show (issue 51 item 4, "markers that
//! survive large motion").
//!
//! A raw jump threshold (a marker more than 5 mm from its last position is hidden) hides
//! markers that only moved with the body under a large load. [`MotionTracker`] tests a
//! marker's new position against a prediction instead:
//!
//! - **Prediction.** Marker m was last accepted in step t_m at position l_m. Each marker j
//!   already accepted in the current step that was also accepted in step t_m shows the
//!   displacement d_j = p_j − q_j (q_j its position in step t_m). m is expected at
//!   l_m + Σ w_j d_j / Σ w_j over the [`NEIGHBOURS`] such markers nearest it (at q_j),
//!   w_j = 1 / |q_j − l_m|² (inverse-distance weighting). With no such neighbour yet, m is
//!   expected at l_m. Only the nearest few count: farther markers (near a fixed edge) move
//!   less than the ones around a loaded marker and would pull its prediction back.
//! - **Closest first.** Among the markers not yet accepted in this step, the (marker,
//!   position) pair nearest its prediction is accepted first, if within the threshold; then
//!   every prediction is updated with the new neighbour and the next pair is taken, until
//!   none is within the threshold. Markers with little motion (a fixed corner) seed the
//!   step; markers that move with the body follow their accepted neighbours; a position
//!   that is off the body's motion (a swapped or reflected marker) stays out.
//!
//! A marker never accepted has no prediction: it is accepted where it is first seen. When
//! every marker moves more than the threshold at once (a rigid jump of the whole body
//! between two frames), no marker seeds the step and all are refused, as with the raw rule.

use crate::math::{norm, sub};

/// Accepted neighbours a marker's prediction is made from: the nearest ones (4, the
/// neighbours of a marker in a grid).
pub const NEIGHBOURS: usize = 4;

/// A marker's accepted neighbours in this step, nearest first (distance at the marker's
/// last step, m; displacement since, m), at most [`NEIGHBOURS`].
type Near = Vec<(f64, [f64; 3])>;

/// The accepted positions of every marker, step by step, and the predictions made from
/// them (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct MotionTracker {
    /// Accepted position of each marker in each step (steps x markers; a short row has the
    /// later markers missing).
    history: Vec<Vec<Option<[f64; 3]>>>,
    /// The step in which each marker was last accepted.
    last: Vec<Option<usize>>,
}

impl MotionTracker {
    /// An empty tracker of `markers` markers, none seen yet.
    pub fn new(markers: usize) -> Self {
        Self {
            history: Vec::new(),
            last: vec![None; markers],
        }
    }

    /// Markers tracked so far.
    pub fn markers(&self) -> usize {
        self.last.len()
    }

    /// Adds a marker not seen yet; returns its index.
    pub fn add_marker(&mut self) -> usize {
        self.last.push(None);
        self.last.len() - 1
    }

    /// The position marker `m` was last accepted at, if ever.
    pub fn last_position(&self, m: usize) -> Option<[f64; 3]> {
        let t = self.last[m]?;
        self.history[t].get(m).copied().flatten()
    }

    fn at(&self, step: usize, m: usize) -> Option<[f64; 3]> {
        self.history[step].get(m).copied().flatten()
    }

    /// Matches one step's `points` to the markers: `candidates(m)` lists the points marker
    /// `m` may take (indices into `points`); a pair is accepted when the point is within
    /// `threshold` (m) of the marker's prediction, closest pairs first, each point and each
    /// marker at most once. Markers never accepted before are not matched here (they have
    /// no prediction). Returns each marker's point; the step is not recorded (see
    /// [`MotionTracker::record`]).
    pub fn match_step<I>(
        &self,
        points: &[[f64; 3]],
        candidates: impl Fn(usize) -> I,
        threshold: f64,
    ) -> Vec<Option<usize>>
    where
        I: IntoIterator<Item = usize>,
    {
        let n = self.markers();
        // Per marker: the nearest neighbours accepted so far in this step.
        let mut near: Vec<Near> = vec![Vec::new(); n];
        let mut assigned: Vec<Option<usize>> = vec![None; n];
        let mut used = vec![false; points.len()];
        loop {
            let mut best: Option<(f64, usize, usize)> = None;
            for m in 0..n {
                let Some(l) = self.last_position(m) else {
                    continue;
                };
                if assigned[m].is_some() {
                    continue;
                }
                let pred = predict(l, &near[m]);
                for j in candidates(m) {
                    if used[j] {
                        continue;
                    }
                    let d = norm(sub(points[j], pred));
                    if d <= threshold && best.is_none_or(|b| d < b.0) {
                        best = Some((d, m, j));
                    }
                }
            }
            let Some((_, m, j)) = best else { break };
            assigned[m] = Some(j);
            used[j] = true;
            self.add_neighbour(&mut near, &assigned, m, points[j]);
        }
        assigned
    }

    /// Adds marker `j`, accepted at `p` in this step, to the predictions of the markers
    /// not accepted yet.
    fn add_neighbour(&self, near: &mut [Near], assigned: &[Option<usize>], j: usize, p: [f64; 3]) {
        for (m, list) in near.iter_mut().enumerate() {
            if assigned[m].is_some() {
                continue;
            }
            let (Some(t), Some(l)) = (self.last[m], self.last_position(m)) else {
                continue;
            };
            let Some(q) = self.at(t, j) else { continue };
            let r = norm(sub(q, l)).max(1e-6);
            let at = list.partition_point(|e| e.0 <= r);
            if at < NEIGHBOURS {
                list.insert(at, (r, sub(p, q)));
                list.truncate(NEIGHBOURS);
            }
        }
    }

    /// Records one step's accepted positions (one per marker, `None` where not accepted).
    pub fn record(&mut self, accepted: &[Option<[f64; 3]>]) {
        let step = self.history.len();
        self.history.push(accepted.to_vec());
        for (m, p) in accepted.iter().enumerate() {
            if p.is_some() {
                self.last[m] = Some(step);
            }
        }
    }
}

/// `l` moved by the inverse-distance-weighted mean displacement of `near` (weights 1/r²);
/// `l` itself without neighbours.
fn predict(l: [f64; 3], near: &[(f64, [f64; 3])]) -> [f64; 3] {
    let (mut s, mut w) = ([0.0; 3], 0.0);
    for (r, d) in near {
        let wj = 1.0 / (r * r);
        (0..3).for_each(|k| s[k] += wj * d[k]);
        w += wj;
    }
    if w > 0.0 {
        [0, 1, 2].map(|k| l[k] + s[k] / w)
    } else {
        l
    }
}

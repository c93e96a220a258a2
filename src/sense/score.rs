//! Scoring `sense --json` output against `truth.json` (`softsense score`): how often loads
//! are located and within 5%, whether the sigma cover the errors, and which misses were
//! reported reliable with no warning (silent misses).
//!
//! Rules, stated once here and in `softsense score --help`:
//! - a true load is matched to the estimate `sense` matched it to (nearest location);
//!   it is *located* when that estimate lies within [`LOCATED`] of it;
//! - *within 5%*: located and |F_est − F_true| ≤ 5% of |F_true|;
//! - a frame is *flagged* when it was not sensed, is marked unreliable, or carries a
//!   warning;
//! - a *silent miss* is a load of an unflagged frame that is not located, or whose 3-D
//!   error exceeds max(5%, 2σ_e) with σ_e the one-sigma of the estimate's covariance
//!   along the error; and an estimate of an unflagged frame matched to no true load
//!   (a phantom);
//! - sigma coverage: the magnitude error against `sigma` (1, 2, 3 σ) and the squared
//!   Mahalanobis distance eᵀ C⁻¹ e of the 3-D error, over located loads;
//! - a frame `sense` took as its reference (`"reference": true`) reads near zero by
//!   construction and is not scored;
//! - an *unloaded* frame (truth with no load) is *above 2σ* when some estimate's magnitude
//!   exceeds twice its `sigma`; its estimates are phantoms as in any frame.

use super::{CameraState, FrameStatus, CHI2_3DOF_95};
use crate::math::median;
use serde::{Deserialize, Serialize};

/// Largest distance between an estimate and its true load for "located" (m).
pub const LOCATED: f64 = 0.005;
/// Largest relative 3-D force error for "within 5%".
pub const WITHIN: f64 = 0.05;

/// The part of one `sense --json` line the score reads.
#[derive(Clone, Debug, Deserialize)]
pub struct SensedFrame {
    /// Frame number.
    pub frame: usize,
    /// Sensed, or why not (`status`, and its `detail` where it has one).
    #[serde(flatten)]
    pub status: FrameStatus,
    /// Estimated forces.
    #[serde(default)]
    pub forces: Vec<SensedForce>,
    /// Whether the frame was marked reliable.
    #[serde(default)]
    pub reliable: bool,
    /// Warnings.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// Errors against the truth, as `sense` matched them.
    #[serde(default)]
    pub errors: Option<Vec<SensedError>>,
    /// Time of the frame (ms).
    #[serde(default)]
    pub ms: f64,
    /// One of the frames `sense` took as its reference (`--reference-frames`): not scored.
    #[serde(default)]
    pub reference: bool,
    /// Each camera's part, for a recording of several cameras (absent for one).
    #[serde(default)]
    pub cameras: Vec<SensedCamera>,
    /// The forces fused over the frames their load was held (`sense --hold`), one per
    /// force of the frame; empty without `--hold` or when the frame ended the hold.
    #[serde(default)]
    pub held: Vec<SensedHeld>,
}

/// One held force as `sense --json --hold` prints it.
#[derive(Clone, Debug, Deserialize)]
pub struct SensedHeld {
    /// Frames fused, this one included.
    pub frames: usize,
    /// The fused force, its magnitude sigma and covariance, as in [`SensedForce`].
    #[serde(flatten)]
    pub fused: SensedForce,
}

/// One camera's part in a frame as `sense --json` prints it.
#[derive(Clone, Debug, Deserialize)]
pub struct SensedCamera {
    /// Seen, missing or unreadable (`status`, and its counts or message).
    #[serde(flatten)]
    pub state: CameraState,
}

impl SensedFrame {
    /// How many cameras the frame was sensed from (1 for a one-camera recording).
    pub fn cameras_seen(&self) -> usize {
        match self.cameras.len() {
            0 => 1,
            _ => (self.cameras.iter())
                .filter(|c| matches!(c.state, CameraState::Seen { .. }))
                .count(),
        }
    }

    /// Whether the frame is flagged: not sensed, marked unreliable, or warned.
    pub fn flagged(&self) -> bool {
        self.status != FrameStatus::Sensed || !self.reliable || !self.warnings.is_empty()
    }
}

/// One estimated force as `sense --json` prints it.
#[derive(Clone, Debug, Deserialize)]
pub struct SensedForce {
    /// Force (N).
    pub force: [f64; 3],
    /// Magnitude sigma (N).
    pub sigma: f64,
    /// Covariance (N²).
    pub covariance: [[f64; 3]; 3],
}

/// One true load's error as `sense --json` prints it.
#[derive(Clone, Debug, Deserialize)]
pub struct SensedError {
    /// True force (N).
    pub truth_force: [f64; 3],
    /// Matched estimate.
    pub estimate: Option<usize>,
    /// Location error (m); null when unmatched.
    pub location_error: Option<f64>,
    /// Relative 3-D force error.
    pub force_error: f64,
}

/// One true load, scored.
#[derive(Clone, Debug, Serialize)]
pub struct LoadScore {
    /// Recording folder.
    pub recording: String,
    /// Frame.
    pub frame: usize,
    /// Loads in the frame.
    pub loads_in_frame: usize,
    /// True magnitude (N).
    pub magnitude: f64,
    /// Location error (m); `None` when no estimate.
    pub location_error: Option<f64>,
    /// Relative 3-D force error.
    pub force_error: f64,
    /// Magnitude error over its sigma.
    pub magnitude_z: Option<f64>,
    /// Squared Mahalanobis distance of the 3-D error.
    pub mahalanobis2: Option<f64>,
    /// The frame was flagged (not sensed, unreliable or warned).
    pub flagged: bool,
    /// Located within [`LOCATED`].
    pub located: bool,
    /// Located and within [`WITHIN`].
    pub within: bool,
    /// A silent miss (see the module rules).
    pub silent: bool,
}

/// A phantom: an estimate matched to no true load.
#[derive(Clone, Debug, Serialize)]
pub struct Phantom {
    /// Recording folder.
    pub recording: String,
    /// Frame.
    pub frame: usize,
    /// Its magnitude (N).
    pub magnitude: f64,
    /// The frame was flagged.
    pub flagged: bool,
}

/// Counts for a group of loads (all, or the frames with k loads).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Summary {
    /// Frames.
    pub frames: usize,
    /// Frames sensed.
    pub sensed: usize,
    /// Frames flagged.
    pub flagged_frames: usize,
    /// True loads.
    pub loads: usize,
    /// Located loads.
    pub located: usize,
    /// Loads within 5%.
    pub within: usize,
    /// Frames whose every load is located.
    pub frames_all_located: usize,
    /// Frames whose every load is within 5%.
    pub frames_all_within: usize,
    /// Silent misses (loads and phantoms).
    pub silent: usize,
    /// Phantom estimates.
    pub phantoms: usize,
    /// Share of located loads with a magnitude error within 1, 2, 3 sigma.
    pub sigma_coverage: [f64; 3],
    /// Median squared Mahalanobis distance (Gaussian, 3-D: 2.366).
    pub median_mahalanobis2: f64,
    /// Share of located loads inside the Gaussian 95% ellipsoid (χ²₃ ≤ [`CHI2_3DOF_95`]).
    pub within_ellipsoid95: f64,
    /// Median time per frame (ms).
    pub median_ms: f64,
    /// Frames whose truth has no load (reference frames left out); written out only when
    /// some.
    #[serde(skip_serializing_if = "is_zero")]
    pub unloaded_frames: usize,
    /// Unloaded frames with an estimate whose magnitude exceeds twice its sigma.
    #[serde(skip_serializing_if = "is_zero")]
    pub unloaded_above_2sigma: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Whether `f` has an estimate whose magnitude exceeds twice its sigma.
fn above_2sigma(f: &SensedFrame) -> bool {
    f.forces.iter().any(|g| {
        let m = g.force.iter().map(|c| c * c).sum::<f64>().sqrt();
        m > 2.0 * g.sigma
    })
}

/// Everything `score` prints.
#[derive(Clone, Debug, Serialize)]
pub struct Score {
    /// All loads.
    pub all: Summary,
    /// Per number of loads in the frame (1, 2, ...).
    pub by_loads: Vec<(usize, Summary)>,
    /// Every scored load.
    pub loads: Vec<LoadScore>,
    /// Every phantom.
    pub phantoms: Vec<Phantom>,
}

fn inverse3(m: &[[f64; 3]; 3]) -> Option<nalgebra::Matrix3<f64>> {
    nalgebra::Matrix3::from_fn(|i, j| m[i][j]).try_inverse()
}

/// Scores one frame: its loads and its phantoms. `frame_ms` is kept per load.
pub fn score_frame(recording: &str, f: &SensedFrame) -> (Vec<LoadScore>, Vec<Phantom>) {
    let flagged = f.flagged();
    let errors = f.errors.as_deref().unwrap_or(&[]);
    let loads = errors
        .iter()
        .map(|e| {
            let magnitude = e.truth_force.iter().map(|c| c * c).sum::<f64>().sqrt();
            let est = e.estimate.and_then(|i| f.forces.get(i));
            let location_error = est.and(e.location_error);
            let located = location_error.is_some_and(|d| d <= LOCATED);
            let mut s = LoadScore {
                recording: recording.to_string(),
                frame: f.frame,
                loads_in_frame: errors.len(),
                magnitude,
                location_error,
                force_error: e.force_error,
                magnitude_z: None,
                mahalanobis2: None,
                flagged,
                located,
                within: located && e.force_error <= WITHIN,
                silent: false,
            };
            let mut quiet_bad = !located;
            if let Some(g) = est {
                let d = [0, 1, 2].map(|k| g.force[k] - e.truth_force[k]);
                let gm = g.force.iter().map(|c| c * c).sum::<f64>().sqrt();
                s.magnitude_z = (g.sigma > 0.0).then(|| (gm - magnitude).abs() / g.sigma);
                let c = nalgebra::Matrix3::from_fn(|i, j| g.covariance[i][j]);
                let dv = nalgebra::Vector3::from(d);
                s.mahalanobis2 = inverse3(&g.covariance).map(|ci| (dv.transpose() * ci * dv)[0]);
                let en = dv.norm();
                let sigma_e = if en > 0.0 {
                    (dv.transpose() * c * dv)[0].max(0.0).sqrt() / en
                } else {
                    0.0
                };
                let limit = (WITHIN * magnitude).max(2.0 * sigma_e);
                quiet_bad |= en > limit;
            }
            s.silent = !flagged && quiet_bad;
            s
        })
        .collect();
    let phantoms = f
        .forces
        .iter()
        .enumerate()
        .filter(|(i, _)| !errors.iter().any(|e| e.estimate == Some(*i)))
        .map(|(_, g)| Phantom {
            recording: recording.to_string(),
            frame: f.frame,
            magnitude: g.force.iter().map(|c| c * c).sum::<f64>().sqrt(),
            flagged,
        })
        .collect();
    (loads, phantoms)
}

/// Summarises loads and phantoms of `frames` (each with its frame time).
fn summarise(frames: &[(&SensedFrame, Vec<LoadScore>, Vec<Phantom>)]) -> Summary {
    let loads: Vec<&LoadScore> = frames.iter().flat_map(|f| &f.1).collect();
    let located: Vec<&&LoadScore> = loads.iter().filter(|l| l.located).collect();
    let share = |n: usize, of: usize| {
        if of == 0 {
            f64::NAN
        } else {
            n as f64 / of as f64
        }
    };
    let cover = [1.0, 2.0, 3.0].map(|k| {
        share(
            located
                .iter()
                .filter(|l| l.magnitude_z.is_some_and(|z| z <= k))
                .count(),
            located.len(),
        )
    });
    let mut m2: Vec<f64> = located.iter().filter_map(|l| l.mahalanobis2).collect();
    let inside95 = m2.iter().filter(|&&d| d <= CHI2_3DOF_95).count();
    let phantoms = frames.iter().map(|f| f.2.len()).sum::<usize>();
    let unloaded: Vec<&SensedFrame> = (frames.iter())
        .filter(|f| f.1.is_empty())
        .map(|f| f.0)
        .collect();
    let silent_phantoms = frames
        .iter()
        .flat_map(|f| &f.2)
        .filter(|p| !p.flagged)
        .count();
    Summary {
        frames: frames.len(),
        sensed: (frames.iter())
            .filter(|f| f.0.status == FrameStatus::Sensed)
            .count(),
        flagged_frames: frames.iter().filter(|f| f.0.flagged()).count(),
        loads: loads.len(),
        located: located.len(),
        within: loads.iter().filter(|l| l.within).count(),
        frames_all_located: frames
            .iter()
            .filter(|f| f.1.iter().all(|l| l.located))
            .count(),
        frames_all_within: frames
            .iter()
            .filter(|f| f.1.iter().all(|l| l.within))
            .count(),
        silent: loads.iter().filter(|l| l.silent).count() + silent_phantoms,
        phantoms,
        sigma_coverage: cover,
        within_ellipsoid95: share(inside95, m2.len()),
        median_mahalanobis2: median(&mut m2),
        median_ms: median(&mut frames.iter().map(|f| f.0.ms).collect::<Vec<_>>()),
        unloaded_frames: unloaded.len(),
        unloaded_above_2sigma: unloaded.iter().filter(|f| above_2sigma(f)).count(),
    }
}

/// The frame that ends a recording's hold, scored by its fused forces (`score --held`):
/// the last scored frame of `lines`, each force replaced by its [`SensedHeld`] and each
/// error measured again against the fused force. A last frame with no fused forces (it
/// failed or was unreliable, which ended the hold) is kept as it is; it is flagged.
/// Returns that frame and how many frames its forces fused (0 when none).
pub fn held_last(lines: &[SensedFrame]) -> Option<(SensedFrame, usize)> {
    let last = lines
        .iter()
        .rev()
        .find(|f| f.errors.is_some() && !f.reference)?;
    let mut f = last.clone();
    if f.held.is_empty() || f.held.len() != f.forces.len() {
        return Some((f, 0));
    }
    let fused = f.held.iter().map(|h| h.frames).min().unwrap_or(0);
    f.forces = f.held.iter().map(|h| h.fused.clone()).collect();
    for e in f.errors.iter_mut().flatten() {
        if let Some(g) = e.estimate.and_then(|i| f.forces.get(i)) {
            let truth = crate::math::norm(e.truth_force);
            let d = crate::math::sub(g.force, e.truth_force);
            e.force_error = crate::math::norm(d) / truth.max(f64::MIN_POSITIVE);
        }
    }
    Some((f, fused))
}

/// Scores every frame of every recording: `(recording name, its sense lines)`. Frames
/// without truth (`errors` absent) and reference frames are left out.
pub fn score(recordings: &[(String, Vec<SensedFrame>)]) -> Score {
    let mut frames = Vec::new();
    for (name, lines) in recordings {
        for f in lines.iter().filter(|f| f.errors.is_some() && !f.reference) {
            let (l, p) = score_frame(name, f);
            frames.push((f, l, p));
        }
    }
    let mut counts: Vec<usize> = frames.iter().map(|f| f.1.len()).collect();
    counts.sort_unstable();
    counts.dedup();
    let by_loads = counts
        .into_iter()
        .map(|k| {
            let group: Vec<_> = frames.iter().filter(|f| f.1.len() == k).cloned().collect();
            (k, summarise(&group))
        })
        .collect();
    Score {
        all: summarise(&frames),
        by_loads,
        loads: frames.iter().flat_map(|f| f.1.clone()).collect(),
        phantoms: frames.iter().flat_map(|f| f.2.clone()).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `sense --json` line: `forces` as (magnitude along z, sigma), `loads` true loads
    /// along z, each matched to the estimate of the same index.
    fn line(frame: usize, reference: bool, forces: &[(f64, f64)], loads: &[f64]) -> SensedFrame {
        let forces = (forces.iter())
            .map(|&(m, s)| format!(r#"{{"force":[0,0,{m}],"sigma":{s},"covariance":[[{v},0,0],[0,{v},0],[0,0,{v}]]}}"#, v = s * s))
            .collect::<Vec<_>>()
            .join(",");
        let errors = (loads.iter().enumerate())
            .map(|(i, m)| format!(r#"{{"truth_force":[0,0,{m}],"estimate":{i},"location_error":0.001,"force_error":0.01}}"#))
            .collect::<Vec<_>>()
            .join(",");
        let text = format!(
            r#"{{"frame":{frame},"reference":{reference},"status":"sensed","reliable":true,"forces":[{forces}],"errors":[{errors}],"ms":10}}"#
        );
        serde_json::from_str(&text).unwrap()
    }

    #[test]
    fn reference_frames_are_not_scored_and_unloaded_frames_are_held_to_two_sigma() {
        let frames = vec![
            // The reference: not scored, whatever it reads.
            line(0, true, &[(0.5, 0.01)], &[]),
            line(1, true, &[], &[]),
            // Unloaded: one reads 0.03 N with sigma 0.01 (above 2 sigma), one 0.01 N.
            line(2, false, &[(0.03, 0.01)], &[]),
            line(3, false, &[(0.01, 0.01)], &[]),
            line(4, false, &[(0.5, 0.01)], &[0.5]),
        ];
        let s = score(&[("r".into(), frames)]);
        assert_eq!(s.all.frames, 3);
        assert_eq!(s.all.loads, 1);
        assert_eq!((s.all.unloaded_frames, s.all.unloaded_above_2sigma), (2, 1));
        // The unloaded frames' estimates are phantoms, as in any frame.
        assert_eq!(s.all.phantoms, 2);
        let json = serde_json::to_value(&s.by_loads[1].1).unwrap();
        assert!(json.get("unloaded_frames").is_none(), "{json}");
    }

    #[test]
    fn a_held_score_takes_the_last_frame_by_its_fused_force_and_measures_its_error_again() {
        let mut last = line(3, false, &[(0.52, 0.02)], &[0.5]);
        let held = r#"{"frames":2,"force":[0,0,0.505],"sigma":0.01,"covariance":[[1e-4,0,0],[0,1e-4,0],[0,0,1e-4]]}"#;
        last.held = vec![serde_json::from_str(held).unwrap()];
        let lines = vec![
            line(0, true, &[], &[]),
            line(1, false, &[(0.1, 0.02)], &[0.5]),
            last.clone(),
        ];
        let (f, fused) = held_last(&lines).unwrap();
        assert_eq!((f.frame, fused), (3, 2));
        assert_eq!(f.forces[0].force, [0.0, 0.0, 0.505]);
        let e = f.errors.as_ref().unwrap()[0].force_error;
        assert!((e - 0.01).abs() < 1e-12, "{e}");
        // A last frame that ended the hold is kept as it was, with 0 frames fused.
        let mut ended = lines.clone();
        ended[2].held.clear();
        let (f, fused) = held_last(&ended).unwrap();
        assert_eq!((f.forces[0].force, fused), ([0.0, 0.0, 0.52], 0));
        assert!(held_last(&lines[..1]).is_none());
    }
}

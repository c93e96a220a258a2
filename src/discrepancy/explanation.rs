//! What the workflow reports: the outcome, fitted effects, per-region statistics, the
//! selection steps and the residuals.

use super::effects::Effect;
use super::features::Feature;
use serde::Serialize;

/// The answer.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Outcome {
    /// The residual is at the noise floor: nothing is missing.
    NoMissingEffect,
    /// These effects explain the residual down to the noise floor on held-out frames.
    Explained {
        /// The fitted effects.
        effects: Vec<FittedEffect>,
    },
    /// Significant residual remains in these regions (ranked); `partial` are effects that
    /// passed the criteria but did not bring the residual to the noise floor.
    UnexplainedResidual {
        /// Region names, most significant first.
        regions: Vec<String>,
        /// Effects kept on the way (not claimed as the explanation).
        partial: Vec<FittedEffect>,
    },
}

/// A fitted effect with its 1-σ uncertainty.
#[derive(Clone, Debug, Serialize)]
pub struct FittedEffect {
    /// The effect and its parameters.
    pub effect: Effect,
    /// Human-readable name.
    pub name: String,
    /// Standard deviation per parameter.
    pub sigma: Vec<f64>,
}

/// Residual statistics of one region (or all).
#[derive(Clone, Debug, Serialize)]
pub struct RegionStats {
    /// Region name.
    pub region: String,
    /// Residual rows.
    pub n: usize,
    /// Sum of squared normalised residuals.
    pub chi2: f64,
    /// (χ² − n)/√(2n).
    pub z: f64,
    /// RMS residual (m).
    pub rms: f64,
    /// RMS noise σ (m): the noise floor.
    pub noise_rms: f64,
}

/// One candidate's score in a greedy step.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateScore {
    /// Effect name.
    pub name: String,
    /// Parameters (fitted jointly with the effects already kept).
    pub k: usize,
    /// Training χ².
    pub chi2: f64,
    /// BIC = χ² + k ln n.
    pub bic: f64,
    /// Whether χ² is from the exact refinement (else from the linear fit).
    pub refined: bool,
}

/// One step of the model selection.
#[derive(Clone, Debug, Serialize)]
pub struct Step {
    /// What the step tried: `add` a candidate, `swap out` a kept effect for a candidate,
    /// or `drop` a kept effect (candidates are then the kept sets without one effect).
    pub action: String,
    /// BIC with the effects kept so far.
    pub bic_current: f64,
    /// Candidates, best first.
    pub candidates: Vec<CandidateScore>,
    /// Held-out χ² before and after the best candidate (NaN when not tried).
    pub holdout_chi2: [f64; 2],
    /// Whether the best candidate was taken.
    pub accepted: bool,
}

/// Residual of one feature in one frame.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Residual {
    /// Feature index.
    pub feature: usize,
    /// Residual along the normal, measured minus model (m).
    pub r: f64,
    /// Noise σ (m).
    pub sigma: f64,
}

/// Everything the workflow found.
#[derive(Clone, Debug, Serialize)]
pub struct Explanation {
    /// The answer.
    pub outcome: Outcome,
    /// Training and held-out frame indices.
    pub split: [Vec<usize>; 2],
    /// Held-out statistics per region before any effect (last entry: all).
    pub before: Vec<RegionStats>,
    /// Held-out statistics per region with the kept effects (last entry: all).
    pub after: Vec<RegionStats>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// The feature points.
    pub features: Vec<Feature>,
    /// Held-out residuals per held-out frame, before and after.
    pub holdout_residuals: [Vec<Vec<Residual>>; 2],
    /// Effects kept (also inside the outcome).
    pub kept: Vec<FittedEffect>,
}

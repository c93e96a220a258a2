//! Tunables of the discrepancy workflow.

use serde::Serialize;

/// Parameters of the workflow.
#[derive(Clone, Debug, Serialize)]
pub struct DiscrepancyParams {
    /// Fraction of the frames held out for confirmation (every k-th frame); default 0.25.
    pub holdout: f64,
    /// Number of feature points (surface-triangle centroids); default 300.
    pub features: usize,
    /// Features this near the clamp are skipped (they hardly move): height above the fixed
    /// nodes as a fraction of the body's free length along its axis; default 0.1.
    pub min_feature_height: f64,
    /// Features need one flat plane around them within this radius (m); default 0.006.
    pub flat_radius: f64,
    /// Normal-line radius of the registration (m); default 0.0015.
    pub line_radius: f64,
    /// Largest offset along the normal line (m); default 0.008.
    pub line_length: f64,
    /// Fewest measured points on a line for a residual; default 3.
    pub min_points: usize,
    /// Features seen more obliquely than this (degrees from the view ray) are skipped;
    /// default 70.
    pub max_view_angle_deg: f64,
    /// Noise added in quadrature to the sensor model's per-feature σ (m): mesh and
    /// linearisation floor; default 0.
    pub sigma_floor: f64,
    /// A region is significant when z = (χ² − n)/√(2n) exceeds this; default 4.
    pub z_significant: f64,
    /// An effect must lower the BIC by at least this much; default 10.
    pub bic_margin: f64,
    /// An effect must lower the held-out χ² by at least this fraction of the held-out
    /// rows; default 0.02.
    pub holdout_gain: f64,
    /// Candidate locations of an unmodelled point load; default 24.
    pub load_candidates: usize,
    /// Largest number of effects added greedily; default 3.
    pub max_effects: usize,
    /// Most chord iterations (exact FE re-solves) per refinement; default 8.
    // They stop early once a step lowers χ² by less than 0.2 %.
    pub refine_iterations: usize,
    /// Candidates (best by the linear fit) refined exactly before choosing, besides the
    /// best of every effect type; default 5.
    pub refine_candidates: usize,
    /// Huber threshold of the linear fits (in σ; 0 for plain least squares); default 3.
    pub huber: f64,
    /// Pairs of candidates refined exactly when the forward path ends above the noise
    /// floor or with more than two effects (0: none); default 6.
    // The pairs are the best by the joint linear fit.
    pub pair_candidates: usize,
    /// An answer is "explained" only while at least this share of the scored residual rows
    /// (features measured in the held-out frames) is still measured with the effects; below
    /// it the verdict is "unexplained residual"; default 0.5.
    // An effect that moves the model or the points off the measured surface (a depth
    // scale of 1.9) leaves no rows, so χ² = 0: it explains the data away, not the data.
    pub min_rows_kept: f64,
}

impl Default for DiscrepancyParams {
    fn default() -> Self {
        Self {
            holdout: 0.25,
            features: 300,
            min_feature_height: super::body::FEATURE_HEIGHT,
            flat_radius: 0.006,
            line_radius: 0.0015,
            line_length: 0.008,
            min_points: 3,
            max_view_angle_deg: 70.0,
            sigma_floor: 0.0,
            z_significant: 4.0,
            bic_margin: 10.0,
            holdout_gain: 0.02,
            load_candidates: 24,
            max_effects: 3,
            refine_iterations: 8,
            refine_candidates: 5,
            huber: 3.0,
            pair_candidates: 6,
            min_rows_kept: 0.5,
        }
    }
}

//! The least squares both force estimators share (thesis 4.4.1 eq. 4.9-4.10 for the
//! markers, 4.5.2 eq. 4.14 for the intensity QP): whether W_ef identifies the forces (I_w,
//! 4.6.1), and the forces' covariance (W_efᵀW_ef)⁻¹W_efᵀ C W_ef(W_efᵀW_ef)⁻¹, σ²(W_efᵀW_ef)⁻¹
//! for independent rows of variance σ². One rank tolerance, [`RANK_RTOL`], decides
//! identifiability for all of them.

use nalgebra::DMatrix;
use serde::Serialize;

/// W_ef has full column rank when σ_min(W_ef) > `RANK_RTOL` σ_max(W_ef), i.e. when the
/// smallest eigenvalue of W_efᵀW_ef exceeds `RANK_RTOL²` (= 1e-12 exactly in f64) times the
/// largest. The tolerance is on σ at 1e-6, not 1e-12: the layout and the covariance work on
/// W_efᵀW_ef, whose eigenvalues are known only to about ε λ_max (σ to √ε ≈ 1.5e-8 σ_max),
/// so a test at 1e-12 on σ would call a numerically singular Gram matrix identifiable and
/// give a finite I_w with a meaningless covariance.
pub const RANK_RTOL: f64 = 1e-6;

/// Whether the squared singular values `min_sq` ≤ `max_sq` (the extreme eigenvalues of
/// W_efᵀW_ef) are of full rank by [`RANK_RTOL`].
pub fn full_rank_sq(min_sq: f64, max_sq: f64) -> bool {
    min_sq > rank_floor_sq(max_sq)
}

/// The eigenvalue of W_efᵀW_ef at and below which a direction counts as unidentified.
pub fn rank_floor_sq(max_sq: f64) -> f64 {
    RANK_RTOL * RANK_RTOL * max_sq.max(f64::MIN_POSITIVE)
}

/// Identifiability of the force unknowns (thesis Corollaries 1-2 and index I_w of 4.6.1).
#[derive(Clone, Debug, Serialize)]
pub struct Identifiability {
    /// Number of feature rows.
    pub rows: usize,
    /// Number of force unknowns.
    pub unknowns: usize,
    /// I_w = ‖W_ef⁺‖₂ = 1 / σ_min(W_ef) (N/m); infinite when rank deficient.
    pub i_w: f64,
    /// A human-readable warning when the forces are not (well) identifiable.
    pub warning: Option<String>,
}

/// I_w = ‖W_ef⁺‖₂ = 1/σ_min(W_ef) (N/m) from W_ef's singular values: infinite when W_ef has
/// fewer rows than columns or is rank deficient by [`RANK_RTOL`]; 0 without rows or
/// columns (no force to identify).
pub fn i_w(w_ef: &DMatrix<f64>) -> f64 {
    let (m, k) = w_ef.shape();
    // ‖W_ef⁺‖ of an empty matrix is 0, and nalgebra's SVD refuses one.
    if k == 0 || m == 0 {
        return 0.0;
    }
    let sv = w_ef.clone().singular_values();
    let smin = if m < k {
        0.0
    } else {
        sv.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let smax = sv.iter().copied().fold(0.0, f64::max);
    if full_rank_sq(smin * smin, smax * smax) {
        1.0 / smin
    } else {
        f64::INFINITY
    }
}

/// I_w (N/m) from the Gram matrix `gram` = W_efᵀW_ef (e.g. a sum of markers' blocks) and
/// log det(gram + εI), ε the rank floor, to rank Gram matrices that do not identify the
/// unknowns (every one of them has I_w = ∞).
pub fn gram_i_w(gram: &DMatrix<f64>) -> (f64, f64) {
    let eig = gram.clone().symmetric_eigen().eigenvalues;
    let max = eig.iter().copied().fold(0.0, f64::max);
    let min = eig.iter().copied().fold(f64::INFINITY, f64::min);
    let eps = rank_floor_sq(max);
    let logdet = eig.iter().map(|l| (l.max(0.0) + eps).ln()).sum::<f64>();
    let i_w = if full_rank_sq(min, max) {
        1.0 / min.sqrt()
    } else {
        f64::INFINITY
    };
    (i_w, logdet)
}

/// Rows against `unknowns` and I_w of `w_ef`, with a warning when there are fewer rows than
/// unknowns (Corollary 1) or I_w exceeds `max_i_w` (N/m).
pub fn identifiability(w_ef: &DMatrix<f64>, unknowns: usize, max_i_w: f64) -> Identifiability {
    let m = w_ef.nrows();
    let i_w = i_w(w_ef);
    let warning = if m < unknowns {
        Some(format!(
            "{m} feature rows for {unknowns} unknowns: forces are not identifiable"
        ))
    } else if i_w > max_i_w || i_w.is_nan() {
        Some(format!(
            "I_w = {i_w:.3e} N/m exceeds {max_i_w:.3e}: forces are poorly conditioned"
        ))
    } else {
        None
    };
    Identifiability {
        rows: m,
        unknowns,
        i_w,
        warning,
    }
}

/// (W_efᵀW_ef)⁻¹ when W_ef has full column rank by [`RANK_RTOL`], else `None`.
fn gram_inverse(w_ef: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let gram = w_ef.transpose() * w_ef;
    // A non-finite Gram matrix is left to the inverse (its result is caught by the
    // callers' finiteness checks): the eigen-solver need not converge on one.
    if gram.nrows() > 0 && gram.iter().all(|v| v.is_finite()) {
        let eig = gram.clone().symmetric_eigenvalues();
        if !full_rank_sq(eig.min(), eig.max()) {
            return None;
        }
    }
    gram.try_inverse()
}

/// The forces' covariance A C Aᵀ for the least squares' map A = (W_efᵀW_ef)⁻¹W_efᵀ (forces
/// x rows) and the rows' covariance C, the product left to `sandwich` (given A; e.g. one
/// that never forms C). `None` when W_ef is rank deficient, `sandwich` gives `None` or the
/// result is not finite and forces x forces.
pub fn covariance_with(
    w_ef: &DMatrix<f64>,
    sandwich: impl FnOnce(&DMatrix<f64>) -> Option<DMatrix<f64>>,
) -> Option<DMatrix<f64>> {
    let a = gram_inverse(w_ef)? * w_ef.transpose();
    let cov = sandwich(&a)?;
    let k = a.nrows();
    (cov.nrows() == k && cov.ncols() == k && cov.iter().all(|v| v.is_finite())).then_some(cov)
}

/// σ sqrt(diag((W_efᵀW_ef)⁻¹)): the Gauss-Markov spread of the forces with independent rows
/// of noise σ (`sigma`). Infinite when W_ef is rank deficient.
pub fn gauss_markov_sigma(w_ef: &DMatrix<f64>, sigma: f64) -> Vec<f64> {
    let k = w_ef.ncols();
    match gram_inverse(w_ef) {
        Some(inv) => (0..k)
            .map(|j| sigma * inv[(j, j)].max(0.0).sqrt())
            .collect(),
        None => vec![f64::INFINITY; k],
    }
}

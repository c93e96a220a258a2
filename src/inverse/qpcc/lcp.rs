//! The forward contact LCP (5.3, 5.4): the plant's contact forces for given gaps.

use super::{affine, complementarity, max_abs};
use crate::inverse::qp::{QpParams, QpProblem, QpStatus};
use crate::inverse::{InverseError, InverseResult};
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use serde::Serialize;

/// How the forward contact LCP ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum LcpStatus {
    /// λ_c, δ_c satisfy the LCP to the QP's accuracy (see the residuals).
    Solved,
    /// No λ_c ≥ 0 makes δ_c ≥ 0: the QP is unbounded below.
    Infeasible,
    /// The QP solver failed otherwise.
    QpFailed(QpStatus),
}

/// The forward contact LCP's result; vectors are empty unless `status` is `Solved`.
#[derive(Clone, Debug, Serialize)]
pub struct LcpSolution {
    /// How the solve ended.
    pub status: LcpStatus,
    /// Contact forces λ_c (n_c).
    pub lambda: Vec<f64>,
    /// Contact gaps δ_c = W_cc λ_c + g (n_c).
    pub delta: Vec<f64>,
    /// max_i |λ_i δ_i| (NaN without a solution).
    pub complementarity: f64,
    /// min_i δ_i, negative when a gap stays penetrated (NaN without a solution).
    pub min_delta: f64,
}

/// Solves the forward contact LCP: λ_c ≥ 0, δ_c = W_cc λ_c + g ≥ 0, λ_c·δ_c = 0, with `g`
/// = W_ca λ_a + δ_c^free the gaps with the actuation applied (5.3, 5.4).
///
/// It is the QP min ½λ_cᵀW_cc λ_c + gᵀλ_c, λ_c ≥ 0: for a symmetric PSD W_cc its KKT
/// conditions are the LCP, and it is unbounded below exactly when the LCP is infeasible.
/// A singular W_cc is fine. The interior-point answer is then polished on its active set
/// (an exact solve of W_AA λ_A = −g_A) when that solve is consistent.
/// Errors on shapes, non-finite data, or a W_cc that is not symmetric PSD.
pub fn solve_contact_lcp(
    w_cc: &DMatrix<f64>,
    gap: &[f64],
    params: &QpParams,
) -> InverseResult<LcpSolution> {
    let n = gap.len();
    if w_cc.nrows() != n || w_cc.ncols() != n {
        return Err(InverseError::ContactLcpShape {
            rows: w_cc.nrows(),
            cols: w_cc.ncols(),
            gaps: n,
        });
    }
    check_symmetric_psd(w_cc)?;
    let mut qp = QpProblem::new(n);
    qp.p = w_cc.clone();
    qp.q = gap.to_vec();
    qp.lower = vec![0.0; n];
    let sol = qp.solve(params)?;
    let status = match sol.status {
        s if s.is_solution() => LcpStatus::Solved,
        QpStatus::DualInfeasible => LcpStatus::Infeasible,
        s => LcpStatus::QpFailed(s),
    };
    if status != LcpStatus::Solved {
        return Ok(LcpSolution {
            status,
            lambda: Vec::new(),
            delta: Vec::new(),
            complementarity: f64::NAN,
            min_delta: f64::NAN,
        });
    }
    let lambda = polish_lcp(w_cc, gap, &sol.x).unwrap_or(sol.x);
    let delta = affine(w_cc, &lambda, gap);
    Ok(LcpSolution {
        status,
        complementarity: complementarity(&lambda, &delta),
        min_delta: delta.iter().copied().fold(f64::INFINITY, f64::min),
        lambda,
        delta,
    })
}

/// W_cc must be symmetric (its lower triangle would otherwise be ignored by the QP but not
/// by δ_c) and PSD (Clarabel's requirement), both to rounding relative to its largest entry.
fn check_symmetric_psd(w: &DMatrix<f64>) -> InverseResult<()> {
    if w.iter().any(|v| !v.is_finite()) {
        return Err(InverseError::NonFiniteQp);
    }
    let scale = w.amax().max(f64::MIN_POSITIVE);
    let asymmetry = (w - w.transpose()).amax();
    let min_eigenvalue = if w.nrows() == 0 {
        0.0
    } else {
        SymmetricEigen::new(0.5 * (w + w.transpose()))
            .eigenvalues
            .min()
    };
    if asymmetry > 1e-12 * scale || min_eigenvalue < -1e-12 * scale * w.nrows() as f64 {
        return Err(InverseError::ContactCompliance {
            asymmetry,
            min_eigenvalue,
        });
    }
    Ok(())
}

/// The LCP solution on the active set the interior point found (δ_i < λ_i), solved
/// exactly; `None` when that system is singular or its solution is not feasible.
fn polish_lcp(w: &DMatrix<f64>, g: &[f64], x: &[f64]) -> Option<Vec<f64>> {
    let delta = affine(w, x, g);
    let active: Vec<usize> = (0..g.len()).filter(|&i| delta[i] < x[i]).collect();
    let mut lambda = vec![0.0; g.len()];
    if !active.is_empty() {
        let w_aa = w.select_rows(&active).select_columns(&active);
        let rhs = DVector::from_iterator(active.len(), active.iter().map(|&i| -g[i]));
        let sol = w_aa.lu().solve(&rhs)?;
        for (k, &i) in active.iter().enumerate() {
            lambda[i] = sol[k];
        }
    }
    let scale = max_abs(g).max(max_abs(x) * w.amax()).max(f64::MIN_POSITIVE);
    let lambda_scale = max_abs(&lambda).max(f64::MIN_POSITIVE);
    if lambda.iter().any(|&l| l < -1e-12 * lambda_scale) {
        return None;
    }
    lambda.iter_mut().for_each(|l| *l = l.max(0.0));
    let polished = affine(w, &lambda, g);
    (polished.iter().all(|&d| d >= -1e-12 * scale)).then_some(lambda)
}

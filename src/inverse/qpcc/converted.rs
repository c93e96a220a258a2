//! The thesis's converted QP (5.13-5.15) and the bound of 5.27 that certifies its optimum.

use super::{complementarity, max_abs, Mode, NodeOutcome, QpccProblem};
use crate::inverse::qp::{QpParams, QpStatus};
use crate::inverse::InverseResult;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use serde::Serialize;

/// The converted QP (5.13): min ½λᵀQλ + cᵀλ, Q = Q_1 + εQ_2, c = c_1 + εc_2, over the
/// bounds (5.14) and δ_c ≥ 0 (5.15), as [`QpccProblem::converted`] builds it.
#[derive(Clone, Debug)]
pub struct ConvertedQp {
    /// Q_1 = W_eᵀW_e (5.6).
    pub q_1: DMatrix<f64>,
    /// c_1 = W_eᵀ(δ_e^free − δ_d) (5.6).
    pub c_1: Vec<f64>,
    /// Q_2 = Q_lcc + Q_lccᵀ, Q_lcc = \[0_{(a+c)×a} W_cᵀ\] (5.10, 5.12).
    pub q_2: DMatrix<f64>,
    /// c_2 = \[0; δ_c^free\] (5.10, 5.12).
    pub c_2: Vec<f64>,
    /// The LCP's weight ε.
    pub epsilon: f64,
    /// Q = Q_1 + εQ_2 (5.13).
    pub q: DMatrix<f64>,
    /// c = c_1 + εc_2 (5.13).
    pub c: Vec<f64>,
}

/// Whether the converted QP's Q is positive semi-definite.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Convexity {
    /// sym(Q)'s smallest eigenvalue is not below −tolerance · its largest |eigenvalue|.
    Convex {
        /// sym(Q)'s smallest eigenvalue.
        min_eigenvalue: f64,
    },
    /// Q is indefinite: a local QP solver may not give the global optimum.
    Indefinite {
        /// sym(Q)'s smallest eigenvalue.
        min_eigenvalue: f64,
    },
}

impl ConvertedQp {
    /// ½λᵀQλ + cᵀλ, which equals (5.6)'s objective + ε λ_cᵀδ_c.
    pub fn objective(&self, lambda: &[f64]) -> f64 {
        let l = DVector::from_column_slice(lambda);
        0.5 * l.dot(&(&self.q * &l)) + DVector::from_column_slice(&self.c).dot(&l)
    }

    /// Q's convexity, by sym(Q)'s smallest eigenvalue against `tolerance` relative to its
    /// largest |eigenvalue|.
    pub fn convexity(&self, tolerance: f64) -> Convexity {
        let eig = SymmetricEigen::new(0.5 * (&self.q + self.q.transpose())).eigenvalues;
        let min_eigenvalue = eig.iter().copied().fold(f64::INFINITY, f64::min);
        let scale = eig.amax().max(f64::MIN_POSITIVE);
        if min_eigenvalue >= -tolerance * scale {
            Convexity::Convex { min_eigenvalue }
        } else {
            Convexity::Indefinite { min_eigenvalue }
        }
    }
}

/// Options of [`QpccProblem::solve_converted`].
#[derive(Clone, Debug)]
pub struct ConvertedParams {
    /// The LCP's weight ε in Q = Q_1 + εQ_2 (5.13). Default 1.
    pub epsilon: f64,
    /// Convexity tolerance, relative to sym(Q)'s largest |eigenvalue|. Default 1e-12.
    pub convexity_tolerance: f64,
    /// Residual ‖W_eλ + δ_e^free − δ_d‖ ≤ tol · ‖δ_e^free − δ_d‖ counts as reachable.
    /// Default 1e-6.
    pub reach_tolerance: f64,
    /// The QP's options.
    pub qp: QpParams,
}

impl Default for ConvertedParams {
    fn default() -> Self {
        Self {
            epsilon: 1.0,
            convexity_tolerance: 1e-12,
            reach_tolerance: 1e-6,
            qp: QpParams::default(),
        }
    }
}

/// How the converted QP's solve ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ConvertedStatus {
    /// Q is convex and Clarabel solved (5.13-5.15).
    Solved,
    /// Q is indefinite; nothing was solved (use [`QpccProblem::solve`]).
    Indefinite {
        /// sym(Q)'s smallest eigenvalue.
        min_eigenvalue: f64,
    },
    /// Q is convex but the QP solver did not solve.
    QpFailed(QpStatus),
}

/// The converted QP's result; `lambda` is empty unless `status` is `Solved`. Its λ solves
/// the QPCC only when the target is reachable (appendix): check `reachable` and
/// `complementarity`.
#[derive(Clone, Debug, Serialize)]
pub struct ConvertedSolution {
    /// How the solve ended.
    pub status: ConvertedStatus,
    /// λ = \[λ_a; λ_c\].
    pub lambda: Vec<f64>,
    /// ½λᵀQλ + cᵀλ at λ (5.13) (NaN without a solution).
    pub objective: f64,
    /// max_i |λ_c,i δ_c,i|: above tolerance, λ is not a QPCC point.
    pub complementarity: f64,
    /// ‖W_eλ + δ_e^free − δ_d‖.
    pub residual: f64,
    /// Whether the residual is within the reach tolerance; when not, the appendix's
    /// equivalence does not apply and λ may differ from the QPCC's optimum.
    pub reachable: bool,
}

/// The bound of 5.27 checked at a point λ of the converted QP.
#[derive(Clone, Debug, Serialize)]
pub struct ConvertedCertificate {
    /// The converted objective ½λᵀQλ + cᵀλ at λ.
    pub value: f64,
    /// −½‖δ_e^free − δ_d‖², a lower bound of the objective on the feasible set (5.27).
    pub lower_bound: f64,
    /// λ's largest violation of (5.14)-(5.15), in λ's and δ_c's units.
    pub violation: f64,
    /// Whether λ is feasible and attains the bound, both to the tolerance: then λ is a
    /// global minimiser of (5.13), even for an indefinite Q.
    pub certified: bool,
}

impl QpccProblem {
    /// The converted QP (5.13) with weight `epsilon`, built as the thesis does.
    pub fn converted(&self, epsilon: f64) -> ConvertedQp {
        let n = self.n();
        let q_1 = self.w_e.transpose() * &self.w_e;
        let c_1: Vec<f64> = (self.w_e.transpose() * DVector::from_vec(self.free_error()))
            .iter()
            .copied()
            .collect();
        let mut q_lcc = DMatrix::zeros(n, n);
        q_lcc
            .columns_mut(self.n_a, self.n_c())
            .copy_from(&self.w_c.transpose());
        let q_2 = &q_lcc + q_lcc.transpose();
        let mut c_2 = vec![0.0; self.n_a];
        c_2.extend_from_slice(&self.delta_c_free);
        let q = &q_1 + epsilon * &q_2;
        let c = c_1.iter().zip(&c_2).map(|(a, b)| a + epsilon * b).collect();
        ConvertedQp {
            q_1,
            c_1,
            q_2,
            c_2,
            epsilon,
            q,
            c,
        }
    }

    /// Solves the converted QP (5.13-5.15) with Clarabel when its Q is convex; an
    /// indefinite Q is reported, never handed to the solver. The interior point's answer is
    /// replaced by its active set's leaf (exact complementarity) when that leaf is as good.
    pub fn solve_converted(&self, params: &ConvertedParams) -> InverseResult<ConvertedSolution> {
        self.validate()?;
        let converted = self.converted(params.epsilon);
        let unsolved = |status| ConvertedSolution {
            status,
            lambda: Vec::new(),
            objective: f64::NAN,
            complementarity: f64::NAN,
            residual: f64::NAN,
            reachable: false,
        };
        if let Convexity::Indefinite { min_eigenvalue } =
            converted.convexity(params.convexity_tolerance)
        {
            return Ok(unsolved(ConvertedStatus::Indefinite { min_eigenvalue }));
        }
        let (mut qp, _) = self.node_qp(&vec![Mode::Free; self.n_c()]);
        qp.p = converted.q.clone();
        qp.q = converted.c.clone();
        let sol = qp.solve(&params.qp)?;
        if !sol.status.is_solution() {
            return Ok(unsolved(ConvertedStatus::QpFailed(sol.status)));
        }
        let mut lambda = sol.x;
        // The interior point leaves λ_i δ_i of the order of its gap tolerance over ε. The
        // leaf of the active set it points to has λ_cᵀδ_c = 0 exactly, so the converted
        // objective is Γ − ½‖δ_e^free − δ_d‖² there, a convex QP; where that leaf is no worse,
        // it is the same optimum with exact complementarity.
        let leaf = self.snap(&vec![Mode::Free; self.n_c()], &lambda);
        if let NodeOutcome::Solved { lambda: l, .. } = self.solve_node(&leaf, &params.qp)? {
            let value = converted.objective(&lambda);
            let slack = 10.0 * params.qp.tolerance * (value.abs() + self.offset());
            if converted.objective(&l) <= value + slack {
                lambda = l;
            }
        }
        let delta_c = self.contacts(&lambda);
        let residual = (2.0 * self.residual_objective(&lambda)).sqrt();
        Ok(ConvertedSolution {
            status: ConvertedStatus::Solved,
            objective: converted.objective(&lambda),
            complementarity: complementarity(&lambda[self.n_a..], &delta_c),
            residual,
            reachable: self.reached(residual, params.reach_tolerance),
            lambda,
        })
    }

    /// Checks a point λ against the bound of 5.27: on the feasible set of (5.13-5.15) the
    /// objective is Γ(λ) − ½‖δ_e^free − δ_d‖² + ε λ_cᵀδ_c with Γ ≥ 0 and λ_cᵀδ_c ≥ 0, so
    /// it is at least −½‖δ_e^free − δ_d‖². A feasible λ whose value equals that bound is a
    /// global minimiser, whatever Q's convexity; this certifies e.g. the QPCC's solution
    /// for a reachable target without solving the (possibly indefinite) converted QP.
    /// `tolerance` is relative: to ½‖δ_e^free − δ_d‖² for the value, to λ's and δ_c's
    /// largest entries for the violation.
    pub fn certify_converted(
        &self,
        converted: &ConvertedQp,
        lambda: &[f64],
        tolerance: f64,
    ) -> ConvertedCertificate {
        let (lower, upper) = self.bounds();
        let delta_c = self.contacts(lambda);
        let bound_violation = (0..self.n())
            .map(|j| (lower[j] - lambda[j]).max(lambda[j] - upper[j]).max(0.0))
            .fold(0.0, f64::max);
        let gap_violation = delta_c.iter().map(|d| (-d).max(0.0)).fold(0.0, f64::max);
        let value = converted.objective(lambda);
        let lower_bound = -self.offset();
        let scale_lambda = max_abs(lambda).max(f64::MIN_POSITIVE);
        let scale_delta = max_abs(&delta_c).max(max_abs(&self.delta_c_free));
        let feasible = bound_violation <= tolerance * scale_lambda
            && gap_violation <= tolerance * scale_delta.max(f64::MIN_POSITIVE);
        let attained = value - lower_bound <= tolerance * self.offset().max(f64::MIN_POSITIVE);
        ConvertedCertificate {
            value,
            lower_bound,
            violation: bound_violation.max(gap_violation),
            certified: feasible && attained,
        }
    }
}

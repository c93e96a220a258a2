//! Contact as a complementarity problem and the FEM controller's QP with complementarity
//! constraints (QPCC), thesis chapter 5.
//!
//! Notation (5.1-5.3): λ = \[λ_a; λ_c\] (n_a actuator inputs, then n_c contact forces);
//! δ_e = W_e λ + δ_e^free, δ_c = W_c λ + δ_c^free; Signorini (5.4): 0 ≤ δ_c ⟂ λ_c ≥ 0.
//!
//! - [`solve_contact_lcp`]: the forward contact LCP, the plant (and the tests' truth): the
//!   contact forces for given gaps with the actuation applied, as the convex QP
//!   min ½λ_cᵀW_cc λ_c + gᵀλ_c, λ_c ≥ 0, whose optimality conditions are the LCP.
//! - [`QpccProblem::solve`]: the controller's QPCC (5.5-5.8), by branch and bound over the
//!   contacts' complementarity. This is the production solver.
//! - [`QpccProblem::converted`] / [`QpccProblem::solve_converted`]: the thesis's converted QP
//!   (5.13-5.15), Q = Q_1 + εQ_2. Q_2 couples λ_a to λ_c through W_ca, so Q is indefinite in
//!   general: it is solved only when it is convex, and otherwise reports so. Its optimum
//!   equals the QPCC's only for a reachable target (appendix, 5.23-5.28), so its solution
//!   carries a `reachable` flag and the complementarity residual.
//! - [`QpccProblem::solve_exhaustive`]: every active set, one convex QP each: the test
//!   oracle, for n_c ≤ [`MAX_ORACLE_CONTACTS`].
//!
//! Why branch and bound: each node fixes some contacts active (δ_c,i = 0) or inactive
//! (λ_c,i = 0) and relaxes the rest, which leaves the convex objective ½‖W_eλ + δ_e^free −
//! δ_d‖² (5.5) over a polyhedron, a convex QP whose optimum bounds its subtree from below.
//! No indefinite matrix ever reaches Clarabel.
//!
//! ```
//! use nalgebra::DMatrix;
//! use softsense::inverse::qpcc::{solve_contact_lcp, LcpStatus};
//! // One contact of compliance 2 penetrating by 1: λ = 0.5 closes the gap.
//! let lcp = solve_contact_lcp(&DMatrix::from_element(1, 1, 2.0), &[-1.0], &Default::default())?;
//! assert_eq!(lcp.status, LcpStatus::Solved);
//! assert!((lcp.lambda[0] - 0.5).abs() < 1e-9 && lcp.delta[0].abs() < 1e-9);
//! # Ok::<(), softsense::inverse::InverseError>(())
//! ```

mod converted;
mod lcp;

pub use converted::{
    ConvertedCertificate, ConvertedParams, ConvertedQp, ConvertedSolution, ConvertedStatus,
    Convexity,
};
pub use lcp::{solve_contact_lcp, LcpSolution, LcpStatus};

use super::qp::{QpParams, QpProblem, QpStatus};
use super::{InverseError, InverseResult};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// The largest contact count [`QpccProblem::solve_exhaustive`] enumerates (2^8 QPs).
pub const MAX_ORACLE_CONTACTS: usize = 8;

/// How the QPCC solvers ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum QpccStatus {
    /// The global optimum, to the gap tolerance.
    Solved,
    /// No λ within the bounds satisfies the contact constraints.
    Infeasible,
    /// The node limit was reached; `lambda` is the best point found (empty if none).
    NodeLimit,
    /// A node's QP failed, so no subtree could be pruned safely; `lambda` is the best point
    /// found so far (empty if none).
    QpFailed(QpStatus),
}

/// Branch and bound options.
#[derive(Clone, Debug)]
pub struct QpccParams {
    /// Complementarity tolerance, relative: λ_i δ_i ≤ tol · ‖λ‖∞ ‖δ_c‖∞. Default 1e-9.
    pub complementarity_tolerance: f64,
    /// Optimality gap, relative to ½‖δ_e^free − δ_d‖² (or the incumbent if larger).
    /// Default 1e-9.
    pub gap_tolerance: f64,
    /// Residual ‖W_eλ + δ_e^free − δ_d‖ ≤ tol · ‖δ_e^free − δ_d‖ counts as reachable.
    /// Default 1e-6.
    pub reach_tolerance: f64,
    /// Maximum nodes (convex QPs) explored. Default 10 000.
    pub max_nodes: usize,
    /// Each node's QP options.
    pub qp: QpParams,
}

impl Default for QpccParams {
    fn default() -> Self {
        Self {
            complementarity_tolerance: 1e-9,
            gap_tolerance: 1e-9,
            reach_tolerance: 1e-6,
            max_nodes: 10_000,
            qp: QpParams::default(),
        }
    }
}

/// A QPCC solver's result; vectors are empty when no feasible point was found.
#[derive(Clone, Debug, Serialize)]
pub struct QpccSolution {
    /// How the solve ended.
    pub status: QpccStatus,
    /// λ = \[λ_a; λ_c\] (n_a + n_c).
    pub lambda: Vec<f64>,
    /// δ_c = W_c λ + δ_c^free (n_c).
    pub delta_c: Vec<f64>,
    /// δ_e = W_e λ + δ_e^free (n_e).
    pub delta_e: Vec<f64>,
    /// Γ(λ) = ½‖W_eλ + δ_e^free − δ_d‖² (5.5) (NaN without a point).
    pub residual_objective: f64,
    /// The thesis's form ½λᵀQ_1λ + c_1ᵀλ (5.6) = Γ(λ) − ½‖δ_e^free − δ_d‖².
    pub objective: f64,
    /// max_i |λ_c,i δ_c,i|.
    pub complementarity: f64,
    /// ‖W_eλ + δ_e^free − δ_d‖.
    pub residual: f64,
    /// Whether the residual is within the reach tolerance: the target was reached.
    pub reachable: bool,
    /// Nodes (convex QPs) solved.
    pub nodes: usize,
}

/// The FEM controller's QPCC (5.5-5.8): min ½‖W_eλ + δ_e^free − δ_d‖² subject to
/// λ_a,min ≤ λ_a ≤ λ_a,max, 0 ≤ λ_c ≤ λ_c,max and 0 ≤ δ_c = W_cλ + δ_c^free ⟂ λ_c.
#[derive(Clone, Debug)]
pub struct QpccProblem {
    /// Effector compliance W_e = \[W_ea W_ec\], n_e x (n_a + n_c).
    pub w_e: DMatrix<f64>,
    /// Contact compliance W_c = \[W_ca W_cc\], n_c x (n_a + n_c).
    pub w_c: DMatrix<f64>,
    /// δ_e^free, the effectors without actuation or contact (n_e).
    pub delta_e_free: Vec<f64>,
    /// δ_c^free, the contact gaps without actuation or contact (n_c); negative penetrates.
    pub delta_c_free: Vec<f64>,
    /// δ_d, the desired effector positions (n_e).
    pub delta_d: Vec<f64>,
    /// Number of actuators n_a (λ's first entries).
    pub n_a: usize,
    /// λ_a,min (n_a). Default 0 (cables only pull).
    pub lambda_a_min: Vec<f64>,
    /// λ_a,max (n_a), +∞ allowed. Default +∞.
    pub lambda_a_max: Vec<f64>,
    /// λ_c,max (n_c), +∞ allowed. Default +∞.
    pub lambda_c_max: Vec<f64>,
}

/// A contact's state in a branch-and-bound node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Both λ_c,i ≥ 0 and δ_c,i ≥ 0, complementarity relaxed.
    Free,
    /// δ_c,i = 0, λ_c,i ≥ 0.
    Active,
    /// λ_c,i = 0, δ_c,i ≥ 0.
    Inactive,
}

/// A node QP's outcome.
enum NodeOutcome {
    Infeasible,
    Failed(QpStatus),
    /// The full λ (inactive contacts' entries zero) and Γ(λ).
    Solved {
        lambda: Vec<f64>,
        value: f64,
    },
}

impl QpccProblem {
    /// A problem with the default bounds: λ_a ≥ 0, λ_c ≥ 0, no upper bounds.
    pub fn new(
        w_e: DMatrix<f64>,
        w_c: DMatrix<f64>,
        delta_e_free: Vec<f64>,
        delta_c_free: Vec<f64>,
        delta_d: Vec<f64>,
        n_a: usize,
    ) -> Self {
        let n_c = w_c.nrows();
        Self {
            w_e,
            w_c,
            delta_e_free,
            delta_c_free,
            delta_d,
            lambda_a_min: vec![0.0; n_a],
            lambda_a_max: vec![f64::INFINITY; n_a],
            lambda_c_max: vec![f64::INFINITY; n_c],
            n_a,
        }
    }

    /// Number of contacts n_c.
    pub fn n_c(&self) -> usize {
        self.w_c.nrows()
    }

    /// Number of unknowns n_a + n_c.
    pub fn n(&self) -> usize {
        self.n_a + self.n_c()
    }

    fn validate(&self) -> InverseResult<()> {
        let (n_e, n_c, n) = (self.w_e.nrows(), self.n_c(), self.n());
        let consistent = self.w_e.ncols() == n
            && self.w_c.ncols() == n
            && self.delta_e_free.len() == n_e
            && self.delta_d.len() == n_e
            && self.delta_c_free.len() == n_c
            && self.lambda_a_min.len() == self.n_a
            && self.lambda_a_max.len() == self.n_a
            && self.lambda_c_max.len() == n_c;
        if !consistent {
            return Err(InverseError::QpccShape {
                effectors: n_e,
                actuators: self.n_a,
                contacts: n_c,
                columns: (self.w_e.ncols(), self.w_c.ncols()),
            });
        }
        let finite = self
            .w_e
            .iter()
            .chain(self.w_c.iter())
            .all(|v| v.is_finite())
            && (self.delta_e_free.iter())
                .chain(&self.delta_c_free)
                .chain(&self.delta_d)
                .all(|v| v.is_finite());
        if !finite {
            return Err(InverseError::NonFiniteQp);
        }
        let (lower, upper) = self.bounds();
        let bad = |j: usize| {
            let (l, u) = (lower[j], upper[j]);
            l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY
        };
        if let Some(index) = (0..n).find(|&j| bad(j)) {
            return Err(InverseError::QpccBounds {
                index,
                lower: lower[index],
                upper: upper[index],
            });
        }
        Ok(())
    }

    /// λ's bounds (5.7): \[λ_a,min; 0\] and \[λ_a,max; λ_c,max\].
    fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        let mut lower = self.lambda_a_min.clone();
        lower.resize(self.n(), 0.0);
        let mut upper = self.lambda_a_max.clone();
        upper.extend_from_slice(&self.lambda_c_max);
        (lower, upper)
    }

    /// δ_e^free − δ_d, the effector error without actuation or contact.
    fn free_error(&self) -> Vec<f64> {
        let d = self.delta_e_free.iter().zip(&self.delta_d);
        d.map(|(f, d)| f - d).collect()
    }

    /// ½‖δ_e^free − δ_d‖², the constant the thesis's objective (5.6) drops; the reachable
    /// optimum of (5.6) and (5.13) is its negative (5.23, 5.26).
    pub fn offset(&self) -> f64 {
        0.5 * self.free_error().iter().map(|e| e * e).sum::<f64>()
    }

    /// δ_e = W_e λ + δ_e^free (5.2).
    pub fn effectors(&self, lambda: &[f64]) -> Vec<f64> {
        affine(&self.w_e, lambda, &self.delta_e_free)
    }

    /// δ_c = W_c λ + δ_c^free (5.3).
    pub fn contacts(&self, lambda: &[f64]) -> Vec<f64> {
        affine(&self.w_c, lambda, &self.delta_c_free)
    }

    /// Γ(λ) = ½‖W_eλ + δ_e^free − δ_d‖² (5.5).
    pub fn residual_objective(&self, lambda: &[f64]) -> f64 {
        let r = affine(&self.w_e, lambda, &self.free_error());
        0.5 * r.iter().map(|v| v * v).sum::<f64>()
    }

    /// The thesis's form (5.6): ½λᵀQ_1λ + c_1ᵀλ = Γ(λ) − ½‖δ_e^free − δ_d‖².
    pub fn thesis_objective(&self, lambda: &[f64]) -> f64 {
        self.residual_objective(lambda) - self.offset()
    }

    /// The convex QP of one node: Γ over the bounds with each contact's `modes` constraint.
    /// Inactive contacts' columns are dropped (λ_c,i = 0 exactly); the returned indices map
    /// the QP's unknowns to λ's.
    fn node_qp(&self, modes: &[Mode]) -> (QpProblem, Vec<usize>) {
        let n_a = self.n_a;
        let keep: Vec<usize> = (0..self.n())
            .filter(|&j| j < n_a || modes[j - n_a] != Mode::Inactive)
            .collect();
        let w_e = self.w_e.select_columns(&keep);
        let w_c = self.w_c.select_columns(&keep);
        let mut qp = QpProblem::least_squares(&w_e, &neg(&self.free_error()))
            .expect("W_e's rows match δ_e^free's, checked by validate");
        let (lower, upper) = self.bounds();
        qp.lower = keep.iter().map(|&j| lower[j]).collect();
        qp.upper = keep.iter().map(|&j| upper[j]).collect();
        let active: Vec<usize> = (0..modes.len())
            .filter(|&i| modes[i] == Mode::Active)
            .collect();
        let open: Vec<usize> = (0..modes.len())
            .filter(|&i| modes[i] != Mode::Active)
            .collect();
        // Active: W_c,i λ = −δ_c,i^free. Otherwise δ_c,i ≥ 0: −W_c,i λ ≤ δ_c,i^free.
        qp.a_eq = w_c.select_rows(&active);
        qp.b_eq = active.iter().map(|&i| -self.delta_c_free[i]).collect();
        qp.a_le = -w_c.select_rows(&open);
        qp.b_le = open.iter().map(|&i| self.delta_c_free[i]).collect();
        (qp, keep)
    }

    fn solve_node(&self, modes: &[Mode], params: &QpParams) -> InverseResult<NodeOutcome> {
        let (qp, keep) = self.node_qp(modes);
        let sol = qp.solve(params)?;
        if sol.status == QpStatus::PrimalInfeasible {
            return Ok(NodeOutcome::Infeasible);
        }
        if !sol.status.is_solution() {
            return Ok(NodeOutcome::Failed(sol.status));
        }
        let mut lambda = vec![0.0; self.n()];
        for (k, &j) in keep.iter().enumerate() {
            lambda[j] = sol.x[k];
        }
        let value = self.residual_objective(&lambda);
        Ok(NodeOutcome::Solved { lambda, value })
    }

    /// The free contact with the largest λ_i δ_i and whether every free contact's product
    /// is within the complementarity tolerance (`None` when no contact is free).
    fn worst_free(&self, modes: &[Mode], lambda: &[f64], tol: f64) -> Option<(usize, bool)> {
        let delta = self.contacts(lambda);
        let lambda_c = &lambda[self.n_a..];
        let scale = max_abs(lambda).max(f64::MIN_POSITIVE) * max_abs(&delta).max(f64::MIN_POSITIVE);
        let product = |i: usize| (lambda_c[i] * delta[i]).max(0.0);
        let worst = (0..modes.len())
            .filter(|&i| modes[i] == Mode::Free)
            .max_by(|&a, &b| product(a).total_cmp(&product(b)))?;
        Some((worst, product(worst) <= tol * scale))
    }

    /// The QPCC (5.5-5.8) by branch and bound over the contacts' complementarity.
    ///
    /// Each node is a convex QP (each contact active, inactive or free) whose optimum bounds its
    /// subtree from below. A node whose free contacts are complementary to tolerance is
    /// snapped to the leaf of its active set (each free contact active where δ_i < λ_i),
    /// which gives an incumbent with exact complementarity; the node is closed when that
    /// leaf is as good as its bound. Otherwise it branches on the free contact with the
    /// largest λ_i δ_i, the likelier side first. Nodes whose bound is not below the
    /// incumbent (less the gap tolerance) are pruned, as are infeasible ones. The first
    /// incumbent is the forward contact LCP at the root's λ_a, when W_cc allows it.
    pub fn solve(&self, params: &QpccParams) -> InverseResult<QpccSolution> {
        self.validate()?;
        let n_c = self.n_c();
        let mut best: Option<(Vec<f64>, f64)> = None;
        let mut stack = vec![vec![Mode::Free; n_c]];
        let mut nodes = 0;
        let mut status = QpccStatus::Solved;
        while let Some(modes) = stack.pop() {
            if nodes >= params.max_nodes {
                status = QpccStatus::NodeLimit;
                break;
            }
            nodes += 1;
            let (lambda, value) = match self.solve_node(&modes, &params.qp)? {
                NodeOutcome::Infeasible => continue,
                NodeOutcome::Failed(s) => {
                    status = QpccStatus::QpFailed(s);
                    break;
                }
                NodeOutcome::Solved { lambda, value } => (lambda, value),
            };
            if nodes == 1 {
                self.lcp_incumbent(&lambda, params, &mut best);
            }
            let gap = self.gap(best.as_ref(), params.gap_tolerance);
            if best.as_ref().is_some_and(|b| value >= b.1 - gap) {
                continue;
            }
            let tol = params.complementarity_tolerance;
            let Some((worst, complementary)) = self.worst_free(&modes, &lambda, tol) else {
                // A leaf: every contact fixed, so complementarity holds up to the QP's
                // accuracy (a reduced-accuracy solve can miss an equality row).
                if self.complementary(&lambda, tol) {
                    best = Some((lambda, value));
                }
                continue;
            };
            if complementary {
                let leaf = self.snap(&modes, &lambda);
                nodes += 1;
                if let NodeOutcome::Solved {
                    lambda: l,
                    value: v,
                } = self.solve_node(&leaf, &params.qp)?
                    && self.complementary(&l, tol)
                {
                    if best.as_ref().is_none_or(|b| v < b.1) {
                        best = Some((l, v));
                    }
                    if v <= value + self.gap(best.as_ref(), params.gap_tolerance) {
                        continue;
                    }
                }
            }
            let delta_i = self.contacts(&lambda)[worst];
            let likely_active = delta_i < lambda[self.n_a + worst];
            let (first, second) = if likely_active {
                (Mode::Active, Mode::Inactive)
            } else {
                (Mode::Inactive, Mode::Active)
            };
            // The stack pops the last child first.
            for mode in [second, first] {
                let mut child = modes.clone();
                child[worst] = mode;
                stack.push(child);
            }
        }
        Ok(self.finish(status, best, nodes, params.reach_tolerance))
    }

    /// Whether every contact's λ_i δ_i is within `tol` · ‖λ‖∞ max(‖δ_c‖∞, ‖δ_c^free‖∞).
    fn complementary(&self, lambda: &[f64], tol: f64) -> bool {
        let delta = self.contacts(lambda);
        // δ_c^free sets the gaps' scale: with every contact closed, δ_c itself is ~0.
        let scale = max_abs(lambda) * max_abs(&delta).max(max_abs(&self.delta_c_free));
        complementarity(&lambda[self.n_a..], &delta) <= tol * scale
    }

    /// Every free contact fixed to the side its relaxed solution is on.
    fn snap(&self, modes: &[Mode], lambda: &[f64]) -> Vec<Mode> {
        let delta = self.contacts(lambda);
        (0..modes.len())
            .map(|i| match modes[i] {
                Mode::Free if delta[i] < lambda[self.n_a + i] => Mode::Active,
                Mode::Free => Mode::Inactive,
                fixed => fixed,
            })
            .collect()
    }

    /// The absolute gap tolerance: relative to ½‖δ_e^free − δ_d‖² or the incumbent.
    fn gap(&self, best: Option<&(Vec<f64>, f64)>, tol: f64) -> f64 {
        let incumbent = best.map_or(0.0, |b| b.1);
        tol * self.offset().max(incumbent).max(f64::MIN_POSITIVE)
    }

    /// A cheap first incumbent: the plant's contact forces (the forward LCP) for the root's
    /// actuation, when W_cc is symmetric PSD and the forces are within their bounds.
    fn lcp_incumbent(&self, root: &[f64], params: &QpccParams, best: &mut Option<(Vec<f64>, f64)>) {
        let (qp, tolerance) = (&params.qp, params.complementarity_tolerance);
        let n_a = self.n_a;
        let actuation: Vec<f64> = (0..self.n())
            .map(|j| if j < n_a { root[j] } else { 0.0 })
            .collect();
        let gaps = self.contacts(&actuation);
        let contact_columns: Vec<usize> = (n_a..self.n()).collect();
        let w_cc = self.w_c.select_columns(&contact_columns);
        let Ok(lcp) = solve_contact_lcp(&w_cc, &gaps, qp) else {
            return;
        };
        let within = lcp
            .lambda
            .iter()
            .zip(&self.lambda_c_max)
            .all(|(l, m)| l <= m);
        // Only an exactly complementary point may become the incumbent (the interior point's
        // answer is kept when the polish fails).
        let scale = max_abs(&lcp.lambda) * max_abs(&lcp.delta);
        let complementary = lcp.complementarity <= tolerance * scale;
        if lcp.status == LcpStatus::Solved && within && complementary {
            let mut lambda = actuation;
            lambda[n_a..].copy_from_slice(&lcp.lambda);
            let value = self.residual_objective(&lambda);
            *best = Some((lambda, value));
        }
    }

    /// The test oracle: every one of the 2^n_c active sets (each contact active or
    /// inactive), one convex QP each, and the best feasible one. Refuses n_c >
    /// [`MAX_ORACLE_CONTACTS`]; use [`QpccProblem::solve`] in production.
    pub fn solve_exhaustive(&self, params: &QpccParams) -> InverseResult<QpccSolution> {
        self.validate()?;
        let n_c = self.n_c();
        if n_c > MAX_ORACLE_CONTACTS {
            return Err(InverseError::OracleContacts {
                contacts: n_c,
                max: MAX_ORACLE_CONTACTS,
            });
        }
        let mut best: Option<(Vec<f64>, f64)> = None;
        let mut status = QpccStatus::Solved;
        let sets = 1usize << n_c;
        for set in 0..sets {
            let modes: Vec<Mode> = (0..n_c)
                .map(|i| {
                    if set >> i & 1 == 1 {
                        Mode::Active
                    } else {
                        Mode::Inactive
                    }
                })
                .collect();
            match self.solve_node(&modes, &params.qp)? {
                NodeOutcome::Infeasible => {}
                NodeOutcome::Failed(s) => status = QpccStatus::QpFailed(s),
                NodeOutcome::Solved { lambda, value } => {
                    let tol = params.complementarity_tolerance;
                    if self.complementary(&lambda, tol) && best.as_ref().is_none_or(|b| value < b.1)
                    {
                        best = Some((lambda, value));
                    }
                }
            }
        }
        Ok(self.finish(status, best, sets, params.reach_tolerance))
    }

    /// The result for the best point found (`None`: infeasible, unless already failed).
    fn finish(
        &self,
        status: QpccStatus,
        best: Option<(Vec<f64>, f64)>,
        nodes: usize,
        reach_tolerance: f64,
    ) -> QpccSolution {
        let Some((lambda, _)) = best else {
            let status = if status == QpccStatus::Solved {
                QpccStatus::Infeasible
            } else {
                status
            };
            return QpccSolution {
                status,
                lambda: Vec::new(),
                delta_c: Vec::new(),
                delta_e: Vec::new(),
                residual_objective: f64::NAN,
                objective: f64::NAN,
                complementarity: f64::NAN,
                residual: f64::NAN,
                reachable: false,
                nodes,
            };
        };
        let delta_c = self.contacts(&lambda);
        let residual_objective = self.residual_objective(&lambda);
        let residual = (2.0 * residual_objective).sqrt();
        QpccSolution {
            status,
            complementarity: complementarity(&lambda[self.n_a..], &delta_c),
            delta_e: self.effectors(&lambda),
            objective: residual_objective - self.offset(),
            residual_objective,
            residual,
            reachable: self.reached(residual, reach_tolerance),
            delta_c,
            lambda,
            nodes,
        }
    }

    /// Whether a residual norm counts as the target reached.
    fn reached(&self, residual: f64, tol: f64) -> bool {
        residual <= tol * (2.0 * self.offset()).sqrt()
    }
}

/// M x + b.
fn affine(m: &DMatrix<f64>, x: &[f64], b: &[f64]) -> Vec<f64> {
    let y = m * DVector::from_column_slice(x);
    y.iter().zip(b).map(|(y, b)| y + b).collect()
}

/// max_i |λ_i δ_i| (0 when empty).
fn complementarity(lambda: &[f64], delta: &[f64]) -> f64 {
    let p = lambda.iter().zip(delta).map(|(l, d)| (l * d).abs());
    p.fold(0.0, f64::max)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn neg(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| -x).collect()
}

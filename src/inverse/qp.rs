//! A small dense QP interface over clarabel:
//! minimise ½xᵀPx + qᵀx subject to equality rows `A_eq x = b_eq`, bounds
//! `lower ≤ x ≤ upper` (infinite bounds are dropped) and second-order cones
//! `‖(G x + h)[1..]‖ ≤ (G x + h)[0]`.
//!
//! The result carries our own [`QpStatus`]; `x` is empty unless the status is a solution,
//! so a certificate of infeasibility can never be mistaken for forces.

use super::{InverseError, InverseResult};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use nalgebra::DMatrix;
use serde::Serialize;

/// How the QP solver ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum QpStatus {
    /// Solved to the requested accuracy.
    Solved,
    /// Solved to a reduced accuracy.
    AlmostSolved,
    /// The constraints cannot all hold (possibly at reduced accuracy).
    PrimalInfeasible,
    /// The objective is unbounded below (possibly at reduced accuracy).
    DualInfeasible,
    /// The iteration (or time) limit was reached first.
    MaxIterations,
    /// The solver failed numerically or stopped making progress.
    NumericalError,
}

impl QpStatus {
    /// Whether `x` is a (possibly reduced-accuracy) solution.
    pub fn is_solution(self) -> bool {
        matches!(self, QpStatus::Solved | QpStatus::AlmostSolved)
    }

    fn from_clarabel(s: SolverStatus) -> Self {
        match s {
            SolverStatus::Solved => QpStatus::Solved,
            SolverStatus::AlmostSolved => QpStatus::AlmostSolved,
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                QpStatus::PrimalInfeasible
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                QpStatus::DualInfeasible
            }
            SolverStatus::MaxIterations | SolverStatus::MaxTime => QpStatus::MaxIterations,
            _ => QpStatus::NumericalError,
        }
    }
}

/// Solver options.
#[derive(Clone, Debug)]
pub struct QpParams {
    /// Maximum interior-point iterations.
    pub max_iterations: u32,
    /// Absolute and relative gap / feasibility tolerance.
    pub tolerance: f64,
}

impl Default for QpParams {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tolerance: 1e-9,
        }
    }
}

/// A second-order cone on an affine image: ‖(G x + h)\[1..\]‖ ≤ (G x + h)\[0\].
#[derive(Clone, Debug)]
pub struct SecondOrderCone {
    /// k x n matrix (k ≥ 2).
    pub g: DMatrix<f64>,
    /// Offset of length k.
    pub h: Vec<f64>,
}

/// A dense QP with `n` unknowns.
#[derive(Clone, Debug)]
pub struct QpProblem {
    /// n x n symmetric positive semi-definite matrix (only the upper triangle is used).
    pub p: DMatrix<f64>,
    /// Linear term, length n.
    pub q: Vec<f64>,
    /// Equality rows, m x n.
    pub a_eq: DMatrix<f64>,
    /// Equality right-hand sides, length m.
    pub b_eq: Vec<f64>,
    /// Inequality rows, k x n: `a_le x <= b_le`.
    pub a_le: DMatrix<f64>,
    /// Inequality right-hand sides, length k.
    pub b_le: Vec<f64>,
    /// Lower bounds (−∞ for none), length n.
    pub lower: Vec<f64>,
    /// Upper bounds (+∞ for none), length n.
    pub upper: Vec<f64>,
    /// Second-order cones.
    pub cones: Vec<SecondOrderCone>,
}

/// The QP result.
#[derive(Clone, Debug, Serialize)]
pub struct QpSolution {
    /// How the solver ended.
    pub status: QpStatus,
    /// The minimiser when `status.is_solution()`, empty otherwise.
    pub x: Vec<f64>,
    /// ½xᵀPx + qᵀx at `x` (NaN when there is no solution).
    pub objective: f64,
    /// Interior-point iterations.
    pub iterations: u32,
}

impl QpSolution {
    /// The minimiser, or [`InverseError::NotSolved`].
    pub fn solution(&self) -> InverseResult<&[f64]> {
        if self.status.is_solution() {
            Ok(&self.x)
        } else {
            Err(InverseError::NotSolved(self.status))
        }
    }
}

impl QpProblem {
    /// An unconstrained zero problem with `n` unknowns.
    pub fn new(n: usize) -> Self {
        Self {
            p: DMatrix::zeros(n, n),
            q: vec![0.0; n],
            a_eq: DMatrix::zeros(0, n),
            b_eq: Vec::new(),
            a_le: DMatrix::zeros(0, n),
            b_le: Vec::new(),
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
            cones: Vec::new(),
        }
    }

    /// The least-squares problem min ½‖M x − d‖²: P = MᵀM, q = −Mᵀd.
    pub fn least_squares(m: &DMatrix<f64>, d: &[f64]) -> InverseResult<Self> {
        if m.nrows() != d.len() {
            return Err(InverseError::LeastSquaresShape {
                rows: m.nrows(),
                targets: d.len(),
            });
        }
        let mut p = Self::new(m.ncols());
        p.p = m.transpose() * m;
        let dv = nalgebra::DVector::from_column_slice(d);
        p.q = (-(m.transpose() * dv)).iter().copied().collect();
        Ok(p)
    }

    /// Number of unknowns.
    pub fn n(&self) -> usize {
        self.q.len()
    }

    fn validate(&self) -> InverseResult<()> {
        let n = self.n();
        if self.p.nrows() != n || self.p.ncols() != n {
            return Err(InverseError::ObjectiveShape {
                rows: self.p.nrows(),
                cols: self.p.ncols(),
                unknowns: n,
            });
        }
        let shape = |kind| Err(InverseError::ConstraintShape { kind });
        if self.a_eq.ncols() != n || self.a_eq.nrows() != self.b_eq.len() {
            return shape("equality");
        }
        if self.a_le.ncols() != n || self.a_le.nrows() != self.b_le.len() {
            return shape("inequality");
        }
        if self.lower.len() != n || self.upper.len() != n {
            return Err(InverseError::BoundsShape {
                lower: self.lower.len(),
                upper: self.upper.len(),
                unknowns: n,
            });
        }
        for (cone, c) in self.cones.iter().enumerate() {
            if c.g.ncols() != n || c.g.nrows() != c.h.len() || c.h.len() < 2 {
                return Err(InverseError::ConeShape { cone });
            }
        }
        let finite = self.p.iter().all(|v| v.is_finite())
            && self.q.iter().all(|v| v.is_finite())
            && self.a_eq.iter().all(|v| v.is_finite())
            && self.b_eq.iter().all(|v| v.is_finite())
            && self.a_le.iter().all(|v| v.is_finite())
            && self.b_le.iter().all(|v| v.is_finite())
            && self
                .cones
                .iter()
                .all(|c| c.g.iter().all(|v| v.is_finite()) && c.h.iter().all(|v| v.is_finite()));
        if !finite {
            return Err(InverseError::NonFiniteQp);
        }
        if self.lower.iter().any(|v| v.is_nan()) || self.upper.iter().any(|v| v.is_nan()) {
            return Err(InverseError::NanBound);
        }
        Ok(())
    }

    /// A QP without unknowns, which Clarabel cannot take (it panics in its factorisation):
    /// solved at x = [] when every constraint holds there, primal infeasible otherwise.
    fn solve_empty(&self) -> QpSolution {
        let feasible = self.b_eq.iter().all(|&b| b == 0.0)
            && self.b_le.iter().all(|&b| b >= 0.0)
            && self.cones.iter().all(|c| {
                let rest = c.h[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
                rest <= c.h[0]
            });
        QpSolution {
            status: match feasible {
                true => QpStatus::Solved,
                false => QpStatus::PrimalInfeasible,
            },
            x: Vec::new(),
            objective: if feasible { 0.0 } else { f64::NAN },
            iterations: 0,
        }
    }

    /// Solves the QP. Errors only on invalid data; a solver failure is a status.
    pub fn solve(&self, params: &QpParams) -> InverseResult<QpSolution> {
        self.validate()?;
        if self.q.is_empty() {
            return Ok(self.solve_empty());
        }
        let pm = self.objective_upper();
        let (am, b, cones) = self.clarabel_constraints();
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .max_iter(params.max_iterations)
            .tol_gap_abs(params.tolerance)
            .tol_gap_rel(params.tolerance)
            .tol_feas(params.tolerance)
            .build()?;
        let mut solver = DefaultSolver::new(&pm, &self.q, &am, &b, &cones, settings)?;
        solver.solve();
        let status = QpStatus::from_clarabel(solver.solution.status);
        let iterations = solver.solution.iterations;
        if !status.is_solution() {
            return Ok(QpSolution {
                status,
                x: Vec::new(),
                objective: f64::NAN,
                iterations,
            });
        }
        let x = solver.solution.x.clone();
        Ok(QpSolution {
            status,
            objective: self.objective(&x),
            x,
            iterations,
        })
    }

    /// P's upper triangle (symmetrised), as Clarabel takes it.
    fn objective_upper(&self) -> CscMatrix<f64> {
        let n = self.n();
        let mut triplets = Vec::new();
        for j in 0..n {
            for i in 0..=j {
                let v = 0.5 * (self.p[(i, j)] + self.p[(j, i)]);
                if v != 0.0 {
                    triplets.push((i, j, v));
                }
            }
        }
        csc(n, n, &triplets)
    }

    /// Every constraint in Clarabel's form A x + s = b, s in the cones: the equalities
    /// (zero cone), the inequalities and finite bounds (nonnegative cone), then the
    /// second-order cones.
    fn clarabel_constraints(&self) -> (CscMatrix<f64>, Vec<f64>, Vec<SupportedConeT<f64>>) {
        let n = self.n();
        let mut rows: Vec<(usize, usize, f64)> = Vec::new();
        let mut b = Vec::new();
        let mut cones = Vec::new();
        push_rows(&mut rows, &mut b, &self.a_eq, &self.b_eq, 1.0);
        if !self.b_eq.is_empty() {
            cones.push(SupportedConeT::ZeroConeT(self.b_eq.len()));
        }
        let before = b.len();
        // a x <= h  <=>  a x + s = h, s >= 0
        push_rows(&mut rows, &mut b, &self.a_le, &self.b_le, 1.0);
        for j in 0..n {
            if self.lower[j].is_finite() {
                // x_j >= l  <=>  -x_j + s = -l, s >= 0
                rows.push((b.len(), j, -1.0));
                b.push(-self.lower[j]);
            }
            if self.upper[j].is_finite() {
                rows.push((b.len(), j, 1.0));
                b.push(self.upper[j]);
            }
        }
        if b.len() > before {
            cones.push(SupportedConeT::NonnegativeConeT(b.len() - before));
        }
        for c in &self.cones {
            // s = G x + h in the cone: rows -G, right-hand side h.
            push_rows(&mut rows, &mut b, &c.g, &c.h, -1.0);
            cones.push(SupportedConeT::SecondOrderConeT(c.h.len()));
        }
        (csc(b.len(), n, &rows), b, cones)
    }

    /// ½xᵀPx + qᵀx.
    pub fn objective(&self, x: &[f64]) -> f64 {
        let n = self.n();
        let mut f = 0.0;
        for i in 0..n {
            f += self.q[i] * x[i];
            for j in 0..n {
                f += 0.5 * x[i] * self.p[(i, j)] * x[j];
            }
        }
        f
    }
}

/// Appends the rows `sign · a` (its non-zeros, as triplets numbered after the rows already
/// in `b`) and their right-hand sides `rhs` to `b`.
fn push_rows(
    rows: &mut Vec<(usize, usize, f64)>,
    b: &mut Vec<f64>,
    a: &DMatrix<f64>,
    rhs: &[f64],
    sign: f64,
) {
    for (i, &h) in rhs.iter().enumerate() {
        for j in 0..a.ncols() {
            let v = a[(i, j)];
            if v != 0.0 {
                rows.push((b.len(), j, sign * v));
            }
        }
        b.push(h);
    }
}

/// A CSC matrix from (row, col, value) triplets without repeats.
fn csc(m: usize, n: usize, t: &[(usize, usize, f64)]) -> CscMatrix<f64> {
    let mut sorted = t.to_vec();
    sorted.sort_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));
    let mut colptr = vec![0usize; n + 1];
    for &(_, j, _) in &sorted {
        colptr[j + 1] += 1;
    }
    for j in 0..n {
        colptr[j + 1] += colptr[j];
    }
    let rowval = sorted.iter().map(|e| e.0).collect();
    let nzval = sorted.iter().map(|e| e.2).collect();
    CscMatrix::new(m, n, colptr, rowval, nzval)
}

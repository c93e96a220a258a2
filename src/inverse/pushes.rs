//! Distributed pushes: a load spread over many surface nodes, each a non-negative push
//! along its own direction (inward), found from displacements the camera sees. It is the
//! load of a contact on the side the camera cannot see (the Punyo bubble seen from inside,
//! docs/real-data.md), where no contact point can be located and the load has no shape
//! known in advance.
//!
//! With whitened rows M = Σ^-½ W (W the compliance of the observed rows to the pushes) and
//! r = Σ^-½ (observed − free), the pushes solve min ½‖M λ − r‖² over λ ≥ 0 (the QP layer).
//! Their noise covariance is taken on the active set A (the pushes above zero):
//! Cov(λ_A) = (M_Aᵀ M_A)⁺, and the net force F = Σ λ_i d_i has Cov(F) = D_A Cov(λ_A) D_Aᵀ.

use super::qp::QpStatus;
use super::{InverseError, InverseResult};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::Serialize;

/// The data of one push problem (SI).
#[derive(Clone, Debug)]
pub struct PushProblem {
    /// Compliance of each observed row to a unit push (rows x pushes, m/N).
    pub compliance: DMatrix<f64>,
    /// What each row reads without pushes: the rest value moved by the known inputs (m).
    pub free: Vec<f64>,
    /// What each row reads in the frame (m).
    pub observed: Vec<f64>,
    /// Each row's noise, one sigma (m, positive).
    pub sigma: Vec<f64>,
    /// Each push's unit direction (the way it pushes the body).
    pub directions: Vec<[f64; 3]>,
    /// Each push's point (m), for the centre of pressure.
    pub positions: Vec<[f64; 3]>,
}

/// Options of [`solve_pushes`].
#[derive(Clone, Debug)]
pub struct PushParams {
    /// A push counts as part of the contact patch above this share of the largest one
    /// (default 0.05).
    pub patch_share: f64,
    /// Most active-set changes of the non-negative least squares (default 2000).
    pub max_iterations: usize,
}

impl Default for PushParams {
    fn default() -> Self {
        Self {
            patch_share: 0.05,
            max_iterations: 2000,
        }
    }
}

/// The pushes of one frame and what they add up to.
#[derive(Clone, Debug, Serialize)]
pub struct PushEstimate {
    /// How the QP ended (the other fields are zero unless it is a solution).
    pub status: QpStatus,
    /// Each push (N, ≥ 0), in the problem's order.
    pub pushes: Vec<f64>,
    /// Their sum as vectors (N).
    pub net_force: [f64; 3],
    /// |net_force| (N).
    pub magnitude: f64,
    /// One sigma of `magnitude` from the rows' noise alone (N).
    pub sigma_noise: f64,
    /// The pushes' mean point weighted by their size (m; the rest positions).
    pub centre_of_pressure: [f64; 3],
    /// The pushes above `patch_share` of the largest (indices into the problem's pushes).
    pub patch: Vec<usize>,
    /// Whitened residual sum of squares at the solution.
    pub chi2: f64,
}

/// Solves a [`PushProblem`].
pub fn solve_pushes(problem: &PushProblem, params: &PushParams) -> InverseResult<PushEstimate> {
    let (m, n) = problem.compliance.shape();
    let shape = InverseError::PushShape {
        rows: m,
        free: problem.free.len(),
        observed: problem.observed.len(),
        sigma: problem.sigma.len(),
        pushes: n,
        directions: problem.directions.len(),
        positions: problem.positions.len(),
    };
    if [
        problem.free.len(),
        problem.observed.len(),
        problem.sigma.len(),
    ] != [m; 3]
        || problem.directions.len() != n
        || problem.positions.len() != n
    {
        return Err(shape);
    }
    if m == 0 {
        return Err(InverseError::NoVisibleRows);
    }
    if let Some(row) = (problem.sigma.iter()).position(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(InverseError::PushSigma {
            row,
            sigma: problem.sigma[row],
        });
    }
    let mut whitened = problem.compliance.clone();
    for (i, s) in problem.sigma.iter().enumerate() {
        whitened.row_mut(i).scale_mut(1.0 / s);
    }
    let target: Vec<f64> = (problem
        .observed
        .iter()
        .zip(&problem.free)
        .zip(&problem.sigma))
    .map(|((o, f), s)| (o - f) / s)
    .collect();
    let target_v = DVector::from_column_slice(&target);
    let gram = whitened.transpose() * &whitened;
    let h = whitened.transpose() * &target_v;
    let (x, converged) = nnls_gram(&gram, &h, params.max_iterations);
    let mut out = PushEstimate {
        status: match converged {
            true => QpStatus::Solved,
            false => QpStatus::MaxIterations,
        },
        pushes: vec![0.0; n],
        net_force: [0.0; 3],
        magnitude: 0.0,
        sigma_noise: 0.0,
        centre_of_pressure: [0.0; 3],
        patch: Vec::new(),
        chi2: f64::NAN,
    };
    if !converged {
        return Ok(out);
    }
    out.pushes = x.iter().map(|v| v.max(0.0)).collect();
    let residual = &whitened * DVector::from_column_slice(&out.pushes) - target_v;
    out.chi2 = residual.norm_squared();
    let mut force = Vector3::zeros();
    let mut centre = Vector3::zeros();
    let total: f64 = out.pushes.iter().sum();
    for (i, &l) in out.pushes.iter().enumerate() {
        force += Vector3::from(problem.directions[i]) * l;
        centre += Vector3::from(problem.positions[i]) * l;
    }
    out.net_force = force.into();
    out.magnitude = force.norm();
    if total > 0.0 {
        out.centre_of_pressure = (centre / total).into();
    }
    let largest = out.pushes.iter().fold(0.0f64, |a, &b| a.max(b));
    out.patch = (0..n)
        .filter(|&i| largest > 0.0 && out.pushes[i] > params.patch_share * largest)
        .collect();
    out.sigma_noise = noise_sigma(problem, &whitened, &out.pushes, force);
    Ok(out)
}

/// One sigma of |F| from the active set's covariance (see the module docs).
fn noise_sigma(problem: &PushProblem, m: &DMatrix<f64>, pushes: &[f64], f: Vector3<f64>) -> f64 {
    // The active set: pushes that are not zero (the solver leaves the others at exactly 0).
    let active: Vec<usize> = (0..pushes.len()).filter(|&i| pushes[i] > 0.0).collect();
    if active.is_empty() || f.norm() == 0.0 {
        return 0.0;
    }
    let ma = m.select_columns(&active);
    let Ok(cov) = (ma.transpose() * &ma).pseudo_inverse(1e-12) else {
        return f64::INFINITY;
    };
    let d = DMatrix::from_fn(3, active.len(), |r, c| problem.directions[active[c]][r]);
    let cov_f: Matrix3<f64> = (&d * cov * d.transpose()).fixed_view::<3, 3>(0, 0).into();
    let u = f / f.norm();
    (u.transpose() * cov_f * u)[(0, 0)].max(0.0).sqrt()
}

/// Non-negative least squares in Gram form, min ½ λᵀ G λ − hᵀ λ over λ ≥ 0 (G = MᵀM,
/// h = Mᵀr of min ‖M λ − r‖²), by Lawson and Hanson's active set: pushes enter one at a
/// time where the gradient is steepest, and leave when the unconstrained solution on the
/// set would make them negative. Returns the solution and whether it converged within
/// `max_iterations` entries.
pub fn nnls_gram(
    g: &DMatrix<f64>,
    h: &DVector<f64>,
    max_iterations: usize,
) -> (DVector<f64>, bool) {
    let n = h.len();
    let mut x = DVector::zeros(n);
    let mut active = vec![false; n];
    let scale = h.amax().max(f64::MIN_POSITIVE);
    let tol = 1e-10 * scale;
    for _ in 0..max_iterations {
        let w = h - g * &x;
        let entering = (0..n)
            .filter(|&j| !active[j] && w[j] > tol)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        let Some(j) = entering else {
            return (x, true);
        };
        active[j] = true;
        loop {
            let set: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
            let Some(z) = solve_on(g, h, &set) else {
                // The set is singular with the new push: it cannot lower the objective.
                active[j] = false;
                return (x, true);
            };
            if z.iter().all(|&v| v > 0.0) {
                for (k, &i) in set.iter().enumerate() {
                    x[i] = z[k];
                }
                break;
            }
            // Step from x toward z until the first push reaches zero; it leaves the set
            // (with any other that reaches zero with it).
            let (mut alpha, mut blocking) = (f64::INFINITY, set[0]);
            for (k, &i) in set.iter().enumerate() {
                if z[k] <= 0.0 {
                    let a = x[i] / (x[i] - z[k]);
                    if a < alpha {
                        (alpha, blocking) = (a, i);
                    }
                }
            }
            let tiny = 1e-14 * x.amax();
            for (k, &i) in set.iter().enumerate() {
                x[i] += alpha * (z[k] - x[i]);
                if i == blocking || x[i] <= tiny {
                    x[i] = 0.0;
                    active[i] = false;
                }
            }
        }
        if !active[j] {
            // The entering push left at once (rounding at the optimum): nothing improves.
            return (x, true);
        }
    }
    (x, false)
}

/// The unconstrained minimiser on `set`: G_ss z = h_s (Cholesky), `None` if singular.
fn solve_on(g: &DMatrix<f64>, h: &DVector<f64>, set: &[usize]) -> Option<DVector<f64>> {
    let gs = g.select_rows(set).select_columns(set);
    let hs = DVector::from_iterator(set.len(), set.iter().map(|&i| h[i]));
    gs.cholesky().map(|c| c.solve(&hs))
}

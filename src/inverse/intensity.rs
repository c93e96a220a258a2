//! The intensity QP in normal space (thesis 4.5.2, equations 4.14-4.18).
//!
//! Unknowns λ = [λ_a; λ_f] (actuator forces, then force intensities at candidate locations).
//! Rows are the normal displacements of the visible registered feature points:
//! δ_e^N = W_ea^N λ_a + W_ef^N λ_f + δ_e^{free,N} (4.14). The QP minimises
//! ½‖W_eI^N λ + δ_e^{free,N} − δ_d^N‖² (4.15/4.16) with λ_a = λ_a^r for force-controlled
//! actuators (4.17) or W_a^N λ + δ_a^{free} = δ_a^r for displacement-controlled ones (4.18),
//! plus pushing-only bounds (λ_f ≥ 0) where asked and an optional Tikhonov term.

use super::lsq;
pub use super::lsq::Identifiability;
use super::qp::{QpParams, QpProblem, QpStatus};
use super::{InverseError, InverseResult};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// How one actuator is driven in the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActuatorInput {
    /// Known force λ_a^r (N): an equality λ_a = value (4.17).
    Force(f64),
    /// Known actuator displacement δ_a^r (m): an equality on the actuator row (4.18).
    Displacement(f64),
}

/// `wei x − target`: the rows' residuals at the unknowns `x` ([actuators, forces]).
fn residuals_of(wei: &DMatrix<f64>, target: &[f64], x: &[f64]) -> DVector<f64> {
    wei * DVector::from_column_slice(x) - DVector::from_column_slice(target)
}

/// The data of one intensity QP (all normal-space, SI).
#[derive(Clone, Debug)]
pub struct IntensityProblem {
    /// W_ea^N: m feature rows x a actuators.
    pub w_ea: DMatrix<f64>,
    /// W_ef^N: m feature rows x k candidate forces.
    pub w_ef: DMatrix<f64>,
    /// δ_e^{free,N}: free normal displacement of each feature row (m).
    pub delta_free_e: Vec<f64>,
    /// δ_d^N: measured normal displacement of each feature row (m).
    pub delta_measured: Vec<f64>,
    /// W_aa: a x a actuator compliance (needed for displacement-controlled actuators).
    pub w_aa: DMatrix<f64>,
    /// W_af: a x k coupling between actuators and candidate forces.
    pub w_af: DMatrix<f64>,
    /// δ_a^{free}: free actuator displacements (a).
    pub delta_free_a: Vec<f64>,
    /// Control input of each actuator (a).
    pub actuators: Vec<ActuatorInput>,
    /// Per candidate force: whether it can only push (λ_f ≥ 0).
    pub push_only: Vec<bool>,
    /// The feature rows' noise, where known (the dense rows); else empty.
    pub row_noise: RowNoise,
}

/// What the dense rows know of their noise (empty for the features, whose noise
/// [`crate::inverse::uncertainty`] takes from their points).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RowNoise {
    /// Each row's expected noise (m).
    pub sigma: Vec<f64>,
    /// Each row's patch (the FE surface triangle it meets): the model cannot bend within
    /// a triangle, so rows of one patch share its misfit.
    pub patch: Vec<usize>,
}

/// Options of the intensity QP.
#[derive(Clone, Debug)]
pub struct IntensityParams {
    /// Tikhonov weight ε on ‖λ_f‖² (relative to the largest diagonal of W_efᵀW_ef).
    pub regularization: f64,
    /// Standard deviation of one measured normal displacement (m), for the uncertainties.
    pub sensor_sigma: f64,
    /// I_w above which a warning is issued (N/m).
    pub max_i_w: f64,
    /// QP solver options.
    pub qp: QpParams,
}

impl Default for IntensityParams {
    fn default() -> Self {
        Self {
            regularization: 0.0,
            sensor_sigma: 1.0e-3,
            max_i_w: 1.0e6,
            qp: QpParams::default(),
        }
    }
}

/// The estimate of one frame.
#[derive(Clone, Debug, Serialize)]
pub struct IntensityEstimate {
    /// QP status (the forces below are empty unless it is a solution).
    pub status: QpStatus,
    /// Actuator forces λ_a (N).
    pub actuator_forces: Vec<f64>,
    /// Force intensities λ_f (N).
    pub forces: Vec<f64>,
    /// One-sigma uncertainty of each λ_f from the sensor noise and W (N): Gauss-Markov
    /// with independent rows of `IntensityParams::sensor_sigma` each, unless replaced by
    /// the square roots of `force_covariance`'s diagonal.
    pub force_sigma: Vec<f64>,
    /// Covariance of the λ_f (N², forces x forces) when the rows' noise is known as a
    /// matrix ([`IntensityProblem::force_covariance`]); `None`: only `force_sigma`.
    #[serde(skip)]
    pub force_covariance: Option<DMatrix<f64>>,
    /// RMS of the normal-displacement residual at the solution (m).
    pub residual_rms: f64,
    /// A robust spread of the same residual: 1.4826 times its median absolute value (m).
    /// It equals the RMS for Gaussian residuals; a few outlying features (points of a
    /// touching object taken for the robot, say) barely move it, while a wrong location
    /// raises it as much as the RMS.
    pub residual_robust: f64,
    /// The identifiability check done before solving.
    pub identifiability: Identifiability,
    /// How far the regularization pulls the least-identified direction of the forces
    /// toward zero: εs / (σ²_min + εs), with σ²_min the smallest eigenvalue of W_efᵀW_ef and
    /// εs the Tikhonov term added to it (both as in the QP; the coupling to the actuator
    /// unknowns is left out). 0 without regularization; 0.1: that direction is estimated
    /// 10% short. See [`IntensityEstimate::regularization_warning`].
    pub regularization_shrink: f64,
}

/// `regularization_shrink` above which [`IntensityEstimate::regularization_warning`] warns.
pub const MAX_REGULARIZATION_SHRINK: f64 = 0.1;

impl IntensityEstimate {
    /// A warning when the regularization pulls the least-identified force direction toward
    /// zero by more than [`MAX_REGULARIZATION_SHRINK`]: the forces are then biased by the
    /// regularization more than decided by the data.
    pub fn regularization_warning(&self) -> Option<String> {
        (self.regularization_shrink > MAX_REGULARIZATION_SHRINK).then(|| {
            format!(
                "the regularization pulls the least-identified force direction {:.0}% toward zero (more than {:.0}%): the forces are biased; lower IntensityParams::regularization",
                100.0 * self.regularization_shrink,
                100.0 * MAX_REGULARIZATION_SHRINK
            )
        })
    }
}

impl IntensityProblem {
    fn check(&self) -> InverseResult<(usize, usize, usize)> {
        let m = self.delta_measured.len();
        let a = self.actuators.len();
        let k = self.push_only.len();
        let ok = self.w_ea.shape() == (m, a)
            && self.w_ef.shape() == (m, k)
            && self.delta_free_e.len() == m
            && self.w_aa.shape() == (a, a)
            && self.w_af.shape() == (a, k)
            && self.delta_free_a.len() == a;
        if !ok {
            return Err(InverseError::IntensityShape {
                rows: m,
                actuators: a,
                forces: k,
            });
        }
        if m == 0 {
            return Err(InverseError::NoVisibleRows);
        }
        Ok((m, a, k))
    }

    /// Rows against unknowns (the forces and the displacement-controlled actuators) and
    /// I_w = ‖W_ef⁺‖ ([`lsq::identifiability`]).
    pub fn identifiability(&self, params: &IntensityParams) -> Identifiability {
        let unknowns = self.w_ef.ncols()
            + (self.actuators.iter())
                .filter(|a| matches!(a, ActuatorInput::Displacement(_)))
                .count();
        lsq::identifiability(&self.w_ef, unknowns, params.max_i_w)
    }

    /// Solves the QP (4.16) with (4.17)/(4.18) and the bounds.
    pub fn solve(&self, params: &IntensityParams) -> InverseResult<IntensityEstimate> {
        let (m, a, k) = self.check()?;
        let ident = self.identifiability(params);
        let n = a + k;
        let (wei, target, scale) = self.weighted();
        // Rows scaled to O(1): interior-point gaps are absolute and compliances are ~1e-3 m/N.
        let scaled_target: Vec<f64> = target.iter().map(|t| t / scale).collect();
        let mut qp = QpProblem::least_squares(&(&wei / scale), &scaled_target)?;
        let mut regularization_shrink = 0.0;
        if params.regularization > 0.0 {
            let scale = (a..n).map(|j| qp.p[(j, j)]).fold(0.0, f64::max);
            let added = params.regularization * scale;
            if k > 0 {
                let forces = qp.p.view((a, a), (k, k)).clone_owned();
                let smallest = forces.symmetric_eigenvalues().min().max(0.0);
                regularization_shrink = added / (smallest + added);
            }
            for j in a..n {
                qp.p[(j, j)] += added;
            }
        }
        let (eq_rows, eq_b) = self.actuator_equations();
        qp.a_eq = DMatrix::from_fn(a, n, |i, j| eq_rows[i][j]);
        qp.b_eq = eq_b;
        for (j, &push) in self.push_only.iter().enumerate() {
            if push {
                qp.lower[a + j] = 0.0;
            }
        }
        let sol = qp.solve(&params.qp)?;
        if !sol.status.is_solution() {
            return Ok(IntensityEstimate {
                status: sol.status,
                actuator_forces: Vec::new(),
                forces: Vec::new(),
                force_sigma: Vec::new(),
                force_covariance: None,
                residual_rms: f64::NAN,
                residual_robust: f64::NAN,
                identifiability: ident,
                regularization_shrink,
            });
        }
        let r = residuals_of(&wei, &target, &sol.x);
        let residual_rms = (r.norm_squared() / m as f64).sqrt();
        let mut abs: Vec<f64> = r.iter().map(|v| v.abs()).collect();
        let residual_robust = 1.4826 * crate::math::median(&mut abs);
        Ok(IntensityEstimate {
            status: sol.status,
            actuator_forces: sol.x[..a].to_vec(),
            forces: sol.x[a..].to_vec(),
            force_sigma: self.force_sigma(params.sensor_sigma),
            force_covariance: None,
            residual_rms,
            residual_robust,
            identifiability: ident,
            regularization_shrink,
        })
    }

    /// Each feature row's residual (m) at `actuator_forces` and `forces` (e.g. an
    /// estimate's): the predicted offset W_ea λ_a + W_ef λ_f less the measured one
    /// (δ_measured − δ_free_e). `None` when the lengths do not fit the problem.
    pub fn residuals(&self, actuator_forces: &[f64], forces: &[f64]) -> Option<Vec<f64>> {
        if actuator_forces.len() != self.w_ea.ncols() || forces.len() != self.w_ef.ncols() {
            return None;
        }
        let (wei, target, _) = self.weighted();
        let x: Vec<f64> = actuator_forces.iter().chain(forces).copied().collect();
        Some(residuals_of(&wei, &target, &x).iter().copied().collect())
    }

    /// The residual RMS of this problem without its push-only bounds: the least squares
    /// under the actuator equations alone, in closed form (the KKT system). Never above the
    /// residual of [`IntensityProblem::solve`] (with `regularization` 0), which has the same
    /// objective and equations and more constraints, so it bounds it from below. `None`
    /// when the forces are not determined without the bounds (a singular KKT system).
    pub fn unbounded_residual_rms(&self) -> Option<f64> {
        let (m, a, k) = self.check().ok()?;
        let n = a + k;
        // Scaled as in `solve`, with the same actuator equations.
        let (wei, target, scale) = self.weighted();
        let w = wei / scale;
        let t = DVector::from_iterator(m, target.iter().map(|v| v / scale));
        let mut kkt = DMatrix::zeros(n + a, n + a);
        kkt.view_mut((0, 0), (n, n))
            .copy_from(&(w.transpose() * &w));
        let mut rhs = DVector::zeros(n + a);
        rhs.rows_mut(0, n).copy_from(&(w.transpose() * &t));
        let (eq_rows, eq_b) = self.actuator_equations();
        for (i, (row, b)) in eq_rows.into_iter().zip(eq_b).enumerate() {
            for (j, v) in row.into_iter().enumerate() {
                kkt[(n + i, j)] = v;
                kkt[(j, n + i)] = v;
            }
            rhs[n + i] = b;
        }
        let lu = kkt.clone().lu();
        let mut sol = lu.solve(&rhs)?;
        // One step of iterative refinement: the bound must not come out above the true
        // minimum by the solve's error.
        sol += lu.solve(&(&rhs - &kkt * &sol))?;
        let x = sol.rows(0, n);
        let r = &w * x - t;
        let rms = scale * (r.norm_squared() / m as f64).sqrt();
        rms.is_finite().then_some(rms)
    }

    /// [W_ea W_ef] (rows x actuators + forces), the target δ_measured − δ_free_e, and the
    /// largest |entry| of the matrix (the scale both solvers divide by).
    fn weighted(&self) -> (DMatrix<f64>, Vec<f64>, f64) {
        let (m, a, k) = (self.w_ef.nrows(), self.w_ea.ncols(), self.w_ef.ncols());
        let mut wei = DMatrix::zeros(m, a + k);
        wei.view_mut((0, 0), (m, a)).copy_from(&self.w_ea);
        wei.view_mut((0, a), (m, k)).copy_from(&self.w_ef);
        let target = (0..m)
            .map(|i| self.delta_measured[i] - self.delta_free_e[i])
            .collect();
        let scale = wei.amax().max(f64::MIN_POSITIVE);
        (wei, target, scale)
    }

    /// The actuator equations (4.17)/(4.18) over [actuators, forces], a row and a right-hand
    /// side each: a force-controlled actuator's force is its input; a displacement-controlled
    /// one's row W_aa, W_af is its input's, divided by its largest |entry|.
    fn actuator_equations(&self) -> (Vec<Vec<f64>>, Vec<f64>) {
        let (a, n) = (
            self.actuators.len(),
            self.actuators.len() + self.push_only.len(),
        );
        let mut eq_rows = Vec::new();
        let mut eq_b = Vec::new();
        for (i, input) in self.actuators.iter().enumerate() {
            let mut row = vec![0.0; n];
            match *input {
                ActuatorInput::Force(f) => {
                    row[i] = 1.0;
                    eq_b.push(f);
                }
                ActuatorInput::Displacement(d) => {
                    for (j, r) in row.iter_mut().enumerate() {
                        *r = if j < a {
                            self.w_aa[(i, j)]
                        } else {
                            self.w_af[(i, j - a)]
                        };
                    }
                    let s = row.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                    let s = if s > 0.0 { s } else { 1.0 };
                    row.iter_mut().for_each(|v| *v /= s);
                    eq_b.push((d - self.delta_free_a[i]) / s);
                }
            }
            eq_rows.push(row);
        }
        (eq_rows, eq_b)
    }

    /// Covariance of the force unknowns (actuator forces held, bounds ignored, as
    /// [`IntensityProblem::force_sigma`]) when the measured offsets have covariance
    /// `rows` (m², feature rows x feature rows): A C Aᵀ with A = (W_efᵀ W_ef)⁻¹ W_efᵀ, the
    /// least squares' own map from offsets to forces. With C = σ² I it is σ² (W_efᵀ W_ef)⁻¹.
    /// `None` when not identifiable or `rows` does not fit.
    pub fn force_covariance(&self, rows: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        let m = self.w_ef.nrows();
        if rows.nrows() != m || rows.ncols() != m {
            return None;
        }
        self.force_covariance_with(|a| Some(a * rows * a.transpose()))
    }

    /// [`IntensityProblem::force_covariance`] with the product A C Aᵀ left to `sandwich`
    /// (given A, forces x rows), e.g. one that never forms C.
    pub fn force_covariance_with(
        &self,
        sandwich: impl FnOnce(&DMatrix<f64>) -> Option<DMatrix<f64>>,
    ) -> Option<DMatrix<f64>> {
        lsq::covariance_with(&self.w_ef, sandwich)
    }

    /// The cluster-robust (White, Liang-Zeger) covariance of the force unknowns from the
    /// `residuals` r of the feature rows: Σ_g (A_g r_g)(A_g r_g)ᵀ over the groups g of rows
    /// sharing a `patch` entry (each row its own group when `patch` is empty), with
    /// A = (W_efᵀ W_ef)⁻¹ W_efᵀ. Each row's variance is its own squared residual, and rows
    /// of a group are as correlated as their residuals. `None` when the lengths differ or
    /// the forces are not identifiable.
    pub fn white_covariance(&self, residuals: &[f64], patch: &[usize]) -> Option<DMatrix<f64>> {
        let m = self.w_ef.nrows();
        if residuals.len() != m || !(patch.is_empty() || patch.len() == m) {
            return None;
        }
        self.force_covariance_with(|a| {
            let k = a.nrows();
            let mut sums: std::collections::BTreeMap<usize, DVector<f64>> = Default::default();
            for (j, r) in residuals.iter().enumerate() {
                let g = if patch.is_empty() { j } else { patch[j] };
                let sum = sums.entry(g).or_insert_with(|| DVector::zeros(k));
                sum.axpy(*r, &a.column(j), 1.0);
            }
            let mut cov = DMatrix::zeros(k, k);
            for s in sums.values() {
                cov.ger(1.0, s, s, 1.0);
            }
            Some(cov)
        })
    }

    /// σ_f = σ_d sqrt(diag((W_efᵀ W_ef)⁻¹)): the Gauss-Markov spread of the force unknowns
    /// with the actuator forces held (bounds ignored). Infinite when not identifiable.
    pub fn force_sigma(&self, sensor_sigma: f64) -> Vec<f64> {
        lsq::gauss_markov_sigma(&self.w_ef, sensor_sigma)
    }
}

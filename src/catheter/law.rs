//! The robot controller (thesis 5.4.3): the PD law in task space (5.20) allocated by the
//! pseudo-inverse of the Jacobian J = W_ea W_aa⁻¹ (5.18, 5.21), u = −J⁺[K_P e_k +
//! K_D (e_k − e_{k−1})] (5.22); and the check of a Jacobian rotation (5.5.7.1): whether
//! the true J seen through the model's pseudo-inverse still points the right way.

use super::{CatheterError, CatheterResult};
use nalgebra::DMatrix;

/// Gains of the PD law (5.20).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdGains {
    /// Proportional gain K_P (per step; 0.2, the thesis's).
    pub kp: f64,
    /// Differential gain K_D (per step; 0.002, the thesis's).
    pub kd: f64,
}

impl Default for PdGains {
    fn default() -> Self {
        Self { kp: 0.2, kd: 0.002 }
    }
}

/// The PD law with its memory of the last error.
#[derive(Clone, Debug)]
pub struct PdLaw {
    /// Gains.
    pub gains: PdGains,
    last_error: Option<Vec<f64>>,
}

/// The Jacobian J = W_ea W_aa⁻¹ (5.18) from the effector and actuator rows of W.
pub fn jacobian(w_ea: &DMatrix<f64>, w_aa: &DMatrix<f64>) -> CatheterResult<DMatrix<f64>> {
    if w_aa.nrows() != w_aa.ncols() || w_ea.ncols() != w_aa.nrows() {
        return Err(CatheterError::Shape(format!(
            "W_ea is {}x{} and W_aa {}x{}: W_aa must be square with W_ea's columns",
            w_ea.nrows(),
            w_ea.ncols(),
            w_aa.nrows(),
            w_aa.ncols()
        )));
    }
    let inv = w_aa.clone().try_inverse().ok_or(CatheterError::Singular {
        what: "W_aa",
        rank: w_aa.rank(1e-12 * w_aa.norm()),
    })?;
    Ok(w_ea * inv)
}

/// J⁺ = Jᵀ(JJᵀ)⁻¹ for a J of full row rank (5.21); an error when the rank is lower.
pub fn right_pseudo_inverse(j: &DMatrix<f64>) -> CatheterResult<DMatrix<f64>> {
    let jjt = j * j.transpose();
    let tol = 1e-12 * jjt.norm().max(f64::MIN_POSITIVE);
    let rank = jjt.rank(tol);
    if rank < j.nrows() {
        return Err(CatheterError::Singular {
            what: "J Jᵀ", rank
        });
    }
    let inv = jjt.try_inverse().ok_or(CatheterError::Singular {
        what: "J Jᵀ", rank
    })?;
    Ok(j.transpose() * inv)
}

impl PdLaw {
    /// A law with no history.
    pub fn new(gains: PdGains) -> Self {
        Self {
            gains,
            last_error: None,
        }
    }

    /// The input increment u = Δδ_a for error e_k = δ_e − δ_d (5.22). At the first step
    /// the differential term is zero (e_{k−1} = e_k).
    pub fn step(&mut self, j: &DMatrix<f64>, error: &[f64]) -> CatheterResult<Vec<f64>> {
        if error.len() != j.nrows() {
            return Err(CatheterError::Shape(format!(
                "error has {} entries, J has {} rows",
                error.len(),
                j.nrows()
            )));
        }
        let last = self.last_error.as_deref().unwrap_or(error);
        let task = nalgebra::DVector::from_iterator(
            error.len(),
            error
                .iter()
                .zip(last)
                .map(|(&e, &l)| -(self.gains.kp * e + self.gains.kd * (e - l))),
        );
        let u = right_pseudo_inverse(j)? * task;
        self.last_error = Some(error.to_vec());
        Ok(u.iter().copied().collect())
    }
}

/// The smallest eigenvalue of sym(J_true Ĵ⁺): negative when the model's Jacobian points
/// some task direction the wrong way through the true robot (a rotated J, 5.5.7.1), so
/// that the loop pushes the error up along it.
pub fn rotation_margin(j_true: &DMatrix<f64>, j_model: &DMatrix<f64>) -> CatheterResult<f64> {
    if j_true.shape() != j_model.shape() {
        return Err(CatheterError::Shape(format!(
            "true J is {:?} and model J {:?}",
            j_true.shape(),
            j_model.shape()
        )));
    }
    let m = j_true * right_pseudo_inverse(j_model)?;
    let sym = (&m + m.transpose()) * 0.5;
    Ok(sym.symmetric_eigenvalues().min())
}

//! Isotropic linear elastic material (Hooke): Young's modulus and Poisson ratio, Lamé form.

use super::{FemError, FemResult};
use nalgebra::Matrix3;

/// An isotropic Hookean material in SI units.
///
/// The fields are private because the element code reads only the Lamé pair: a Young's
/// modulus changed in place would be silently ignored. Build a changed material with
/// [`Material::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    young: f64,
    poisson: f64,
    lambda: f64,
    mu: f64,
}

impl Material {
    /// From Young's modulus `e` (Pa) and Poisson ratio `nu`; rejects non-physical values.
    pub fn new(e: f64, nu: f64) -> FemResult<Self> {
        if !(e > 0.0 && e.is_finite()) {
            return Err(FemError::Material(format!(
                "Young's modulus {e} must be > 0"
            )));
        }
        if !(nu > -1.0 && nu < 0.5) {
            return Err(FemError::Material(format!(
                "Poisson ratio {nu} must be in (-1, 0.5)"
            )));
        }
        Ok(Self {
            young: e,
            poisson: nu,
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
        })
    }

    /// Young's modulus (Pa).
    pub fn young(&self) -> f64 {
        self.young
    }

    /// Poisson ratio (-1 < nu < 0.5).
    pub fn poisson(&self) -> f64 {
        self.poisson
    }

    /// First Lamé parameter lambda (Pa).
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// Shear modulus mu (Pa).
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// Cauchy stress of a (symmetric) small strain: lambda tr(eps) I + 2 mu eps.
    pub fn stress(&self, eps: &Matrix3<f64>) -> Matrix3<f64> {
        Matrix3::identity() * (self.lambda * eps.trace()) + eps * (2.0 * self.mu)
    }
}

/// Von Mises equivalent stress of a symmetric stress tensor.
pub fn von_mises(s: &Matrix3<f64>) -> f64 {
    let d = (s[(0, 0)] - s[(1, 1)]).powi(2)
        + (s[(1, 1)] - s[(2, 2)]).powi(2)
        + (s[(2, 2)] - s[(0, 0)]).powi(2);
    let o = s[(0, 1)].powi(2) + s[(1, 2)].powi(2) + s[(0, 2)].powi(2);
    (0.5 * d + 3.0 * o).sqrt()
}

//! The compressible Neo-Hookean tetrahedron: a hyperelastic law for large strains, with
//! the same Lamé pair (λ, μ from E, ν) as the linear and corotational elements, so that
//! the three agree at small strain.
//!
//! Energy density (Pa), with J = det F:
//! W(F) = μ/2 (tr(FᵀF) − 3) − μ ln J + λ/2 (ln J)².
//! First Piola stress P = ∂W/∂F = μ (F − F⁻ᵀ) + λ ln J F⁻ᵀ, nodal force f_a = V P g_a
//! (g_a the rest shape-function gradients), and the consistent tangent per 3x3 block,
//! with h_a = F⁻ᵀ g_a:
//! K_ab = V (μ (g_a · g_b) I + λ h_a h_bᵀ + (μ − λ ln J) h_b h_aᵀ),
//! the exact Hessian of V W (symmetric). At F = I it is the small-strain K0.
//!
//! J ≤ 0 is an inverted element ([`FemError::InvertedElement`]): W is undefined there.

use super::material::Material;
use super::tet4::{ElementState, Mat12, Tangent, TetRest, ALL_BLOCKS};
use super::{FemError, FemResult};
use nalgebra::{Matrix3, SMatrix, Vector3};

/// dP/dF as a 9x9 matrix: entry (3i + j, 3k + l) is ∂P_ij/∂F_kl.
pub type Mat9 = SMatrix<f64, 9, 9>;

/// Energy density W(F) (Pa) for det F > 0 (see the module docs).
pub fn compute_energy_density(m: &Material, f: &Matrix3<f64>) -> f64 {
    let ln_j = f.determinant().ln();
    0.5 * m.mu() * (f.norm_squared() - 3.0) - m.mu() * ln_j + 0.5 * m.lambda() * ln_j * ln_j
}

/// First Piola stress P = μ (F − F⁻ᵀ) + λ ln J F⁻ᵀ (Pa) for det F > 0.
pub fn compute_stress(m: &Material, f: &Matrix3<f64>) -> Matrix3<f64> {
    let (f_inv_t, ln_j) = inverse_transpose_and_log_det(f);
    piola(m, f, &f_inv_t, ln_j)
}

/// P from F, F⁻ᵀ and ln J.
fn piola(m: &Material, f: &Matrix3<f64>, f_inv_t: &Matrix3<f64>, ln_j: f64) -> Matrix3<f64> {
    f * m.mu() + f_inv_t * (m.lambda() * ln_j - m.mu())
}

/// The stress derivative dP/dF (Pa) for det F > 0, with G = F⁻¹:
/// ∂P_ij/∂F_kl = μ δ_ik δ_jl + λ G_ji G_lk + (μ − λ ln J) G_jk G_li.
#[allow(non_snake_case)]
pub fn compute_stiffness(m: &Material, f: &Matrix3<f64>) -> Mat9 {
    let (f_inv_t, ln_j) = inverse_transpose_and_log_det(f);
    let G = f_inv_t.transpose();
    let c = m.mu() - m.lambda() * ln_j;
    Mat9::from_fn(|r, s| {
        let (i, j, k, l) = (r / 3, r % 3, s / 3, s % 3);
        let id = if i == k && j == l { m.mu() } else { 0.0 };
        id + m.lambda() * G[(j, i)] * G[(l, k)] + c * G[(j, k)] * G[(l, i)]
    })
}

/// F⁻ᵀ and ln det F (det F > 0, checked by the callers).
fn inverse_transpose_and_log_det(f: &Matrix3<f64>) -> (Matrix3<f64>, f64) {
    let f_inv = f
        .try_inverse()
        .unwrap_or_else(|| Matrix3::from_element(f64::NAN));
    (f_inv.transpose(), f.determinant().ln())
}

impl TetRest {
    /// Deformation gradient F at positions `x`, checked for the Neo-Hookean element: det F
    /// ≤ 0 (or NaN) is the inverted-element error naming `tet`, as W is undefined there.
    pub fn neo_hookean_gradient(&self, tet: usize, x: &[[f64; 3]; 4]) -> FemResult<Matrix3<f64>> {
        let f = self.deformation_gradient(x);
        let det = f.determinant();
        if !(det > 0.0) {
            return Err(FemError::InvertedElement { tet, volume: det });
        }
        Ok(f)
    }

    /// Neo-Hookean internal force, Cauchy stress and consistent tangent at positions `x`;
    /// `tet` names the element if it is inverted (det F ≤ 0).
    pub fn neo_hookean(
        &self,
        tet: usize,
        m: &Material,
        x: &[[f64; 3]; 4],
    ) -> FemResult<ElementState> {
        let f = self.neo_hookean_gradient(tet, x)?;
        let mut out = ElementState::default();
        self.neo_hookean_into(m, &f, Tangent::Consistent, ALL_BLOCKS, &mut out);
        Ok(out)
    }

    /// As [`TetRest::neo_hookean`] at the deformation gradient `f` of
    /// [`TetRest::neo_hookean_gradient`] (det F > 0), written into `out`, with the
    /// consistent tangent or, with [`Tangent::Definite`], its positive semi-definite
    /// projection (the solver's fallback when the consistent K is not positive definite).
    /// Only the tangent blocks whose bit 4a + b is set in `blocks` are written (as
    /// [`TetRest::corotational_into`]). The rotation of `out` is the identity: this element
    /// has no corotated frame.
    pub fn neo_hookean_into(
        &self,
        m: &Material,
        f: &Matrix3<f64>,
        tangent: Tangent,
        blocks: u16,
        out: &mut ElementState,
    ) {
        debug_assert!(f.determinant() > 0.0, "an inverted F: check it first");
        let f = *f;
        let (f_inv_t, ln_j) = inverse_transpose_and_log_det(&f);
        let p = piola(m, &f, &f_inv_t, ln_j);
        out.force = self.forces(&p);
        match tangent {
            Tangent::Consistent => {
                self.neo_hookean_blocks(m, &f_inv_t, ln_j, blocks, &mut out.tangent)
            }
            Tangent::Definite => {
                let h = project_positive(&compute_stiffness(m, &f));
                self.blocks_of_stiffness(&h, blocks, &mut out.tangent);
            }
        }
        // Cauchy stress sigma = P Fᵀ / J.
        out.stress = p * f.transpose() / f.determinant();
        out.rotation = Matrix3::identity();
    }

    /// The consistent tangent's blocks `blocks` into `k` (module docs), from F⁻ᵀ and ln J.
    fn neo_hookean_blocks(
        &self,
        m: &Material,
        f_inv_t: &Matrix3<f64>,
        ln_j: f64,
        blocks: u16,
        k: &mut Mat12,
    ) {
        let h: [Vector3<f64>; 4] = self.grads.map(|g| f_inv_t * g);
        let (vl, vc) = (
            self.volume * m.lambda(),
            self.volume * (m.mu() - m.lambda() * ln_j),
        );
        for a in 0..4 {
            for b in 0..4 {
                if blocks & (1 << (4 * a + b)) == 0 {
                    continue;
                }
                let gab = self.volume * m.mu() * self.grads[a].dot(&self.grads[b]);
                let blk = h[a] * h[b].transpose() * vl + h[b] * h[a].transpose() * vc;
                for i in 0..3 {
                    for j in 0..3 {
                        k[3 * a + i][3 * b + j] = blk[(i, j)] + if i == j { gab } else { 0.0 };
                    }
                }
            }
        }
    }

    /// The blocks `blocks` of V Bᵀ H B into `k` for a stress derivative `h` (as
    /// [`compute_stiffness`]): K_(a i),(b k) = V Σ_jl H_(3i+j),(3k+l) g_aj g_bl.
    fn blocks_of_stiffness(&self, h: &Mat9, blocks: u16, k: &mut Mat12) {
        for a in 0..4 {
            for b in 0..4 {
                if blocks & (1 << (4 * a + b)) == 0 {
                    continue;
                }
                let (ga, gb) = (&self.grads[a], &self.grads[b]);
                for i in 0..3 {
                    for kk in 0..3 {
                        let mut v = 0.0;
                        for j in 0..3 {
                            for l in 0..3 {
                                v += h[(3 * i + j, 3 * kk + l)] * ga[j] * gb[l];
                            }
                        }
                        k[3 * a + i][3 * b + kk] = self.volume * v;
                    }
                }
            }
        }
    }
}

/// The symmetric matrix `h` with its negative eigenvalues set to zero: the nearest
/// positive semi-definite matrix (Frobenius norm).
fn project_positive(h: &Mat9) -> Mat9 {
    let sym = (h + h.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let mut out = Mat9::zeros();
    for (i, &lam) in eig.eigenvalues.iter().enumerate() {
        if lam > 0.0 {
            let v = eig.eigenvectors.column(i);
            out += v * v.transpose() * lam;
        }
    }
    out
}

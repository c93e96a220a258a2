//! The linear tetrahedron: rest gradients, small-strain stiffness, and the corotational
//! force with its consistent tangent (rotation by polar decomposition of F).
//!
//! Corotational: with F = R S (polar), the strain is eps = sym(S) - I, the stress
//! sigma = C : eps, and the nodal force f_a = V R sigma g_a (g_a the rest shape-function
//! gradients). This is the gradient of E = 1/2 (R^T x - X)^T K0 (R^T x - X), so its exact
//! derivative (the consistent tangent) is symmetric; it includes dR from
//! (tr(S) I - S) w = axial(R^T dF - dF^T R), dR = R \[w\]x.

use super::material::Material;
use super::mesh::signed_volume;
use super::{FemError, FemResult};
use nalgebra::{Matrix3, Vector3};

/// Precomputed rest data of one tetrahedron.
#[derive(Debug, Clone, Copy)]
pub struct TetRest {
    /// Gradients of the four shape functions in the rest configuration.
    pub grads: [Vector3<f64>; 4],
    /// Rest volume (positive).
    pub volume: f64,
}

/// An element's 12x12 matrix (node-major: row 3a+i).
pub type Mat12 = [[f64; 12]; 12];

/// The factors (p_a, q_b) of the consistent tangent's rotation-derivative blocks p_a q_b.
type RotationTerms = ([Matrix3<f64>; 4], [Matrix3<f64>; 4]);

/// Every 3x3 block of a [`Mat12`] (bit 4a + b for block (a, b)).
pub const ALL_BLOCKS: u16 = u16::MAX;

impl TetRest {
    /// Rest data from the four corners; `tet` names the element in errors.
    pub fn new(tet: usize, c: [[f64; 3]; 4]) -> FemResult<Self> {
        let v = signed_volume(c[0], c[1], c[2], c[3]);
        if v < 0.0 {
            return Err(FemError::InvertedElement { tet, volume: v });
        }
        let col = |i: usize| Vector3::new(c[i][0] - c[0][0], c[i][1] - c[0][1], c[i][2] - c[0][2]);
        let dm = Matrix3::from_columns(&[col(1), col(2), col(3)]);
        let inv = dm
            .try_inverse()
            .filter(|_| v > 0.0)
            .ok_or(FemError::DegenerateElement { tet, volume: v })?;
        let g1 = inv.row(0).transpose();
        let g2 = inv.row(1).transpose();
        let g3 = inv.row(2).transpose();
        Ok(Self {
            grads: [-(g1 + g2 + g3), g1, g2, g3],
            volume: v,
        })
    }

    /// Deformation gradient F = sum_a x_a g_a^T.
    pub fn deformation_gradient(&self, x: &[[f64; 3]; 4]) -> Matrix3<f64> {
        let mut f = Matrix3::zeros();
        for (xa, ga) in x.iter().zip(&self.grads) {
            f += Vector3::from(*xa) * ga.transpose();
        }
        f
    }

    /// Small-strain stiffness K0 (12x12).
    pub fn stiffness(&self, m: &Material) -> Mat12 {
        let mut k = [[0.0; 12]; 12];
        for a in 0..4 {
            for b in 0..4 {
                let ga = &self.grads[a];
                let gb = &self.grads[b];
                let gab = ga.dot(gb);
                for i in 0..3 {
                    for j in 0..3 {
                        let mut v = m.lambda() * ga[i] * gb[j] + m.mu() * ga[j] * gb[i];
                        if i == j {
                            v += m.mu() * gab;
                        }
                        k[3 * a + i][3 * b + j] = self.volume * v;
                    }
                }
            }
        }
        k
    }

    /// Nodal forces V P g_a for a first-Piola-like stress P.
    pub(super) fn forces(&self, p: &Matrix3<f64>) -> [f64; 12] {
        let mut f = [0.0; 12];
        for a in 0..4 {
            let fa = p * self.grads[a] * self.volume;
            f[3 * a..3 * a + 3].copy_from_slice(fa.as_slice());
        }
        f
    }

    /// Small-strain internal force, stress, tangent (K0) for displacements `u`.
    pub fn small_strain(&self, m: &Material, u: &[[f64; 3]; 4]) -> ElementState {
        let grad_u = self.deformation_gradient(u);
        let eps = (grad_u + grad_u.transpose()) * 0.5;
        let sigma = m.stress(&eps);
        ElementState {
            force: self.forces(&sigma),
            tangent: self.stiffness(m),
            stress: sigma,
            rotation: Matrix3::identity(),
        }
    }

    /// Corotational internal force, Cauchy-like stress (rotated) and tangent at positions `x`.
    /// `tet` names the element if it is inverted (det F <= 0).
    pub fn corotational(
        &self,
        tet: usize,
        m: &Material,
        x: &[[f64; 3]; 4],
        tangent: Tangent,
    ) -> FemResult<ElementState> {
        let mut out = ElementState::default();
        self.corotational_into(tet, m, x, tangent, ALL_BLOCKS, &mut out)?;
        Ok(out)
    }

    /// As [`TetRest::corotational`], written into `out`, with only the 3x3 tangent blocks
    /// (a, b) whose bit 4a + b is set in `blocks` (e.g. the stored upper triangle, see
    /// [`crate::fem::assembly::Pattern::block_mask`]); the other blocks of `out.tangent`
    /// are left as they were. The computed entries equal those of the full tangent.
    pub fn corotational_into(
        &self,
        tet: usize,
        m: &Material,
        x: &[[f64; 3]; 4],
        tangent: Tangent,
        blocks: u16,
        out: &mut ElementState,
    ) -> FemResult<()> {
        let f = self.deformation_gradient(x);
        let det = f.determinant();
        if !(det > 0.0) {
            return Err(FemError::InvertedElement { tet, volume: det });
        }
        let r = polar_rotation(&f);
        let s = r.transpose() * f;
        let s = (s + s.transpose()) * 0.5;
        let eps = s - Matrix3::identity();
        let sigma = m.stress(&eps);
        let force = self.forces(&(r * sigma));
        // Both tangents in closed form per 3x3 block (a, b), with h_a = R g_a:
        //   R K0_ab R^T = V (lambda h_a h_b^T + mu h_b h_a^T + mu (g_a . g_b) I),
        // and the consistent one adds the rotation derivative V (R M_a) (A^-1 [g_b]x R^T),
        // M_a = -[sigma g_a]x + mu [S g_a]x - mu S [g_a]x, A = tr(S) I - S. This is the
        // column-by-column derivative dF = e_j g_b^T (see the module docs) gathered
        // into products: dR = R [w]x with w = A^-1 (g_b x R^T e_j).
        let h = self.grads.map(|g| r * g);
        let rot = match tangent {
            Tangent::Consistent => {
                let a_inv = (Matrix3::identity() * s.trace() - s)
                    .try_inverse()
                    .ok_or(FemError::InvertedElement { tet, volume: det })?;
                let rt = r.transpose();
                let p = self.grads.map(|g| {
                    let ma = -(sigma * g - s * g * m.mu()).cross_matrix()
                        - s * g.cross_matrix() * m.mu();
                    r * ma * self.volume
                });
                let q = self.grads.map(|g| a_inv * g.cross_matrix() * rt);
                Some((p, q))
            }
            Tangent::Definite => None,
        };
        out.force = force;
        self.rotated_blocks(m, &h, rot.as_ref(), blocks, &mut out.tangent);
        out.stress = r * sigma * r.transpose();
        out.rotation = r;
        Ok(())
    }

    /// The blocks `blocks` (as in [`TetRest::corotational_into`]) of the rotated tangent
    /// R K0 Rᵀ for the rotation `r` of a corotational state (e.g.
    /// [`ElementState::rotation`]) into `k`: equal to the tangent `corotational` returns
    /// with [`Tangent::Definite`] at the positions that gave `r`, without the polar
    /// decomposition.
    pub fn rotated_tangent(&self, m: &Material, r: &Matrix3<f64>, blocks: u16, k: &mut Mat12) {
        self.rotated_blocks(m, &self.grads.map(|g| r * g), None, blocks, k);
    }

    /// R K0 Rᵀ from h_a = R g_a, plus the rotation derivative p_a q_b when given, in the
    /// blocks `blocks` of `k`.
    fn rotated_blocks(
        &self,
        m: &Material,
        h: &[Vector3<f64>; 4],
        rot: Option<&RotationTerms>,
        blocks: u16,
        k: &mut Mat12,
    ) {
        let (vl, vm) = (self.volume * m.lambda(), self.volume * m.mu());
        for a in 0..4 {
            for b in 0..4 {
                if blocks & (1 << (4 * a + b)) == 0 {
                    continue;
                }
                let gab = vm * self.grads[a].dot(&self.grads[b]);
                let mut blk = h[a] * h[b].transpose() * vl + h[b] * h[a].transpose() * vm;
                if let Some((p, q)) = rot {
                    blk += p[a] * q[b];
                }
                for i in 0..3 {
                    for j in 0..3 {
                        k[3 * a + i][3 * b + j] = blk[(i, j)] + if i == j { gab } else { 0.0 };
                    }
                }
            }
        }
    }
}

/// Which tangent the corotational and Neo-Hookean elements return.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tangent {
    /// The exact derivative of the force (includes the rotation derivative).
    #[default]
    Consistent,
    /// A positive semi-definite tangent, the fallback where the consistent one is not:
    /// R K0 R^T for the corotational element (SOFA's "large" method), the consistent
    /// tangent projected onto the positive semi-definite cone for the Neo-Hookean one.
    Definite,
}

/// Force, stress and tangent of one element.
#[derive(Debug, Clone)]
pub struct ElementState {
    /// Internal nodal forces (node-major).
    pub force: [f64; 12],
    /// Tangent stiffness d force / d x.
    pub tangent: Mat12,
    /// Cauchy stress in world axes (Pa).
    pub stress: Matrix3<f64>,
    /// Rotation of the polar decomposition F = R S (corotational; the identity for small
    /// strain and Neo-Hookean).
    pub rotation: Matrix3<f64>,
}

impl Default for ElementState {
    /// Zero force, tangent and stress; the identity rotation.
    fn default() -> Self {
        ElementState {
            force: [0.0; 12],
            tangent: [[0.0; 12]; 12],
            stress: Matrix3::zeros(),
            rotation: Matrix3::identity(),
        }
    }
}

/// Rotation of the polar decomposition F = R S (det F > 0), by scaled Newton iteration.
pub fn polar_rotation(f: &Matrix3<f64>) -> Matrix3<f64> {
    let mut r = *f;
    for _ in 0..40 {
        let Some(inv) = r.try_inverse() else { break };
        // Frobenius-norm scaling (Higham): as fast to converge as the determinant
        // scaling, without a software cube root.
        let g = (inv.norm() / r.norm()).sqrt();
        let next = (r * g + inv.transpose() / g) * 0.5;
        let diff = (next - r).abs().max();
        r = next;
        // Convergence is quadratic: the error of `next` is about half the square of the
        // step just taken, below 1e-14 once the step is below 1e-7 (this saves the last
        // iteration, whose step would only confirm it).
        if diff < 1e-7 {
            break;
        }
    }
    r
}

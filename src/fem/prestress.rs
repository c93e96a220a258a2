//! Initial stress: the stiffening of a stress the body carries at rest, balanced by loads
//! the model leaves out. An inflated membrane is the case in point: its gauge pressure
//! tensions it, and that tension, not its modulus, is most of its stiffness against a push
//! (docs/real-data.md: without it a linear membrane reads the Punyo press at about half).
//!
//! Each tetrahedron may carry a constant Cauchy stress S0 (Pa). Its stiffness is the
//! initial-stress (geometric) matrix K_σ = V (∇N_a · S0 ∇N_b) I₃ for nodes a, b, and its
//! internal force K_σ (x − X): linear about the rest shape, so the rest shape stays an
//! equilibrium and the tangent is exact. It is meant for small motions about that shape
//! (sensing a membrane); it is not rotated with the element.

use super::tet4::{ElementState, Mat12, TetRest};

/// A symmetric Cauchy stress (Pa, world axes).
pub type Stress = [[f64; 3]; 3];

/// An isotropic in-plane tension `tension` (N/m) of a layer `thickness` (m) thick whose
/// normal is `normal`: S0 = (T / t)(I − n nᵀ), zero through the thickness (plane stress).
pub fn in_plane_tension(tension: f64, thickness: f64, normal: [f64; 3]) -> Stress {
    let len = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
    let n = normal.map(|v| v / len);
    let s = tension / thickness;
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = s * (f64::from(u8::from(i == j)) - n[i] * n[j]);
        }
    }
    out
}

/// G_ab = V ∇N_a · S0 ∇N_b: K_σ is G ⊗ I₃.
fn gram(rest: &TetRest, s: &Stress) -> [[f64; 4]; 4] {
    let mut g = [[0.0; 4]; 4];
    for (a, row) in g.iter_mut().enumerate() {
        let ga = rest.grads[a];
        for (b, v) in row.iter_mut().enumerate() {
            let gb = rest.grads[b];
            let mut sum = 0.0;
            for i in 0..3 {
                for j in 0..3 {
                    sum += ga[i] * s[i][j] * gb[j];
                }
            }
            *v = rest.volume * sum;
        }
    }
    g
}

/// Adds K_σ to `k`.
pub(super) fn add_tangent(rest: &TetRest, s: &Stress, k: &mut Mat12) {
    let g = gram(rest, s);
    for (a, row) in g.iter().enumerate() {
        for (b, v) in row.iter().enumerate() {
            for c in 0..3 {
                k[3 * a + c][3 * b + c] += v;
            }
        }
    }
}

/// Adds K_σ to the element's tangent and K_σ (x − X) to its force (`u` the corner
/// displacements x − X).
pub(super) fn add_to_state(rest: &TetRest, s: &Stress, u: &[[f64; 3]; 4], out: &mut ElementState) {
    let g = gram(rest, s);
    for (a, row) in g.iter().enumerate() {
        for (b, v) in row.iter().enumerate() {
            for (c, uc) in u[b].iter().enumerate() {
                out.tangent[3 * a + c][3 * b + c] += v;
                out.force[3 * a + c] += v * uc;
            }
        }
    }
}

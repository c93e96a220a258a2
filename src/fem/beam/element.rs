//! The corotational two-node element: its rigid frame, its local deformations, its internal
//! force and its tangent.
//!
//! Frame (Crisfield's, as Battini and Pacoste write it): x along the chord; the transverse
//! axes from q = ½(q_a + q_b), each node's rest-frame y axis carried by its current rotation
//! (r₃ = r₁ × q / |r₁ × q|, r₂ = r₃ × r₁). Local deformations d = (u, θ̄_a, θ̄_b): the
//! stretch u = l − l₀ and the rotation vectors θ̄ = log(R_rᵀ R_node O) of each end against
//! the element frame (O: the node's rest rotation into the element's rest frame, so d = 0
//! at rest). Variations use spatial spins, R ← exp(δw) R, so
//! δu = r₁·(δx_b − δx_a) and δθ̄ = J_l⁻¹(θ̄) R_rᵀ (δw_node − δw_r), with the frame's spin
//! δw_r derived from the frame's definition (`frame_spin`).

use super::BeamStiffness;
use crate::math::{Mat3, Vec3};
use nalgebra::{Rotation3, SMatrix, SVector, UnitQuaternion};

/// 7 local deformations by 12 element DOFs (x_a, w_a, x_b, w_b; world frame).
pub(super) type Bmat = SMatrix<f64, 7, 12>;
/// A 12×12 element matrix (world frame).
pub(super) type Mat12 = SMatrix<f64, 12, 12>;
/// A 12-vector of element forces (f_a, m_a, f_b, m_b; world frame).
pub(super) type Vec12 = SVector<f64, 12>;

/// An element's rest data.
#[derive(Debug, Clone)]
pub(super) struct ElementRest {
    /// Rest chord length l₀ (m).
    pub length: f64,
    /// Rest element frame (columns r₁, r₂, r₃ in the world).
    pub world_from_element: UnitQuaternion<f64>,
    /// Each end node's rest rotation into the element's rest frame, O = R_node₀ᵀ R_r₀.
    pub node_from_element: [UnitQuaternion<f64>; 2],
}

/// An element's ends at the current configuration.
pub(super) struct Ends<'a> {
    pub x: [&'a Vec3; 2],
    pub world_from_node: [&'a UnitQuaternion<f64>; 2],
}

/// The element's state: its frame, its deformations and B = ∂d/∂p.
pub(super) struct Corotated {
    pub d: SVector<f64, 7>,
    pub b: Bmat,
}

/// Skew matrix: `skew(a) b = a × b`.
pub(super) fn skew(a: &Vec3) -> Mat3 {
    a.cross_matrix()
}

/// The rotation vector of a unit quaternion (angle in [0, π]), exact near zero, where
/// nalgebra's axis-angle would round a small rotation away.
pub(super) fn log(q: &UnitQuaternion<f64>) -> Vec3 {
    let (w, v) = (q.w, q.imag());
    // q and −q are the same rotation: take the one with w ≥ 0 for the angle in [0, π].
    let (w, v) = if w < 0.0 { (-w, -v) } else { (w, v) };
    let s = v.norm();
    if s < 1e-300 {
        return 2.0 * v;
    }
    2.0 * s.atan2(w) / s * v
}

/// Inverse of the left Jacobian of SO(3): δθ = J_l⁻¹(θ) δw for exp(θ) ← exp(δw) exp(θ).
fn left_jacobian_inverse(theta: &Vec3) -> Mat3 {
    let t = theta.norm();
    let s = skew(theta);
    // Below this the series 1/12 + t²/720 is exact to rounding.
    let c = if t < 1e-4 {
        1.0 / 12.0 + t * t / 720.0
    } else {
        1.0 / (t * t) - (1.0 + t.cos()) / (2.0 * t * t.sin())
    };
    Mat3::identity() - 0.5 * s + c * s * s
}

impl ElementRest {
    /// The current element frame and the two transverse reference vectors q_a, q_b.
    fn frame(&self, ends: &Ends) -> (Mat3, f64, [Vec3; 2]) {
        let chord = ends.x[1] - ends.x[0];
        let l = chord.norm();
        let r1 = chord / l;
        let y = Vec3::y();
        let qa = ends.world_from_node[0] * (self.node_from_element[0] * y);
        let qb = ends.world_from_node[1] * (self.node_from_element[1] * y);
        let q = 0.5 * (qa + qb);
        let r3 = r1.cross(&q).normalize();
        let r2 = r3.cross(&r1);
        (Mat3::from_columns(&[r1, r2, r3]), l, [qa, qb])
    }

    /// Deformations and B at the current configuration.
    pub fn corotate(&self, ends: &Ends) -> Corotated {
        let (rr, l, [qa, qb]) = self.frame(ends);
        let r1 = rr.column(0).into_owned();
        let mut d = SVector::<f64, 7>::zeros();
        d[0] = l - self.length;
        let mut b = Bmat::zeros();
        b.fixed_view_mut::<1, 3>(0, 0).copy_from(&(-r1.transpose()));
        b.fixed_view_mut::<1, 3>(0, 6).copy_from(&r1.transpose());
        let g = frame_spin(&rr, l, &qa, &qb);
        let rr_t = rr.transpose();
        let element_from_world =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rr)).inverse();
        for end in 0..2 {
            let bar = element_from_world * ends.world_from_node[end] * self.node_from_element[end];
            let theta = log(&bar);
            d.fixed_rows_mut::<3>(1 + 3 * end).copy_from(&theta);
            // δθ̄ = J_l⁻¹ (R_rᵀ δw_end − ω_r), ω_r = G δp in the element frame.
            let mut p = -g;
            let col = 3 + 6 * end;
            let local = p.fixed_view::<3, 3>(0, col) + rr_t;
            p.fixed_view_mut::<3, 3>(0, col).copy_from(&local);
            let rows = left_jacobian_inverse(&theta) * p;
            b.fixed_view_mut::<3, 12>(1 + 3 * end, 0).copy_from(&rows);
        }
        Corotated { d, b }
    }
}

/// The element frame's spin in the element frame, ω_r = G δp (3×12 over x_a, w_a, x_b,
/// w_b in the world frame). From r₁ = chord / l: ω₂ = −r₃·δr₁, ω₃ = r₂·δr₁; from
/// r₃ ∝ r₁ × q with q = q₁r₁ + q₂r₂ (no r₃ part): ω₁ = (r₃·δq − q₁ r₃·δr₁)/q₂, and
/// r₃·δq_a = δw_a·(q_a × r₃).
fn frame_spin(rr: &Mat3, l: f64, qa: &Vec3, qb: &Vec3) -> SMatrix<f64, 3, 12> {
    let (r1, r2, r3): (Vec3, Vec3, Vec3) = (
        rr.column(0).into_owned(),
        rr.column(1).into_owned(),
        rr.column(2).into_owned(),
    );
    let q = 0.5 * (qa + qb);
    let (q1, q2) = (q.dot(&r1), q.dot(&r2));
    let mut g = SMatrix::<f64, 3, 12>::zeros();
    // r₃·δr₁ = r₃·(δx_b − δx_a)/l, r₂·δr₁ likewise.
    let r3l = r3.transpose() / l;
    let r2l = r2.transpose() / l;
    g.fixed_view_mut::<1, 3>(1, 0).copy_from(&r3l);
    g.fixed_view_mut::<1, 3>(1, 6).copy_from(&(-r3l));
    g.fixed_view_mut::<1, 3>(2, 0).copy_from(&(-r2l));
    g.fixed_view_mut::<1, 3>(2, 6).copy_from(&r2l);
    let w_a = (0.5 * qa.cross(&r3)).transpose() / q2;
    let w_b = (0.5 * qb.cross(&r3)).transpose() / q2;
    g.fixed_view_mut::<1, 3>(0, 0).copy_from(&(q1 / q2 * r3l));
    g.fixed_view_mut::<1, 3>(0, 6).copy_from(&(-q1 / q2 * r3l));
    g.fixed_view_mut::<1, 3>(0, 3).copy_from(&w_a);
    g.fixed_view_mut::<1, 3>(0, 9).copy_from(&w_b);
    g
}

/// The local Euler-Bernoulli stiffness on (u, θ̄_a, θ̄_b), θ̄ = (twist, bend about y,
/// bend about z): EA/l₀, GJ/l₀ on the twist difference, EI/l₀ [[4, 2], [2, 4]] per bending
/// plane (rotations measured from the chord, so the transverse translations are gone).
pub(super) fn local_stiffness(s: &BeamStiffness, l0: f64) -> SMatrix<f64, 7, 7> {
    let mut k = SMatrix::<f64, 7, 7>::zeros();
    k[(0, 0)] = s.axial / l0;
    let gj = s.torsional / l0;
    k[(1, 1)] = gj;
    k[(4, 4)] = gj;
    k[(1, 4)] = -gj;
    k[(4, 1)] = -gj;
    let ei = s.bending / l0;
    for axis in [2, 3] {
        let (a, b) = (axis, axis + 3);
        k[(a, a)] = 4.0 * ei;
        k[(b, b)] = 4.0 * ei;
        k[(a, b)] = 2.0 * ei;
        k[(b, a)] = 2.0 * ei;
    }
    k
}

/// Step of the central differences of B (rad; translations scaled by l₀).
const B_STEP: f64 = 1e-6;

impl ElementRest {
    /// Internal force Bᵀ K_l d (world frame, 12 entries).
    pub fn force(&self, s: &BeamStiffness, ends: &Ends) -> Vec12 {
        let c = self.corotate(ends);
        c.b.transpose() * (local_stiffness(s, self.length) * c.d)
    }

    /// Internal force and tangent: the material part Bᵀ K_l B, and the geometric part
    /// Σ_k f_k ∂B_kᵀ/∂p by central differences of the analytic B (f = K_l d held).
    /// Not symmetric off equilibrium (spins do not commute); the assembly symmetrises.
    /// `geometric: false` leaves the geometric part out (the material part is positive
    /// semi-definite, the fallback when the whole is not definite).
    pub fn force_and_tangent(
        &self,
        s: &BeamStiffness,
        ends: &Ends,
        geometric: bool,
    ) -> (Vec12, Mat12) {
        let c = self.corotate(ends);
        let f_local = local_stiffness(s, self.length) * c.d;
        let force = c.b.transpose() * f_local;
        let mut k = c.b.transpose() * local_stiffness(s, self.length) * c.b;
        for j in (0..12).filter(|_| geometric) {
            let h = if (j / 3) % 2 == 0 {
                B_STEP * self.length
            } else {
                B_STEP
            };
            let plus = self.corotate(&perturbed(ends, j, h).as_ends());
            let minus = self.corotate(&perturbed(ends, j, -h).as_ends());
            let col = (plus.b - minus.b).transpose() * f_local / (2.0 * h);
            let sum = k.column(j) + col;
            k.set_column(j, &sum);
        }
        (force, k)
    }
}

/// Owned ends moved by one DOF: a translation, or a spin exp(h e) R.
pub(super) struct OwnedEnds {
    pub x: [Vec3; 2],
    pub world_from_node: [UnitQuaternion<f64>; 2],
}

impl OwnedEnds {
    pub fn as_ends(&self) -> Ends<'_> {
        Ends {
            x: [&self.x[0], &self.x[1]],
            world_from_node: [&self.world_from_node[0], &self.world_from_node[1]],
        }
    }
}

fn perturbed(ends: &Ends, dof: usize, h: f64) -> OwnedEnds {
    let mut o = OwnedEnds {
        x: [*ends.x[0], *ends.x[1]],
        world_from_node: [*ends.world_from_node[0], *ends.world_from_node[1]],
    };
    let (end, kind, axis) = (dof / 6, (dof / 3) % 2, dof % 3);
    let mut e = Vec3::zeros();
    e[axis] = h;
    if kind == 0 {
        o.x[end] += e;
    } else {
        o.world_from_node[end] = UnitQuaternion::from_scaled_axis(e) * o.world_from_node[end];
    }
    o
}

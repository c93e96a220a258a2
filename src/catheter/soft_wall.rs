//! A soft tube (thesis 5.5.7.2): the tube's wall meshed with linear tetrahedra along its
//! centreline, its outer surface held, so that a catheter pushing on it dents it.
//! Deformable-to-deformable contact then adds the wall's compliance to the catheter's in
//! the contact block, W_cc = H1 K1⁻¹ H1ᵀ + H2 K2⁻¹ H2ᵀ (5.4 with both bodies soft).
//!
//! The wall is linear (small strain), so K2 is factorised once and its compliance on the
//! inner surface is computed once: C_in, one row per inner node along that node's radial
//! direction. A push at a point of the inner surface is spread over the four inner nodes
//! of its cell by bilinear weights w (H2's row), and the wall's compliance between two
//! pushes is wᵢᵀ C_in wⱼ. The row takes each node's own radial direction rather than the
//! push's normal; the two differ by at most half a cell's angle (7.5° for 24 cells round).

use super::tube::Centreline;
use super::{CatheterError, CatheterResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::material::Material;
use crate::fem::mesh::TetMesh;
use crate::fem::solve::{Formulation, MappedPoint, Problem};
use crate::math::{cross, dot, sub, unit};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// The soft wall's material and mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoftWallParams {
    /// Wall thickness (m; 3e-3), from the inner radius out to the held outer surface.
    pub thickness: f64,
    /// Young's modulus (Pa; 100e3, soft tissue's order).
    pub young_modulus: f64,
    /// Poisson's ratio (0.45, nearly incompressible like tissue).
    pub poisson: f64,
    /// Cells round the circumference (24).
    pub around: usize,
    /// Cells through the thickness (2).
    pub layers: usize,
    /// Cell length along the centreline (m; 3e-3, near the catheter's element).
    pub ring_step: f64,
}

impl Default for SoftWallParams {
    fn default() -> Self {
        Self {
            thickness: 3e-3,
            young_modulus: 100e3,
            poisson: 0.45,
            around: 24,
            layers: 2,
            ring_step: 3e-3,
        }
    }
}

/// A ring of the wall's mesh: a centreline point with its transported frame.
#[derive(Clone, Copy, Debug)]
struct Ring {
    point: [f64; 3],
    tangent: [f64; 3],
    n1: [f64; 3],
    n2: [f64; 3],
}

/// The soft wall round a tube: its mesh and its compliance on the inner surface.
#[derive(Clone, Debug)]
pub struct SoftWall {
    params: SoftWallParams,
    rings: Vec<Ring>,
    /// Arc length between rings (m).
    ring_ds: f64,
    mesh: TetMesh,
    /// C_in: inner node by inner node, radial (m/N); inner node (i, k) is `k * around + i`.
    compliance: DMatrix<f64>,
}

impl SoftWall {
    /// The wall round `centreline` from `inner_radius` m outwards, meshed and with its
    /// inner-surface compliance computed (one factorisation and one solve per inner node).
    pub fn new(
        centreline: &Centreline,
        inner_radius: f64,
        params: &SoftWallParams,
    ) -> CatheterResult<Self> {
        check(params, inner_radius)?;
        let length = centreline.length();
        let n_rings = (length / params.ring_step).ceil().max(1.0) as usize;
        let ring_ds = length / n_rings as f64;
        let rings = transported_rings(centreline, n_rings, ring_ds);
        let mesh = wall_mesh(&rings, inner_radius, params)?;
        let around = params.around;
        let outer: Vec<usize> = (0..mesh.num_nodes())
            .filter(|&v| (v / around) % (params.layers + 1) == params.layers)
            .collect();
        let material = Material::new(params.young_modulus, params.poisson)?;
        let mut problem = Problem::new(mesh.clone(), material, Formulation::SmallStrain);
        problem.fixed = outer;
        let x = problem.initial_positions();
        let rows: Vec<ConstraintRow> = (0..rings.len())
            .flat_map(|k| (0..around).map(move |i| (k, i)))
            .map(|(k, i)| {
                let v = node_id(k, 0, i, params);
                let radial = sub(x[v], rings[k].point);
                ConstraintRow::along(RowKind::Force, &MappedPoint::node(v), radial)
            })
            .collect::<Result<_, _>>()?;
        let compliance = problem.solver()?.compliance_at(&x, &rows)?.w;
        Ok(Self {
            params: params.clone(),
            rings,
            ring_ds,
            mesh,
            compliance,
        })
    }

    /// The wall's mesh at rest (its outer surface held).
    pub fn mesh(&self) -> &TetMesh {
        &self.mesh
    }

    /// The options it was built with.
    pub fn params(&self) -> &SoftWallParams {
        &self.params
    }

    /// H2's row of a push at `point` on (or near) the inner surface, as inner-node indices
    /// into C_in with bilinear weights over the four corners of its cell.
    fn weights(&self, point: [f64; 3], s: f64) -> [(usize, f64); 4] {
        let around = self.params.around;
        let last = self.rings.len() - 2;
        let q = (s / self.ring_ds).max(0.0);
        let k = (q.floor() as usize).min(last);
        let u = (q - k as f64).clamp(0.0, 1.0);
        let (a, b) = (&self.rings[k], &self.rings[k + 1]);
        let lerp = |p: [f64; 3], r: [f64; 3]| std::array::from_fn(|j| p[j] + u * (r[j] - p[j]));
        let centre = lerp(a.point, b.point);
        let tangent = unit(lerp(a.tangent, b.tangent));
        let off = sub(point, centre);
        let off = sub(off, tangent.map(|t| t * dot(off, tangent)));
        let (n1, n2) = (lerp(a.n1, b.n1), lerp(a.n2, b.n2));
        let theta = dot(off, n2).atan2(dot(off, n1)).rem_euclid(TAU);
        let cell = theta / (TAU / around as f64);
        let i = (cell.floor() as usize).min(around - 1);
        let v = (cell - i as f64).clamp(0.0, 1.0);
        let j = (i + 1) % around;
        [
            (k * around + i, (1.0 - u) * (1.0 - v)),
            (k * around + j, (1.0 - u) * v),
            ((k + 1) * around + i, u * (1.0 - v)),
            ((k + 1) * around + j, u * v),
        ]
    }

    /// The wall's compliance between pushes at `points` on its inner surface, with the
    /// arc length `s` of each one's nearest centreline point (m/N; symmetric).
    pub fn compliance(&self, points: &[([f64; 3], f64)]) -> DMatrix<f64> {
        let w: Vec<_> = points.iter().map(|&(p, s)| self.weights(p, s)).collect();
        DMatrix::from_fn(points.len(), points.len(), |a, b| {
            let mut c = 0.0;
            for &(i, wi) in &w[a] {
                for &(j, wj) in &w[b] {
                    c += wi * wj * self.compliance[(i, j)];
                }
            }
            c
        })
    }
}

fn check(p: &SoftWallParams, inner_radius: f64) -> CatheterResult<()> {
    let positive = |what: &str, v: f64| match v > 0.0 && v.is_finite() {
        true => Ok(()),
        false => Err(CatheterError::Path(format!(
            "soft wall: {what} {v} must be > 0 and finite"
        ))),
    };
    positive("thickness", p.thickness)?;
    positive("Young's modulus", p.young_modulus)?;
    positive("ring step", p.ring_step)?;
    positive("inner radius", inner_radius)?;
    if !(p.poisson > -1.0 && p.poisson < 0.5) {
        return Err(CatheterError::Path(format!(
            "soft wall: Poisson's ratio {} must be in (-1, 0.5)",
            p.poisson
        )));
    }
    if p.around < 6 || p.layers < 1 {
        return Err(CatheterError::Path(format!(
            "soft wall: at least 6 cells round and 1 through the thickness (got {} and {})",
            p.around, p.layers
        )));
    }
    Ok(())
}

/// Rings every `ds` m along the centreline, their frames carried along by projecting the
/// last one's normal onto each new cross-section (a rotation-minimising frame).
fn transported_rings(centreline: &Centreline, n_rings: usize, ds: f64) -> Vec<Ring> {
    let mut rings: Vec<Ring> = Vec::with_capacity(n_rings + 1);
    for k in 0..=n_rings {
        let c = centreline.at(k as f64 * ds);
        let t = unit(c.tangent);
        let guess = match rings.last() {
            Some(r) => r.n1,
            None => crate::math::tangents(t).0,
        };
        let n1 = unit(sub(guess, t.map(|v| v * dot(guess, t))));
        rings.push(Ring {
            point: c.point,
            tangent: t,
            n1,
            n2: cross(t, n1),
        });
    }
    rings
}

/// Node (ring k, layer j from the inner surface, angle i) of the wall's mesh.
fn node_id(k: usize, j: usize, i: usize, p: &SoftWallParams) -> usize {
    (k * (p.layers + 1) + j) * p.around + i
}

/// The wall's tetrahedra: the Kuhn split of a structured box in (angle, layer, ring),
/// closed round the circumference and swept along the rings.
fn wall_mesh(rings: &[Ring], inner_radius: f64, p: &SoftWallParams) -> CatheterResult<TetMesh> {
    let cells = [p.around, p.layers, rings.len() - 1];
    let unit_box = TetMesh::structured_box([0.0; 3], [1.0; 3], cells)?;
    // The box numbers its nodes angle fastest, with one more angle column than the closed
    // wall: the last column is the first.
    let remap = |v: usize| {
        let i = v % (p.around + 1);
        let rest = v / (p.around + 1);
        let (j, k) = (rest % (p.layers + 1), rest / (p.layers + 1));
        node_id(k, j, i % p.around, p)
    };
    let mut nodes = Vec::with_capacity(rings.len() * (p.layers + 1) * p.around);
    for ring in rings {
        for j in 0..=p.layers {
            let r = inner_radius + p.thickness * j as f64 / p.layers as f64;
            for i in 0..p.around {
                let (sn, cs) = (TAU * i as f64 / p.around as f64).sin_cos();
                nodes.push(std::array::from_fn(|d| {
                    ring.point[d] + r * (cs * ring.n1[d] + sn * ring.n2[d])
                }));
            }
        }
    }
    let tets: Vec<[usize; 4]> = (unit_box.tets.iter()).map(|t| t.map(remap)).collect();
    let mut mesh = TetMesh::new(nodes, tets)?;
    let volumes = mesh.signed_volumes();
    let positive = volumes.iter().filter(|&&v| v > 0.0).count();
    if positive != 0 && positive != volumes.len() || volumes.contains(&0.0) {
        return Err(CatheterError::Path(format!(
            "soft wall: the mesh folds ({} of {} tetrahedra turned): every bend's radius must \
             exceed the wall's outer radius ({:.1} mm)",
            positive.min(volumes.len() - positive),
            volumes.len(),
            1e3 * (inner_radius + p.thickness)
        )));
    }
    mesh.orient_positive();
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::norm;

    #[test]
    fn the_ring_frames_stay_orthonormal_round_a_bend() {
        let c = Centreline::from_pieces(
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            &[super::super::tube::Piece::Arc {
                radius: 0.05,
                angle: 1.5,
                plane: 0.3,
            }],
            1e-3,
        )
        .unwrap();
        for r in transported_rings(&c, 30, c.length() / 30.0) {
            assert!((norm(r.n1) - 1.0).abs() < 1e-9 && dot(r.n1, r.tangent).abs() < 1e-9);
            assert!((norm(r.n2) - 1.0).abs() < 1e-9);
        }
    }
}

//! Cable actuators: their length, their row (d shortening / dx) and the geometric
//! stiffness their tension adds to the tangent.

use super::mesh::{norm, sub};
use super::problem::MappedPoint;
use super::solve::Solver;
use super::{FemError, FemResult};
use serde::Serialize;

/// How a cable is driven.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum CableControl {
    /// Given tension (N, >= 0 pulls).
    Force(f64),
    /// Given shortening of the cable length from rest (m).
    Displacement(f64),
}

/// Sets the control of each cable named in `inputs` (unlisted cables keep theirs); the
/// error names a cable that is not there or is not given exactly one of shorten, force.
pub fn apply_cable_inputs(
    cables: &mut [Cable],
    inputs: &[crate::recording::CableInput],
) -> FemResult<()> {
    for c in inputs {
        let cable = cables
            .iter_mut()
            .find(|k| k.name == c.name)
            .ok_or_else(|| FemError::NoSuchCable {
                name: c.name.clone(),
            })?;
        cable.control = match (c.shorten, c.force) {
            (Some(s), None) => CableControl::Displacement(s),
            (None, Some(f)) => CableControl::Force(f),
            _ => {
                return Err(FemError::CableInputNotOne {
                    name: c.name.clone(),
                })
            }
        };
    }
    Ok(())
}

/// A cable actuator: from a fixed pull point through attach points on the mesh.
/// Its length is |p1 - pull| + sum |p(i+1) - p(i)|; the actuator value is the shortening
/// L0 - L(x) and the tension lambda >= 0 pulls the attach points along the cable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cable {
    /// Name (for reports).
    pub name: String,
    /// Fixed pull point in space.
    pub pull: [f64; 3],
    /// Attach points along the cable, from the pull point outward.
    pub attach: Vec<MappedPoint>,
    /// Force or displacement control.
    pub control: CableControl,
}

impl Cable {
    /// Cable length for node positions `x`.
    pub fn length(&self, x: &[[f64; 3]]) -> f64 {
        let mut prev = self.pull;
        let mut l = 0.0;
        for a in &self.attach {
            let p = a.position(x);
            l += norm(sub(p, prev));
            prev = p;
        }
        l
    }

    /// d(shortening)/dx as (node, 3-vector) pairs: minus the length gradient.
    pub fn row(&self, x: &[[f64; 3]]) -> Vec<(usize, [f64; 3])> {
        let pts: Vec<[f64; 3]> = self.attach.iter().map(|a| a.position(x)).collect();
        let unit = |a: [f64; 3], b: [f64; 3]| {
            let d = sub(a, b);
            let l = norm(d);
            if l > 0.0 {
                d.map(|c| c / l)
            } else {
                [0.0; 3]
            }
        };
        let mut out = Vec::new();
        for (i, a) in self.attach.iter().enumerate() {
            let prev = if i == 0 { self.pull } else { pts[i - 1] };
            let mut g = unit(pts[i], prev);
            if i + 1 < pts.len() {
                let u = unit(pts[i + 1], pts[i]);
                for k in 0..3 {
                    g[k] -= u[k];
                }
            }
            for (n, w) in a.nodes.iter().zip(a.weights) {
                if w != 0.0 {
                    out.push((*n, g.map(|c| -w * c)));
                }
            }
        }
        out
    }
}

impl Solver<'_> {
    /// Adds the geometric stiffness of a cable under tension `t` at positions `x`:
    /// t d2L/dx2, with (I - u u^T) / l for each straight segment of length l.
    pub fn add_cable_stiffness(&mut self, cable: &Cable, t: f64, x: &[[f64; 3]]) {
        if t == 0.0 {
            return;
        }
        let pts: Vec<[f64; 3]> = cable.attach.iter().map(|a| a.position(x)).collect();
        for i in 0..pts.len() {
            let prev = if i == 0 { cable.pull } else { pts[i - 1] };
            let d = sub(pts[i], prev);
            let l = norm(d);
            if !(l > 0.0) {
                continue;
            }
            let u = d.map(|c| c / l);
            let mut blk = [[0.0; 3]; 3];
            for (r, row) in blk.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = t * ((if r == c { 1.0 } else { 0.0 }) - u[r] * u[c]) / l;
                }
            }
            // Segment between attach i-1 (if any) and attach i: [[A, -A], [-A, A]].
            let mut ends: Vec<(&MappedPoint, f64)> = vec![(&cable.attach[i], 1.0)];
            if i > 0 {
                ends.push((&cable.attach[i - 1], -1.0));
            }
            for (pa, sa) in &ends {
                for (pb, sb) in &ends {
                    for (na, wa) in pa.nodes.iter().zip(pa.weights) {
                        for (nb, wb) in pb.nodes.iter().zip(pb.weights) {
                            let f = sa * sb * wa * wb;
                            if f != 0.0 {
                                let k = blk.map(|r| r.map(|v| v * f));
                                self.pattern
                                    .add_block(&self.dofs, *na, *nb, &k, &mut self.values);
                            }
                        }
                    }
                }
            }
        }
    }
}

impl Solver<'_> {
    /// Adds the geometric stiffness of the problem's actuators under `tensions` (one per
    /// actuator: cable tensions, then cavity pressures; actuators past the end of
    /// `tensions` add nothing) at positions `x`.
    pub(super) fn add_cables_stiffness(&mut self, x: &[[f64; 3]], tensions: &[f64]) {
        let p = self.problem;
        for (c, t) in p.cables.iter().zip(tensions) {
            self.add_cable_stiffness(c, *t, x);
        }
        let pressures = tensions.get(p.cables.len()..).unwrap_or(&[]);
        for (c, q) in p.cavities.iter().zip(pressures) {
            self.add_cavity_stiffness(c, *q, x);
        }
    }
}

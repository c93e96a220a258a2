//! The body's own frame, found from its fixed nodes, so that the workflow's regions work on
//! any robot: the axis runs from the fixed nodes' centroid through the centroid of all
//! nodes, heights are fractions of the free length along it (0 at the clamp's far face, 1
//! at the far end), and the four sides are angular sectors about it.
//!
//! On the four-legged robot (fixed block |x|, |y| ≤ 15 mm, z ≤ 12.5 mm, symmetric about z)
//! the axis is +z, the sides are its legs (north +y, east +x, south −y, west −x) and the
//! clamp is its base block.

use super::{DiscrepancyError, DiscrepancyResult};
use crate::fem::solve::Problem;
use crate::math::{cross, dot, norm, sub, unit};

/// Heights (fractions of the free length) up to which the clamp reaches: the four-legged
/// robot's base block took tetrahedra centred up to 12.5 mm, which is 4.17 mm above its
/// fixed nodes of 117 mm, and its centres there sit at 10.4 and 12.500015 mm (rounded
/// nodes): 0.03 (11.8 mm) keeps that split.
pub const CLAMP_BAND: f64 = 0.03;
/// Feature points start this high: near the clamp the surface hardly moves (the
/// four-legged robot's 20 mm).
pub const FEATURE_HEIGHT: f64 = 0.1;
/// Candidate point loads start this high (the four-legged robot's 30 mm).
pub const LOAD_HEIGHT: f64 = 0.2;
/// Feature points from this high are the "top" region (the four-legged robot's 105 mm).
pub const TOP_REGION: f64 = 0.83;
/// Tetrahedra from this high are in no side (the four-legged robot's platform, 110 mm).
pub const TOP_TETS: f64 = 0.85;

/// The body's frame (internal SI metres).
#[derive(Clone, Debug)]
pub struct Body {
    /// Centroid of the fixed nodes.
    base: [f64; 3],
    /// Unit axis from `base` towards the body.
    axis: [f64; 3],
    /// Unit directions across the axis: sector 1 (east) along `side[0]`, sector 0 (north)
    /// along `side[1]`.
    side: [[f64; 3]; 2],
    /// Farthest fixed node along the axis from `base` (m).
    clamp_s: f64,
    /// The free length: the farthest node along the axis beyond `clamp_s` (m).
    length: f64,
    /// The fixed nodes' extent across the axis: low and high along `side[0]`, `side[1]`.
    clamp_side: [[f64; 2]; 2],
}

/// The mean of some points.
fn centroid<'a>(points: impl Iterator<Item = &'a [f64; 3]>) -> Option<[f64; 3]> {
    let (mut s, mut n) = ([0.0; 3], 0usize);
    for p in points {
        (0..3).for_each(|k| s[k] += p[k]);
        n += 1;
    }
    (n > 0).then(|| s.map(|c| c / n as f64))
}

impl Body {
    /// The frame of a problem's rest mesh; errors without fixed nodes or when they sit at
    /// the centroid of the body (no axis).
    pub fn of(problem: &Problem) -> DiscrepancyResult<Self> {
        let x = &problem.mesh.nodes_in_rest;
        let fixed = &problem.fixed;
        let base = centroid(fixed.iter().map(|&i| &x[i]))
            .ok_or_else(|| DiscrepancyError::Data("the model has no fixed node".into()))?;
        let all = centroid(x.iter()).unwrap_or(base);
        let d = sub(all, base);
        if norm(d) <= 1e-12 {
            return Err(DiscrepancyError::Data(
                "the fixed nodes sit at the body's centroid: no axis".into(),
            ));
        }
        let axis = unit(d);
        // The two world axes least along the body axis, in x, y, z order, made
        // perpendicular to it: x and y for a body along z, so that the sectors are the
        // compass legs about z.
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| axis[a].abs().total_cmp(&axis[b].abs()));
        let (i, j) = (order[0].min(order[1]), order[0].max(order[1]));
        let e = |k: usize| [0, 1, 2].map(|m| f64::from(u8::from(m == k)));
        let u = unit(sub(e(i), axis.map(|c| c * axis[i])));
        let v = cross(axis, u);
        // Keep the second world axis's sense (north +y about z).
        let v = if v[j] < 0.0 { v.map(|c| -c) } else { v };
        let along = |p: &[f64; 3]| dot(sub(*p, base), axis);
        let clamp_s = fixed.iter().map(|&i| along(&x[i])).fold(f64::MIN, f64::max);
        let far = x.iter().map(along).fold(f64::MIN, f64::max);
        let mut clamp_side = [[f64::MAX, f64::MIN]; 2];
        for &i in fixed {
            let d = sub(x[i], base);
            for (k, s) in [u, v].iter().enumerate() {
                let c = dot(d, *s);
                clamp_side[k] = [clamp_side[k][0].min(c), clamp_side[k][1].max(c)];
            }
        }
        Ok(Self {
            base,
            axis,
            side: [u, v],
            clamp_s,
            length: (far - clamp_s).max(1e-12),
            clamp_side,
        })
    }

    /// The unit body axis (from the fixed nodes towards the body).
    pub fn axis(&self) -> [f64; 3] {
        self.axis
    }

    /// The free length along the axis (m).
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Height of a rest position above the clamp as a fraction of the free length (below 0
    /// within the clamp's span, 1 at the far end).
    pub fn height(&self, p: [f64; 3]) -> f64 {
        (dot(sub(p, self.base), self.axis) - self.clamp_s) / self.length
    }

    /// Position across the axis: along `side[0]` and `side[1]` (m).
    fn lateral(&self, p: [f64; 3]) -> [f64; 2] {
        let d = sub(p, self.base);
        [dot(d, self.side[0]), dot(d, self.side[1])]
    }

    /// Sector (0 north, 1 east, 2 south, 3 west) of a rest position about the axis: the
    /// side whose direction dominates its position across the axis.
    pub fn sector(&self, p: [f64; 3]) -> usize {
        let [e, n] = self.lateral(p);
        if n.abs() >= e.abs() {
            if n >= 0.0 {
                0
            } else {
                2
            }
        } else if e >= 0.0 {
            1
        } else {
            3
        }
    }

    /// Whether a rest position lies in the clamp: across the axis within the fixed nodes'
    /// span, along it below [`CLAMP_BAND`].
    pub fn in_clamp(&self, p: [f64; 3]) -> bool {
        // A relative tolerance, so that points on the clamp's faces count as in it.
        let tol = 1e-9 * self.length;
        let l = self.lateral(p);
        self.height(p) <= CLAMP_BAND
            && (0..2)
                .all(|k| l[k] >= self.clamp_side[k][0] - tol && l[k] <= self.clamp_side[k][1] + tol)
    }
}

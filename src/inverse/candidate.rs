//! Candidate forces ([`Candidate`]: an unknown intensity at a point of the mesh, along a
//! direction) and the point loads their intensities put on the model ([`loads_of`]), the
//! one place intensities become loads (the sensing loop, the markers' least squares, the
//! reported forces).

use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::solve::{MappedPoint, PointLoad};
use crate::fem::FemResult;

/// A candidate force: an unknown intensity λ (N) at a point of the mesh, acting as the
/// force λ · `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Where the force acts.
    pub at: MappedPoint,
    /// Direction of a positive intensity, unit ([`Candidate::new`] normalises it).
    pub direction: [f64; 3],
    /// Whether the intensity is bounded below by zero (a push, or a hanging weight).
    pub push_only: bool,
}

impl Candidate {
    /// A candidate at `at` along `direction` normalised.
    pub fn new(at: MappedPoint, direction: [f64; 3], push_only: bool) -> Self {
        Self {
            at,
            direction: crate::math::unit(direction),
            push_only,
        }
    }

    /// A pushing-only force on node `node` along `direction` (normalised).
    pub fn at_node(node: usize, direction: [f64; 3]) -> Self {
        Self::new(MappedPoint::node(node), direction, true)
    }

    /// Its compliance row: the displacement of its point along its direction (taken as
    /// unit, not normalised again). Errors on a zero direction.
    pub fn row(&self) -> FemResult<ConstraintRow> {
        ConstraintRow::along_unit(RowKind::Force, &self.at, self.direction)
    }
}

/// The point load of each candidate under its intensity (N): λ · direction at its point,
/// in the candidates' order.
pub fn loads_of(candidates: &[Candidate], intensities: &[f64]) -> Vec<PointLoad> {
    assert_eq!(
        candidates.len(),
        intensities.len(),
        "one intensity per candidate"
    );
    (candidates.iter().zip(intensities))
        .map(|(c, l)| PointLoad {
            at: c.at,
            force: c.direction.map(|d| d * l),
        })
        .collect()
}

/// The sum of the forces of `loads` (N), added from zero in their order: the force of
/// several candidates at one place.
pub fn total_force(loads: &[PointLoad]) -> [f64; 3] {
    let mut f = [0.0; 3];
    for l in loads {
        for (fk, lk) in f.iter_mut().zip(l.force) {
            *fk += lk;
        }
    }
    f
}

//! Points bound to the FE surface: a marker, a feature or a painted disc at its nearest
//! surface-triangle point at rest, as barycentric weights that then hold in every shape
//! (marker sensing, feature calibration and the scene generator's painted markers).

use super::constraint::{ConstraintRow, RowKind};
use super::mesh::Surface;
use super::solve::MappedPoint;
use super::{FemError, FemResult};
use crate::geometry::triangle::closest_point_on_triangle_weights;
use crate::math::{norm, sub};

/// A marker bound to the surface.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundMarker {
    /// Name (as in the track file).
    pub name: String,
    /// Its point on the rest surface (triangle nodes and weights; the fourth weight 0).
    pub at: MappedPoint,
    /// Distance from the given position to the surface (m).
    pub distance: f64,
}

impl BoundMarker {
    /// Its three rows (x, y, z displacement of the bound point).
    pub fn rows(&self) -> Vec<ConstraintRow> {
        ConstraintRow::point3(RowKind::Effector, &self.at)
    }
}

/// Binds each of `positions` (m, model frame) to its nearest surface triangle point with the
/// nodes at `x` (the rest shape, or the free equilibrium the first frame shows); the
/// barycentric weights then hold in every shape. A position farther than `max_distance`
/// from the surface is an error.
pub fn bind_markers(
    x: &[[f64; 3]],
    surface: &Surface,
    names: &[String],
    positions: &[[f64; 3]],
    max_distance: f64,
) -> FemResult<Vec<BoundMarker>> {
    assert_eq!(names.len(), positions.len(), "one name per marker position");
    let mut out = Vec::with_capacity(positions.len());
    for (name, p) in names.iter().zip(positions) {
        // PERF: brute force over the triangles; a few dozen markers on a few thousand.
        let mut best = (f64::INFINITY, [0usize; 3], [0.0; 3]);
        for tri in &surface.triangles {
            let [a, b, c] = tri.map(|v| x[v]);
            let (q, w) = closest_point_on_triangle_weights(*p, a, b, c);
            let d = norm(sub(*p, q));
            if d < best.0 {
                best = (d, *tri, w);
            }
        }
        let (distance, tri, w) = best;
        if distance.is_nan() || distance > max_distance {
            return Err(FemError::OffSurface {
                name: name.clone(),
                position: *p,
                distance,
                max_distance,
            });
        }
        out.push(BoundMarker {
            name: name.clone(),
            at: MappedPoint {
                nodes: [tri[0], tri[1], tri[2], tri[0]],
                weights: [w[0], w[1], w[2], 0.0],
            },
            distance,
        });
    }
    Ok(out)
}

//! Feature points for residuals: centroids of surface triangles with their face normals.
//!
//! The robot mesh is stair-stepped (cubes split into tetrahedra), so vertex normals are
//! averages over perpendicular faces and a vertex's normal line meets the measured surface
//! off the vertex (a bias of about 1.5 mm). A triangle centroid lies at least a third of a
//! cube side (about 2.9 mm) from the face's edges, farther than the registration's line
//! radius, so its line only sees points of its own flat face: unbiased.

use super::body::{Body, TOP_REGION};
use crate::fem::mesh::Surface;
use crate::fem::solve::MappedPoint;
use crate::register::{farthest_point_sampling, LineMatch, RegisterParams, Registrar};
use serde::Serialize;

/// Names of the surface regions residuals are gathered in: the far end of the body, then
/// its four sides about its axis ([`Body::sector`]; the four-legged robot's top platform
/// and legs).
pub const REGION_NAMES: [&str; 5] = ["top", "north-leg", "east-leg", "south-leg", "west-leg"];

/// Region index of a rest position (m): the far end from [`TOP_REGION`] of the free
/// length, else its side about the axis.
pub fn region_of(body: &Body, p: [f64; 3]) -> usize {
    if body.height(p) >= TOP_REGION {
        0
    } else {
        body.sector(p) + 1
    }
}

/// One feature point: a surface triangle.
#[derive(Clone, Debug, Serialize)]
pub struct Feature {
    /// The triangle's nodes.
    pub triangle: [usize; 3],
    /// Rest centroid (m).
    pub rest: [f64; 3],
    /// Region index into [`REGION_NAMES`].
    pub region: usize,
}

impl Feature {
    /// The feature as a mapped point (weights 1/3 on the triangle, 0 on a fourth node).
    pub fn mapped(&self) -> MappedPoint {
        let t = self.triangle;
        MappedPoint {
            nodes: [t[0], t[1], t[2], t[0]],
            weights: [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0],
        }
    }

    /// Centroid and unit outward face normal at node positions `x` (normal zero if degenerate).
    pub fn at(&self, x: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
        let [a, b, c] = self.triangle.map(|i| x[i]);
        let p = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
        let e1 = [0, 1, 2].map(|k| b[k] - a[k]);
        let e2 = [0, 1, 2].map(|k| c[k] - a[k]);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        (p, if l > 0.0 { n.map(|c| c / l) } else { [0.0; 3] })
    }
}

/// Chooses up to `count` triangles spread evenly (farthest-point sampling of centroids)
/// among those higher than `min_height` along the body (a fraction of its free length,
/// [`Body::height`]: near the clamp the body does not move) whose surroundings within
/// `flat_radius` (m) are one plane: a face can then slide by about that much before its
/// normal line leaves the plane, which keeps the residual linear in the model change.
pub fn choose_features(
    x: &[[f64; 3]],
    surface: &Surface,
    count: usize,
    body: &Body,
    min_height: f64,
    flat_radius: f64,
) -> Vec<Feature> {
    let tri = &surface.triangles;
    let geo: Vec<([f64; 3], [f64; 3])> = tri
        .iter()
        .map(|t| {
            Feature {
                triangle: *t,
                rest: [0.0; 3],
                region: 0,
            }
            .at(x)
        })
        .collect();
    let r2 = flat_radius * flat_radius;
    let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
    let flat = |i: usize| -> bool {
        let (c, n) = geo[i];
        tri.iter().enumerate().all(|(j, t)| {
            if !t.iter().any(|&v| d2(x[v], c) < r2) {
                return true;
            }
            let nj = geo[j].1;
            let dot: f64 = (0..3).map(|k| n[k] * nj[k]).sum();
            dot > 0.9999
                && t.iter()
                    .all(|&v| (0..3).map(|k| n[k] * (x[v][k] - c[k])).sum::<f64>().abs() < 1e-7)
        })
    };
    let candidates: Vec<usize> = (0..geo.len())
        .filter(|&i| body.height(geo[i].0) > min_height && flat(i))
        .collect();
    let centroids: Vec<[f64; 3]> = geo.iter().map(|g| g.0).collect();
    farthest_point_sampling(&centroids, &candidates, count)
        .into_iter()
        .map(|i| Feature {
            triangle: tri[i],
            rest: centroids[i],
            region: region_of(body, centroids[i]),
        })
        .collect()
}

/// The measured offset along the normal line `p + t n` (the one place registration is
/// called, so that a reworked registration can be swapped in here).
pub fn measure_offset(
    registrar: &Registrar,
    p: [f64; 3],
    n: [f64; 3],
    params: &RegisterParams,
) -> Option<LineMatch> {
    registrar.match_feature(p, n, params)
}

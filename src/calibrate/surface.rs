//! Exact closest points on the FE surface triangles at given node positions.

use crate::math::Vec3;
use crate::register::closest_point_on_triangle_weights;
use kiddo::{KdTree, SquaredEuclidean};

/// The closest surface point to a query.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceMatch {
    /// Triangle index.
    pub triangle: usize,
    /// Barycentric weights on the triangle's nodes.
    pub weights: [f64; 3],
    /// The closest point (m).
    pub point: [f64; 3],
    /// The triangle's unit outward normal.
    pub normal: [f64; 3],
    /// Distance from the query (m).
    pub distance: f64,
}

/// Exact closest-point queries on a triangle surface at given node positions: a KD-tree
/// over triangle centroids gives a bound (the nearest centroid's distance) and every
/// triangle whose centroid lies within that bound plus the largest centroid-to-corner
/// distance is tested exactly.
pub struct SurfaceIndex {
    tree: KdTree<f64, 3>,
    tris: Vec<[Vec3; 3]>,
    normals: Vec<Vec3>,
    radius: f64,
}

impl SurfaceIndex {
    /// Indexes `triangles` at node positions `x` (degenerate triangles are skipped).
    pub fn new(x: &[[f64; 3]], triangles: &[[usize; 3]]) -> Self {
        let mut tree = KdTree::with_capacity(triangles.len().max(1));
        let mut tris = Vec::with_capacity(triangles.len());
        let mut normals = Vec::with_capacity(triangles.len());
        let mut radius: f64 = 0.0;
        for (i, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| Vec3::from(x[v]));
            let n = (b - a).cross(&(c - a));
            let l = n.norm();
            if !(l > 0.0 && l.is_finite()) {
                // Keep indices aligned: a far-away placeholder never wins.
                tris.push([Vec3::repeat(f64::MAX); 3]);
                normals.push(Vec3::zeros());
                continue;
            }
            let centroid = (a + b + c) / 3.0;
            radius = radius.max(
                [a, b, c]
                    .iter()
                    .map(|p| (p - centroid).norm())
                    .fold(0.0, f64::max),
            );
            tree.add(&[centroid.x, centroid.y, centroid.z], i as u64);
            tris.push([a, b, c]);
            normals.push(n / l);
        }
        Self {
            tree,
            tris,
            normals,
            radius,
        }
    }

    /// The exact closest point of the surface to `p`, or None for an empty surface.
    pub fn closest(&self, p: [f64; 3]) -> Option<SurfaceMatch> {
        if self.tree.size() == 0 {
            return None;
        }
        let nearest = self.tree.nearest_one::<SquaredEuclidean>(&p);
        let bound = nearest.distance.sqrt() + self.radius;
        let q = Vec3::from(p);
        let mut best: Option<SurfaceMatch> = None;
        for nb in self
            .tree
            .within_unsorted::<SquaredEuclidean>(&p, bound * bound)
        {
            let i = nb.item as usize;
            let [a, b, c] = self.tris[i];
            let (s, w) = closest_point_on_triangle_weights(p, a.into(), b.into(), c.into());
            let s = Vec3::from(s);
            let d = (q - s).norm();
            if best.is_none_or(|m| d < m.distance) {
                let n = self.normals[i];
                best = Some(SurfaceMatch {
                    triangle: i,
                    weights: w,
                    point: [s.x, s.y, s.z],
                    normal: [n.x, n.y, n.z],
                    distance: d,
                });
            }
        }
        best
    }
}

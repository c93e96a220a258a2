//! Normal-line registration (thesis Algorithm 4.2): FE feature points spread evenly over the
//! surface, each matched to the measured robot points nearest to its normal line. A feature
//! is hidden when no point lies within `d_m` of its line, or the match is more than `d_l`
//! along it. A KD-tree ball query (radius √(d_m² + d_l²)) replaces the thesis's brute force.
//!
//! ```
//! use softsense::register::{Registrar, RegisterParams};
//! // A flat patch of points at z = 0.002 and one feature at the origin with normal +z.
//! let pts: Vec<[f64; 3]> = (0..100)
//!     .map(|i| [(i % 10) as f64 * 1e-3 - 5e-3, (i / 10) as f64 * 1e-3 - 5e-3, 0.002])
//!     .collect();
//! let r = Registrar::new(&pts);
//! let m = r.match_feature([0.0; 3], [0.0, 0.0, 1.0], &RegisterParams::default());
//! assert!((m.unwrap().offset - 0.002).abs() < 1e-12);
//! ```

use kiddo::{KdTree, SquaredEuclidean};
use serde::Serialize;

/// Registration parameters.
#[derive(Clone, Debug)]
pub struct RegisterParams {
    /// Number of feature points (thesis: 51).
    pub features: usize,
    /// Largest distance from a point to the normal line (m).
    pub d_m: f64,
    /// Largest offset of a match along the normal line (m).
    pub d_l: f64,
    /// Average the offsets of all points within `d_m` of the line (less noise) instead of
    /// taking the single nearest point (the thesis's choice).
    pub average: bool,
}

impl Default for RegisterParams {
    fn default() -> Self {
        Self {
            features: 51,
            d_m: 0.0015,
            d_l: 0.02,
            average: true,
        }
    }
}

/// One feature's match.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LineMatch {
    /// Signed offset of the match along the unit normal from the feature point (m).
    pub offset: f64,
    /// Distance of the (nearest) matched point to the line (m).
    pub line_distance: f64,
    /// Number of points used.
    pub points: usize,
}

/// Farthest-point sampling of `count` vertices among `candidates` (deterministic: starts at
/// the candidate farthest from the candidates' centroid).
pub fn farthest_point_sampling(
    positions: &[[f64; 3]],
    candidates: &[usize],
    count: usize,
) -> Vec<usize> {
    let valid: Vec<usize> = candidates
        .iter()
        .copied()
        .filter(|&i| i < positions.len())
        .collect();
    if valid.is_empty() || count == 0 {
        return Vec::new();
    }
    let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
    let mut c = [0.0; 3];
    for &i in &valid {
        for (ck, pk) in c.iter_mut().zip(positions[i]) {
            *ck += pk / valid.len() as f64;
        }
    }
    let first = valid
        .iter()
        .map(|&i| d2(positions[i], c))
        .enumerate()
        .fold(
            (0, f64::NEG_INFINITY),
            |b, (j, d)| if d > b.1 { (j, d) } else { b },
        )
        .0;
    let mut dist = vec![f64::INFINITY; valid.len()];
    dist[first] = f64::MAX;
    let mut chosen = Vec::with_capacity(count.min(valid.len()));
    while chosen.len() < count.min(valid.len()) {
        let (best, _) =
            dist.iter().enumerate().fold(
                (0, f64::NEG_INFINITY),
                |b, (j, &d)| if d > b.1 { (j, d) } else { b },
            );
        let p = positions[valid[best]];
        chosen.push(valid[best]);
        for (j, d) in dist.iter_mut().enumerate() {
            *d = d.min(d2(positions[valid[j]], p));
        }
    }
    chosen
}

/// Area-weighted unit vertex normals of a triangle surface at node positions `x`
/// (zero for nodes not on the surface).
pub fn vertex_normals(x: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0; 3]; x.len()];
    for t in triangles {
        if t.iter().any(|&i| i >= x.len()) {
            continue;
        }
        let [a, b, c] = t.map(|i| x[i]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let f = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &v in t {
            for k in 0..3 {
                n[v][k] += f[k];
            }
        }
    }
    for v in &mut n {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

/// A KD-tree over the measured robot points (robot frame, m).
pub struct Registrar {
    tree: KdTree<f64, 3>,
    points: Vec<[f64; 3]>,
}

impl Registrar {
    /// Indexes the finite points.
    pub fn new(points: &[[f64; 3]]) -> Self {
        let points: Vec<[f64; 3]> = points
            .iter()
            .copied()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .collect();
        let mut tree = KdTree::with_capacity(points.len().max(1));
        for (i, p) in points.iter().enumerate() {
            tree.add(p, i as u64);
        }
        Self { tree, points }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The match of the line `p + t n` (n unit), or None when hidden.
    pub fn match_feature(
        &self,
        p: [f64; 3],
        n: [f64; 3],
        params: &RegisterParams,
    ) -> Option<LineMatch> {
        if self.points.is_empty() {
            return None;
        }
        let r2 = params.d_m * params.d_m + params.d_l * params.d_l;
        let near = self.tree.within_unsorted::<SquaredEuclidean>(&p, r2);
        let mut best: Option<(f64, f64)> = None;
        let (mut sum, mut count) = (0.0, 0usize);
        for nb in near {
            let q = self.points[nb.item as usize];
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            let perp2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - t * t).max(0.0);
            if t.abs() > params.d_l || perp2 > params.d_m * params.d_m {
                continue;
            }
            sum += t;
            count += 1;
            if best.is_none_or(|b| perp2 < b.1) {
                best = Some((t, perp2));
            }
        }
        best.map(|(t, perp2)| LineMatch {
            offset: if params.average {
                sum / count as f64
            } else {
                t
            },
            line_distance: perp2.sqrt(),
            points: if params.average { count } else { 1 },
        })
    }

    /// Matches every feature node; `None` entries are hidden features.
    pub fn register(
        &self,
        x: &[[f64; 3]],
        normals: &[[f64; 3]],
        features: &[usize],
        params: &RegisterParams,
    ) -> Vec<Option<LineMatch>> {
        features
            .iter()
            .map(|&f| match (x.get(f), normals.get(f)) {
                (Some(&p), Some(&n)) => self.match_feature(p, n, params),
                _ => None,
            })
            .collect()
    }
}

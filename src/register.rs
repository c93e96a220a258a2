//! Normal-line registration (thesis Algorithm 4.2): FE feature points spread evenly over the
//! surface, each matched to the measured robot points nearest to its normal line. A feature
//! is hidden when no point lies within `d_m` of its line, or the match is more than `d_l`
//! along it. A dense grid of the points, walked over the cells of each line's cylinder,
//! replaces the thesis's brute force over all points.
//!
//! Where the features sit matters. On a faceted FE surface the line through a mesh *vertex*
//! along its averaged vertex normal meets the measured surface off the vertex, and the points
//! within `d_m` of the line lie on several facets at different heights: on the project's
//! stair-stepped robot mesh that reads as a false displacement of about −1.5 mm at edge
//! vertices. [`surface_features`] therefore places features inside flat patches of the
//! surface (every triangle within a flatness radius ≥ `d_m` coplanar), mapped by barycentric
//! weights and matched along the patch's own normal, and optionally only where a camera sees
//! the surface. There the offset of a measured surface that equals the model is zero up to
//! sensor noise, so no per-feature bias has to be calibrated away.
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

use crate::fem::mesh::Surface;
use crate::fem::solve::MappedPoint;
use crate::geometry::raycast::Bvh;
use crate::math::{cross, dot, norm, sub, unit};
use serde::Serialize;

pub use crate::geometry::triangle::{
    closest_point_on_triangle, closest_point_on_triangle_weights, point_triangle_distance2,
    vertex_normals,
};

/// Registration parameters.
#[derive(Clone, Debug, PartialEq)]
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
    /// With `average`: only points whose offset is within this of the nearest point's are
    /// averaged (m), so a line crossing a thin part does not mix its two sides.
    pub sheet: f64,
}

impl Default for RegisterParams {
    fn default() -> Self {
        Self {
            features: 51,
            d_m: 0.0015,
            d_l: 0.02,
            average: true,
            sheet: 0.004,
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

/// Edge of the registrar's grid cells (m) when the points' bounding box allows it: the
/// registration radius `d_m` of the sensing chain, so a normal line's cylinder crosses few
/// cells of a handful of points each.
pub const GRID_CELL: f64 = 0.005;

/// Most cells of the registrar's dense grid (128 along each axis); a wider cloud gets
/// coarser cells.
const MAX_CELLS: usize = 1 << 21;

/// The measured robot points (robot frame, m) on a dense uniform grid: counting-sorted by
/// cell, so the points of a cell are one contiguous run. A normal line's cylinder is answered
/// by walking the cells of its bounding box, skipping empty ones (a surface fills few) and
/// those too far from the line, and testing the points of the rest.
pub struct Registrar {
    /// Points in cell order.
    points: Vec<[f64; 3]>,
    /// Index of each (cell-ordered) point in the finite input points: ties break by it.
    index: Vec<u32>,
    /// Start of each cell's run in `points` (cells in x-fastest order), plus the end.
    starts: Vec<u32>,
    origin: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    /// The last few [`Registrar::match_features`] calls, newest last.
    memo: std::sync::Mutex<Vec<Registered>>,
}

/// One [`Registrar::match_features`] call: its positions and parameters, and its answer
/// (which holds the features).
struct Registered {
    positions: Vec<[f64; 3]>,
    params: RegisterParams,
    matches: FeatureMatches,
}

/// The points an averaged match used ([`RegisterParams::average`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SheetPoints {
    /// Their indices in the registrar's finite points, ascending.
    pub indices: Vec<u32>,
    /// The sum of their squared deviations from the match's offset (m²): the scatter along
    /// the line that the noise of a point, and the surface within the disc, make.
    pub scatter: f64,
}

/// Features registered at one state ([`Registrar::match_features`]): each feature's match
/// and, when the matches average, the points behind them. The sensing loop returns its last
/// one, so the forces' uncertainty and the pictures read what was registered instead of
/// registering again.
#[derive(Clone, Debug, Default)]
pub struct FeatureMatches {
    /// The features, in the caller's order.
    pub features: Vec<SurfaceFeature>,
    /// Each feature's match (`None`: hidden, a degenerate triangle, or not registered).
    pub matches: Vec<Option<LineMatch>>,
    /// With [`RegisterParams::average`], the points of each match, one entry per `Some`
    /// in `matches`, in order (the sensing loop's feature rows); empty otherwise.
    pub points: Vec<SheetPoints>,
}

impl FeatureMatches {
    /// `features`, none of them registered (e.g. a frame registered densely).
    pub fn unmatched(features: &[SurfaceFeature]) -> Self {
        Self {
            features: features.to_vec(),
            matches: vec![None; features.len()],
            points: Vec::new(),
        }
    }

    /// Each feature with its match.
    pub fn iter(&self) -> impl Iterator<Item = (&SurfaceFeature, Option<&LineMatch>)> {
        self.features
            .iter()
            .zip(self.matches.iter().map(Option::as_ref))
    }
}

/// Calls [`Registrar::match_features`] remembers (a frame's estimate and the location
/// choices at its states, two frames' worth in a tracked stream's parallel steps).
const MEMO_CALLS: usize = 4;

impl Registrar {
    /// Indexes the finite points.
    pub fn new(points: &[[f64; 3]]) -> Self {
        let finite: Vec<[f64; 3]> = points
            .iter()
            .copied()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .collect();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &finite {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if finite.is_empty() {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        // 5 mm cells, or coarser for a cloud wider than 127 of them, so at most 128 cells
        // along each axis (MAX_CELLS in all). A cloud of infinite extent (finite points
        // ±1e308 apart) gets one cell.
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let cell = GRID_CELL.max(extent / 127.0);
        // `as` saturates (NaN to 0), so no axis has 0 or more than 128 cells.
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / cell) as usize).min(127) + 1);
        debug_assert!(dims.iter().product::<usize>() <= MAX_CELLS);
        let cell_of = |p: &[f64; 3]| {
            let c = |k: usize| (((p[k] - lo[k]) / cell) as usize).min(dims[k] - 1);
            c(0) + dims[0] * (c(1) + dims[1] * c(2))
        };
        let ncells = dims[0] * dims[1] * dims[2];
        let mut starts = vec![0u32; ncells + 1];
        let cells: Vec<usize> = finite.iter().map(cell_of).collect();
        for &c in &cells {
            starts[c + 1] += 1;
        }
        for c in 0..ncells {
            starts[c + 1] += starts[c];
        }
        let mut fill = starts.clone();
        let mut sorted = vec![[0.0; 3]; finite.len()];
        let mut index = vec![0u32; finite.len()];
        for (i, (&c, p)) in cells.iter().zip(&finite).enumerate() {
            let at = fill[c] as usize;
            fill[c] += 1;
            sorted[at] = *p;
            index[at] = i as u32;
        }
        Self {
            points: sorted,
            index,
            starts,
            origin: lo,
            cell,
            dims,
            memo: Default::default(),
        }
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
        // (offset along the line, squared distance to the line, point index) of the points
        // within `d_m` of the segment |t| ≤ `d_l`.
        let on_line = self.near_line(p, n, params.d_m, params.d_l);
        if !params.average {
            // The thesis's rule: the point nearest to the line.
            let &(t, perp2, _) = on_line.iter().min_by(|a, b| {
                a.1.total_cmp(&b.1)
                    .then(a.0.abs().total_cmp(&b.0.abs()))
                    .then(a.2.cmp(&b.2))
            })?;
            return Some(LineMatch {
                offset: t,
                line_distance: perp2.sqrt(),
                points: 1,
            });
        }
        self.sheet(&on_line, params).map(|(m, _)| m)
    }

    /// The sheet of surface nearest to the feature along the line, among `on_line`: start
    /// at the point of smallest |offset|, average the points within `params.sheet` of it,
    /// re-centre once. The match, and the centre the averaged points are within `sheet` of.
    fn sheet(
        &self,
        on_line: &[(f64, f64, u32)],
        params: &RegisterParams,
    ) -> Option<(LineMatch, f64)> {
        let &(t0, _, _) = on_line.iter().min_by(|a, b| {
            a.0.abs()
                .total_cmp(&b.0.abs())
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
        })?;
        let sheet = |centre: f64| {
            on_line
                .iter()
                .filter(|m| (m.0 - centre).abs() <= params.sheet)
                .fold((0.0, 0usize, f64::INFINITY), |(s, c, d), m| {
                    (s + m.0, c + 1, d.min(m.1))
                })
        };
        let (sum, count, _) = sheet(t0);
        let centre = sum / count as f64;
        let (sum, count, perp2) = sheet(centre);
        (count > 0).then(|| {
            let m = LineMatch {
                offset: sum / count as f64,
                line_distance: perp2.sqrt(),
                points: count,
            };
            (m, centre)
        })
    }

    /// [`Registrar::match_feature`] (averaged: `params.average`), and the points it
    /// averaged. `None` when hidden, or when the match is the thesis's single nearest point.
    pub fn match_feature_points(
        &self,
        p: [f64; 3],
        n: [f64; 3],
        params: &RegisterParams,
    ) -> Option<(LineMatch, SheetPoints)> {
        if !params.average || self.points.is_empty() {
            return None;
        }
        let on_line = self.near_line(p, n, params.d_m, params.d_l);
        let (m, centre) = self.sheet(&on_line, params)?;
        let mut indices = Vec::with_capacity(m.points);
        let mut scatter = 0.0;
        for q in on_line
            .iter()
            .filter(|q| (q.0 - centre).abs() <= params.sheet)
        {
            indices.push(q.2);
            scatter += (q.0 - m.offset).powi(2);
        }
        indices.sort_unstable();
        Some((m, SheetPoints { indices, scatter }))
    }

    /// `(t, squared distance to the line, index)` of every point with |t| ≤ `d_l` and
    /// within `d_m` of the line `p + t n`.
    fn near_line(&self, p: [f64; 3], n: [f64; 3], d_m: f64, d_l: f64) -> Vec<(f64, f64, u32)> {
        let mut out = Vec::new();
        if d_m.is_nan() || d_l.is_nan() || d_m < 0.0 || d_l < 0.0 {
            return out;
        }
        // The cells of the cylinder's bounding box: along axis k the segment spans
        // p_k ± d_l |n_k| and the disc adds d_m √(1 - n_k²).
        let h = self.cell;
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for k in 0..3 {
            let half = d_l * n[k].abs() + d_m * (1.0 - n[k] * n[k]).max(0.0).sqrt();
            let a = ((p[k] - half - self.origin[k]) / h).floor();
            let b = ((p[k] + half - self.origin[k]) / h).floor();
            if a.is_nan() || b.is_nan() || b < 0.0 || a >= self.dims[k] as f64 || a > b {
                return out;
            }
            lo[k] = a.max(0.0) as usize;
            hi[k] = (b as usize).min(self.dims[k] - 1);
        }
        // A cell whose centre is farther than d_m + half its diagonal from the segment
        // holds no point of the cylinder.
        let reach = d_m + 0.5 * 3f64.sqrt() * h;
        let (dm2, reach2) = (d_m * d_m, reach * reach);
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                let row = self.dims[0] * (cy + self.dims[1] * cz);
                for cx in lo[0]..=hi[0] {
                    let c = row + cx;
                    let (s, e) = (self.starts[c] as usize, self.starts[c + 1] as usize);
                    if s == e {
                        continue;
                    }
                    let centre = [cx, cy, cz].map(|v| v as f64 + 0.5);
                    let d = [0, 1, 2].map(|k| self.origin[k] + centre[k] * h - p[k]);
                    let t = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]).clamp(-d_l, d_l);
                    let off = [0, 1, 2].map(|k| d[k] - t * n[k]);
                    if off[0] * off[0] + off[1] * off[1] + off[2] * off[2] > reach2 {
                        continue;
                    }
                    for (q, &i) in self.points[s..e].iter().zip(&self.index[s..e]) {
                        let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                        let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                        let perp2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - t * t).max(0.0);
                        if t.abs() <= d_l && perp2 <= dm2 {
                            out.push((t, perp2, i));
                        }
                    }
                }
            }
        }
        out
    }

    /// The match of each feature at node positions `positions` (its point and the normal
    /// of its triangle there; `None`: hidden, or a degenerate triangle), and with
    /// `params.average` the points of each, in one search per feature. Remembered: the
    /// same features, positions and parameters, bit for bit, get the same registration
    /// without the search (a frame's location choice linearises at the state its last
    /// estimate ended at, where every feature was matched already).
    pub fn match_features(
        &self,
        features: &[SurfaceFeature],
        positions: &[[f64; 3]],
        params: &RegisterParams,
    ) -> FeatureMatches {
        let bits = |a: &[[f64; 3]], b: &[[f64; 3]]| {
            a.len() == b.len()
                && a.iter()
                    .flatten()
                    .zip(b.iter().flatten())
                    .all(|(u, v)| u.to_bits() == v.to_bits())
        };
        let same = |r: &Registered| {
            r.params == *params && r.matches.features == features && bits(&r.positions, positions)
        };
        if let Ok(memo) = self.memo.lock() {
            if let Some(r) = memo.iter().find(|r| same(r)) {
                return r.matches.clone();
            }
        }
        let mut found = FeatureMatches {
            features: features.to_vec(),
            ..FeatureMatches::default()
        };
        for f in features {
            let n = f.normal(positions);
            let m = match (n == [0.0; 3], params.average) {
                (true, _) => None,
                (false, true) => self
                    .match_feature_points(f.position(positions), n, params)
                    .map(|(m, points)| {
                        found.points.push(points);
                        m
                    }),
                (false, false) => self.match_feature(f.position(positions), n, params),
            };
            found.matches.push(m);
        }
        if let Ok(mut memo) = self.memo.lock() {
            if memo.len() >= MEMO_CALLS {
                memo.remove(0);
            }
            memo.push(Registered {
                positions: positions.to_vec(),
                params: params.clone(),
                matches: found.clone(),
            });
        }
        found
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

/// A feature point on the FE surface: a fixed barycentric point of one surface triangle. It
/// moves with the mesh; its normal line is the triangle's outward normal at the current state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SurfaceFeature {
    /// The surface triangle (volume node indices, oriented outward).
    pub triangle: [usize; 3],
    /// Barycentric weights in the triangle (sum 1).
    pub weights: [f64; 3],
}

impl SurfaceFeature {
    /// Position at node positions `x` (m).
    pub fn position(&self, x: &[[f64; 3]]) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (&v, &w) in self.triangle.iter().zip(&self.weights) {
            for k in 0..3 {
                p[k] += w * x[v][k];
            }
        }
        p
    }

    /// Unit outward normal of the triangle at node positions `x` (zero if degenerate).
    pub fn normal(&self, x: &[[f64; 3]]) -> [f64; 3] {
        let [a, b, c] = self.triangle.map(|v| x[v]);
        unit(cross(sub(b, a), sub(c, a)))
    }

    /// The feature as an FE mapped point (the fourth weight is zero).
    pub fn mapped(&self) -> MappedPoint {
        let [a, b, c] = self.triangle;
        let [wa, wb, wc] = self.weights;
        MappedPoint {
            nodes: [a, b, c, a],
            weights: [wa, wb, wc, 0.0],
        }
    }
}

/// How [`surface_features`] chooses feature points.
#[derive(Clone, Debug)]
pub struct FeatureParams {
    /// Number of features (thesis: 51).
    pub count: usize,
    /// Radius around a feature within which the surface must be one plane (m); keep it
    /// ≥ [`RegisterParams::d_m`] so the points matched to a line all lie on that plane.
    pub flat_radius: f64,
    /// Largest angle between two triangles' normals still called coplanar (rad).
    pub coplanar_angle: f64,
    /// The camera centres in the robot frame (m): keep only features some camera sees at
    /// the rest shape (facing it, not occluded). Empty: the whole surface.
    pub eyes: Vec<[f64; 3]>,
    /// With `eyes`: the smallest cosine between the normal and the direction to the camera
    /// (rejects grazing views, where depth sensors leave holes).
    pub min_view_cos: f64,
}

impl Default for FeatureParams {
    fn default() -> Self {
        Self {
            count: 51,
            flat_radius: 0.002,
            coplanar_angle: 1f64.to_radians(),
            eyes: Vec::new(),
            min_view_cos: 0.2,
        }
    }
}

/// Feature points spread evenly (farthest-point sampling) over the flat patches of the surface
/// at node positions `x` (usually the rest shape). Candidates are triangle centroids and the
/// midpoints of edges between coplanar triangles (the centres of split quads); a candidate is
/// kept when every surface triangle within `flat_radius` of it is coplanar with its own, and,
/// with `eyes`, when it faces a camera and the first surface hit of the ray from that camera
/// is it.
/// Deterministic; fewer than `count` when fewer candidates qualify.
pub fn surface_features(
    x: &[[f64; 3]],
    surface: &Surface,
    params: &FeatureParams,
) -> Vec<SurfaceFeature> {
    let tris: Vec<[usize; 3]> = surface
        .triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&v| v < x.len()))
        .collect();
    if tris.is_empty() || params.count == 0 {
        return Vec::new();
    }
    let normals: Vec<[f64; 3]> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| x[v]);
            unit(cross(sub(b, a), sub(c, a)))
        })
        .collect();
    let cos_max = params.coplanar_angle.cos();
    // Candidates: centroids, and midpoints of edges shared by two coplanar triangles.
    let mut candidates: Vec<(usize, [f64; 3])> =
        (0..tris.len()).map(|t| (t, [1.0 / 3.0; 3])).collect();
    let mut edges: Vec<([usize; 2], usize, usize)> = Vec::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges.push(([a.min(b), a.max(b)], t, k));
        }
    }
    edges.sort_unstable();
    for w in edges.windows(2) {
        if w[0].0 == w[1].0 && dot(normals[w[0].1], normals[w[1].1]) >= cos_max {
            let (t, k) = (w[0].1, w[0].2);
            let mut bary = [0.0; 3];
            bary[k] = 0.5;
            bary[(k + 1) % 3] = 0.5;
            candidates.push((t, bary));
        }
    }
    // Bounding boxes of the triangles for the flatness test.
    let boxes: Vec<([f64; 3], [f64; 3])> = tris
        .iter()
        .map(|t| {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for &v in t {
                for k in 0..3 {
                    lo[k] = lo[k].min(x[v][k]);
                    hi[k] = hi[k].max(x[v][k]);
                }
            }
            (lo, hi)
        })
        .collect();
    let bvh = (!params.eyes.is_empty()).then(|| Bvh::new(x, &tris));
    let r = params.flat_radius.max(0.0);
    let flat_and_seen = |&(t, bary): &(usize, [f64; 3])| -> Option<(SurfaceFeature, [f64; 3])> {
        let f = SurfaceFeature {
            triangle: tris[t],
            weights: bary,
        };
        let p = f.position(x);
        let n = normals[t];
        if n == [0.0; 3] {
            return None;
        }
        for (u, (lo, hi)) in boxes.iter().enumerate() {
            if (0..3).any(|k| p[k] < lo[k] - r || p[k] > hi[k] + r) {
                continue;
            }
            let [a, b, c] = tris[u].map(|v| x[v]);
            if point_triangle_distance2(p, a, b, c) > r * r {
                continue;
            }
            let off = [a, b, c].map(|q| dot(sub(q, p), n).abs());
            if dot(normals[u], n) < cos_max || off.iter().any(|&o| o > 1e-3 * r) {
                return None;
            }
        }
        if let Some(bvh) = &bvh {
            let seen = |&eye: &[f64; 3]| {
                let d = sub(p, eye);
                let dist = norm(d);
                if dist == 0.0 || -dot(d, n) / dist < params.min_view_cos {
                    return false;
                }
                matches!(bvh.cast(eye, d), Some(hit) if (hit.t - 1.0).abs() * dist <= 1e-6 + 1e-3 * r)
            };
            if !params.eyes.iter().any(seen) {
                return None;
            }
        }
        Some((f, p))
    };
    #[cfg(feature = "parallel")]
    let kept: Vec<(SurfaceFeature, [f64; 3])> = {
        use rayon::prelude::*;
        candidates.par_iter().filter_map(flat_and_seen).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let kept: Vec<(SurfaceFeature, [f64; 3])> =
        candidates.iter().filter_map(flat_and_seen).collect();
    let positions: Vec<[f64; 3]> = kept.iter().map(|k| k.1).collect();
    let all: Vec<usize> = (0..kept.len()).collect();
    farthest_point_sampling(&positions, &all, params.count)
        .into_iter()
        .map(|i| kept[i].0)
        .collect()
}

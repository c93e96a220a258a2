//! A reference (tare) taken from unloaded frames: how far the body the camera sees sits off
//! the model's unloaded surface, along the surface normal, as a smooth field on the surface
//! nodes ([`Tare`]). A real body's rest shape and sag differ from its model's (another
//! modulus, another mesh, a base that gives); without a reference that difference is read
//! as force. Later frames are sensed relative to it: each robot point moves back by the
//! field's offset at the surface point it sees ([`Tare::apply`]), so a body that sags
//! differently from its model reads zero when unloaded.
//!
//! The field lives on the nodes (material points), so it follows the body when the cable
//! inputs change: a frame's points are matched to the surface of its own free state.

use crate::geometry::raycast::Bvh;
use crate::geometry::triangle::closest_point_on_triangle_weights;
use crate::math::{dot, sub, unit};
use std::collections::BTreeMap;

/// Tunables of the reference fit.
#[derive(Clone, Copy, Debug)]
pub struct TareParams {
    /// A point farther than this from the unloaded surface along its normal is not the
    /// body's (a stray point, the table) and is left out of the fit, and left unmoved (m,
    /// 0.01).
    pub max_offset: f64,
    /// A point whose ray meets the surface more obliquely than this (|cos| of the ray with
    /// the normal) is left out of the fit (0.25), as the dense rows do.
    pub min_view_cos: f64,
    /// Weight of the smoothness between two neighbouring surface nodes, in units of one
    /// point's (1.0): it fills nodes no point sees from their neighbours.
    pub smoothing: f64,
}

impl Default for TareParams {
    fn default() -> Self {
        Self {
            max_offset: 0.01,
            min_view_cos: 0.25,
            smoothing: 1.0,
        }
    }
}

/// Where a ray from `eye` through `q` meets the surface at node positions `x`: the
/// triangle's index, the barycentric weights of the hit and the outward normal, and the
/// point's offset from the surface along that normal (m). `None` when it misses, meets a
/// face turned away, or more obliquely than `min_cos`.
pub(crate) fn surface_hit(
    bvh: &Bvh,
    triangles: &[[usize; 3]],
    x: &[[f64; 3]],
    eye: [f64; 3],
    q: [f64; 3],
    min_cos: f64,
) -> Option<(usize, [f64; 3], [f64; 3], f64)> {
    let to = sub(q, eye);
    let range = dot(to, to).sqrt();
    let d = unit(to);
    let (hit, k) = bvh.cast_triangle(eye, d)?;
    let cos = dot(hit.normal, d);
    if cos > -min_cos {
        return None;
    }
    let tri = triangles[k];
    let p = [0, 1, 2].map(|c| eye[c] + hit.t * d[c]);
    let (_, w) = closest_point_on_triangle_weights(p, x[tri[0]], x[tri[1]], x[tri[2]]);
    // The point's offset along the normal, n·(q − p): its miss along the ray, projected.
    Some((k, w, hit.normal, cos * (range - hit.t)))
}

/// The reference fit's normal equations, gathered view by view ([`TareFit::add_view`]) and
/// solved once ([`TareFit::finish`]).
#[derive(Clone, Debug)]
pub struct TareFit {
    params: TareParams,
    triangles: Vec<[usize; 3]>,
    /// Diagonal of the data term, per volume node.
    diagonal: Vec<f64>,
    /// Off-diagonal of the data term, per node pair (smaller index first).
    pairs: BTreeMap<(usize, usize), f64>,
    /// Right-hand side, per volume node.
    rhs: Vec<f64>,
    /// The points' offsets (m): the misfit before the field.
    offsets: Vec<f64>,
    /// Each point's triangle and weights, for the misfit after.
    hits: Vec<(usize, [f64; 3])>,
    frames: usize,
}

impl TareFit {
    /// An empty fit on a body of `nodes` volume nodes with these surface triangles.
    pub fn new(nodes: usize, triangles: &[[usize; 3]], params: TareParams) -> Self {
        Self {
            params,
            triangles: triangles.to_vec(),
            diagonal: vec![0.0; nodes],
            pairs: BTreeMap::new(),
            rhs: vec![0.0; nodes],
            offsets: Vec::new(),
            hits: Vec::new(),
            frames: 0,
        }
    }

    /// Adds one camera's robot points of an unloaded frame (robot frame, m), seen from
    /// `eye`, against the model's unloaded state `x` at that frame's inputs.
    pub fn add_view(&mut self, x: &[[f64; 3]], eye: [f64; 3], points: &[[f64; 3]]) {
        let bvh = Bvh::new(x, &self.triangles);
        let (triangles, p) = (&self.triangles, self.params);
        let found = super::par_map(points, |&q| {
            surface_hit(&bvh, triangles, x, eye, q, p.min_view_cos)
                .filter(|h| h.3.abs() <= p.max_offset)
        });
        for (k, w, _, r) in found.into_iter().flatten() {
            let tri = self.triangles[k];
            for a in 0..3 {
                self.rhs[tri[a]] += w[a] * r;
                self.diagonal[tri[a]] += w[a] * w[a];
                for b in a + 1..3 {
                    let key = (tri[a].min(tri[b]), tri[a].max(tri[b]));
                    *self.pairs.entry(key).or_insert(0.0) += w[a] * w[b];
                }
            }
            self.offsets.push(r);
            self.hits.push((k, w));
        }
    }

    /// Counts one more reference frame (its views added).
    pub fn end_frame(&mut self) {
        self.frames += 1;
    }

    /// Solves for the field: least squares of the points' offsets plus the smoothness
    /// between neighbouring surface nodes (conjugate gradients, Jacobi-preconditioned).
    /// `None` when no point was fitted.
    pub fn finish(self) -> Option<Tare> {
        if self.offsets.is_empty() {
            return None;
        }
        let n = self.diagonal.len();
        let mut surface = vec![false; n];
        let mut diagonal = self.diagonal.clone();
        let mut pairs = self.pairs.clone();
        let lambda = self.params.smoothing;
        for t in &self.triangles {
            for a in 0..3 {
                surface[t[a]] = true;
                let (i, j) = (t[a], t[(a + 1) % 3]);
                // Each edge is in two triangles: half the weight from each.
                let half = 0.5 * lambda;
                diagonal[i] += half;
                diagonal[j] += half;
                *pairs.entry((i.min(j), i.max(j))).or_insert(0.0) -= half;
            }
        }
        let matrix = SymmetricSparse::new(n, &diagonal, &pairs, &surface);
        let offsets = matrix.solve(&self.rhs, &surface);
        let residual_sq: f64 = (self.hits.iter().zip(&self.offsets))
            .map(|(&(k, w), r)| {
                let t = self.triangles[k];
                let f: f64 = (0..3).map(|a| w[a] * offsets[t[a]]).sum();
                (r - f).powi(2)
            })
            .sum();
        let count = self.offsets.len();
        let before = self.offsets.iter().map(|r| r * r).sum::<f64>() / count as f64;
        Some(Tare {
            offsets,
            frames: self.frames,
            points: count,
            rms_before: before.sqrt(),
            rms_after: (residual_sq / count as f64).sqrt(),
            params: self.params,
        })
    }
}

/// The reference of unloaded frames: a normal offset per surface node ([`TareFit`]).
#[derive(Clone, Debug)]
pub struct Tare {
    /// Per volume node, how far the seen body sits outside the model's unloaded surface
    /// along its normal (m); 0 off the surface.
    pub offsets: Vec<f64>,
    /// Reference frames fitted.
    pub frames: usize,
    /// Points fitted, over all frames and cameras.
    pub points: usize,
    /// RMS of the points' offsets from the model's unloaded surface (m): how far the body
    /// sat off its model.
    pub rms_before: f64,
    /// RMS of what the field leaves of them (m): the depth noise, and detail finer than the
    /// mesh.
    pub rms_after: f64,
    params: TareParams,
}

impl Tare {
    /// The largest |offset| of a node (m).
    pub fn largest_offset(&self) -> f64 {
        self.offsets.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// Moves each of `points` (robot frame, m, seen from `eye`) back by the field's offset
    /// where its ray meets the surface at the unloaded state `x` of its frame's inputs,
    /// along that normal: what the camera would see of a body whose rest shape is the
    /// model's. Points that meet no surface, or sit farther off it than
    /// [`TareParams::max_offset`], stay.
    pub fn apply(
        &self,
        x: &[[f64; 3]],
        triangles: &[[usize; 3]],
        eye: [f64; 3],
        points: &mut [[f64; 3]],
    ) {
        let bvh = Bvh::new(x, triangles);
        let p = self.params;
        // Any face seen at all: the shift is along its normal, so grazing is harmless.
        let shifts = super::par_map(points, |&q| {
            let (k, w, n, r) = surface_hit(&bvh, triangles, x, eye, q, 0.0)?;
            if r.abs() > p.max_offset {
                return None;
            }
            let t = triangles[k];
            let delta: f64 = (0..3).map(|a| w[a] * self.offsets[t[a]]).sum();
            Some(n.map(|c| c * delta))
        });
        for (q, s) in points.iter_mut().zip(shifts) {
            if let Some(s) = s {
                *q = sub(*q, s);
            }
        }
    }
}

/// A symmetric sparse matrix in rows of (column, value), over the nodes marked `active`.
struct SymmetricSparse {
    diagonal: Vec<f64>,
    rows: Vec<Vec<(usize, f64)>>,
}

impl SymmetricSparse {
    fn new(
        n: usize,
        diagonal: &[f64],
        pairs: &BTreeMap<(usize, usize), f64>,
        active: &[bool],
    ) -> Self {
        let mut rows = vec![Vec::new(); n];
        for (&(i, j), &v) in pairs {
            if active[i] && active[j] {
                rows[i].push((j, v));
                rows[j].push((i, v));
            }
        }
        Self {
            diagonal: diagonal.to_vec(),
            rows,
        }
    }

    fn mul(&self, x: &[f64], active: &[bool]) -> Vec<f64> {
        (0..x.len())
            .map(|i| {
                if !active[i] {
                    return 0.0;
                }
                let off: f64 = self.rows[i].iter().map(|&(j, v)| v * x[j]).sum();
                self.diagonal[i] * x[i] + off
            })
            .collect()
    }

    /// Conjugate gradients from zero, preconditioned by the diagonal, over the active
    /// nodes (inactive ones stay 0), to a relative residual of 1e-10.
    fn solve(&self, b: &[f64], active: &[bool]) -> Vec<f64> {
        let n = b.len();
        // A vanishing ridge keeps a surface part no point saw (its field 0) definite.
        let inv: Vec<f64> = (0..n)
            .map(|i| {
                if active[i] {
                    1.0 / (self.diagonal[i] + 1e-12)
                } else {
                    0.0
                }
            })
            .collect();
        let mut x = vec![0.0; n];
        let mut r: Vec<f64> = (0..n).map(|i| if active[i] { b[i] } else { 0.0 }).collect();
        let norm_b = dot_n(&r, &r).sqrt();
        if norm_b == 0.0 {
            return x;
        }
        let mut z: Vec<f64> = r.iter().zip(&inv).map(|(r, m)| r * m).collect();
        let mut p = z.clone();
        let mut rz = dot_n(&r, &z);
        for _ in 0..10 * n.max(10) {
            let ap = self.mul(&p, active);
            let pap = dot_n(&p, &ap);
            if pap <= 0.0 {
                break;
            }
            let alpha = rz / pap;
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
            }
            if dot_n(&r, &r).sqrt() <= 1e-10 * norm_b {
                break;
            }
            z = r.iter().zip(&inv).map(|(r, m)| r * m).collect();
            let rz_next = dot_n(&r, &z);
            let beta = rz_next / rz;
            rz = rz_next;
            for i in 0..n {
                p[i] = z[i] + beta * p[i];
            }
        }
        x
    }
}

fn dot_n(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

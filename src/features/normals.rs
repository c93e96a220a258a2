//! Normal estimation by PCA (PCL `NormalEstimation`, Open3D `estimate_normals`).

use super::FeatureError;
use crate::cloud::PointCloud;
use crate::search::{join, map_indices, map_knn_with, KdTree, KnnSearch, Parallelism, RadiusQuery};
use crate::search::{map_knn, FlannTree};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The neighbourhood of a point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Neighbourhood {
    /// The `k` nearest points, the point itself included.
    Knn(usize),
    /// All points strictly within the radius (metres), the point itself included.
    Radius(f64),
}

/// Which library's conventions to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NormalMode {
    /// PCL: flip towards the viewpoint; fewer than 3 neighbours or a non-finite point
    /// give NaN normal and curvature, collinear neighbours a NaN normal (curvature
    /// still computed); `f32` search distances; a k-NN neighbourhood with several
    /// points at the k-th distance keeps those FLANN visits first (for k ≤ 250, see
    /// [`FlannTree`](crate::search::FlannTree)), as PCL's `KdTreeFLANN` does.
    #[default]
    Pcl,
    /// Open3D: no orientation; fewer than 3 neighbours give `(0,0,1)` (curvature NaN);
    /// `f64` radius test; a tie at the k-th distance keeps the smaller indices.
    Open3d,
}

/// Largest k for which FLANN uses its `KNNSimpleResultSet` (PCL mode emulates its tie
/// choice up to here; above, FLANN's heap result set decides ties, not emulated: the
/// smaller index is kept).
const FLANN_SIMPLE_MAX_K: usize = 250;

/// Parameters of [`estimate_normals`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NormalParams {
    /// Neighbourhood used for the covariance.
    pub neighbourhood: Neighbourhood,
    /// Conventions.
    pub mode: NormalMode,
    /// Point to orient normals towards (PCL mode); `None`: the cloud's viewpoint origin.
    pub viewpoint: Option<[f32; 3]>,
    /// Threads.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for NormalParams {
    fn default() -> Self {
        NormalParams::knn(10)
    }
}

impl NormalParams {
    /// k-NN neighbourhood, PCL mode.
    pub fn knn(k: usize) -> Self {
        NormalParams {
            neighbourhood: Neighbourhood::Knn(k),
            mode: NormalMode::Pcl,
            viewpoint: None,
            parallelism: Parallelism::default(),
        }
    }
}

/// Estimated normals and curvature, one per input point.
#[derive(Debug, Clone, PartialEq)]
pub struct Normals {
    /// Unit normals (NaN where undefined in PCL mode).
    pub normals: Vec<[f32; 3]>,
    /// Curvature `λ0 / (λ0 + λ1 + λ2)` (0 when the trace is 0; NaN where undefined).
    pub curvature: Vec<f32>,
}

impl Normals {
    /// Stores the result in the cloud's `normals` and `curvature` columns.
    pub fn apply_to(self, cloud: &mut PointCloud) {
        cloud.normals = Some(self.normals);
        cloud.curvature = Some(self.curvature);
    }
}

/// Estimates a normal and curvature for every point of `cloud`: the eigenvector of the
/// smallest eigenvalue of the neighbourhood's population covariance (de-meaned, `f64`).
pub fn estimate_normals(
    cloud: &PointCloud,
    params: &NormalParams,
) -> Result<Normals, FeatureError> {
    cloud.validate()?;
    match params.neighbourhood {
        Neighbourhood::Knn(0) => return Err(FeatureError::ZeroK),
        Neighbourhood::Radius(r) if !(r.is_finite() && r > 0.0) => {
            return Err(FeatureError::InvalidRadius(r))
        }
        _ => {}
    }
    let vp = params.viewpoint.unwrap_or(cloud.viewpoint.origin);
    let pcl = params.mode == NormalMode::Pcl;
    let invalid = if pcl {
        ([f32::NAN; 3], f32::NAN)
    } else {
        ([0.0, 0.0, 1.0], f32::NAN)
    };
    let ctx = Ctx {
        positions: &cloud.positions,
        pcl,
        viewpoint: vp,
        invalid,
    };
    let par = params.parallelism;
    let res: Vec<([f32; 3], f32)> = match params.neighbourhood {
        // PERF: all k-NN lists at once on a grid (exact, ties to the smaller index).
        Neighbourhood::Knn(k) if !pcl || k > FLANN_SIMPLE_MAX_K => ctx.by_knn(k, par),
        Neighbourhood::Knn(k) => ctx.by_knn_flann_ties(k, cloud.is_organized(), par),
        Neighbourhood::Radius(r) => ctx.by_radius(r, par),
    };
    Ok(Normals {
        normals: res.iter().map(|r| r.0).collect(),
        curvature: res.iter().map(|r| r.1).collect(),
    })
}

impl Ctx<'_> {
    /// Normals over each point's k nearest (ties at the k-th place to the smaller index).
    fn by_knn(&self, k: usize, par: Parallelism) -> Vec<([f32; 3], f32)> {
        map_knn(self.positions, k, par, |i, nbrs| {
            if nbrs.is_empty() {
                return self.invalid;
            }
            self.normal_of(i, nbrs.iter().map(|n| n.index))
        })
    }

    /// Normals over each point's k nearest as PCL's FLANN picks them (`organized`: the
    /// cloud is a sensor frame).
    fn by_knn_flann_ties(
        &self,
        k: usize,
        organized: bool,
        par: Parallelism,
    ) -> Vec<([f32; 3], f32)> {
        // PCL: where points tie at the k-th distance, FLANN's visiting order decides
        // which of them are kept. The grid asks for k + 1 neighbours to see the tie;
        // the untied points (almost all) are done in this pass, the tied ones by the
        // FLANN-order tree, built only when there is one.
        // PERF: sensor frames (organised clouds) nearly always tie somewhere (2-4% of
        // the points of the Kinect frames at k = 10), so their FLANN tree is built
        // while the grid is sorted on one thread, which leaves the other idle.
        let speculate = organized && par == Parallelism::Rayon;
        let (search, mut tree) = join(
            par,
            || KnnSearch::new(self.positions, k.saturating_add(1)),
            || speculate.then(|| FlannTree::build_with(self.positions, par)),
        );
        let first = map_knn_with(&search, par, |i, nbrs| {
            if nbrs.is_empty() {
                return Some(self.invalid);
            }
            if nbrs.len() > k && nbrs[k].squared_distance == nbrs[k - 1].squared_distance {
                // A tie: FLANN's order decides, here when its tree is already built.
                let t = tree.as_ref()?;
                let nbrs = t.nearest_k(&self.positions[i], k);
                return Some(self.normal_of(i, nbrs.iter().map(|n| n.index)));
            }
            Some(self.normal_of(i, nbrs.iter().take(k).map(|n| n.index)))
        });
        let tied: Vec<usize> = (0..first.len()).filter(|&i| first[i].is_none()).collect();
        let fixed = if tied.is_empty() {
            Vec::new()
        } else {
            let tree = tree.get_or_insert_with(|| FlannTree::build_with(self.positions, par));
            map_indices(tied.len(), par, |t| {
                let i = tied[t];
                let nbrs = tree.nearest_k(&self.positions[i], k);
                self.normal_of(i, nbrs.iter().map(|n| n.index))
            })
        };
        let mut fixed = fixed.into_iter();
        first
            .into_iter()
            .map(|r| r.unwrap_or_else(|| fixed.next().unwrap_or(self.invalid)))
            .collect()
    }

    /// Normals over the points within `r` (m) of each point.
    fn by_radius(&self, r: f64, par: Parallelism) -> Vec<([f32; 3], f32)> {
        let tree = KdTree::build(self.positions);
        map_indices(self.positions.len(), par, |i| {
            let p = &self.positions[i];
            if !PointCloud::is_finite_point(p) {
                return self.invalid;
            }
            let q = RadiusQuery::unsorted();
            let nbrs: Vec<usize> = if self.pcl {
                tree.within_radius(p, r, q)
                    .iter()
                    .map(|n| n.index)
                    .collect()
            } else {
                tree.within_radius_f64(p, r, q)
                    .iter()
                    .map(|n| n.index)
                    .collect()
            };
            self.normal_of(i, nbrs.into_iter())
        })
    }
}

/// What [`estimate_normals`] needs to turn a neighbourhood into a normal.
struct Ctx<'a> {
    positions: &'a [[f32; 3]],
    pcl: bool,
    viewpoint: [f32; 3],
    /// The answer for an undefined normal.
    invalid: ([f32; 3], f32),
}

impl Ctx<'_> {
    /// The normal and curvature of point `i` from its neighbours' indices.
    #[inline]
    fn normal_of(&self, i: usize, nbrs: impl Iterator<Item = usize>) -> ([f32; 3], f32) {
        let Some((n, curv, degenerate, count)) = pca_normal(self.positions, nbrs) else {
            return self.invalid;
        };
        if count < 3 {
            return self.invalid;
        }
        if self.pcl && degenerate {
            // Collinear (or coincident) neighbours: the plane is undefined. PCL's eigen33
            // gives a NaN vector here (its cross products vanish) with a finite curvature.
            return ([f32::NAN; 3], curv);
        }
        let mut n = n;
        if self.pcl {
            let p = &self.positions[i];
            let vp = self.viewpoint;
            let v = [vp[0] - p[0], vp[1] - p[1], vp[2] - p[2]];
            if v[0] * n[0] + v[1] * n[1] + v[2] * n[2] < 0.0 {
                n = n.map(|c| -c);
            }
        }
        (n, curv)
    }
}

/// Normal (unit eigenvector of the smallest eigenvalue), curvature, whether the
/// neighbourhood is degenerate (rank ≤ 1: the middle eigenvalue is below 1e-12 of the
/// largest), and the number of points, for the points at `idx`. The covariance is
/// accumulated in `f64` relative to the first point (exact differences of `f32`
/// coordinates, so far-from-origin clouds lose nothing), i.e. de-meaned. `None` if there
/// is no point or the covariance is not finite.
pub(crate) fn pca_normal(
    points: &[[f32; 3]],
    mut idx: impl Iterator<Item = usize>,
) -> Option<([f32; 3], f32, bool, usize)> {
    let first = points[idx.next()?];
    let o = first.map(f64::from);
    let (mut s, mut ss) = ([0f64; 3], [0f64; 6]);
    let mut count = 1usize;
    for i in idx {
        let p = points[i];
        let d = [p[0] as f64 - o[0], p[1] as f64 - o[1], p[2] as f64 - o[2]];
        s[0] += d[0];
        s[1] += d[1];
        s[2] += d[2];
        ss[0] += d[0] * d[0];
        ss[1] += d[0] * d[1];
        ss[2] += d[0] * d[2];
        ss[3] += d[1] * d[1];
        ss[4] += d[1] * d[2];
        ss[5] += d[2] * d[2];
        count += 1;
    }
    let n = count as f64;
    let m = s.map(|v| v / n);
    let c = |k: usize, a: usize, b: usize| ss[k] / n - m[a] * m[b];
    let cov = Matrix3::new(
        c(0, 0, 0),
        c(1, 0, 1),
        c(2, 0, 2),
        c(1, 0, 1),
        c(3, 1, 1),
        c(4, 1, 2),
        c(2, 0, 2),
        c(4, 1, 2),
        c(5, 2, 2),
    );
    if !cov.iter().all(|c| c.is_finite()) {
        return None;
    }
    let six = [
        cov[(0, 0)],
        cov[(0, 1)],
        cov[(0, 2)],
        cov[(1, 1)],
        cov[(1, 2)],
        cov[(2, 2)],
    ];
    let (ev, v) = match eigen_sym3_halley(&six).or_else(|| eigen_sym3_closed_form(&cov)) {
        Some(r) => r,
        None => {
            // Repeated eigenvalues (or a zero matrix): the iterative solver decides.
            let eig = cov.symmetric_eigen();
            let mut imin = 0;
            for a in 1..3 {
                if eig.eigenvalues[a] < eig.eigenvalues[imin] {
                    imin = a;
                }
            }
            let c = eig.eigenvectors.column(imin);
            let mut ev = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];
            ev.sort_by(f64::total_cmp);
            (ev, [c[0], c[1], c[2]])
        }
    };
    let lmin = ev[0];
    let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let normal = [
        (v[0] / norm) as f32,
        (v[1] / norm) as f32,
        (v[2] / norm) as f32,
    ];
    let trace = cov[(0, 0)] + cov[(1, 1)] + cov[(2, 2)];
    let curvature = if trace != 0.0 {
        (lmin.abs() / trace) as f32
    } else {
        0.0
    };
    let degenerate = ev[1] <= 1e-12 * ev[2].abs();
    Some((normal, curvature, degenerate, count))
}

/// Eigenvalues (ascending) of the symmetric 3x3 matrix with upper triangle
/// `[a00, a01, a02, a11, a12, a22]` and an eigenvector of the smallest, for a positive
/// semi-definite matrix (a covariance) whose smallest eigenvalue is well separated:
/// Halley's method on the characteristic cubic from just left of 0, then the other two
/// from the deflated quadratic, and the eigenvector as in [`eigen_sym3_closed_form`].
/// `None` when the iteration does not settle within [`ROOT_STEPS`] steps or the two
/// smallest eigenvalues are within 1e-5 of the largest entry (the caller then uses the
/// trigonometric solution).
///
/// PERF: for a surface patch (smallest eigenvalue well below the others) Halley's
/// cubic convergence settles in 2-3 steps, cheaper than the `acos` and two `cos` of the
/// trigonometric solution. It stops once a step is below 1e-6 of the trace: the next
/// error is about the cube of that, times the squared ratio of the trace to the other
/// two eigenvalues' product, far below what normals and curvature need.
fn eigen_sym3_halley(a: &[f64; 6]) -> Option<([f64; 3], [f64; 3])> {
    let s = a.iter().fold(0f64, |m, v| m.max(v.abs()));
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let inv = 1.0 / s;
    let [xx, xy, xz, yy, yz, zz] = a.map(|v| v * inv);
    let c2 = xx + yy + zz;
    let (m_xx, m_xy, m_xz) = (yy * zz - yz * yz, xy * zz - yz * xz, xy * yz - yy * xz);
    let c1 = m_xx + (xx * zz - xz * xz) + (xx * yy - xy * xy);
    let c0 = xx * m_xx - xy * m_xy + xz * m_xz;
    // The smallest eigenvalue is ≥ 0 up to rounding; start just left of it.
    let mut l = -1e-12 * c2.abs();
    let mut settled = false;
    for _ in 0..ROOT_STEPS {
        let f = ((l - c2) * l + c1) * l - c0;
        let df = (3.0 * l - 2.0 * c2) * l + c1;
        if df.is_nan() || df <= 0.0 {
            return None;
        }
        let ddf = 6.0 * l - 2.0 * c2;
        let step = 2.0 * f * df / (2.0 * df * df - f * ddf);
        l -= step;
        if step.abs() <= 1e-6 * c2.abs() {
            settled = true;
            break;
        }
    }
    if !settled {
        return None;
    }
    let sum = c2 - l;
    let prod = c1 - l * sum;
    let e_max = 0.5 * (sum + (sum * sum - 4.0 * prod).max(0.0).sqrt());
    let e_mid = if e_max > 0.0 { prod / e_max } else { 0.0 };
    let gap = e_mid - l;
    if gap.is_nan() || gap <= 1e-5 {
        return None;
    }
    let rows = [
        nalgebra::Vector3::new(xx - l, xy, xz),
        nalgebra::Vector3::new(xy, yy - l, yz),
        nalgebra::Vector3::new(xz, yz, zz - l),
    ];
    let v = largest_cross(&rows)?;
    let mut ev = [l * s, e_mid * s, e_max * s];
    ev.sort_by(f64::total_cmp);
    Some((ev, v))
}

/// Steps [`eigen_sym3_halley`] may take.
const ROOT_STEPS: usize = 12;

/// The largest cross product of two of the rows of `A − λI` (an eigenvector of `λ`),
/// `None` when it is too small to be one (a repeated eigenvalue; rows of unit scale).
fn largest_cross(rows: &[nalgebra::Vector3<f64>; 3]) -> Option<[f64; 3]> {
    let crosses = [
        rows[0].cross(&rows[1]),
        rows[0].cross(&rows[2]),
        rows[1].cross(&rows[2]),
    ];
    let best = crosses
        .iter()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))?;
    if best.norm_squared().is_nan() || best.norm_squared() <= 1e-20 {
        return None;
    }
    Some([best[0], best[1], best[2]])
}

/// Eigenvalues (ascending) of a symmetric 3x3 matrix and an eigenvector of the smallest,
/// in closed form: the trigonometric solution of the characteristic cubic on the
/// matrix scaled to unit largest entry, then the largest cross product of two rows of
/// `A − λ₀I`. `None` when that is ill-conditioned (the two smallest eigenvalues within
/// 1e-5 of the largest entry, a multiple of the identity, the zero matrix); the caller then uses an iterative solver.
///
/// PERF: several times faster than nalgebra's QR iteration, and in `f64` its error is
/// far below what normals and curvature need (1e-10 rad for an eigenvalue gap of 1e-6
/// of the largest).
fn eigen_sym3_closed_form(a: &Matrix3<f64>) -> Option<([f64; 3], [f64; 3])> {
    let s = a.iter().fold(0f64, |m, v| m.max(v.abs()));
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let b = a / s;
    let q = (b[(0, 0)] + b[(1, 1)] + b[(2, 2)]) / 3.0;
    let p1 = b[(0, 1)].powi(2) + b[(0, 2)].powi(2) + b[(1, 2)].powi(2);
    let p2 = (b[(0, 0)] - q).powi(2) + (b[(1, 1)] - q).powi(2) + (b[(2, 2)] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    if p <= 1e-12 {
        return None;
    }
    let c = (b - Matrix3::identity() * q) / p;
    let r = (c.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e_max = q + 2.0 * p * phi.cos();
    let e_min = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    let e_mid = 3.0 * q - e_max - e_min;
    // Near a double root the cubic's solution loses half its digits (about 1e-8 here),
    // enough to hide a rank-1 (collinear) neighbourhood: leave close pairs to QR.
    if e_mid - e_min <= 1e-5 {
        return None;
    }
    let m = b - Matrix3::identity() * e_min;
    let rows = [
        m.row(0).transpose(),
        m.row(1).transpose(),
        m.row(2).transpose(),
    ];
    let v = largest_cross(&rows)?;
    let mut ev = [e_min * s, e_mid * s, e_max * s];
    ev.sort_by(f64::total_cmp);
    Some((ev, v))
}

//! Step 2 of the geometric segmentation: the support plane by RANSAC with a fixed seed
//! and a least-squares refit, and the points that lie on it.

use super::{dot, norm, sub, widen, GeometricParams};

/// Small deterministic generator (xorshift64*) for RANSAC: the same cloud always gives
/// the same plane.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as usize % n.max(1)
    }
}

/// RANSAC for the dominant plane among points whose normal agrees with it, refitted by
/// least squares on its inliers; `None` when it holds less than `plane_min_fraction`.
pub(super) fn support_plane(
    pts: &[[f32; 3]],
    nrm: &[Option<[f64; 3]>],
    params: &GeometricParams,
) -> Option<[f64; 4]> {
    let m = pts.len();
    let step = (m / 20_000).max(1);
    let sample: Vec<usize> = (0..m).step_by(step).collect();
    let cos_plane = params.plane_normal_deg.to_radians().cos();
    let count = |pl: [f64; 4], idx: &mut dyn Iterator<Item = usize>| -> usize {
        idx.filter(|&i| is_inlier(pts[i], nrm[i], pl, params.plane_distance_m, cos_plane))
            .count()
    };
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut best: Option<([f64; 4], usize)> = None;
    for _ in 0..params.ransac_iterations {
        let (a, b, c) = (
            sample[rng.below(sample.len())],
            sample[rng.below(sample.len())],
            sample[rng.below(sample.len())],
        );
        let (u, v) = (sub(pts[b], pts[a]), sub(pts[c], pts[a]));
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let len = norm(n);
        if len.is_nan() || len <= 1e-12 {
            continue;
        }
        let n = n.map(|x| x / len);
        let pl = [n[0], n[1], n[2], -dot(n, widen(pts[a]))];
        let k = count(pl, &mut sample.iter().copied());
        if best.is_none_or(|(_, bk)| k > bk) {
            best = Some((pl, k));
        }
    }
    let (pl, _) = best?;
    let inliers: Vec<usize> = (0..m)
        .filter(|&i| is_inlier(pts[i], nrm[i], pl, params.plane_distance_m, cos_plane))
        .collect();
    let pl = refit(pts, &inliers).unwrap_or(pl);
    let k = count(pl, &mut (0..m));
    (k as f64 >= params.plane_min_fraction * m as f64).then_some(pl)
}

fn is_inlier(p: [f32; 3], n: Option<[f64; 3]>, pl: [f64; 4], dist: f64, cos: f64) -> bool {
    let nn = [pl[0], pl[1], pl[2]];
    (dot(nn, widen(p)) + pl[3]).abs() < dist && n.is_some_and(|n| dot(n, nn).abs() >= cos)
}

/// Least-squares plane through `idx` (smallest eigenvector of the covariance), normal
/// oriented towards the origin side of the plane (the viewpoint for camera clouds).
fn refit(pts: &[[f32; 3]], idx: &[usize]) -> Option<[f64; 4]> {
    if idx.len() < 3 {
        return None;
    }
    let mut c = [0f64; 3];
    for &i in idx {
        for a in 0..3 {
            c[a] += pts[i][a] as f64;
        }
    }
    let c = c.map(|v| v / idx.len() as f64);
    let mut cov = nalgebra::Matrix3::<f64>::zeros();
    for &i in idx {
        let d = nalgebra::Vector3::new(
            pts[i][0] as f64 - c[0],
            pts[i][1] as f64 - c[1],
            pts[i][2] as f64 - c[2],
        );
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let k = eig.eigenvalues.imin();
    let n = eig.eigenvectors.column(k);
    let mut n = [n[0], n[1], n[2]];
    let mut d = -dot(n, c);
    if d < 0.0 {
        n = n.map(|x| -x);
        d = -d;
    }
    n.iter()
        .all(|v| v.is_finite())
        .then_some([n[0], n[1], n[2], d])
}

/// Per point: on the support plane (close to it and with a normal along it); all `false`
/// without a plane.
pub(super) fn plane_members(
    pts: &[[f32; 3]],
    nrm: &[Option<[f64; 3]>],
    plane: Option<[f64; 4]>,
    params: &GeometricParams,
) -> Vec<bool> {
    let m = pts.len();
    let cos_plane = params.plane_normal_deg.to_radians().cos();
    match plane {
        Some(pl) => (0..m)
            .map(|i| {
                let p = widen(pts[i]);
                let dist = (dot([pl[0], pl[1], pl[2]], p) + pl[3]).abs();
                let along =
                    nrm[i].is_some_and(|n| dot(n, [pl[0], pl[1], pl[2]]).abs() >= cos_plane);
                dist < params.plane_distance_m && along
            })
            .collect(),
        None => vec![false; m],
    }
}

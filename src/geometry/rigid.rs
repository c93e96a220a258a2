//! Rigid fits: Kabsch (point-to-point, thesis 3.15) and one point-to-plane Gauss-Newton
//! step. Calibration, marker calibration and the ICP all fit rigid motions here.

use crate::math::{Iso3, Mat3, Vec3};
use nalgebra::{Matrix6, Rotation3, Translation3, UnitQuaternion, Vector6};

/// The rigid transform T minimising Σ‖T src_i − dst_i‖² (SVD, Kabsch/Umeyama without
/// scale; thesis 3.15). None for fewer than 3 pairs, unequal lengths or non-finite data.
pub fn kabsch(src: &[[f64; 3]], dst: &[[f64; 3]]) -> Option<Iso3> {
    if src.len() != dst.len() || src.len() < 3 {
        return None;
    }
    let n = src.len() as f64;
    let c = |ps: &[[f64; 3]]| ps.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let (cs, cd) = (c(src), c(dst));
    let mut h = Mat3::zeros();
    for (s, d) in src.iter().zip(dst) {
        h += (Vec3::from(*s) - cs) * (Vec3::from(*d) - cd).transpose();
    }
    if !h.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = Mat3::identity();
    if (vt.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = vt.transpose() * d * u.transpose();
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = cd - rot * cs;
    Some(Iso3::from_parts(Translation3::from(t), rot))
}

/// One Gauss-Newton step of point-to-plane ICP: the small rigid motion D (about the
/// centroid of `src`) minimising Σ (n_i · (D src_i − dst_i))² to first order. The step is
/// returned as a proper rigid transform (rotation by the solved rotation vector). None when
/// the 6x6 normal matrix is singular (e.g. all normals parallel).
pub fn point_to_plane_step(
    src: &[[f64; 3]],
    dst: &[[f64; 3]],
    normals: &[[f64; 3]],
) -> Option<Iso3> {
    if src.len() != dst.len() || src.len() != normals.len() || src.len() < 6 {
        return None;
    }
    let n = src.len() as f64;
    let c = src.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let mut a = Matrix6::<f64>::zeros();
    let mut b = Vector6::<f64>::zeros();
    for ((s, d), nn) in src.iter().zip(dst).zip(normals) {
        let p = Vec3::from(*s) - c;
        let nv = Vec3::from(*nn);
        let r = nv.dot(&(Vec3::from(*s) - Vec3::from(*d)));
        let pn = p.cross(&nv);
        let j = Vector6::new(pn.x, pn.y, pn.z, nv.x, nv.y, nv.z);
        a += j * j.transpose();
        b -= j * r;
    }
    let x = a.cholesky()?.solve(&b);
    if !x.iter().all(|v| v.is_finite()) {
        return None;
    }
    let w = Vec3::new(x[0], x[1], x[2]);
    let t = Vec3::new(x[3], x[4], x[5]);
    let rot = UnitQuaternion::from_scaled_axis(w);
    // p' = c + R (p - c) + t
    Some(Iso3::from_parts(Translation3::from(c + t - rot * c), rot))
}

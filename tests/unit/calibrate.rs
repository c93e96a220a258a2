//! Rigid fits and exact closest points of the calibration, against known transforms and
//! brute-force oracles.
use proptest::prelude::*;
use softsense::calibrate::{
    kabsch, point_to_plane_step, pose_difference, pose_from_matrix, pose_to_matrix, SurfaceIndex,
};
use softsense::fem::mesh::TetMesh;
use softsense::math::{Iso3, Point3, Vec3};
use softsense::register::{closest_point_on_triangle, closest_point_on_triangle_weights};

fn apply(t: &Iso3, p: [f64; 3]) -> [f64; 3] {
    let q = t * Point3::from(p);
    [q.x, q.y, q.z]
}

/// Brute force: the closest of a dense barycentric grid on the triangle.
fn grid_closest(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f64 {
    let k = 300;
    let mut best = f64::INFINITY;
    for i in 0..=k {
        for j in 0..=(k - i) {
            let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
            best = best.min((a + (b - a) * u + (c - a) * v - p).norm());
        }
    }
    best
}

#[test]
fn closest_point_and_weights_on_a_triangle_match_a_dense_grid_in_every_region() {
    let (a, b, c) = (
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.2, 0.8, 0.0),
    );
    // Queries in the interior and beyond each vertex and edge, above the plane.
    for p in [
        [0.3, 0.2, 0.5],
        [-0.5, -0.5, 0.1],
        [1.5, -0.2, -0.3],
        [0.2, 1.5, 0.2],
        [0.5, -0.6, 0.0],
        [0.9, 0.6, 0.4],
        [-0.3, 0.5, -0.2],
    ] {
        let p = Vec3::from(p);
        let (s, w) = closest_point_on_triangle_weights(p.into(), a.into(), b.into(), c.into());
        let s = Vec3::from(s);
        let d = (s - p).norm();
        assert!((d - grid_closest(p, a, b, c)).abs() < 5e-3, "{p:?}");
        assert!(
            d <= grid_closest(p, a, b, c) + 1e-12,
            "not below the grid: {p:?}"
        );
        let back = a * w[0] + b * w[1] + c * w[2];
        assert!((back - s).norm() < 1e-12);
        assert!(w.iter().all(|v| *v >= -1e-12) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn surface_index_finds_the_same_distance_as_brute_force_over_all_triangles() {
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let x = &m.nodes_in_rest;
    let index = SurfaceIndex::new(x, &s.triangles);
    let mut seed = 7u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..300 {
        let p = [
            0.14 * rnd() - 0.02,
            0.08 * rnd() - 0.02,
            0.06 * rnd() - 0.02,
        ];
        let got = index.closest(p).unwrap();
        let brute = s
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| Vec3::from(x[i]));
                let q = closest_point_on_triangle(p, a.into(), b.into(), c.into());
                (Vec3::from(q) - Vec3::from(p)).norm()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(
            (got.distance - brute).abs() < 1e-12,
            "{p:?}: {} vs {brute}",
            got.distance
        );
    }
}

#[test]
fn kabsch_recovers_a_known_transform_exactly() {
    let truth = Iso3::new(Vec3::new(0.03, -0.2, 0.45), Vec3::new(0.4, -1.1, 0.7));
    let src: Vec<[f64; 3]> = (0..20)
        .map(|i| {
            let f = i as f64;
            [(f * 0.37).sin() * 0.1, (f * 0.71).cos() * 0.05, f * 0.004]
        })
        .collect();
    let dst: Vec<[f64; 3]> = src.iter().map(|p| apply(&truth, *p)).collect();
    let fit = kabsch(&src, &dst).unwrap();
    let (dt, dr) = pose_difference(&fit, &truth);
    assert!(dt < 1e-12 && dr < 1e-9, "{dt} {dr}");
    assert!(kabsch(&src[..2], &dst[..2]).is_none());
}

#[test]
fn point_to_plane_icp_on_a_box_surface_recovers_a_known_transform() {
    // Points sampled on a box surface, moved by a known transform; point-to-plane steps
    // with exact closest points bring them back (the oracle is the transform itself).
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.06, 0.04], [5, 3, 2]).unwrap();
    let s = m.surface();
    let x = &m.nodes_in_rest;
    let index = SurfaceIndex::new(x, &s.triangles);
    let mut pts = Vec::new();
    for t in &s.triangles {
        let [a, b, c] = t.map(|i| Vec3::from(x[i]));
        for (u, v) in [(0.2, 0.2), (0.6, 0.2), (0.2, 0.6), (0.33, 0.33)] {
            let p = a + (b - a) * u + (c - a) * v;
            pts.push([p.x, p.y, p.z]);
        }
    }
    let truth = Iso3::new(
        Vec3::new(0.004, -0.003, 0.002),
        Vec3::new(0.03, -0.02, 0.05),
    );
    let moved: Vec<[f64; 3]> = pts.iter().map(|p| apply(&truth.inverse(), *p)).collect();
    let mut pose = Iso3::identity();
    for _ in 0..30 {
        let src: Vec<[f64; 3]> = moved.iter().map(|p| apply(&pose, *p)).collect();
        let hits: Vec<_> = src.iter().map(|p| index.closest(*p).unwrap()).collect();
        let dst: Vec<[f64; 3]> = hits.iter().map(|h| h.point).collect();
        let nrm: Vec<[f64; 3]> = hits.iter().map(|h| h.normal).collect();
        pose = point_to_plane_step(&src, &dst, &nrm).unwrap() * pose;
    }
    let (dt, dr) = pose_difference(&pose, &truth);
    assert!(dt < 1e-9 && dr < 1e-8, "{dt} m {dr} rad");
}

#[test]
fn point_to_plane_step_matches_finite_differences_of_its_objective() {
    // Gauss-Newton on a zero-residual problem: one step cuts the objective by orders of
    // magnitude, a few reach round-off, and there the finite-difference gradient of the
    // true objective (the oracle) vanishes.
    let src = [
        [0.0, 0.0, 0.0],
        [0.1, 0.0, 0.01],
        [0.0, 0.1, 0.02],
        [0.1, 0.1, -0.01],
        [0.05, 0.02, 0.1],
        [0.02, 0.07, 0.05],
        [0.08, 0.03, 0.06],
    ];
    let normals: Vec<[f64; 3]> = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.6, 0.8, 0.0],
        [0.0, 0.6, 0.8],
        [0.8, 0.0, 0.6],
        [0.48, 0.6, 0.64],
    ]
    .to_vec();
    let truth = Iso3::new(Vec3::new(1e-4, -2e-4, 1.5e-4), Vec3::new(1e-3, 2e-3, -1e-3));
    let dst: Vec<[f64; 3]> = src.iter().map(|p| apply(&truth, *p)).collect();
    let f = |t: &Iso3| -> f64 {
        src.iter()
            .zip(&dst)
            .zip(&normals)
            .map(|((s, d), n)| {
                let p = apply(t, *s);
                (0..3).map(|k| n[k] * (p[k] - d[k])).sum::<f64>().powi(2)
            })
            .sum()
    };
    let start = f(&Iso3::identity());
    let one = f(&point_to_plane_step(&src, &dst, &normals).unwrap());
    assert!(one < 1e-4 * start, "one step: {start} -> {one}");
    let mut step = Iso3::identity();
    for _ in 0..4 {
        let moved: Vec<[f64; 3]> = src.iter().map(|p| apply(&step, *p)).collect();
        step = point_to_plane_step(&moved, &dst, &normals).unwrap() * step;
    }
    let f0 = f(&step);
    assert!(f0 < 1e-26, "objective after four steps {f0}");
    let h = 1e-6;
    for k in 0..6 {
        let mut v = [0.0; 6];
        v[k] = h;
        let d = Iso3::new(Vec3::new(v[3], v[4], v[5]), Vec3::new(v[0], v[1], v[2]));
        let g = (f(&(d * step)) - f(&(d.inverse() * step))) / (2.0 * h);
        assert!(g.abs() < 1e-12, "gradient component {k} = {g}");
    }
}

#[test]
fn pose_from_matrix_refuses_non_rigid_matrices() {
    let mut m = pose_to_matrix(&Iso3::identity());
    m[0][0] = 2.0;
    assert!(pose_from_matrix(&m).is_err());
    let mut m = pose_to_matrix(&Iso3::identity());
    m[3][0] = 1.0;
    assert!(pose_from_matrix(&m).is_err());
    let mut m = pose_to_matrix(&Iso3::identity());
    m[1][1] = -1.0; // det -1: a reflection
    assert!(pose_from_matrix(&m).is_err());
    m[1][1] = f64::NAN;
    assert!(pose_from_matrix(&m).is_err());
}

proptest! {
    #[test]
    fn kabsch_recovers_any_rigid_transform_of_a_non_degenerate_point_set(
        ax in -3.0f64..3.0, ay in -3.0f64..3.0, az in -3.0f64..3.0,
        tx in -1.0f64..1.0, ty in -1.0f64..1.0, tz in -1.0f64..1.0,
        pts in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 4..30),
    ) {
        let src: Vec<[f64; 3]> = pts.iter().map(|p| [p.0, p.1, p.2]).collect();
        // Non-degenerate: the smallest singular value of the centred cloud is not tiny.
        let n = src.len() as f64;
        let c = src.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
        let mut cov = nalgebra::Matrix3::<f64>::zeros();
        for p in &src {
            let d = Vec3::from(*p) - c;
            cov += d * d.transpose();
        }
        let sv = cov.singular_values();
        prop_assume!(sv.min() > 1e-2 * sv.max());
        let truth = Iso3::new(Vec3::new(tx, ty, tz), Vec3::new(ax, ay, az));
        let dst: Vec<[f64; 3]> = src.iter().map(|p| apply(&truth, *p)).collect();
        let fit = kabsch(&src, &dst).unwrap();
        let (dt, dr) = pose_difference(&fit, &truth);
        // A rotation off by dr moves the centroid (up to ~1 m from the origin here) by
        // about dr: the translation bound is the rotation's (1e-9 failed at 1.4e-9 m).
        prop_assert!(dt < 1e-7 && dr < 1e-7, "{} {}", dt, dr);
    }

    #[test]
    fn pose_matrix_round_trip_is_exact_to_rounding(
        ax in -3.0f64..3.0, ay in -3.0f64..3.0, az in -3.0f64..3.0,
        tx in -1.0f64..1.0, ty in -1.0f64..1.0, tz in -1.0f64..1.0,
    ) {
        let p = Iso3::new(Vec3::new(tx, ty, tz), Vec3::new(ax, ay, az));
        let back = pose_from_matrix(&pose_to_matrix(&p)).unwrap();
        let (dt, dr) = pose_difference(&back, &p);
        prop_assert!(dt < 1e-12 && dr < 1e-7);
    }
}

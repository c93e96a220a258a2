//! Normal estimation: known surfaces, orientation, invalid neighbourhoods, far from the origin.

use softsense::cloud::PointCloud;
use softsense::features::*;
use softsense::search::Parallelism;

/// A jittered grid on the plane through `origin` with unit normal `n` (deterministic).
fn plane(origin: [f64; 3], n: [f64; 3], count: usize, spacing: f64) -> Vec<[f32; 3]> {
    let n = nalgebra::Vector3::from(n).normalize();
    let u = n.cross(&nalgebra::Vector3::new(0.3, 0.5, 0.7)).normalize();
    let v = n.cross(&u);
    let mut out = Vec::new();
    let mut s = 12345u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 33) as f64 / (1u64 << 31) as f64 - 0.5
    };
    for i in 0..count {
        for j in 0..count {
            let a = (i as f64 + 0.3 * rnd()) * spacing;
            let b = (j as f64 + 0.3 * rnd()) * spacing;
            let p = nalgebra::Vector3::from(origin) + u * a + v * b;
            out.push([p[0] as f32, p[1] as f32, p[2] as f32]);
        }
    }
    out
}

fn angle_deg(a: [f32; 3], b: [f64; 3]) -> f64 {
    // atan2(|a×b|, |a·b|): accurate for small angles, sign-blind.
    let a = nalgebra::Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let b = nalgebra::Vector3::from(b);
    a.cross(&b).norm().atan2(a.dot(&b).abs()).to_degrees()
}

#[test]
fn plane_normals_are_exact_and_face_the_viewpoint() {
    let n = [0.0, 0.6, 0.8];
    let cloud = PointCloud::from_positions(plane([0.1, 0.2, 1.0], n, 12, 0.01));
    let out = estimate_normals(&cloud, &NormalParams::knn(10)).unwrap();
    for (i, nrm) in out.normals.iter().enumerate() {
        assert!(angle_deg(*nrm, n) < 1e-3, "point {i}: {nrm:?}");
        let p = cloud.positions[i];
        assert!(
            -(p[0] * nrm[0] + p[1] * nrm[1] + p[2] * nrm[2]) >= 0.0,
            "faces the origin"
        );
        assert!(out.curvature[i] < 1e-6);
    }
    let far_vp = NormalParams {
        viewpoint: Some([0.0, 10.0, 10.0]),
        ..NormalParams::knn(10)
    };
    let out2 = estimate_normals(&cloud, &far_vp).unwrap();
    assert!(out2.normals.iter().all(|m| m[2] > 0.0));
}

#[test]
fn radius_neighbourhood_and_serial_equals_parallel() {
    let cloud = PointCloud::from_positions(plane([0.0, 0.0, 1.0], [1.0, 1.0, 1.0], 15, 0.01));
    let p = NormalParams {
        neighbourhood: Neighbourhood::Radius(0.025),
        ..NormalParams::knn(1)
    };
    let par = estimate_normals(&cloud, &p).unwrap();
    let ser = estimate_normals(
        &cloud,
        &NormalParams {
            parallelism: Parallelism::Serial,
            ..p
        },
    )
    .unwrap();
    assert_eq!(format!("{par:?}"), format!("{ser:?}")); // Debug compares NaN too
    assert!(par
        .normals
        .iter()
        .all(|m| angle_deg(*m, [1.0 / 3f64.sqrt(); 3]) < 1e-3));
}

#[test]
fn fewer_than_three_neighbours_give_nan_in_pcl_mode_and_z_in_open3d_mode() {
    let cloud = PointCloud::from_positions(vec![
        [0.0, 0.0, 1.0],
        [0.01, 0.0, 1.0],
        [5.0, 5.0, 5.0],
        [f32::NAN; 3],
    ]);
    let p = NormalParams {
        neighbourhood: Neighbourhood::Radius(0.05),
        ..NormalParams::knn(1)
    };
    let out = estimate_normals(&cloud, &p).unwrap();
    assert!(out.normals.iter().all(|n| n.iter().all(|c| c.is_nan())));
    assert!(out.curvature.iter().all(|c| c.is_nan()));
    let o = estimate_normals(
        &cloud,
        &NormalParams {
            mode: NormalMode::Open3d,
            ..p
        },
    )
    .unwrap();
    assert!(o.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
    assert_eq!(
        estimate_normals(&cloud, &NormalParams::knn(0)),
        Err(FeatureError::ZeroK)
    );
}

#[test]
fn curvature_is_the_smallest_eigenvalue_over_the_trace() {
    // The 8 corners of a unit cube: isotropic, so every eigenvalue is equal: 1/3.
    let mut pts = Vec::new();
    for i in 0..8 {
        pts.push([(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32]);
    }
    let out = estimate_normals(&PointCloud::from_positions(pts), &NormalParams::knn(8)).unwrap();
    assert!(out.curvature.iter().all(|&c| (c - 1.0 / 3.0).abs() < 1e-6));
}

/// PCL-style covariance in `f32`, one pass (`E[xxᵀ] − μμᵀ`), as PCL did before shifting
/// and as many ports still do: catastrophic cancellation far from the origin.
fn one_pass_f32_normal(pts: &[[f32; 3]]) -> [f32; 3] {
    let n = pts.len() as f32;
    let mut s = [0f32; 3];
    let mut ss = [[0f32; 3]; 3];
    for p in pts {
        for a in 0..3 {
            s[a] += p[a];
            for b in 0..3 {
                ss[a][b] += p[a] * p[b];
            }
        }
    }
    let m = nalgebra::Matrix3::<f32>::from_fn(|a, b| ss[a][b] / n - (s[a] / n) * (s[b] / n));
    let e = m.map(|v| v as f64).symmetric_eigen();
    let i = e.eigenvalues.imin();
    let v = e.eigenvectors.column(i);
    [v[0] as f32, v[1] as f32, v[2] as f32]
}

#[test]
fn normals_stay_right_on_a_cloud_translated_far_from_the_origin_where_one_pass_f32_fails() {
    let n = [0.2, 0.3, 0.9];
    let nn = nalgebra::Vector3::from(n).normalize();
    let n = [nn[0], nn[1], nn[2]];
    let pts = plane([100.0, -200.0, 50.0], n, 10, 0.01);
    let cloud = PointCloud::from_positions(pts.clone());
    let out = estimate_normals(&cloud, &NormalParams::knn(20)).unwrap();
    let worst = out
        .normals
        .iter()
        .map(|m| angle_deg(*m, n))
        .fold(0.0, f64::max);
    assert!(worst < 1.0, "two-pass f64 worst angle {worst} deg");
    let naive = one_pass_f32_normal(&pts[..20]);
    let naive_err = angle_deg(naive, n);
    assert!(naive_err > 10.0, "one-pass f32 error only {naive_err} deg");
}

/// The population covariance of `pts` in `f64`, de-meaned: the brute-force oracle.
fn covariance(pts: &[[f32; 3]]) -> nalgebra::Matrix3<f64> {
    let n = pts.len() as f64;
    let mean = pts.iter().fold(nalgebra::Vector3::zeros(), |m, p| {
        m + nalgebra::Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }) / n;
    pts.iter().fold(nalgebra::Matrix3::zeros(), |c, p| {
        let d = nalgebra::Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) - mean;
        c + d * d.transpose()
    }) / n
}

use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    /// Every shape of neighbourhood (flat, noisy, elongated, nearly isotropic, from 3 to
    /// 30 points, far from the origin or not): the normal is nalgebra's eigenvector of
    /// the smallest eigenvalue (compared where that is well defined, a gap of 1e-3 of
    /// the largest) and the curvature its eigenvalue over the trace.
    #[test]
    fn normals_and_curvature_equal_a_full_eigendecomposition_of_the_covariance(
        pts in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 3..30),
        scale in (0.001f64..1.0, 1e-4f64..1.0, 0.0f64..1.0),
        offset in prop_oneof![Just(0.0f64), -50.0f64..50.0],
        open3d in any::<bool>(),
    ) {
        // Axis scales make planes (small z), lines (small y and z) and blobs.
        let pts: Vec<[f32; 3]> = pts
            .iter()
            .map(|&(x, y, z)| {
                [
                    (offset + x * scale.0) as f32,
                    (offset + y * scale.0 * scale.1) as f32,
                    (1.0 + z * scale.0 * scale.1 * scale.2) as f32,
                ]
            })
            .collect();
        let cloud = PointCloud::from_positions(pts.clone());
        let params = NormalParams {
            mode: if open3d { NormalMode::Open3d } else { NormalMode::Pcl },
            ..NormalParams::knn(pts.len())
        };
        let out = estimate_normals(&cloud, &params).unwrap();
        let eig = covariance(&pts).symmetric_eigen();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let ev = order.map(|a| eig.eigenvalues[a]);
        let v = eig.eigenvectors.column(order[0]);
        let trace = ev.iter().sum::<f64>();
        // The same neighbourhood (all points) for every point: one answer.
        let (nrm, curv) = (out.normals[0], out.curvature[0]);
        if trace > 0.0 {
            prop_assert!((curv as f64 - ev[0].max(0.0) / trace).abs() < 1e-6,
                "curvature {} vs {}", curv, ev[0] / trace);
        }
        if ev[1] - ev[0] > 1e-3 * ev[2] && ev[1] > 1e-9 * ev[2] {
            let angle = angle_deg(nrm, [v[0], v[1], v[2]]);
            // f32 output, and nalgebra's own error of about 1e-16 / gap.
            prop_assert!(angle < 1e-3, "angle {} deg, eigenvalues {:?}", angle, ev);
        }
    }
}

/// An organised sensor-like frame (a pixel lattice with millimetre-quantised depth,
/// full of ties at the k-th distance, and NaN holes): PCL-mode k-NN normals, whose
/// FLANN tie tree is built alongside the grid on such clouds, are the same with one
/// thread and with two, and equal those of the same points as an unorganised cloud.
#[test]
fn organised_frames_with_ties_give_the_same_normals_on_one_thread_and_on_two() {
    let (w, h) = (64u32, 48u32);
    let pts: Vec<[f32; 3]> = (0..w * h)
        .map(|j| {
            let (u, v) = ((j % w) as f32, (j / w) as f32);
            if j % 97 == 5 {
                return [f32::NAN; 3];
            }
            // Depth in whole millimetres, as a Kinect reports it.
            let z = ((0.8 + 0.0004 * u + 0.1 * (v * 0.2).sin()) * 1000.0).round() / 1000.0;
            [(u - 32.0) * 0.0015 * z, (v - 24.0) * 0.0015 * z, z]
        })
        .collect();
    let mut organised = PointCloud::from_positions(pts.clone());
    organised.width = w;
    organised.height = h;
    assert!(organised.is_organized());
    let flat = PointCloud::from_positions(pts);
    for k in [3, 10, 25] {
        let par = estimate_normals(&organised, &NormalParams::knn(k)).unwrap();
        let ser = estimate_normals(
            &organised,
            &NormalParams {
                parallelism: Parallelism::Serial,
                ..NormalParams::knn(k)
            },
        )
        .unwrap();
        let unorganised = estimate_normals(&flat, &NormalParams::knn(k)).unwrap();
        assert_eq!(format!("{par:?}"), format!("{ser:?}"), "k {k}");
        assert_eq!(format!("{par:?}"), format!("{unorganised:?}"), "k {k}");
    }
}

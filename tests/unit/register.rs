//! Normal-line registration on clouds sampled from a displaced FE surface.
use proptest::prelude::*;
use softsense::fem::mesh::TetMesh;
use softsense::geometry::raycast::Bvh;
use softsense::register::{
    closest_point_on_triangle, farthest_point_sampling, surface_features, vertex_normals,
    FeatureParams, LineMatch, RegisterParams, Registrar,
};

/// Dense samples (24 steps per edge) on every triangle.
fn sample_triangles(x: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    let k = 24;
    for t in triangles {
        let [a, b, c] = t.map(|i| x[i]);
        for i in 0..=k {
            for j in 0..=(k - i) {
                let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
                pts.push([0, 1, 2].map(|q| a[q] + u * (b[q] - a[q]) + v * (c[q] - a[q])));
            }
        }
    }
    pts
}

/// Box surface (rest), displaced nodes (a bend in z growing with x), dense samples on the
/// displaced triangles.
#[allow(clippy::type_complexity)]
fn setup() -> (
    Vec<[f64; 3]>,
    Vec<[f64; 3]>,
    Vec<[usize; 3]>,
    Vec<usize>,
    Vec<[f64; 3]>,
) {
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let rest = m.nodes_in_rest.clone();
    let disp: Vec<[f64; 3]> = rest
        .iter()
        .map(|p| [p[0], p[1], p[2] + 0.004 * (p[0] / 0.1).powi(2)])
        .collect();
    let pts = sample_triangles(&disp, &s.triangles);
    (rest, disp, s.triangles, s.nodes, pts)
}

#[test]
fn farthest_point_sampling_spreads_features_evenly() {
    let (rest, _, _, nodes, _) = setup();
    let f = farthest_point_sampling(&rest, &nodes, 20);
    assert_eq!(f.len(), 20);
    let mut sorted = f.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), 20, "no repeats");
    // Every surface node is within the covering radius, and chosen points are at least that far apart.
    let d = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    let cover = nodes
        .iter()
        .map(|&n| {
            f.iter()
                .map(|&c| d(rest[n], rest[c]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let sep = f
        .iter()
        .enumerate()
        .flat_map(|(i, &a)| f[..i].iter().map(move |&b| (a, b)))
        .map(|(a, b)| d(rest[a], rest[b]))
        .fold(f64::INFINITY, f64::min);
    assert!(
        sep >= cover - 1e-12,
        "separation {sep} < covering radius {cover}"
    );
    assert!(farthest_point_sampling(&rest, &[], 5).is_empty());
}

#[test]
fn registration_recovers_normal_offsets_of_a_displaced_surface() {
    let (rest, disp, tris, nodes, pts) = setup();
    let normals = vertex_normals(&rest, &tris);
    let feats = farthest_point_sampling(&rest, &nodes, 51);
    let reg = Registrar::new(&pts);
    let params = RegisterParams {
        d_m: 0.0008,
        average: false,
        ..Default::default()
    };
    let matches = reg.register(&rest, &normals, &feats, &params);
    let bvh = Bvh::new(&disp, &tris);
    let mut worst: f64 = 0.0;
    let mut found = 0;
    for (m, &f) in matches.iter().zip(&feats) {
        let n = normals[f];
        // Exact: where the normal line meets the displaced surface, from 6 mm behind (the box is 20 mm thick).
        let o = [0, 1, 2].map(|k| rest[f][k] - 0.006 * n[k]);
        let exact = bvh.cast(o, n).map(|h| h.t - 0.006);
        let on_face = n.iter().any(|c| c.abs() > 0.999);
        match (m, exact) {
            (Some(m), Some(e)) => {
                found += 1;
                worst = worst.max((m.offset - e).abs());
            }
            // Face features (not on box edges, whose diagonal normals can miss the
            // sampled surface) must be matched.
            (None, Some(_)) => assert!(!on_face, "face feature {f} not matched"),
            _ => {}
        }
    }
    eprintln!("{found} of 51 features matched, worst offset error {worst:e} m");
    assert!(found >= 20, "only {found} of 51 features matched");
    // Samples are ~0.4 mm apart on a surface tilted by at most ~0.08 rad.
    assert!(worst < 2e-4, "worst offset error {worst} m");
}

#[test]
fn registration_equals_brute_force_and_hides_unseen_features() {
    let (rest, _, tris, nodes, pts) = setup();
    let normals = vertex_normals(&rest, &tris);
    let feats = farthest_point_sampling(&rest, &nodes, 51);
    // Crop away the half x > 0.05: features there must be hidden.
    let kept: Vec<[f64; 3]> = pts.iter().copied().filter(|p| p[0] < 0.05).collect();
    let reg = Registrar::new(&kept);
    let params = RegisterParams {
        average: false,
        ..Default::default()
    };
    let matches = reg.register(&rest, &normals, &feats, &params);
    for (m, &f) in matches.iter().zip(&feats) {
        let (p, n) = (rest[f], normals[f]);
        let brute = kept
            .iter()
            .filter_map(|q| {
                let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                let perp = (d.iter().map(|c| c * c).sum::<f64>() - t * t)
                    .max(0.0)
                    .sqrt();
                (t.abs() <= params.d_l && perp <= params.d_m).then_some((perp, t))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match (m, brute) {
            (None, None) => {}
            (Some(m), Some(b)) => {
                assert!((m.line_distance - b.0).abs() < 1e-12);
                // Ties in line distance may pick another point: it must be one of the tied.
                let tied = kept.iter().any(|q| {
                    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                    let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                    (t - m.offset).abs() < 1e-12
                });
                assert!(tied);
            }
            _ => panic!("feature {f}: tree {m:?} vs brute force {brute:?}"),
        }
        if p[0] > 0.06 {
            assert!(m.is_none(), "feature {f} at x = {} should be hidden", p[0]);
        }
    }
    assert!(Registrar::new(&[])
        .register(&rest, &normals, &feats, &params)
        .iter()
        .all(|m| m.is_none()));
}

#[test]
fn surface_features_of_an_undeformed_surface_read_zero_offsets_with_averaging() {
    // The bias the features avoid: averaged matches at box-edge vertices read non-zero
    // offsets even when the measured surface IS the model surface.
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let rest = m.nodes_in_rest.clone();
    let pts = sample_triangles(&rest, &s.triangles);
    let reg = Registrar::new(&pts);
    let params = RegisterParams::default();
    let feats = surface_features(&rest, &s, &FeatureParams::default());
    assert_eq!(feats.len(), 51);
    let mut worst: f64 = 0.0;
    for f in &feats {
        let m = reg
            .match_feature(f.position(&rest), f.normal(&rest), &params)
            .expect("a feature on the sampled surface is matched");
        worst = worst.max(m.offset.abs());
    }
    assert!(
        worst < 1e-12,
        "surface feature offset {worst} m on an undeformed surface"
    );
    // Vertex features at the box's edges do read a bias.
    let normals = vertex_normals(&rest, &s.triangles);
    let verts = farthest_point_sampling(&rest, &s.nodes, 51);
    let biased = reg
        .register(&rest, &normals, &verts, &params)
        .iter()
        .flatten()
        .map(|m| m.offset.abs())
        .fold(0.0, f64::max);
    assert!(
        biased > 1e-4,
        "vertex features unexpectedly unbiased ({biased} m)"
    );
}

#[test]
fn surface_features_seen_from_a_camera_face_it() {
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let rest = m.nodes_in_rest.clone();
    let eye = [0.05, 0.02, 0.5];
    let feats = surface_features(
        &rest,
        &s,
        &FeatureParams {
            eyes: vec![eye],
            count: 20,
            ..Default::default()
        },
    );
    assert_eq!(feats.len(), 20);
    for f in &feats {
        // Only the top face (z = 0.02, normal +z) is visible from above.
        let p = f.position(&rest);
        assert!(
            (p[2] - 0.02).abs() < 1e-12 && f.normal(&rest)[2] > 0.999,
            "{p:?}"
        );
        let w: f64 = f.weights.iter().sum();
        assert!((w - 1.0).abs() < 1e-12);
        assert!((f.mapped().position(&rest)[0] - p[0]).abs() < 1e-15);
    }
}

#[test]
fn surface_features_seen_by_two_cameras_lie_on_the_faces_either_one_sees() {
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let rest = m.nodes_in_rest.clone();
    // One camera above the top face, one beyond the end face x = 0.1.
    let (above, beside) = ([0.05, 0.02, 0.5], [0.6, 0.02, 0.01]);
    let with = |eyes: Vec<[f64; 3]>| {
        surface_features(
            &rest,
            &s,
            &FeatureParams {
                eyes,
                count: 1000,
                ..Default::default()
            },
        )
    };
    let (top, end, both) = (
        with(vec![above]),
        with(vec![beside]),
        with(vec![above, beside]),
    );
    assert!(!top.is_empty() && !end.is_empty());
    assert_eq!(both.len(), top.len() + end.len());
    for f in &both {
        let (p, n) = (f.position(&rest), f.normal(&rest));
        let on_top = (p[2] - 0.02).abs() < 1e-12 && n[2] > 0.999;
        let on_end = (p[0] - 0.1).abs() < 1e-12 && n[0] > 0.999;
        assert!(on_top || on_end, "{p:?} {n:?}");
    }
}

fn brute_closest(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let k = 300;
    let mut best = f64::INFINITY;
    for i in 0..=k {
        for j in 0..=(k - i) {
            let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
            let q = [0, 1, 2].map(|q| a[q] + u * (b[q] - a[q]) + v * (c[q] - a[q]));
            best = best.min((0..3).map(|m| (p[m] - q[m]).powi(2)).sum::<f64>());
        }
    }
    best.sqrt()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn closest_point_on_a_triangle_is_no_farther_than_any_sampled_point(
        v in proptest::collection::vec(-1.0f64..1.0, 12)
    ) {
        let (a, b, c, p) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]], [v[9], v[10], v[11]]);
        let q = closest_point_on_triangle(p, a, b, c);
        let d = (0..3).map(|m| (p[m] - q[m]).powi(2)).sum::<f64>().sqrt();
        let brute = brute_closest(p, a, b, c);
        // The brute force samples a 300-step grid: it is never closer, and at most one grid
        // cell (edge / 300) farther.
        let edge = [a, b, c].iter().zip([b, c, a]).map(|(x, y)| (0..3).map(|m| (x[m] - y[m]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max);
        prop_assert!(d <= brute + 1e-12, "closest {d} > sampled {brute}");
        prop_assert!(brute - d <= 2.0 * edge / 300.0 + 1e-12, "closest {d} << sampled {brute}");
    }
}

/// The averaged rule by brute force over all points: the sheet around the point of smallest
/// |offset| within the cylinder, re-centred once. Returns (offset, points).
fn brute_average(
    pts: &[[f64; 3]],
    p: [f64; 3],
    n: [f64; 3],
    r: &RegisterParams,
) -> Option<(f64, usize)> {
    let on: Vec<f64> = pts
        .iter()
        .filter_map(|q| {
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
            let perp2 = (d.iter().map(|c| c * c).sum::<f64>() - t * t).max(0.0);
            (t.abs() <= r.d_l && perp2 <= r.d_m * r.d_m).then_some(t)
        })
        .collect();
    let t0 = *on.iter().min_by(|a, b| a.abs().total_cmp(&b.abs()))?;
    let sheet = |c: f64| {
        let s: Vec<f64> = on
            .iter()
            .copied()
            .filter(|t| (t - c).abs() <= r.sheet)
            .collect();
        (s.iter().sum::<f64>() / s.len() as f64, s.len())
    };
    let (c, _) = sheet(t0);
    Some(sheet(c))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn the_grid_registrar_matches_every_line_as_a_brute_force_search_does(
        seed in 0u64..1_000_000,
        far in prop::bool::ANY,
        d_m in 0.001f64..0.012,
        dir in proptest::collection::vec(-1.0f64..1.0, 3),
    ) {
        // A wavy sheet of 4000 points over 0.2 m x 0.2 m, 1 mm thick noise; `far` adds a point
        // 200 m away, which forces the grid to coarse cells.
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = move || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut pts: Vec<[f64; 3]> = (0..4000)
            .map(|_| {
                let (x, y) = (0.2 * next() - 0.1, 0.2 * next() - 0.1);
                [x, y, 0.01 * (30.0 * x).sin() + 0.001 * next()]
            })
            .collect();
        if far {
            pts.push([200.0, -150.0, 90.0]);
        }
        pts.push([f64::NAN, 0.0, 0.0]);
        let reg = Registrar::new(&pts);
        let l = dir.iter().map(|c| c * c).sum::<f64>().sqrt();
        prop_assume!(l > 0.1);
        let n = [dir[0] / l, dir[1] / l, dir[2] / l];
        for average in [true, false] {
            let r = RegisterParams { d_m, average, ..Default::default() };
            for k in 0..20 {
                let p = [0.24 * next() - 0.12, 0.24 * next() - 0.12, 0.03 * next() - 0.015];
                let got = reg.match_feature(p, n, &r);
                if average {
                    let want = brute_average(&pts, p, n, &r);
                    match (got, want) {
                        (None, None) => {}
                        (Some(g), Some((t, c))) => {
                            prop_assert_eq!(g.points, c, "line {}", k);
                            prop_assert!((g.offset - t).abs() < 1e-12, "line {}: {} vs {}", k, g.offset, t);
                        }
                        (g, w) => prop_assert!(false, "line {}: grid {:?} vs brute {:?}", k, g, w),
                    }
                } else {
                    let want = pts.iter().filter_map(|q| {
                        let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                        let t = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                        let perp2 = (d.iter().map(|c| c * c).sum::<f64>() - t * t).max(0.0);
                        (t.abs() <= r.d_l && perp2 <= d_m * d_m).then_some(perp2.sqrt())
                    }).min_by(f64::total_cmp);
                    prop_assert_eq!(got.map(|g| g.line_distance), want, "line {}", k);
                }
            }
        }
    }
}

#[test]
fn a_cloud_of_absurd_extent_is_indexed_and_its_near_points_still_match() {
    // Finite points 1e300 and ±1e308 apart (the latter's extent overflows to infinity):
    // no panic, no cell count blow-up, and the patch at the origin is still found.
    let patch: Vec<[f64; 3]> = (0..100)
        .map(|i| {
            [
                (i % 10) as f64 * 1e-3 - 5e-3,
                (i / 10) as f64 * 1e-3 - 5e-3,
                0.002,
            ]
        })
        .collect();
    let r = RegisterParams::default();
    for far in [[1e300, 0.0, 0.0], [1e308, -1e308, 0.0]] {
        let mut pts = patch.clone();
        pts.push(far);
        pts.push(far.map(|c| -c));
        let reg = Registrar::new(&pts);
        assert_eq!(reg.len(), 102);
        let m = reg.match_feature([0.0; 3], [0.0, 0.0, 1.0], &r);
        assert!(
            (m.expect("the patch is found").offset - 0.002).abs() < 1e-12,
            "{far:?}"
        );
    }
}

#[test]
fn an_averaged_match_reports_the_very_points_it_averaged() {
    // A plane z = 0.2 mm with a ripple, points on a 1 mm grid: the points returned are
    // those within d_m of the line whose offsets average to the match's offset, and the
    // scatter is their squared deviations from it.
    let mut pts = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            let (x, y) = (i as f64 * 1e-3, j as f64 * 1e-3);
            pts.push([
                x,
                y,
                2e-4 + 1e-4 * (i as f64 * 0.7).sin() * (j as f64 * 1.3).cos(),
            ]);
        }
    }
    let reg = Registrar::new(&pts);
    let params = RegisterParams {
        d_m: 5e-3,
        ..RegisterParams::default()
    };
    let (p, n) = ([0.02, 0.021, 0.0], [0.0, 0.0, 1.0]);
    let (m, points) = reg.match_feature_points(p, n, &params).unwrap();
    let (used, scatter) = (points.indices, points.scatter);
    let plain = reg.match_feature(p, n, &params).unwrap();
    assert_eq!((m.offset, m.points), (plain.offset, plain.points));
    let brute: Vec<u32> = (0..pts.len() as u32)
        .filter(|&i| {
            let q = pts[i as usize];
            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) <= params.d_m * params.d_m
        })
        .collect();
    assert_eq!(used, brute);
    assert_eq!(used.len(), m.points);
    let mean = used.iter().map(|&i| pts[i as usize][2]).sum::<f64>() / used.len() as f64;
    assert!((mean - m.offset).abs() < 1e-15);
    let s: f64 = used
        .iter()
        .map(|&i| (pts[i as usize][2] - m.offset).powi(2))
        .sum();
    assert!((s - scatter).abs() <= 1e-12 * s);
    // The thesis's single nearest point has no average to report.
    let single = RegisterParams {
        average: false,
        ..params
    };
    assert!(reg.match_feature_points(p, n, &single).is_none());
}

#[test]
fn remembered_feature_matches_equal_fresh_ones_and_follow_the_positions() {
    let (rest, disp, _, _, pts) = setup();
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let s = m.surface();
    let feats = surface_features(&rest, &s, &FeatureParams::default());
    let reg = Registrar::new(&pts);
    let params = RegisterParams {
        average: true,
        d_m: 0.004,
        ..RegisterParams::default()
    };
    let unremembered = Registrar::new(&pts);
    let fresh = |x: &[[f64; 3]], p: &RegisterParams| -> Vec<Option<(u64, u64, usize)>> {
        feats
            .iter()
            .map(|f| {
                unremembered
                    .match_feature(f.position(x), f.normal(x), p)
                    .map(|m| (m.offset.to_bits(), m.line_distance.to_bits(), m.points))
            })
            .collect()
    };
    let bits = |r: softsense::register::FeatureMatches| -> Vec<Option<(u64, u64, usize)>> {
        r.matches
            .into_iter()
            .map(|m| m.map(|m| (m.offset.to_bits(), m.line_distance.to_bits(), m.points)))
            .collect()
    };
    // Asked twice (the second from memory), at two states, and with other parameters: each
    // answer is the fresh search's, bit for bit.
    for _ in 0..2 {
        for x in [&disp, &rest] {
            assert_eq!(
                bits(reg.match_features(&feats, x, &params)),
                fresh(x, &params)
            );
        }
    }
    let narrow = RegisterParams {
        d_m: 0.001,
        ..params.clone()
    };
    assert_eq!(
        bits(reg.match_features(&feats, &disp, &narrow)),
        fresh(&disp, &narrow)
    );
    // The states and the parameters change the matches (else the test could not tell a
    // memory that ignores them).
    assert_ne!(fresh(&disp, &params), fresh(&rest, &params));
    assert_ne!(fresh(&disp, &params), fresh(&disp, &narrow));
}

#[test]
fn one_registration_pass_gives_each_features_match_and_its_points() {
    let (rest, disp, _, _, pts) = setup();
    let m = TetMesh::structured_box([0.0, 0.0, 0.0], [0.1, 0.04, 0.02], [10, 4, 2]).unwrap();
    let feats = surface_features(&rest, &m.surface(), &FeatureParams::default());
    let reg = Registrar::new(&pts);
    let params = RegisterParams {
        d_m: 0.004,
        ..RegisterParams::default()
    };
    let key = |m: &LineMatch| (m.offset.to_bits(), m.line_distance.to_bits(), m.points);
    // Twice: the second answer comes from memory and must carry the same points.
    for _ in 0..2 {
        let got = reg.match_features(&feats, &disp, &params);
        assert_eq!(got.features, feats);
        let mut points = got.points.iter();
        let mut matched = 0;
        for (f, m) in got.iter() {
            let (p, n) = (f.position(&disp), f.normal(&disp));
            let alone = reg.match_feature_points(p, n, &params);
            assert_eq!(m.map(key), alone.as_ref().map(|(m, _)| key(m)));
            if let Some((_, sheet)) = alone {
                assert_eq!(points.next(), Some(&sheet));
                matched += 1;
            }
        }
        assert!(points.next().is_none());
        assert!(matched > 10, "{matched} matched");
    }
    // The thesis's single nearest point: the same matches as alone, and no points.
    let single = RegisterParams {
        average: false,
        ..params
    };
    let got = reg.match_features(&feats, &disp, &single);
    assert!(got.points.is_empty());
    for (f, m) in got.iter() {
        let alone = reg.match_feature(f.position(&disp), f.normal(&disp), &single);
        assert_eq!(m.map(key), alone.as_ref().map(key));
    }
}

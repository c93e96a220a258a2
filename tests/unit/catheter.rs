//! The catheter workflow's path, tube, mapping (Algorithm 5.1) and PD law (5.18-5.22).

use nalgebra::DMatrix;
use softsense::catheter::law::{jacobian, right_pseudo_inverse, rotation_margin, PdGains, PdLaw};
use softsense::catheter::mapping::{Mapping, MappingParams};
use softsense::catheter::tube::{Centreline, Obstacle, Piece, Surface, Tube};
use softsense::catheter::CatheterError;
use std::f64::consts::FRAC_PI_2;

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
}

/// 20 mm straight, a 90° bend of radius 50 mm towards +y, 20 mm straight.
fn elbow(step: f64) -> Centreline {
    let pieces = [
        Piece::Straight { length: 0.02 },
        Piece::Arc {
            radius: 0.05,
            angle: FRAC_PI_2,
            plane: 0.0,
        },
        Piece::Straight { length: 0.02 },
    ];
    Centreline::from_pieces([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], &pieces, step).unwrap()
}

#[test]
fn an_elbow_of_pieces_ends_where_the_geometry_says() {
    let c = elbow(5e-4);
    let end = c.at(c.length());
    assert!(
        close(end.point, [0.07, 0.07, 0.0], 1e-12),
        "{:?}",
        end.point
    );
    assert!(
        close(end.tangent, [0.0, 1.0, 0.0], 1e-12),
        "{:?}",
        end.tangent
    );
    let exact = 0.04 + 0.05 * FRAC_PI_2;
    // Chords are a little shorter than the arc: relative (step/R)²/24 at most.
    assert!(
        (c.length() - exact).abs() < exact * 1e-4,
        "{} vs {exact}",
        c.length()
    );
    // Mid-bend point lies on the circle about (0.02, 0.05).
    let mid = c.at(0.02 + 0.05 * FRAC_PI_2 / 2.0);
    let r = ((mid.point[0] - 0.02).powi(2) + (mid.point[1] - 0.05).powi(2)).sqrt();
    assert!((r - 0.05).abs() < 1e-6, "radius {r}");
}

#[test]
fn a_bend_turns_in_the_plane_it_is_given() {
    let pieces = [Piece::Arc {
        radius: 0.05,
        angle: FRAC_PI_2,
        plane: FRAC_PI_2,
    }];
    let c =
        Centreline::from_pieces([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], &pieces, 1e-3).unwrap();
    // The normal +y turned 90° about +x is +z.
    let end = c.at(c.length());
    assert!(
        close(end.point, [0.05, 0.0, 0.05], 1e-12),
        "{:?}",
        end.point
    );
    assert!(close(end.tangent, [0.0, 0.0, 1.0], 1e-12));
}

#[test]
fn the_nearest_point_is_never_farther_than_any_sample() {
    let c = elbow(2e-3);
    for k in 0..200 {
        let t = k as f64 * 0.37;
        let p = [
            0.08 * (t.sin() * 0.5 + 0.5),
            0.08 * (t.cos() * 0.5 + 0.5),
            0.01 * t.sin(),
        ];
        let n = c.nearest(p);
        let d = |q: [f64; 3]| {
            ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt()
        };
        let best = c
            .points()
            .iter()
            .map(|&q| d(q))
            .fold(f64::INFINITY, f64::min);
        assert!(d(n.point) <= best + 1e-15, "{} > {best}", d(n.point));
        let tn: f64 = n.tangent.iter().map(|v| v * v).sum();
        assert!((tn - 1.0).abs() < 1e-12);
    }
}

#[test]
fn bad_paths_are_refused_with_a_reason() {
    let zero = [Piece::Straight { length: 0.0 }];
    let e = Centreline::from_pieces([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], &zero, 1e-3);
    assert!(matches!(e, Err(CatheterError::Path(m)) if m.contains("piece 0")));
    let parallel = [Piece::Straight { length: 0.01 }];
    let e = Centreline::from_pieces([0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], &parallel, 1e-3);
    assert!(matches!(e, Err(CatheterError::Path(_))));
    assert!(Tube::new(elbow(1e-3), -1.0).is_err());
}

#[test]
fn the_gap_to_a_straight_tube_is_radius_minus_offset() {
    let tube = Tube::new(elbow(1e-3), 0.014).unwrap();
    let c = tube.gap([0.01, 0.004, -0.003], 0.0035);
    assert!(
        (c.gap - (0.014 - 0.0035 - 0.005)).abs() < 1e-12,
        "{}",
        c.gap
    );
    assert!(close(c.normal, [0.0, -0.8, 0.6], 1e-12), "{:?}", c.normal);
    // Only nodes within the alarm distance of the wall become contacts.
    let nodes = [[0.005, 0.0, 0.0], [0.01, 0.0095, 0.0], [0.015, 0.0, 0.011]];
    let contacts = tube.contacts(&nodes, 0.0035, 0.002);
    let found: Vec<usize> = contacts.iter().map(|c| c.node).collect();
    assert_eq!(found, vec![1, 2]);
    assert!(
        contacts[1].gap < 0.0,
        "node 2 penetrates: {}",
        contacts[1].gap
    );
}

#[test]
fn an_obstacles_gap_is_the_brute_force_distance_to_its_axis_less_both_radii() {
    let wire = Obstacle {
        a: [0.03, -0.014, 0.002],
        b: [0.036, 0.014, -0.001],
        radius: 0.0008,
    };
    let point = Obstacle { b: wire.a, ..wire };
    let tube = Tube::new(elbow(1e-3), 0.014)
        .unwrap()
        .with_obstacles(vec![wire, point])
        .unwrap();
    let samples = 20_000;
    for p in [
        [0.028, 0.001, 0.004],
        [0.05, 0.02, -0.003],
        [0.031, -0.02, 0.0],
        [0.033, 0.0, 0.0],
    ] {
        for (i, o) in tube.obstacles.iter().enumerate() {
            let brute = (0..=samples)
                .map(|k| {
                    let u = k as f64 / samples as f64;
                    let q: [f64; 3] = std::array::from_fn(|j| o.a[j] + u * (o.b[j] - o.a[j]));
                    softsense::math::dist(p, q)
                })
                .fold(f64::INFINITY, f64::min);
            let c = tube.gap_to(Surface::Obstacle(i), p, 0.0035);
            assert!(
                (c.gap - (brute - 0.0008 - 0.0035)).abs() < 2e-6,
                "obstacle {i} at {p:?}: gap {} against {}",
                c.gap,
                brute - 0.0043
            );
            // The push is away from the axis: one step along it opens the gap by the step.
            let q: [f64; 3] = std::array::from_fn(|j| p[j] + 1e-6 * c.normal[j]);
            let opened = tube.gap_to(Surface::Obstacle(i), q, 0.0035).gap - c.gap;
            assert!((opened - 1e-6).abs() < 1e-9, "opened {opened}");
        }
    }
}

#[test]
fn a_node_between_the_wall_and_an_obstacle_gets_one_row_for_each() {
    let post = Obstacle {
        a: [0.01, 0.0, 0.0],
        b: [0.01, 0.0, 0.0],
        radius: 0.004,
    };
    let tube = Tube::new(elbow(1e-3), 0.014)
        .unwrap()
        .with_obstacles(vec![post])
        .unwrap();
    // Node 0 is 0.5 mm from the post and 2.5 mm from the wall; node 1 is far from both.
    let nodes = [[0.01, 0.008, 0.0], [0.03, -0.002, 0.0]];
    let rows = tube.contacts(&nodes, 0.0035, 0.003);
    let found: Vec<(usize, Surface)> = rows.iter().map(|c| (c.node, c.surface)).collect();
    assert_eq!(found, vec![(0, Surface::Wall), (0, Surface::Obstacle(0))]);
    assert!((rows[1].gap - 0.0005).abs() < 1e-12, "{}", rows[1].gap);
    assert!(close(rows[0].normal, [0.0, -1.0, 0.0], 1e-12));
    assert!(close(rows[1].normal, [0.0, 1.0, 0.0], 1e-12));
    let bad = Obstacle {
        radius: -1e-3,
        ..post
    };
    let e = Tube::new(elbow(1e-3), 0.014)
        .unwrap()
        .with_obstacles(vec![bad]);
    assert!(matches!(e, Err(CatheterError::Path(m)) if m.contains("obstacle 0")));
}

#[test]
fn the_local_frame_is_right_handed_and_the_error_lies_along_py() {
    let path = elbow(5e-4);
    let mut m = Mapping::new(MappingParams::default());
    for tip in [
        [0.01, 0.003, 0.001],
        [0.05, 0.02, -0.004],
        [0.068, 0.06, 0.002],
    ] {
        let f = m.frame(&path, tip);
        let z = softsense::math::cross(f.x, f.y);
        assert!(close(z, f.z, 1e-12), "x × y = {z:?}, z = {:?}", f.z);
        let e = f.error_2d(tip);
        let dist = softsense::math::dist(tip, f.p);
        // The tip-to-P vector is normal to the nearest chord, and Px (interpolated between
        // samples) is within step/2R = 0.005 rad of it: it maps onto Py to 1.3e-5.
        assert!(
            e[1].abs() < 1e-12 && (e[0].abs() - dist).abs() < 2e-5 * dist,
            "{e:?} vs {dist}"
        );
        let rows = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
        let mapped = f.rows_2d(&rows);
        let expect = f.z[0] * 0.0 + f.z[1] * 1.0 + f.z[2] * 3.0;
        assert!((mapped[(1, 1)] - expect).abs() < 1e-12);
    }
}

#[test]
fn a_tip_on_the_path_keeps_the_last_bending_plane() {
    let path = elbow(5e-4);
    let mut m = Mapping::new(MappingParams::default());
    let first = m.frame(&path, [0.01, 0.0, 0.002]);
    assert!(close(first.z, [0.0, 1.0, 0.0], 1e-12) || close(first.z, [0.0, -1.0, 0.0], 1e-12));
    let on = m.frame(&path, [0.012, 0.0, 0.0]);
    assert!(close(on.z, first.z, 1e-12), "{:?} vs {:?}", on.z, first.z);
    // With no history, the reference axis (made normal to Px) is used.
    let fresh = Mapping::new(MappingParams::default()).frame(&path, [0.012, 0.0, 0.0]);
    assert!(close(fresh.z, [0.0, 0.0, 1.0], 1e-12));
}

#[test]
fn the_pd_law_is_minus_kp_e_through_the_pseudo_inverse_at_the_first_step() {
    let j = DMatrix::from_row_slice(2, 4, &[1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 2.0, -2.0]);
    let mut law = PdLaw::new(PdGains::default());
    let u = law.step(&j, &[0.01, -0.02]).unwrap();
    let task = &j * nalgebra::DVector::from_column_slice(&u);
    assert!((task[0] + 0.2 * 0.01).abs() < 1e-15 && (task[1] - 0.2 * 0.02).abs() < 1e-15);
    // Minimum norm: antagonistic cables share the work equally.
    assert!((u[0] + u[1]).abs() < 1e-15 && (u[2] + u[3]).abs() < 1e-15);
}

#[test]
fn the_pd_law_converges_on_its_own_model_and_diverges_on_a_rotated_one() {
    let j_model = DMatrix::from_row_slice(2, 2, &[1.0, 0.2, -0.1, 0.8]);
    let rot = |a: f64| DMatrix::from_row_slice(2, 2, &[a.cos(), -a.sin(), a.sin(), a.cos()]);
    let run = |j_true: &DMatrix<f64>| {
        let mut law = PdLaw::new(PdGains::default());
        let mut e = nalgebra::DVector::from_column_slice(&[0.01, 0.005]);
        for _ in 0..200 {
            let u = law.step(&j_model, e.as_slice()).unwrap();
            e += j_true * nalgebra::DVector::from_column_slice(&u);
        }
        e.norm()
    };
    assert!(run(&j_model) < 1e-12);
    assert!(rotation_margin(&j_model, &j_model).unwrap() > 0.99);
    let inverted = rot(2.5) * &j_model;
    assert!(rotation_margin(&inverted, &j_model).unwrap() < 0.0);
    assert!(
        run(&inverted) > 0.01,
        "a rotated J past 90° pushes the error up"
    );
}

#[test]
fn the_jacobian_is_w_ea_times_w_aa_inverse_and_singular_ones_are_refused() {
    let w_aa = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
    let w_ea = DMatrix::from_row_slice(1, 2, &[1.0, 3.0]);
    let j = jacobian(&w_ea, &w_aa).unwrap();
    assert!(((&j * &w_aa) - &w_ea).norm() < 1e-14);
    let singular = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
    assert!(matches!(
        jacobian(&w_ea, &singular),
        Err(CatheterError::Singular { .. })
    ));
    let rank_one = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 3.0, 2.0, 4.0, 6.0]);
    assert!(matches!(
        right_pseudo_inverse(&rank_one),
        Err(CatheterError::Singular { rank: 1, .. })
    ));
}

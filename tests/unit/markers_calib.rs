//! The tracker-to-robot transform fitted to markers (`markers::calib`).
use softsense::markers::calib::{
    fit_robot_from_tracker, read_calibration, rigid_fit_covariance, write_calibration,
};
use softsense::markers::MarkersError;
use softsense::math::pose::Pose;
use softsense::math::rand::normal;
use softsense::math::{Iso3, Vec3};

fn names(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("m{i}")).collect()
}

/// A seeded rigid transform: a rotation of up to π about a random axis, a translation of
/// up to about a metre.
fn random_pose(seed: u64) -> Iso3 {
    let v = |k: u64| {
        Vec3::new(
            normal(seed, k, 0, 0),
            normal(seed, k, 1, 0),
            normal(seed, k, 2, 0),
        )
    };
    let axis = v(0).normalize();
    let angle = std::f64::consts::PI * (0.5 + 0.5 * normal(seed, 1, 3, 0).tanh());
    Iso3::new(0.5 * v(2), axis * angle)
}

/// Marker positions spread over a 10 cm body (m).
fn body_markers(seed: u64, n: usize) -> Vec<[f64; 3]> {
    (0..n as u64)
        .map(|m| [0, 1, 2].map(|a| 0.05 * normal(seed, 100 + m, a, 1)))
        .collect()
}

#[test]
fn a_random_rigid_transform_of_exact_marker_positions_is_recovered() {
    for seed in 0..20 {
        let model = body_markers(seed, 8);
        let robot_from_tracker = random_pose(seed);
        let tracker_from_robot = robot_from_tracker.inverse();
        let tracks: Vec<[f64; 3]> = (model.iter())
            .map(|p| {
                (tracker_from_robot * softsense::math::Point3::from(*p))
                    .coords
                    .into()
            })
            .collect();
        let c = fit_robot_from_tracker(&names(8), &tracks, &model).unwrap();
        let want = Pose::from_iso(&robot_from_tracker).to_matrix();
        let got = c.robot_from_tracker.to_matrix();
        for (r, row) in got.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                assert!(
                    (v - want[r][k]).abs() < 1e-9,
                    "seed {seed}: {got:?} against {want:?}"
                );
            }
        }
        assert!(c.residual_rms_m < 1e-9, "seed {seed}: {}", c.residual_rms_m);
    }
}

#[test]
fn noisy_tracks_give_a_residual_near_the_noise() {
    // 0.1 mm per coordinate on 16 markers: the RMS distance left is about
    // 0.1 mm * sqrt(3 (16 - 2) / 16) (6 of the 48 coordinates absorbed by the fit).
    let model = body_markers(3, 16);
    let tracks: Vec<[f64; 3]> = (model.iter().enumerate())
        .map(|(m, p)| [0, 1, 2].map(|a| p[a] + 1e-4 * normal(9, 0, m as u64, a as u64)))
        .collect();
    let c = fit_robot_from_tracker(&names(16), &tracks, &model).unwrap();
    let expected = 1e-4 * (3.0 * 14.0 / 16.0f64).sqrt();
    assert!(
        c.residual_rms_m > 0.6 * expected && c.residual_rms_m < 1.4 * expected,
        "{} against {expected}",
        c.residual_rms_m
    );
    assert_eq!(c.residuals_m.len(), 16);
}

#[test]
fn fewer_than_three_or_collinear_markers_are_refused() {
    let two = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]];
    let err = fit_robot_from_tracker(&names(2), &two, &two).unwrap_err();
    assert!(
        matches!(err, MarkersError::CalibrationTooFew { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("at least 3"), "{err}");
    let line = [
        [0.0, 0.0, 0.0],
        [0.1, 0.1, 0.0],
        [0.2, 0.2, 0.0],
        [0.3, 0.3, 0.0],
    ];
    let err = fit_robot_from_tracker(&names(4), &line, &line).unwrap_err();
    assert!(err.to_string().contains("one line"), "{err}");
}

#[test]
fn a_calibration_file_round_trips_and_a_sheared_matrix_is_refused() {
    let model = body_markers(5, 4);
    let c = fit_robot_from_tracker(&names(4), &model, &model).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tracker.json");
    write_calibration(&path, &c).unwrap();
    assert_eq!(read_calibration(&path).unwrap(), c);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["robot_from_tracker"][0][0] = serde_json::json!(2.0);
    std::fs::write(&path, v.to_string()).unwrap();
    let err = read_calibration(&path).unwrap_err();
    assert!(err.to_string().contains("tracker.json"), "{err}");
}

#[test]
fn the_rigid_fit_covariance_matches_the_spread_of_repeated_noisy_fits() {
    // 8 markers fitted 400 times with 1 mm noise; the offset the fit leaves at a point
    // outside them (5 cm above their centre) against B (BᵀB)⁻¹ Bᵀ.
    let model = body_markers(11, 8);
    let far = [[0.0, 0.0, 0.1]];
    let predicted = rigid_fit_covariance(&model, &far, 1);
    let trials = 400;
    let mut sum = [0.0; 3];
    for t in 0..trials {
        let noisy: Vec<[f64; 3]> = (model.iter().enumerate())
            .map(|(m, p)| [0, 1, 2].map(|a| p[a] + 1e-3 * normal(77, t, m as u64, a as u64)))
            .collect();
        let c = fit_robot_from_tracker(&names(8), &noisy, &model).unwrap();
        // The truth maps to itself: how far the fit moves a point is its error there.
        let moved = c.robot_from_tracker.apply(far[0]);
        for (a, s) in sum.iter_mut().enumerate() {
            *s += ((moved[a] - far[0][a]) / 1e-3).powi(2) / trials as f64;
        }
    }
    for (a, s) in sum.iter().enumerate() {
        let ratio = s / predicted[(a, a)];
        assert!(
            (ratio - 1.0).abs() < 0.2,
            "axis {a}: {s} against {}",
            predicted[(a, a)]
        );
    }
}

//! The control package's pieces without an FE solve: tasks, Theorem 2's mismatch and bound,
//! the bounded input allocation, the sensor's latency and losses, scenario checks.

use nalgebra::DMatrix;
use softsense::control::law::{gain_bound, mismatch};
use softsense::control::plant::Sensor;
use softsense::control::predictor::Kinematics;
use softsense::control::scenario::{Actuation, SensorSpec, TaskSpec};
use softsense::control::task::Task;

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[test]
fn a_circle_starts_at_its_centre_and_after_the_lead_in_stays_on_its_radius() {
    let start = [0.01, -0.02, 0.12];
    let spec = TaskSpec::Circle {
        radius_mm: 15.0,
        rad_per_s: None,
        rad_per_step: Some(1.0 / 30.0),
        normal: [0.0, 0.0, 1.0],
    };
    let task = Task::new(spec, start, 31.0);
    assert!(dist(task.target(0), start) < 1e-15);
    for k in 30..300 {
        let p = task.target(k);
        assert!((dist(p, start) - 0.015).abs() < 1e-12, "step {k}");
        assert!((p[2] - start[2]).abs() < 1e-15, "in the xy plane");
        // The path has no jump: each step moves at most the circle's speed.
        assert!(dist(task.target(k + 1), p) <= 0.015 / 30.0 + 1e-12);
    }
    assert!(task.preassigned());
}

#[test]
fn a_moving_target_is_not_known_ahead_and_starts_at_the_start() {
    let spec = TaskSpec::Follow {
        amplitude_mm: [10.0, 10.0, 5.0],
        rad_per_step: 0.02,
        seed: 3,
    };
    let task = Task::new(spec, [0.0, 0.0, 0.1], 31.0);
    assert!(!task.preassigned());
    assert!(dist(task.target(0), [0.0, 0.0, 0.1]) < 1e-15);
    assert!(dist(task.target(100), [0.0, 0.0, 0.1]) > 1e-3);
}

#[test]
fn the_mismatch_of_equal_jacobians_is_zero_and_of_a_doubled_one_is_one() {
    let j = DMatrix::from_row_slice(
        3,
        4,
        &[1.0, 0.2, -0.3, 0.0, 0.1, 0.9, 0.0, -0.4, 0.0, 0.3, 1.1, 0.5],
    );
    assert!(mismatch(&j, &j) < 1e-12);
    assert!((mismatch(&(&j * 2.0), &j) - 1.0).abs() < 1e-12);
    assert!((mismatch(&(&j * 1.25), &j) - 0.25).abs() < 1e-12);
    assert_eq!(gain_bound(0.0), Some(2.0));
    assert!((gain_bound(0.25).unwrap() - 1.6).abs() < 1e-15);
    assert_eq!(gain_bound(1.0), None);
}

fn kinematics(actuation: Actuation) -> Kinematics {
    Kinematics {
        position: [0.0; 3],
        j: DMatrix::from_row_slice(
            3,
            4,
            &[
                0.5, 0.0, -0.5, 0.0, 0.0, 0.5, 0.0, -0.5, -0.2, -0.2, -0.2, -0.2,
            ],
        ),
        w_aa: DMatrix::from_fn(4, 4, |i, k| if i == k { 2e-3 } else { -2e-4 }),
        tension: vec![1.0, 1.0, 1.0, 1.0],
        actuation,
    }
}

#[test]
fn without_an_active_bound_the_allocation_is_the_pseudo_inverse() {
    let k = kinematics(Actuation::Displacement);
    let a = k
        .allocate([1e-4, -2e-4, -1e-4], &[0.01; 4], [0.0, 0.04])
        .unwrap();
    assert!(!a.bounded);
    let pinv = k.j.clone().pseudo_inverse(1e-15).unwrap();
    let want = pinv * nalgebra::DVector::from_column_slice(&[1e-4, -2e-4, -1e-4]);
    for (d, w) in a.delta.iter().zip(want.iter()) {
        assert!((d - w).abs() < 1e-15);
    }
}

#[test]
fn an_allocation_past_a_limit_is_replaced_by_the_closest_motion_within_it() {
    let k = kinematics(Actuation::Displacement);
    let inputs = [0.0002, 0.01, 0.01, 0.01];
    let wanted = [-5e-4, 0.0, 0.0];
    let free = k.allocate(wanted, &[0.02; 4], [0.0, 0.04]).unwrap();
    assert!(
        !free.bounded,
        "far from the limits the pseudo-inverse is kept"
    );
    let a = k.allocate(wanted, &inputs, [0.0, 0.04]).unwrap();
    assert!(a.bounded);
    for (v, d) in inputs.iter().zip(&a.delta) {
        assert!(
            v + d >= -1e-9 && v + d <= 0.04 + 1e-9,
            "input {} outside the limits",
            v + d
        );
    }
    // The tension change W_aa⁻¹ Δ never takes a cable below zero.
    let dt = k.w_aa.clone().try_inverse().unwrap() * nalgebra::DVector::from_column_slice(&a.delta);
    for (t, d) in k.tension.iter().zip(dt.iter()) {
        assert!(t + d >= -1e-6, "tension {}", t + d);
    }
}

#[test]
fn force_inputs_never_go_below_zero_tension() {
    let k = kinematics(Actuation::Force);
    let a = k.allocate([0.0, 0.0, 0.5], &[0.2; 4], [0.0, 10.0]).unwrap();
    assert!(a.bounded);
    assert!(a.delta.iter().all(|d| 0.2 + d >= -1e-9));
}

#[test]
fn the_sensor_shows_the_state_one_step_late_and_nothing_while_lost() {
    let spec = SensorSpec {
        noise_mm: 0.0,
        latency: 1,
        lost: vec![[3, 4]],
        seed: 1,
    };
    let mut s = Sensor::new(&spec);
    for k in 0..6 {
        s.record([k as f64, 0.0, 0.0]);
    }
    assert!(s.measure(0).is_none(), "nothing is old enough at step 0");
    let m = s.measure(2).unwrap();
    assert_eq!((m.of_step, m.position[0]), (1, 1.0));
    assert!(s.measure(3).is_none() && s.measure(4).is_none());
    assert_eq!(s.measure(5).unwrap().of_step, 4);
}

#[test]
fn the_sensor_noise_has_the_asked_spread() {
    let spec = SensorSpec {
        noise_mm: 0.1,
        latency: 0,
        lost: vec![],
        seed: 9,
    };
    let mut s = Sensor::new(&spec);
    let n = 4000;
    for _ in 0..n {
        s.record([0.0; 3]);
    }
    let var: f64 = (0..n)
        .map(|k| {
            s.measure(k)
                .unwrap()
                .position
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
        })
        .sum::<f64>()
        / (3 * n) as f64;
    let sd_mm = 1e3 * var.sqrt();
    assert!((sd_mm - 0.1).abs() < 0.005, "{sd_mm}");
}

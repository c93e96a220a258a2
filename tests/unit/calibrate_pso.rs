//! The PSO core of the simultaneous calibration (thesis 3.12-3.14) on analytic functions.

use softsense::calibrate::pso::{inertia, minimise, PsoParams};

#[test]
fn pso_finds_the_minimum_of_a_shifted_ill_conditioned_quadratic_in_six_dimensions() {
    let shift = [0.3, -0.2, 0.7, -0.5, 0.1, 0.9];
    let f = |x: &[f64]| {
        (0..6)
            .map(|k| 10f64.powi(k as i32 / 2) * (x[k] - shift[k]).powi(2))
            .sum::<f64>()
    };
    let p = PsoParams::default();
    let best = minimise(f, &[-2.0; 6], &[2.0; 6], &[0.0; 6], &p, 0);
    for (x, s) in best.x.iter().zip(shift) {
        assert!((x - s).abs() < 1e-5, "{:?}", best.x);
    }
    assert_eq!(best.evaluations, p.particles * (p.iterations + 1));
}

#[test]
fn pso_reaches_the_valley_floor_of_a_shifted_rosenbrock_in_three_dimensions() {
    // Minimum at x = (1, 1, 1) + shift, value 0.
    let shift = [-0.4, 0.25, 0.1];
    let f = |x: &[f64]| {
        let y: Vec<f64> = (0..3).map(|k| x[k] - shift[k]).collect();
        (0..2)
            .map(|k| 100.0 * (y[k + 1] - y[k] * y[k]).powi(2) + (1.0 - y[k]).powi(2))
            .sum::<f64>()
    };
    let p = PsoParams {
        iterations: 2000,
        ..PsoParams::default()
    };
    let best = minimise(f, &[-3.0; 3], &[3.0; 3], &[0.0; 3], &p, 0);
    assert!(best.value < 1e-6, "{}", best.value);
    for (x, s) in best.x.iter().zip(shift) {
        assert!((x - 1.0 - s).abs() < 1e-2, "{:?}", best.x);
    }
}

#[test]
fn pso_is_reproducible_for_a_seed_and_differs_between_seeds() {
    let f = |x: &[f64]| x.iter().map(|v| (v - 0.1).powi(2)).sum::<f64>();
    let p = PsoParams {
        iterations: 20,
        ..PsoParams::default()
    };
    let a = minimise(f, &[-1.0; 4], &[1.0; 4], &[0.5; 4], &p, 3);
    let b = minimise(f, &[-1.0; 4], &[1.0; 4], &[0.5; 4], &p, 3);
    let c = minimise(f, &[-1.0; 4], &[1.0; 4], &[0.5; 4], &p, 4);
    assert_eq!(a.x, b.x);
    assert_ne!(a.x, c.x);
}

#[test]
fn inertia_decreases_linearly_from_w_start_to_w_end_as_equation_3_14() {
    let p = PsoParams {
        iterations: 200,
        w_start: 0.9,
        w_end: 0.4,
        ..PsoParams::default()
    };
    assert!((inertia(&p, 0) - 0.9).abs() < 1e-15);
    assert!((inertia(&p, 100) - 0.65).abs() < 1e-15);
    assert!((inertia(&p, 200) - 0.4).abs() < 1e-15);
    for t in 0..200 {
        let step = inertia(&p, t) - inertia(&p, t + 1);
        assert!((step - 0.5 / 200.0).abs() < 1e-15, "{t}: {step}");
    }
}

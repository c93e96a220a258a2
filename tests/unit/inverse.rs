//! The QP wrapper against closed-form and KKT solutions, and the intensity QP on synthetic W.
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use softsense::inverse::intensity::{ActuatorInput, IntensityParams, IntensityProblem};
use softsense::inverse::qp::{QpParams, QpProblem, QpStatus, SecondOrderCone};

/// Standard normal draws (Box-Muller on a 64-bit LCG), reproducible from `seed`.
fn normals(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        let mut u = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

fn spd(n: usize, seed: u64) -> DMatrix<f64> {
    let mut s = seed;
    let mut r = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    };
    let m = DMatrix::from_fn(n, n, |_, _| r());
    &m * m.transpose() + DMatrix::identity(n, n)
}

#[test]
fn unconstrained_qp_matches_the_closed_form() {
    let mut p = QpProblem::new(3);
    p.p = spd(3, 1);
    p.q = vec![1.0, -2.0, 0.5];
    let s = p.solve(&QpParams::default()).unwrap();
    assert_eq!(s.status, QpStatus::Solved);
    let x =
        -p.p.clone()
            .lu()
            .solve(&DVector::from_vec(p.q.clone()))
            .unwrap();
    for i in 0..3 {
        assert!((s.x[i] - x[i]).abs() < 1e-7, "{} vs {}", s.x[i], x[i]);
    }
    assert!((s.objective - p.objective(x.as_slice())).abs() < 1e-9);
}

#[test]
fn equality_constrained_qp_matches_the_kkt_system() {
    let n = 4;
    let mut p = QpProblem::new(n);
    p.p = spd(n, 7);
    p.q = vec![0.3, -1.0, 2.0, 0.1];
    p.a_eq = DMatrix::from_row_slice(2, n, &[1.0, 1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 2.0]);
    p.b_eq = vec![1.0, -0.5];
    let s = p.solve(&QpParams::default()).unwrap();
    assert_eq!(s.status, QpStatus::Solved);
    let mut kkt = DMatrix::zeros(n + 2, n + 2);
    kkt.view_mut((0, 0), (n, n)).copy_from(&p.p);
    kkt.view_mut((n, 0), (2, n)).copy_from(&p.a_eq);
    kkt.view_mut((0, n), (n, 2)).copy_from(&p.a_eq.transpose());
    let mut rhs = DVector::zeros(n + 2);
    for i in 0..n {
        rhs[i] = -p.q[i];
    }
    rhs[n] = 1.0;
    rhs[n + 1] = -0.5;
    let z = kkt.lu().solve(&rhs).unwrap();
    for i in 0..n {
        assert!((s.x[i] - z[i]).abs() < 1e-7, "{i}: {} vs {}", s.x[i], z[i]);
    }
}

#[test]
fn active_bounds_clip_the_minimiser() {
    // min (x0-1)^2 + (x1+1)^2 with x >= 0 -> (1, 0); with x0 <= 0.5 -> (0.5, 0)
    let mut p = QpProblem::new(2);
    p.p = DMatrix::identity(2, 2) * 2.0;
    p.q = vec![-2.0, 2.0];
    p.lower = vec![0.0, 0.0];
    let s = p.solve(&QpParams::default()).unwrap();
    assert!(
        (s.x[0] - 1.0).abs() < 1e-7 && s.x[1].abs() < 1e-7,
        "{:?}",
        s.x
    );
    p.upper[0] = 0.5;
    let s = p.solve(&QpParams::default()).unwrap();
    assert!(
        (s.x[0] - 0.5).abs() < 1e-7 && s.x[1].abs() < 1e-7,
        "{:?}",
        s.x
    );
}

#[test]
fn second_order_cone_projects_onto_the_cone() {
    // Project (0, 3, 4) onto {t >= |(u, v)|}: (2.5, 1.5, 2.0).
    let mut p = QpProblem::new(3);
    p.p = DMatrix::identity(3, 3);
    p.q = vec![0.0, -3.0, -4.0];
    p.cones.push(SecondOrderCone {
        g: DMatrix::identity(3, 3),
        h: vec![0.0; 3],
    });
    let s = p.solve(&QpParams::default()).unwrap();
    assert_eq!(s.status, QpStatus::Solved);
    for (a, b) in s.x.iter().zip([2.5, 1.5, 2.0]) {
        assert!((a - b).abs() < 1e-6, "{:?}", s.x);
    }
}

#[test]
fn infeasible_bounds_give_no_solution() {
    let mut p = QpProblem::new(1);
    p.p[(0, 0)] = 1.0;
    p.lower[0] = 1.0;
    p.upper[0] = -1.0;
    let s = p.solve(&QpParams::default()).unwrap();
    assert_eq!(s.status, QpStatus::PrimalInfeasible);
    assert!(s.x.is_empty());
    assert!(s.solution().is_err());
}

#[test]
fn unbounded_objective_is_dual_infeasible() {
    let mut p = QpProblem::new(1);
    p.q[0] = -1.0;
    let s = p.solve(&QpParams::default()).unwrap();
    assert_eq!(s.status, QpStatus::DualInfeasible);
    assert!(s.x.is_empty());
}

#[test]
fn iteration_limit_is_reported_not_returned() {
    let mut p = QpProblem::new(3);
    p.p = spd(3, 3);
    p.q = vec![1.0, 1.0, 1.0];
    p.lower = vec![0.1; 3];
    let s = p
        .solve(&QpParams {
            max_iterations: 1,
            ..Default::default()
        })
        .unwrap();
    assert_eq!(s.status, QpStatus::MaxIterations);
    assert!(s.x.is_empty());
}

#[test]
fn bad_dimensions_and_nan_are_rejected() {
    let mut p = QpProblem::new(2);
    p.q.push(0.0);
    assert!(p.solve(&QpParams::default()).is_err());
    let mut p = QpProblem::new(2);
    p.p[(0, 1)] = f64::NAN;
    assert!(p.solve(&QpParams::default()).is_err());
}

proptest! {
    #[test]
    fn least_squares_qp_solves_the_normal_equations(seed in 0u64..1000, m in 3usize..8) {
        let a = spd(m, seed).columns(0, 3).into_owned();
        let d: Vec<f64> = (0..m).map(|i| (i as f64 * 0.37 + seed as f64 * 0.01).sin()).collect();
        let p = QpProblem::least_squares(&a, &d).unwrap();
        let s = p.solve(&QpParams::default()).unwrap();
        let x = a.clone().svd(true, true).solve(&DVector::from_vec(d), 1e-12).unwrap();
        for i in 0..3 {
            prop_assert!((s.x[i] - x[i]).abs() < 1e-6 * (1.0 + x[i].abs()));
        }
    }
}

fn synthetic(actuators: Vec<ActuatorInput>) -> (IntensityProblem, Vec<f64>, Vec<f64>) {
    // 12 rows, 2 actuators, 2 forces; truth lambda_a = [0.4, 0.1], lambda_f = [0.7, 0.2].
    let w = spd(16, 5) * 1e-3;
    let (m, a, k) = (12, 2, 2);
    let w_ea = w.view((0, 0), (m, a)).into_owned();
    let w_ef = w.view((0, a), (m, k)).into_owned();
    let w_aa = w.view((m, 0), (a, a)).into_owned() + DMatrix::identity(2, 2) * 1e-3;
    let w_af = w.view((m, a), (a, k)).into_owned();
    let la = DVector::from_vec(vec![0.4, 0.1]);
    let lf = DVector::from_vec(vec![0.7, 0.2]);
    let free_e: Vec<f64> = (0..m).map(|i| 1e-4 * i as f64).collect();
    let free_a = vec![2e-4, -1e-4];
    let meas = &w_ea * &la + &w_ef * &lf + DVector::from_vec(free_e.clone());
    let act = &w_aa * &la + &w_af * &lf + DVector::from_vec(free_a.clone());
    let actuators = actuators
        .into_iter()
        .enumerate()
        .map(|(i, x)| match x {
            ActuatorInput::Force(_) => ActuatorInput::Force(la[i]),
            ActuatorInput::Displacement(_) => ActuatorInput::Displacement(act[i]),
        })
        .collect();
    (
        IntensityProblem {
            w_ea,
            w_ef,
            delta_free_e: free_e,
            delta_measured: meas.iter().copied().collect(),
            w_aa,
            w_af,
            delta_free_a: free_a,
            actuators,
            push_only: vec![true, true],
            row_noise: Default::default(),
        },
        la.iter().copied().collect(),
        lf.iter().copied().collect(),
    )
}

#[test]
fn intensity_qp_recovers_forces_with_force_controlled_actuators() {
    let (p, la, lf) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    let e = p.solve(&IntensityParams::default()).unwrap();
    assert_eq!(e.status, QpStatus::Solved);
    for i in 0..2 {
        assert!((e.forces[i] - lf[i]).abs() < 1e-6, "{:?}", e.forces);
        assert!((e.actuator_forces[i] - la[i]).abs() < 1e-7);
    }
    assert!(e.residual_rms < 1e-9);
    assert!(e.identifiability.warning.is_none());
    assert!(e.force_sigma.iter().all(|s| s.is_finite() && *s > 0.0));
}

#[test]
fn intensity_qp_recovers_forces_with_displacement_controlled_actuators() {
    let (p, la, lf) = synthetic(vec![
        ActuatorInput::Displacement(0.0),
        ActuatorInput::Force(0.0),
    ]);
    let e = p.solve(&IntensityParams::default()).unwrap();
    for i in 0..2 {
        assert!((e.forces[i] - lf[i]).abs() < 1e-6, "{:?}", e.forces);
        assert!(
            (e.actuator_forces[i] - la[i]).abs() < 1e-6,
            "{:?}",
            e.actuator_forces
        );
    }
}

#[test]
fn pushing_only_bound_holds_when_the_data_pull() {
    let (mut p, _, _) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    // Measured = free: the best unbounded fit is zero force; flip the sign to ask for a pull.
    let d: Vec<f64> = p
        .delta_measured
        .iter()
        .zip(&p.delta_free_e)
        .map(|(m, f)| 2.0 * f - m)
        .collect();
    p.delta_measured = d;
    p.actuators = vec![ActuatorInput::Force(0.0); 2];
    let e = p.solve(&IntensityParams::default()).unwrap();
    assert!(e.forces.iter().all(|f| *f >= -1e-8), "{:?}", e.forces);
}

#[test]
fn too_few_rows_warn_about_identifiability() {
    let (mut p, _, _) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    p.w_ef = p.w_ef.rows(0, 1).into_owned();
    p.w_ea = p.w_ea.rows(0, 1).into_owned();
    p.delta_free_e.truncate(1);
    p.delta_measured.truncate(1);
    let id = p.identifiability(&IntensityParams::default());
    assert!(id.warning.is_some());
    assert!(id.i_w.is_infinite());
}

#[test]
fn the_robust_residual_matches_the_rms_on_gaussian_noise_and_ignores_a_few_outliers() {
    // 400 feature rows, 1 force-controlled actuator, 2 forces; the data are the model plus
    // Gaussian noise of 0.1 mm.
    let (m, sigma) = (400, 1e-4);
    let mut state = 7u64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let w_ef = DMatrix::from_fn(m, 2, |i, j| {
        1e-3 * (1.0 + ((i * (j + 3)) % 17) as f64 / 17.0)
    });
    let w_ea = DMatrix::from_fn(m, 1, |i, _| 1e-4 * ((i % 5) as f64));
    let lf = DVector::from_vec(vec![0.5, 0.3]);
    let model = &w_ea * DVector::from_vec(vec![0.2]) + &w_ef * &lf;
    let noise: Vec<f64> = (0..m)
        .map(|_| {
            let (u, v) = (uniform(), uniform());
            sigma * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        })
        .collect();
    let problem = |measured: Vec<f64>| IntensityProblem {
        w_ea: w_ea.clone(),
        w_ef: w_ef.clone(),
        delta_free_e: vec![0.0; m],
        delta_measured: measured,
        w_aa: DMatrix::identity(1, 1) * 1e-3,
        w_af: DMatrix::zeros(1, 2),
        delta_free_a: vec![0.0],
        actuators: vec![ActuatorInput::Force(0.2)],
        push_only: vec![true, true],
        row_noise: Default::default(),
    };
    let clean: Vec<f64> = (0..m).map(|i| model[i] + noise[i]).collect();
    let e = problem(clean.clone())
        .solve(&IntensityParams::default())
        .unwrap();
    assert!((e.residual_robust / sigma - 1.0).abs() < 0.15, "{e:?}");
    assert!((e.residual_rms / sigma - 1.0).abs() < 0.15, "{e:?}");
    // Two rows 5 mm off (points of another object matched to those features): the RMS
    // triples, the robust spread stays. (Many outliers would pull the fit itself, and then
    // every residual grows: the robust spread is robust to a few, not to a wrong fit.)
    let mut dirty = clean;
    dirty[0] += 5e-3;
    dirty[200] -= 5e-3;
    let d = problem(dirty).solve(&IntensityParams::default()).unwrap();
    assert!(d.residual_rms > 3.0 * sigma, "{d:?}");
    assert!(
        (d.residual_robust / e.residual_robust - 1.0).abs() < 0.1,
        "{d:?}"
    );
}

#[test]
fn the_median_by_selection_equals_the_middle_of_the_sorted_values() {
    assert!(softsense::math::median(&mut []).is_nan());
    let mut state = 3u64;
    for n in 1..40 {
        let mut v: Vec<f64> = (0..n)
            .map(|_| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                (state >> 40) as f64 - 8e6
            })
            .collect();
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        let want = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
        };
        assert_eq!(softsense::math::median(&mut v), want, "n = {n}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// The bound the location choice prunes with: without the push-only bounds the fit is
    /// never worse, and equal when the QP's bounds are not active.
    #[test]
    fn the_unbounded_residual_is_a_lower_bound_of_the_qp_residual_and_equal_when_no_bound_acts(
        noise in proptest::collection::vec(-1e-4f64..1e-4, 12),
        flip in proptest::collection::vec(-1.5f64..1.5, 2),
        displacement in prop::bool::ANY,
    ) {
        let inputs = if displacement {
            vec![ActuatorInput::Displacement(0.0), ActuatorInput::Force(0.0)]
        } else {
            vec![ActuatorInput::Force(0.0); 2]
        };
        let (mut p, _, lf) = synthetic(inputs);
        // Data of forces `flip * truth` (negative: a pull the bounds refuse), plus noise.
        for (i, (d, n)) in p.delta_measured.iter_mut().zip(&noise).enumerate() {
            *d += n + (0..2).map(|j| p.w_ef[(i, j)] * lf[j] * (flip[j] - 1.0)).sum::<f64>();
        }
        let e = p.solve(&IntensityParams::default()).unwrap();
        prop_assert!(e.status.is_solution());
        let b = p.unbounded_residual_rms().unwrap();
        prop_assert!(b <= e.residual_rms * (1.0 + 1e-6), "bound {b:e} above the QP's {:e}", e.residual_rms);
        if e.forces.iter().all(|f| *f > 1e-3) {
            prop_assert!((b - e.residual_rms).abs() <= 1e-6 * e.residual_rms.max(1e-12),
                "no bound acts, yet {b:e} vs {:e}", e.residual_rms);
        }
    }
}

#[test]
fn a_problem_s_residuals_are_zero_at_its_truth_and_give_the_estimate_s_rms() {
    let (mut p, la, lf) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    let r = p.residuals(&la, &lf).unwrap();
    assert_eq!(r.len(), 12);
    assert!(r.iter().all(|v| v.abs() < 1e-15), "{r:?}");
    // One row off by 1e-5 m: its residual is that offset, with the sign of predicted less
    // measured.
    p.delta_measured[3] += 1e-5;
    let r = p.residuals(&la, &lf).unwrap();
    assert!((r[3] + 1e-5).abs() < 1e-15);
    let e = p.solve(&IntensityParams::default()).unwrap();
    let r = p.residuals(&e.actuator_forces, &e.forces).unwrap();
    let rms = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
    assert!(
        (rms - e.residual_rms).abs() <= 1e-12 * e.residual_rms,
        "{rms} vs {}",
        e.residual_rms
    );
    assert!(p.residuals(&la, &lf[..1]).is_none());
    assert!(p.residuals(&la[..1], &lf).is_none());
}

#[test]
fn a_singular_problem_has_no_unbounded_residual() {
    let (mut p, _, _) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    // Two identical force columns: without the bounds their split is not determined.
    let c = p.w_ef.column(0).into_owned();
    p.w_ef.set_column(1, &c);
    let c = p.w_af.column(0).into_owned();
    p.w_af.set_column(1, &c);
    assert!(p.unbounded_residual_rms().is_none());
}

#[test]
fn force_covariance_of_independent_rows_is_the_gauss_markov_one() {
    let (p, _, _) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    let sigma = 2e-5;
    let m = p.w_ef.nrows();
    let cov = p
        .force_covariance(&(DMatrix::identity(m, m) * sigma * sigma))
        .unwrap();
    for (i, s) in p.force_sigma(sigma).iter().enumerate() {
        assert!(
            (cov[(i, i)].sqrt() - s).abs() <= 1e-9 * s,
            "{i}: {cov} vs {s}"
        );
    }
    // A covariance that does not fit the rows is refused.
    assert!(p
        .force_covariance(&DMatrix::identity(m + 1, m + 1))
        .is_none());
}

#[test]
fn force_covariance_of_correlated_rows_matches_the_spread_of_solved_forces() {
    // Monte Carlo oracle: the QP solved on offsets with correlated noise (half of each
    // row's variance shared by all rows), force-controlled actuators held; the sample
    // covariance of the solved forces against `force_covariance`.
    let (p, _, lf) = synthetic(vec![ActuatorInput::Force(0.0); 2]);
    let m = p.w_ef.nrows();
    let s = 3e-5;
    let c = DMatrix::from_fn(m, m, |i, j| s * s * (0.5 + if i == j { 0.5 } else { 0.0 }));
    let l = c.clone().cholesky().unwrap().l();
    let predicted = p.force_covariance(&c).unwrap();
    let gauss_markov = p.force_sigma(s);
    let mut normal = normals(17);
    let n = 2000;
    let mut samples = Vec::with_capacity(n);
    for _ in 0..n {
        let z = DVector::from_fn(m, |_, _| normal());
        let noise = &l * z;
        let mut q = p.clone();
        for (v, e) in q.delta_measured.iter_mut().zip(noise.iter()) {
            *v += e;
        }
        let e = q.solve(&IntensityParams::default()).unwrap();
        samples.push([e.forces[0] - lf[0], e.forces[1] - lf[1]]);
    }
    for i in 0..2 {
        let var = samples.iter().map(|x| x[i] * x[i]).sum::<f64>() / n as f64;
        let ratio = var.sqrt() / predicted[(i, i)].sqrt();
        // 2000 samples: the sample σ is within ~1.6% (1σ) of the true one.
        assert!(
            (ratio - 1.0).abs() < 0.06,
            "force {i}: sample/predicted σ {ratio}"
        );
        // Independent rows would be 14-16% off here, one too small, one too large.
        let gm = gauss_markov[i] / var.sqrt();
        assert!(
            (gm - 1.0).abs() > 0.1,
            "force {i}: Gauss-Markov/sample σ {gm}"
        );
    }
}

#[test]
fn the_regularization_shrink_is_the_ridge_factor_of_the_weakest_force_and_warns_above_a_tenth() {
    // Two forces on disjoint rows (orthogonal columns), the second 10 times weaker, and an
    // actuator that moves no feature: the regularized QP is a ridge regression per force,
    // whose estimate is the truth times σ² / (σ² + εs). The weakest force's factor is
    // 1 − regularization_shrink.
    let m = 20;
    let w_ef = DMatrix::from_fn(m, 2, |i, j| match (i < 10, j) {
        (true, 0) => 1e-3 * (1.0 + (i % 3) as f64),
        (false, 1) => 1e-4 * (1.0 + (i % 4) as f64),
        _ => 0.0,
    });
    let truth = DVector::from_vec(vec![0.6, 0.4]);
    let problem = IntensityProblem {
        w_ea: DMatrix::zeros(m, 1),
        w_ef: w_ef.clone(),
        delta_free_e: vec![0.0; m],
        delta_measured: (&w_ef * &truth).iter().copied().collect(),
        w_aa: DMatrix::identity(1, 1) * 1e-3,
        w_af: DMatrix::zeros(1, 2),
        delta_free_a: vec![0.0],
        actuators: vec![ActuatorInput::Force(0.0)],
        push_only: vec![false, false],
        row_noise: Default::default(),
    };
    let plain = problem.solve(&IntensityParams::default()).unwrap();
    assert_eq!(plain.regularization_shrink, 0.0);
    assert!(plain.regularization_warning().is_none());
    for (eps, warned) in [(1e-4, false), (1e-2, true), (1e-1, true)] {
        let params = IntensityParams {
            regularization: eps,
            ..Default::default()
        };
        let e = problem.solve(&params).unwrap();
        assert_eq!(e.status, QpStatus::Solved);
        let factor = e.forces[1] / truth[1];
        assert!(
            (factor - (1.0 - e.regularization_shrink)).abs() < 1e-6,
            "ε {eps}: weakest force scaled by {factor}, shrink {}",
            e.regularization_shrink
        );
        assert_eq!(
            e.regularization_warning().is_some(),
            warned,
            "ε {eps}: {e:?}"
        );
    }
}

/// A passive problem: two free forces, no actuators, `measured` offsets of the rows `w_ef`.
fn passive(w_ef: &DMatrix<f64>, measured: Vec<f64>) -> IntensityProblem {
    let m = w_ef.nrows();
    IntensityProblem {
        w_ea: DMatrix::zeros(m, 0),
        w_ef: w_ef.clone(),
        delta_free_e: vec![0.0; m],
        delta_measured: measured,
        w_aa: DMatrix::zeros(0, 0),
        w_af: DMatrix::zeros(0, w_ef.ncols()),
        delta_free_a: Vec::new(),
        actuators: Vec::new(),
        push_only: vec![false; w_ef.ncols()],
        row_noise: Default::default(),
    }
}

/// White's covariance from one draw's residuals (the dense rows' σ) against the truth
/// A diag(s_i²) Aᵀ of rows whose noise differs: the rows that decide force 0 are four
/// times as noisy as those that decide force 1.
#[test]
fn white_covariance_from_one_draw_matches_the_truth_when_each_row_has_its_own_noise() {
    let m = 4000;
    let mut normal = normals(29);
    let w_ef = DMatrix::from_fn(m, 2, |i, j| {
        let strong = (i % 2 == 0) == (j == 0);
        1e-3 * if strong { 1.0 } else { 0.2 }
    });
    let s: Vec<f64> = (0..m)
        .map(|i| if i % 2 == 0 { 4e-4 } else { 1e-4 })
        .collect();
    let truth = [0.5, 0.3];
    let residual_noise: Vec<f64> = s.iter().map(|si| si * normal()).collect();
    let clean = &w_ef * DVector::from_column_slice(&truth);
    let measured = clean.iter().zip(&residual_noise).map(|(c, e)| c + e);
    let p = passive(&w_ef, measured.collect());
    let e = p.solve(&IntensityParams::default()).unwrap();
    let r = p.residuals(&e.actuator_forces, &e.forces).unwrap();
    let white = p.white_covariance(&r, &[]).unwrap();
    let exact = p
        .force_covariance(&DMatrix::from_diagonal(&DVector::from_iterator(
            m,
            s.iter().map(|v| v * v),
        )))
        .unwrap();
    // One pooled noise (the rows' rms) for Gauss-Markov.
    let pooled = (s.iter().map(|v| v * v).sum::<f64>() / m as f64).sqrt();
    let gauss_markov = p.force_sigma(pooled);
    for i in 0..2 {
        let ratio = (white[(i, i)] / exact[(i, i)]).sqrt();
        // 4000 rows: the estimate's σ is within a few % of the truth.
        assert!(
            (ratio - 1.0).abs() < 0.06,
            "force {i}: white/true σ {ratio}"
        );
    }
    // A pooled noise puts force 1's σ far off (its rows are the quiet ones).
    let gm = gauss_markov[1] / exact[(1, 1)].sqrt();
    assert!(gm > 1.3, "force 1: Gauss-Markov/true σ {gm}");
    // Rows that do not fit are refused.
    assert!(p.white_covariance(&r[1..], &[]).is_none());
}

/// Rows of one patch share an offset (a misfit the model cannot bend to inside one FE
/// triangle): the cluster-robust covariance over the patches matches the spread of the
/// solved forces over many draws, and treating the rows as independent is far too small.
#[test]
fn patch_robust_covariance_covers_noise_shared_within_each_patch() {
    let (m, patch_size) = (2400, 20);
    let mut normal = normals(31);
    let w_ef = DMatrix::from_fn(m, 2, |i, j| {
        let t = i as f64 / m as f64;
        1e-3 * if j == 0 { 1.0 + t } else { (6.0 * t).sin() }
    });
    let patch: Vec<usize> = (0..m).map(|i| i / patch_size).collect();
    let truth = DVector::from_vec(vec![0.5, 0.3]);
    let clean = &w_ef * &truth;
    let draw = |normal: &mut dyn FnMut() -> f64| {
        let shared: Vec<f64> = (0..m / patch_size).map(|_| 2e-4 * normal()).collect();
        let measured: Vec<f64> = (0..m)
            .map(|i| clean[i] + shared[patch[i]] + 1e-4 * normal())
            .collect();
        passive(&w_ef, measured)
    };
    let params = IntensityParams::default();
    let (n, mut spread, mut robust, mut independent) = (300, [0.0; 2], [0.0; 2], [0.0; 2]);
    for _ in 0..n {
        let p = draw(&mut normal);
        let e = p.solve(&params).unwrap();
        let r = p.residuals(&e.actuator_forces, &e.forces).unwrap();
        let by_patch = p.white_covariance(&r, &patch).unwrap();
        let by_row = p.white_covariance(&r, &[]).unwrap();
        for i in 0..2 {
            spread[i] += (e.forces[i] - truth[i]).powi(2) / n as f64;
            robust[i] += by_patch[(i, i)] / n as f64;
            independent[i] += by_row[(i, i)] / n as f64;
        }
    }
    for i in 0..2 {
        // 300 draws: the sample σ is within ~4% (1σ) of the true one.
        let ratio = (robust[i] / spread[i]).sqrt();
        assert!(
            (ratio - 1.0).abs() < 0.15,
            "force {i}: by patch/sample σ {ratio}"
        );
        let ratio = (independent[i] / spread[i]).sqrt();
        assert!(ratio < 0.6, "force {i}: by row/sample σ {ratio}");
    }
}

#[test]
fn candidate_loads_are_the_intensities_along_the_unit_directions_and_sum_in_order() {
    use softsense::fem::solve::MappedPoint;
    use softsense::inverse::{loads_of, total_force, Candidate};
    let at = MappedPoint::node(3);
    let c = [
        Candidate::new(at, [0.0, 0.0, -2.0], true),
        Candidate::new(at, [3.0, 4.0, 0.0], false),
    ];
    assert_eq!(c[0].direction, [0.0, 0.0, -1.0]);
    let loads = loads_of(&c, &[0.5, -1.0]);
    assert_eq!(loads.len(), 2);
    assert_eq!(loads[0].at, at);
    assert_eq!(loads[0].force, [0.0, 0.0, -0.5]);
    assert_eq!(loads[1].force, [-0.6, -0.8, -0.0]);
    assert_eq!(total_force(&loads), [-0.6, -0.8, -0.5]);
    assert_eq!(c[1].row().unwrap().entries, vec![(3, [0.6, 0.8, 0.0])]);
}

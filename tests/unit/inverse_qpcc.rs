//! The contact LCP and the QPCC of thesis chapter 5 ([`softsense::inverse::qpcc`]) against
//! brute-force oracles: every LCP active set solved exactly, every QPCC active set solved as
//! a convex QP, and the bound of 5.27 for the converted QP (5.13) on reachable targets.
//!
//! Instances come from one physical compliance W = B Bᵀ + 0.1 I over the rows
//! \[effectors; actuators; contacts\], so W_e and W_c share it; with `decoupled` the actuator
//! and contact rows of B use disjoint columns (W_ca = 0), which keeps Q convex.
use nalgebra::{DMatrix, DVector};
use softsense::inverse::qp::QpParams;
use softsense::inverse::qpcc::{
    solve_contact_lcp, ConvertedParams, ConvertedStatus, Convexity, LcpStatus, QpccParams,
    QpccProblem, QpccStatus,
};
use softsense::inverse::InverseError;
use softsense::math::rand::{normal, uniform};

#[derive(Clone, Copy, Debug)]
struct Dims {
    e: usize,
    a: usize,
    c: usize,
}

/// W = B Bᵀ + 0.1 I over \[effectors; actuators; contacts\].
fn compliance(seed: u64, d: Dims, decoupled: bool) -> DMatrix<f64> {
    let n = d.e + d.a + d.c;
    let m = n + 2;
    let b = DMatrix::from_fn(n, m, |i, j| {
        let actuator = (d.e..d.e + d.a).contains(&i);
        let contact = i >= d.e + d.a;
        if decoupled && ((actuator && j >= m / 2) || (contact && j < m / 2)) {
            0.0
        } else {
            normal(seed, 1, i as u64, j as u64)
        }
    });
    &b * b.transpose() + 0.1 * DMatrix::identity(n, n)
}

/// W_e = W\[e, a∪c\] and W_c = W\[c, a∪c\].
fn blocks(w: &DMatrix<f64>, d: Dims) -> (DMatrix<f64>, DMatrix<f64>) {
    let cols = d.a + d.c;
    let w_e = w.view((0, d.e), (d.e, cols)).into_owned();
    let w_c = w.view((d.e + d.a, d.e), (d.c, cols)).into_owned();
    (w_e, w_c)
}

fn params() -> QpccParams {
    QpccParams {
        qp: QpParams {
            tolerance: 1e-11,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A general instance: n_c in 1..=6, targets mostly out of reach, some bounds finite.
fn random_instance(seed: u64) -> QpccProblem {
    let u = |k: u64| uniform(seed, 2, k, 0);
    let d = Dims {
        e: 1 + (u(0) * 4.0) as usize,
        a: 1 + (u(1) * 3.0) as usize,
        c: 1 + (u(2) * 6.0) as usize,
    };
    let (w_e, w_c) = blocks(&compliance(seed, d, u(3) < 0.3), d);
    let draw = |stream: u64, n: usize, s: f64| -> Vec<f64> {
        (0..n)
            .map(|i| s * normal(seed, 3, i as u64, stream))
            .collect()
    };
    let mut p = QpccProblem::new(
        w_e,
        w_c,
        draw(0, d.e, 1.0),
        draw(1, d.c, 1.0),
        draw(2, d.e, 2.0),
        d.a,
    );
    if u(4) < 0.5 {
        p.lambda_a_max = vec![3.0; d.a];
    }
    if u(5) < 0.3 {
        p.lambda_c_max = vec![2.0; d.c];
    }
    p
}

/// A reachable instance (BM-1): λ* within bounds with a random active/inactive split, δ_c^free
/// set so that λ*_c ⟂ δ_c*, δ_d = W_e λ* + δ_e^free, n_e ≤ n_a.
fn reachable_instance(seed: u64) -> QpccProblem {
    let u = |k: u64| uniform(seed, 4, k, 0);
    let a = 2 + (u(0) * 3.0) as usize;
    let d = Dims {
        e: 1 + (u(1) * a as f64) as usize,
        a,
        c: 1 + (u(2) * 5.0) as usize,
    };
    let (w_e, w_c) = blocks(&compliance(seed, d, u(3) < 0.5), d);
    let mut lambda = vec![0.0; d.a + d.c];
    let mut delta_c = vec![0.0; d.c];
    for (j, l) in lambda.iter_mut().enumerate().take(d.a) {
        *l = 0.1 + 1.5 * uniform(seed, 5, j as u64, 0);
    }
    for i in 0..d.c {
        let size = 0.2 + 0.8 * uniform(seed, 6, i as u64, 0);
        if uniform(seed, 7, i as u64, 0) < 0.5 {
            lambda[d.a + i] = size;
        } else {
            delta_c[i] = size;
        }
    }
    let l = DVector::from_column_slice(&lambda);
    let wl_c = &w_c * &l;
    let delta_c_free = (0..d.c).map(|i| delta_c[i] - wl_c[i]).collect();
    let delta_e_free: Vec<f64> = (0..d.e).map(|i| normal(seed, 8, i as u64, 0)).collect();
    let wl_e = &w_e * &l;
    let delta_d = (0..d.e).map(|i| wl_e[i] + delta_e_free[i]).collect();
    let mut p = QpccProblem::new(w_e, w_c, delta_e_free, delta_c_free, delta_d, d.a);
    p.lambda_a_max = vec![2.0; d.a];
    p
}

/// The LCP by every active set A: W_AA λ_A = −g_A exactly, the first feasible one.
fn brute_force_lcp(w: &DMatrix<f64>, g: &[f64]) -> Option<Vec<f64>> {
    let n = g.len();
    (0..1usize << n).find_map(|set| {
        let active: Vec<usize> = (0..n).filter(|i| set >> i & 1 == 1).collect();
        let mut lambda = vec![0.0; n];
        if !active.is_empty() {
            let w_aa = w.select_rows(&active).select_columns(&active);
            let rhs = DVector::from_iterator(active.len(), active.iter().map(|&i| -g[i]));
            let x = w_aa.lu().solve(&rhs)?;
            for (k, &i) in active.iter().enumerate() {
                lambda[i] = x[k];
            }
        }
        let delta = w * DVector::from_column_slice(&lambda) + DVector::from_column_slice(g);
        let ok = lambda.iter().all(|&l| l >= -1e-12) && delta.iter().all(|&d| d >= -1e-12);
        ok.then_some(lambda)
    })
}

#[test]
fn the_forward_lcp_equals_brute_force_enumeration_of_its_active_sets() {
    let mut worst: f64 = 0.0;
    for seed in 0..40u64 {
        let d = Dims {
            e: 0,
            a: 0,
            c: 1 + (uniform(seed, 9, 0, 0) * 6.0) as usize,
        };
        let w = compliance(seed, d, false);
        let g: Vec<f64> = (0..d.c).map(|i| normal(seed, 10, i as u64, 0)).collect();
        let lcp = solve_contact_lcp(&w, &g, &QpParams::default()).unwrap();
        assert_eq!(lcp.status, LcpStatus::Solved, "seed {seed}");
        let truth = brute_force_lcp(&w, &g).expect("a PD W_cc has a solution");
        let err = (0..d.c)
            .map(|i| (lcp.lambda[i] - truth[i]).abs())
            .fold(0.0, f64::max);
        let rel = err / max_abs(&truth).max(1e-12);
        worst = worst.max(rel);
        assert!(err <= 1e-7 * max_abs(&truth) + 1e-12, "seed {seed}: {err}");
        assert!(
            lcp.min_delta >= -1e-9 && lcp.complementarity <= 1e-9,
            "seed {seed}"
        );
    }
    eprintln!("forward LCP vs brute force: worst relative λ error {worst:.2e}");
}

#[test]
fn a_singular_contact_compliance_is_solved_and_an_infeasible_lcp_is_reported() {
    // Two contacts on one rigid link: W_cc = [[1, 1], [1, 1]], λ_1 + λ_2 = 1 closes both.
    let w = DMatrix::from_element(2, 2, 1.0);
    let lcp = solve_contact_lcp(&w, &[-1.0, -1.0], &QpParams::default()).unwrap();
    assert_eq!(lcp.status, LcpStatus::Solved);
    assert!((lcp.lambda[0] + lcp.lambda[1] - 1.0).abs() < 1e-7);
    assert!(lcp.complementarity < 1e-7 && lcp.min_delta > -1e-7);
    // A penetration no force can open: W_cc = 0, g < 0.
    let lcp = solve_contact_lcp(&DMatrix::zeros(1, 1), &[-1.0], &QpParams::default()).unwrap();
    assert_eq!(lcp.status, LcpStatus::Infeasible);
    assert!(lcp.lambda.is_empty());
    // Not PSD: an error, never handed to Clarabel.
    let bad = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    let err = solve_contact_lcp(&bad, &[0.0, 0.0], &QpParams::default()).unwrap_err();
    assert!(
        matches!(err, InverseError::ContactCompliance { .. }),
        "{err}"
    );
}

#[test]
fn regression_a_qpcc_with_no_contacts_does_not_panic_in_its_lcp() {
    // The catheter's first steps have no contact: the LCP has no unknowns, which Clarabel
    // cannot take (it panicked inside its factorisation).
    let lcp = solve_contact_lcp(&DMatrix::zeros(0, 0), &[], &QpParams::default()).unwrap();
    assert_eq!(lcp.status, LcpStatus::Solved);
    assert!(lcp.lambda.is_empty());
    let w_e = DMatrix::from_row_slice(2, 2, &[1.0, 0.2, 0.0, 1.0]);
    let problem = QpccProblem::new(
        w_e,
        DMatrix::zeros(0, 2),
        vec![-0.5, -0.3],
        vec![],
        vec![0.0; 2],
        2,
    );
    let sol = problem.solve(&params()).unwrap();
    assert_eq!(sol.status, QpccStatus::Solved);
    assert!(sol.residual_objective < 1e-12, "{}", sol.residual_objective);
}

/// B&B and the oracle on the random instances of `seeds`; returns (indefinite Q count at
/// ε = 1, worst relative difference, B&B nodes, oracle QPs).
fn compare_with_oracle(seeds: std::ops::Range<u64>) -> (usize, f64, usize, usize) {
    let p = params();
    let (mut indefinite, mut worst, mut nodes, mut oracle_qps) = (0, 0.0f64, 0, 0);
    for seed in seeds {
        let problem = random_instance(seed);
        let conv = problem.converted(1.0);
        if matches!(conv.convexity(1e-12), Convexity::Indefinite { .. }) {
            indefinite += 1;
        }
        let bb = problem.solve(&p).unwrap();
        let oracle = problem.solve_exhaustive(&p).unwrap();
        assert_eq!(bb.status, oracle.status, "seed {seed}");
        nodes += bb.nodes;
        oracle_qps += oracle.nodes;
        if oracle.status != QpccStatus::Solved {
            continue;
        }
        // B&B's point is QPCC-feasible on its own terms. The gaps' scale is the free
        // gaps': with every contact closed, δ_c itself is ~0 and no scale at all.
        let gaps = max_abs(&bb.delta_c).max(max_abs(&problem.delta_c_free));
        let scale_c = max_abs(&bb.lambda) * gaps;
        assert!(
            bb.complementarity <= 1e-8 * scale_c.max(1e-12),
            "seed {seed}: complementarity {:e}, scale {scale_c:e}, max δ_c {:e}",
            bb.complementarity,
            max_abs(&bb.delta_c)
        );
        assert!(bb.delta_c.iter().all(|&d| d >= -1e-8), "seed {seed}");
        let floor = 1e-10 * problem.offset().max(1e-12);
        let diff = bb.residual_objective - oracle.residual_objective;
        assert!(diff >= -floor, "seed {seed}: B&B beat the oracle by {diff}");
        assert!(
            diff <= 1e-8 * oracle.residual_objective + floor,
            "seed {seed}: B&B {} vs oracle {}",
            bb.residual_objective,
            oracle.residual_objective
        );
        worst = worst.max(diff.abs() / oracle.residual_objective.max(floor));
        let thesis_gap = (bb.objective - (bb.residual_objective - problem.offset())).abs();
        assert!(thesis_gap <= 1e-12 * problem.offset().max(1.0));
    }
    (indefinite, worst, nodes, oracle_qps)
}

#[test]
fn branch_and_bound_never_beats_the_exhaustive_oracle() {
    let (indefinite, worst, nodes, qps) = compare_with_oracle(0..25);
    eprintln!(
        "B&B vs oracle, 25 instances: {indefinite} with indefinite Q (ε = 1), worst relative \
         difference {worst:.2e}, {nodes} B&B nodes vs {qps} oracle QPs"
    );
    assert!(indefinite > 0, "the instances should include indefinite Q");
}

#[test]
fn the_oracle_refuses_more_than_eight_contacts() {
    let n = 9;
    let p = QpccProblem::new(
        DMatrix::zeros(1, n + 1),
        DMatrix::identity(n, n + 1),
        vec![0.0],
        vec![0.0; n],
        vec![0.0],
        1,
    );
    let err = p.solve_exhaustive(&params()).unwrap_err();
    assert!(matches!(
        err,
        InverseError::OracleContacts {
            contacts: 9,
            max: 8
        }
    ));
}

#[test]
fn the_converted_matrices_are_the_thesis_objective_plus_epsilon_times_complementarity() {
    let problem = random_instance(7);
    let conv = problem.converted(0.5);
    assert_eq!(conv.q_2, conv.q_2.transpose());
    let lambda: Vec<f64> = (0..problem.n())
        .map(|j| uniform(7, 11, j as u64, 0))
        .collect();
    let delta_c = problem.contacts(&lambda);
    let lcc: f64 = (0..problem.n_c())
        .map(|i| lambda[problem.n_a + i] * delta_c[i])
        .sum();
    let want = problem.thesis_objective(&lambda) + 0.5 * lcc;
    assert!((conv.objective(&lambda) - want).abs() < 1e-10 * want.abs().max(1.0));
}

#[test]
fn bm1_reachable_targets_give_the_thesis_optimum_for_every_epsilon() {
    let p = params();
    for epsilon in [1e-3, 1.0, 1e3] {
        let (mut convex, mut indefinite, mut worst_value, mut worst_comp) = (0, 0, 0.0f64, 0.0f64);
        for seed in 0..20u64 {
            let problem = reachable_instance(seed);
            let target = -problem.offset();
            let conv = problem.converted(epsilon);
            let solved = problem
                .solve_converted(&ConvertedParams {
                    epsilon,
                    qp: p.qp.clone(),
                    ..Default::default()
                })
                .unwrap();
            let (lambda, value) = match solved.status {
                ConvertedStatus::Solved => {
                    convex += 1;
                    assert!(solved.reachable, "seed {seed} ε {epsilon}");
                    (solved.lambda.clone(), solved.objective)
                }
                ConvertedStatus::Indefinite { .. } => {
                    indefinite += 1;
                    let bb = problem.solve(&p).unwrap();
                    assert_eq!(bb.status, QpccStatus::Solved, "seed {seed}");
                    assert!(bb.reachable, "seed {seed}");
                    let cert = problem.certify_converted(&conv, &bb.lambda, 1e-8);
                    assert!(cert.certified, "seed {seed} ε {epsilon}: {cert:?}");
                    (bb.lambda, cert.value)
                }
                ConvertedStatus::QpFailed(s) => panic!("seed {seed} ε {epsilon}: {s:?}"),
            };
            let rel = (value - target).abs() / target.abs();
            worst_value = worst_value.max(rel);
            assert!(rel <= 1e-8, "seed {seed} ε {epsilon}: {value} vs {target}");
            let delta_c = problem.contacts(&lambda);
            let comp = (0..problem.n_c())
                .map(|i| (lambda[problem.n_a + i] * delta_c[i]).abs())
                .fold(0.0, f64::max);
            let scale = max_abs(&lambda) * max_abs(&delta_c).max(max_abs(&problem.delta_c_free));
            worst_comp = worst_comp.max(comp / scale);
            assert!(comp <= 1e-8 * scale, "seed {seed} ε {epsilon}: {comp}");
        }
        eprintln!(
            "BM-1 ε = {epsilon:e}: {convex} convex (Clarabel), {indefinite} indefinite (B&B + \
             5.27 bound); worst relative value error {worst_value:.2e}, worst relative \
             complementarity {worst_comp:.2e}"
        );
    }
}

/// An unreachable instance whose converted QP is convex: W_ca = 0, three effectors for one
/// actuator, contacts open (δ_c^free > 0) so that contact forces can act as extra actuators.
fn unreachable_instance(seed: u64) -> QpccProblem {
    let d = Dims {
        e: 3,
        a: 1,
        c: 2 + (uniform(seed, 12, 0, 0) * 3.0) as usize,
    };
    let (w_e, w_c) = blocks(&compliance(seed, d, true), d);
    let free: Vec<f64> = (0..d.c)
        .map(|i| 0.05 + 0.5 * uniform(seed, 13, i as u64, 0))
        .collect();
    let delta_d = (0..d.e)
        .map(|i| 3.0 * normal(seed, 14, i as u64, 0))
        .collect();
    QpccProblem::new(w_e, w_c, vec![0.0; d.e], free, delta_d, d.a)
}

#[test]
fn an_unreachable_target_is_reported_when_the_converted_qp_disagrees_with_the_qpcc() {
    let p = params();
    let mut disagreements = 0;
    for seed in 0..12u64 {
        let problem = unreachable_instance(seed);
        let qpcc = problem.solve(&p).unwrap();
        assert_eq!(qpcc.status, QpccStatus::Solved);
        assert!(!qpcc.reachable, "seed {seed}: residual {}", qpcc.residual);
        let conv = problem
            .solve_converted(&ConvertedParams {
                epsilon: 1e-3,
                qp: p.qp.clone(),
                ..Default::default()
            })
            .unwrap();
        assert_eq!(
            conv.status,
            ConvertedStatus::Solved,
            "W_ca = 0 keeps Q convex"
        );
        let scale = max_abs(&conv.lambda) * max_abs(&problem.contacts(&conv.lambda));
        let broken = conv.complementarity > 1e-6 * scale;
        let other = (problem.residual_objective(&conv.lambda) - qpcc.residual_objective).abs()
            > 1e-6 * problem.offset();
        if broken || other {
            disagreements += 1;
            assert!(
                !conv.reachable,
                "seed {seed}: a disagreement must be reported"
            );
        }
    }
    eprintln!("unreachable, ε = 1e-3: {disagreements} of 12 converted QPs disagree with the QPCC");
    assert!(
        disagreements > 0,
        "small ε should break complementarity somewhere"
    );
}

#[test]
fn an_indefinite_converted_qp_is_reported_not_solved() {
    let problem = (0..50)
        .map(reachable_instance)
        .find(|p| {
            matches!(
                p.converted(1.0).convexity(1e-12),
                Convexity::Indefinite { .. }
            )
        })
        .expect("some reachable instance has an indefinite Q");
    let conv = problem
        .solve_converted(&ConvertedParams::default())
        .unwrap();
    assert!(
        matches!(conv.status, ConvertedStatus::Indefinite { min_eigenvalue } if min_eigenvalue < 0.0)
    );
    assert!(conv.lambda.is_empty());
}

//! The least squares' identifiability and covariance ([`softsense::inverse::lsq`]) against
//! brute-force oracles: explicit inverses and a Gram matrix built by hand.
use nalgebra::DMatrix;
use softsense::inverse::lsq;

/// A well-conditioned 5 x 3 W_ef.
fn w_ef() -> DMatrix<f64> {
    DMatrix::from_row_slice(
        5,
        3,
        &[
            2.0, 0.1, 0.0, 0.3, 1.5, 0.2, 0.0, 0.4, 1.0, 0.5, 0.0, 0.3, 0.1, 0.2, 0.6,
        ],
    )
}

#[test]
fn covariance_with_identity_rows_is_sigma_squared_times_the_explicit_inverse_of_the_gram() {
    let w = w_ef();
    let s2 = 0.25;
    let cov = lsq::covariance_with(&w, |a| Some(a * a.transpose() * s2)).unwrap();
    // The oracle: (WᵀW)⁻¹ by cofactors of the 3 x 3 Gram matrix.
    let g = w.transpose() * &w;
    let det = g.determinant();
    let cof = |i: usize, j: usize| {
        let r: Vec<usize> = (0..3).filter(|&r| r != j).collect();
        let c: Vec<usize> = (0..3).filter(|&c| c != i).collect();
        let s = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
        s * (g[(r[0], c[0])] * g[(r[1], c[1])] - g[(r[0], c[1])] * g[(r[1], c[0])])
    };
    for i in 0..3 {
        for j in 0..3 {
            let want = s2 * cof(i, j) / det;
            assert!(
                (cov[(i, j)] - want).abs() < 1e-12 * want.abs().max(1.0),
                "{i},{j}"
            );
        }
    }
    let sigma = lsq::gauss_markov_sigma(&w, s2.sqrt());
    for (k, s) in sigma.iter().enumerate() {
        assert!((s * s - cov[(k, k)]).abs() < 1e-12);
    }
}

#[test]
fn i_w_is_one_over_the_smallest_singular_value_by_either_route() {
    let w = w_ef();
    let smin = w.clone().singular_values().min();
    assert!((lsq::i_w(&w) - 1.0 / smin).abs() < 1e-12 / smin);
    let (i_w, _) = lsq::gram_i_w(&(w.transpose() * &w));
    assert!((i_w - 1.0 / smin).abs() < 1e-9 / smin);
    let ident = lsq::identifiability(&w, 3, 1e6);
    assert_eq!((ident.rows, ident.unknowns), (5, 3));
    assert!(ident.warning.is_none());
}

#[test]
fn a_rank_deficient_w_ef_is_reported_unidentifiable_with_no_covariance() {
    // The third column is the sum of the first two.
    let mut w = w_ef();
    for r in 0..5 {
        w[(r, 2)] = w[(r, 0)] + w[(r, 1)];
    }
    assert_eq!(lsq::i_w(&w), f64::INFINITY);
    assert_eq!(lsq::gram_i_w(&(w.transpose() * &w)).0, f64::INFINITY);
    let ident = lsq::identifiability(&w, 3, 1e6);
    assert!(ident.warning.unwrap().contains("poorly conditioned"));
    assert!(lsq::covariance_with(&w, |a| Some(a * a.transpose())).is_none());
    assert!(lsq::gauss_markov_sigma(&w, 1.0)
        .iter()
        .all(|s| s.is_infinite()));
}

#[test]
fn fewer_rows_than_unknowns_is_unidentifiable_by_corollary_1() {
    let w = w_ef().rows(0, 2).clone_owned();
    assert_eq!(lsq::i_w(&w), f64::INFINITY);
    let ident = lsq::identifiability(&w, 3, 1e6);
    assert!(ident.warning.unwrap().contains("not identifiable"));
}

#[test]
fn the_rank_tolerance_is_one_in_a_million_on_singular_values() {
    // σ ratio 1e-7 is below the tolerance, 1e-5 above, by both routes.
    for (ratio, finite) in [(1e-7, false), (1e-5, true)] {
        let w = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, ratio, 0.0, 0.0]);
        assert_eq!(lsq::i_w(&w).is_finite(), finite, "{ratio}");
        assert_eq!(lsq::gram_i_w(&(w.transpose() * &w)).0.is_finite(), finite);
    }
    assert_eq!(lsq::RANK_RTOL * lsq::RANK_RTOL, 1e-12);
}

//! Marker layouts: greedy and exchange never raise I_w, Spearman's rank correlation,
//! Corollary 1's refusal.
use crate::common::markers::{grid, model, sensor, sheet_markers};
use nalgebra::DMatrix;
use softsense::markers::layout::{
    exchange, greedy, layout_i_w, propose_layout, spearman, LayoutParams,
};
use softsense::markers::{Directions, MarkersError};
use softsense::math::rand::normal;

/// 40 seeded random 3 × 6 rows as blocks WᵀW.
fn random_blocks() -> Vec<DMatrix<f64>> {
    (0..40u64)
        .map(|i| {
            let w = DMatrix::from_fn(3, 6, |r, c| normal(11, i, r as u64, c as u64));
            w.tr_mul(&w)
        })
        .collect()
}

#[test]
fn greedy_never_raises_i_w_as_markers_are_added() {
    let blocks = random_blocks();
    let (chosen, trace) = greedy(&blocks, 12);
    assert_eq!(chosen.len(), 12);
    // Two markers give 6 rows for 6 unknowns: from then on I_w is finite.
    assert!(trace[0].is_infinite() && trace[1].is_finite(), "{trace:?}");
    assert!(trace.windows(2).all(|w| w[1] <= w[0]), "{trace:?}");
    let last = *trace.last().unwrap();
    assert!((last - layout_i_w(&blocks, &chosen)).abs() <= 1e-12 * last);
}

#[test]
fn exchange_never_raises_i_w() {
    let blocks = random_blocks();
    let start: Vec<usize> = (0..4).collect();
    let before = layout_i_w(&blocks, &start);
    let (chosen, trace) = exchange(&blocks, start, 5);
    assert!(
        !trace.is_empty(),
        "the first four of 40 random blocks are not the best"
    );
    assert!(
        trace[0] < before && trace.windows(2).all(|w| w[1] < w[0]),
        "{trace:?}"
    );
    let last = *trace.last().unwrap();
    assert!((last - layout_i_w(&blocks, &chosen)).abs() <= 1e-12 * last);
    // Exchanges after the greedy phase only improve on it too.
    let (g, gt) = greedy(&blocks, 4);
    let (_, et) = exchange(&blocks, g, 5);
    assert!(et.iter().all(|&v| v < *gt.last().unwrap()));
}

#[test]
fn spearman_matches_a_hand_example_with_ties() {
    // Ranks of a: 1, 2.5, 2.5, 4, 5; of b: 2, 1, 3, 5, 4. Pearson of the ranks is 7/sqrt(9.5 * 10).
    let a = [1.0, 2.0, 2.0, 3.0, 7.0];
    let b = [20.0, 10.0, 30.0, 50.0, 40.0];
    let want = 7.0 / (9.5f64 * 10.0).sqrt();
    assert!(
        (spearman(&a, &b) - want).abs() < 1e-12,
        "{}",
        spearman(&a, &b)
    );
    assert_eq!(spearman(&[1.0, 2.0, 3.0], &[3.0, 9.0, 27.0]), 1.0);
    assert_eq!(spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]), -1.0);
}

#[test]
fn fewer_rows_than_unknowns_is_refused_by_corollary_1() {
    let m = model("sheet.toml");
    let cands = grid(&[-60.0, -20.0, 20.0, 60.0], &[-40.0, 0.0, 40.0], 4.0);
    let s = sensor(&m, &sheet_markers()[..1], &cands, Directions::Normal);
    let params = LayoutParams {
        markers: 3,
        ..Default::default()
    };
    match propose_layout(&s.problem, &s.newton, &s.locations, None, &params) {
        Err(e @ MarkersError::TooFewMarkers { .. }) => {
            let msg = e.to_string();
            assert!(
                msg.contains("Corollary 1") && msg.contains("at least 4 markers"),
                "{msg}"
            )
        }
        other => panic!("{other:?}"),
    }
}

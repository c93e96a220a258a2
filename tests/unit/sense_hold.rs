//! Fusion over held frames (`sense::Hold`) on reports made by hand: the fused force is the
//! inverse-covariance mean, its σ shrinks as 1/√n down to what every frame shares, and a
//! change beyond the noise, a moved force or a bad frame starts over once the next frame
//! does not return to the hold.

use softsense::sense::{ForceEstimate, FrameReport, FrameStatus, Hold, HoldParams};

/// A sensed, reliable report of one force `force` (N) at `at` with covariance σ² I.
fn report(frame: usize, force: [f64; 3], sigma: f64, at: [f64; 3]) -> FrameReport {
    let mut r = FrameReport::empty(frame, FrameStatus::Sensed);
    r.reliable = true;
    let s2 = sigma * sigma;
    r.forces.push(ForceEstimate {
        source: "contact".into(),
        seen_at: None,
        contact_points: 0,
        location: at,
        node: None,
        force,
        magnitude: softsense::math::norm(force),
        sigma,
        sigma_max: sigma,
        covariance: [[s2, 0.0, 0.0], [0.0, s2, 0.0], [0.0, 0.0, s2]],
        location_sigma: None,
        alternatives: Vec::new(),
    });
    r
}

/// Ten frames of 0.5 N along y with alternating ±`wiggle` on y, σ 2 mN each.
fn held_ten(hold: &mut Hold, wiggle: f64) -> Vec<FrameReport> {
    (0..10)
        .map(|k| {
            let y = 0.5 + if k % 2 == 0 { wiggle } else { -wiggle };
            let mut r = report(k, [0.0, y, 0.0], 0.002, [0.05, 0.0, 0.1]);
            hold.push(&mut r);
            r
        })
        .collect()
}

#[test]
fn ten_frames_of_one_held_load_fuse_to_their_mean_with_a_sigma_of_one_over_root_ten() {
    let mut hold = Hold::new(HoldParams::default(), 0, 0.0);
    let reports = held_ten(&mut hold, 0.001);
    let h = &reports[9].held[0];
    assert_eq!((h.since, h.frames), (0, 10));
    assert!((h.force[1] - 0.5).abs() < 1e-12, "{:?}", h.force);
    let expected = 0.002 / 10f64.sqrt();
    assert!(
        (h.sigma / expected - 1.0).abs() < 1e-9,
        "{} vs {expected}",
        h.sigma
    );
}

#[test]
fn a_reference_and_the_modulus_keep_what_every_frame_shares_under_the_fused_sigma() {
    // Each frame's σ² is 1.5 σ0² (a reference of 2 frames) + (0.02 F)².
    let (sigma0, eps, f) = (0.002f64, 0.02f64, 0.5f64);
    let sigma = (1.5 * sigma0 * sigma0 + (eps * f).powi(2)).sqrt();
    let mut hold = Hold::new(HoldParams::default(), 2, eps);
    let mut last = None;
    for k in 0..10 {
        // Only y carries the modulus term; x and z are σ0·√1.5.
        let mut r = report(k, [0.0, f, 0.0], sigma0 * 1.5f64.sqrt(), [0.05, 0.0, 0.1]);
        r.forces[0].covariance[1][1] = sigma * sigma;
        hold.push(&mut r);
        last = Some(r);
    }
    let h = &last.unwrap().held[0];
    let expected = (sigma0 * sigma0 / 10.0 + 0.5 * sigma0 * sigma0 + (eps * f).powi(2)).sqrt();
    assert!(
        (h.sigma / expected - 1.0).abs() < 1e-6,
        "{} vs {expected}",
        h.sigma
    );
    assert!(h.sigma > eps * f);
}

#[test]
fn a_load_that_changes_beyond_its_noise_starts_a_new_hold() {
    let mut hold = Hold::new(HoldParams::default(), 0, 0.0);
    held_ten(&mut hold, 0.0);
    let mut r = report(10, [0.0, 0.52, 0.0], 0.002, [0.05, 0.0, 0.1]);
    hold.push(&mut r);
    assert_eq!((r.held[0].since, r.held[0].frames), (10, 1));
    // A second frame at the new load confirms the change: the new hold goes on.
    let mut r = report(11, [0.0, 0.52, 0.0], 0.002, [0.05, 0.0, 0.1]);
    hold.push(&mut r);
    assert_eq!((r.held[0].since, r.held[0].frames), (10, 2));
    assert!((r.held[0].force[1] - 0.52).abs() < 1e-12);
}

#[test]
fn one_frame_that_disagrees_does_not_end_a_hold_that_the_next_frame_agrees_with() {
    let mut hold = Hold::new(HoldParams::default(), 0, 0.0);
    held_ten(&mut hold, 0.0);
    let mut odd = report(10, [0.0, 0.52, 0.0], 0.002, [0.05, 0.0, 0.1]);
    hold.push(&mut odd);
    assert_eq!((odd.held[0].since, odd.held[0].frames), (10, 1));
    let mut back = report(11, [0.0, 0.5, 0.0], 0.002, [0.05, 0.0, 0.1]);
    hold.push(&mut back);
    // The odd frame is left out: eleven frames at 0.5 N fused.
    assert_eq!((back.held[0].since, back.held[0].frames), (0, 11));
    assert!((back.held[0].force[1] - 0.5).abs() < 1e-12);
    // Likewise one unreliable frame.
    let mut bad = report(12, [0.0, 0.5, 0.0], 0.002, [0.05, 0.0, 0.1]);
    bad.reliable = false;
    hold.push(&mut bad);
    assert!(bad.held.is_empty());
    let mut next = report(13, [0.0, 0.5, 0.0], 0.002, [0.05, 0.0, 0.1]);
    hold.push(&mut next);
    assert_eq!((next.held[0].since, next.held[0].frames), (0, 12));
}

#[test]
fn a_force_that_moved_or_a_frame_that_is_unreliable_ends_the_hold() {
    let mut hold = Hold::new(HoldParams::default(), 0, 0.0);
    held_ten(&mut hold, 0.0);
    let mut moved = report(10, [0.0, 0.5, 0.0], 0.002, [0.05, 0.01, 0.1]);
    hold.push(&mut moved);
    assert_eq!(moved.held[0].frames, 1);
    let mut bad = report(11, [0.0, 0.5, 0.0], 0.002, [0.05, 0.01, 0.1]);
    bad.reliable = false;
    hold.push(&mut bad);
    assert!(bad.held.is_empty());
    // Two frames in a row that do not continue the first hold end it: the moved force
    // and the unreliable frame. The next frame at the moved place joins the moved one.
    let mut next = report(12, [0.0, 0.5, 0.0], 0.002, [0.05, 0.01, 0.1]);
    hold.push(&mut next);
    assert_eq!((next.held[0].since, next.held[0].frames), (10, 2));
    // Two unusable frames in a row end every hold.
    for k in [13, 14] {
        let mut bad = report(k, [0.0, 0.5, 0.0], 0.002, [0.05, 0.01, 0.1]);
        bad.reliable = false;
        hold.push(&mut bad);
    }
    let mut after = report(15, [0.0, 0.5, 0.0], 0.002, [0.05, 0.01, 0.1]);
    hold.push(&mut after);
    assert_eq!((after.held[0].since, after.held[0].frames), (15, 1));
}

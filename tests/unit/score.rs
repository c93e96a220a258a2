//! `sense::score`: the located / within-5% / silent-miss rules and the sigma statistics on
//! hand-made sense lines whose answers are known.

use softsense::sense::score::{score, score_frame, SensedFrame};
use softsense::sense::FrameStatus;

/// A sense line with one true load of `truth` N along x and one estimate `est` N along x
/// with isotropic covariance sigma², `located_mm` from the truth.
fn line(truth: f64, est: f64, sigma: f64, located_mm: f64, reliable: bool) -> SensedFrame {
    let err = (est - truth).abs() / truth;
    serde_json::from_value(serde_json::json!({
        "frame": 0,
        "status": "sensed",
        "forces": [{
            "force": [est, 0.0, 0.0],
            "sigma": sigma,
            "covariance": [[sigma * sigma, 0.0, 0.0], [0.0, sigma * sigma, 0.0], [0.0, 0.0, sigma * sigma]],
        }],
        "reliable": reliable,
        "warnings": [],
        "errors": [{
            "truth_force": [truth, 0.0, 0.0],
            "estimate": 0,
            "location_error": located_mm * 1e-3,
            "force_error": err,
        }],
        "ms": 100.0,
    }))
    .unwrap()
}

#[test]
fn a_load_within_5_percent_and_5_mm_is_located_and_within_and_not_silent() {
    let (loads, phantoms) = score_frame("r", &line(0.5, 0.51, 0.01, 1.0, true));
    let l = &loads[0];
    assert!(l.located && l.within && !l.silent && !l.flagged);
    assert!(phantoms.is_empty());
    // One sigma off along x, isotropic covariance: squared Mahalanobis distance 1.
    assert!((l.mahalanobis2.unwrap() - 1.0).abs() < 1e-9);
    assert!((l.magnitude_z.unwrap() - 1.0).abs() < 1e-9);
}

#[test]
fn a_reliable_unwarned_load_8_percent_off_with_a_small_sigma_is_a_silent_miss() {
    let (loads, _) = score_frame("r", &line(0.5, 0.54, 0.005, 1.0, true));
    assert!(loads[0].located && !loads[0].within && loads[0].silent);
}

#[test]
fn a_load_8_percent_off_within_2_sigma_is_a_miss_but_not_silent() {
    // 40 mN off with sigma 25 mN: the uncertainty said so.
    let (loads, _) = score_frame("r", &line(0.5, 0.54, 0.025, 1.0, true));
    assert!(!loads[0].within && !loads[0].silent);
}

#[test]
fn a_miss_in_a_frame_marked_unreliable_is_flagged_not_silent() {
    let (loads, _) = score_frame("r", &line(0.5, 0.8, 0.001, 12.0, false));
    assert!(!loads[0].located && loads[0].flagged && !loads[0].silent);
}

#[test]
fn a_load_located_6_mm_off_in_a_reliable_frame_is_a_silent_miss() {
    let (loads, _) = score_frame("r", &line(0.5, 0.5, 0.01, 6.0, true));
    assert!(!loads[0].located && loads[0].silent);
}

#[test]
fn an_estimate_matched_to_no_load_is_a_phantom_and_silent_when_unflagged() {
    let mut f = line(0.5, 0.5, 0.01, 1.0, true);
    f.forces.push(f.forces[0].clone());
    let s = score(&[("r".into(), vec![f])]);
    assert_eq!(s.phantoms.len(), 1);
    assert_eq!(s.all.silent, 1);
    assert_eq!((s.all.loads, s.all.located, s.all.within), (1, 1, 1));
}

#[test]
fn coverage_counts_each_sigma_band_over_located_loads() {
    // Magnitude errors of 0.5, 1.5 and 2.5 sigma: within 1/2/3 sigma 1/3, 2/3, 3/3.
    let frames: Vec<SensedFrame> = [0.5, 1.5, 2.5]
        .iter()
        .map(|k| line(0.5, 0.5 + k * 0.01, 0.01, 1.0, false))
        .collect();
    let s = score(&[("r".into(), frames)]);
    let c = s.all.sigma_coverage;
    assert!((c[0] - 1.0 / 3.0).abs() < 1e-12 && (c[1] - 2.0 / 3.0).abs() < 1e-12);
    assert!((c[2] - 1.0).abs() < 1e-12);
    assert!((s.all.median_mahalanobis2 - 2.25).abs() < 1e-9);
    assert_eq!(s.all.median_ms, 100.0);
}

#[test]
fn a_frame_not_sensed_is_flagged_and_not_counted_sensed_whatever_its_detail() {
    let not_solved: SensedFrame = serde_json::from_value(serde_json::json!({
        "frame": 0, "status": "not_solved", "detail": "the QP failed", "errors": [],
    }))
    .unwrap();
    assert_eq!(
        not_solved.status,
        FrameStatus::NotSolved("the QP failed".into())
    );
    let crowded: SensedFrame = serde_json::from_value(serde_json::json!({
        "frame": 1, "status": "too_many_contacts", "detail": {"seen": 9, "max": 6}, "errors": [],
    }))
    .unwrap();
    assert_eq!(
        crowded.status,
        FrameStatus::TooManyContacts { seen: 9, max: 6 }
    );
    let sensed = line(0.5, 0.5, 0.01, 1.0, true);
    assert!(not_solved.flagged() && crowded.flagged() && !sensed.flagged());
    let s = score(&[("r".into(), vec![not_solved, crowded, sensed])]);
    assert_eq!(
        (s.all.frames, s.all.sensed, s.all.flagged_frames),
        (3, 1, 2)
    );
}

#[test]
fn a_frame_of_a_rig_counts_the_cameras_it_was_seen_by() {
    let f: SensedFrame = serde_json::from_value(serde_json::json!({
        "frame": 0, "status": "sensed",
        "cameras": [
            {"name": "front", "status": "seen", "robot_points": 10, "object_points": 0},
            {"name": "side", "status": "unreadable", "message": "no such file"},
            {"name": "top", "status": "missing"},
        ],
    }))
    .unwrap();
    assert_eq!(f.cameras_seen(), 1);
    assert_eq!(line(0.5, 0.5, 0.01, 1.0, true).cameras_seen(), 1);
}

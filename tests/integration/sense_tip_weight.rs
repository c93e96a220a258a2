//! `sense` end to end on the generated tip-weight scene (sensor noise on, thesis Table 4.6
//! weights 0.26-1.06 N along gravity, constant cable inputs): depth + colour frames -> robot
//! points by colour -> features on flat camera-facing patches -> registration -> intensity QP
//! with FE updates. No contact is visible (the string is thin), so the location is the
//! model's force point that explains the frame best.
use softsense::fem::model::Model;
use softsense::sense::{compare, FrameStatus, Recording, SenseParams, Sensor};
use std::path::Path;

/// (magnitude error, location error in m) per loaded frame.
fn run(hide_fraction: f64) -> Vec<(f64, f64)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rec = Recording::open(&root.join("clouds/scenes/tip_weight")).unwrap();
    let model = Model::load(&rec.model_path().unwrap(), None).unwrap();
    let mut sensor = Sensor::new(model, rec.robot_from_camera, SenseParams::default());
    assert_eq!(
        sensor.features.len(),
        51,
        "visible flat patches on the robot"
    );
    if hide_fraction > 0.0 {
        // Drop every k-th feature, as if cropped away.
        let n = sensor.features.len();
        let keep = ((1.0 - hide_fraction) * n as f64).round() as usize;
        sensor.features = (0..keep).map(|i| sensor.features[i * n / keep]).collect();
    }
    let mut out = Vec::new();
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.actuators_of(frame));
        assert_eq!(report.status, FrameStatus::Sensed, "frame {frame}");
        let truth = rec.truth_of(frame).unwrap();
        for e in compare(&report, truth) {
            eprintln!(
                "frame {frame}: |F| truth {:.3} N, magnitude error {:.2}%, location error {:.1} mm, visible {}/{}, updates {}",
                softsense::math::Vec3::from(e.truth_force).norm(),
                100.0 * e.magnitude_error,
                1e3 * e.location_error,
                report.features_visible,
                report.features,
                report.updates
            );
            out.push((e.magnitude_error, e.location_error));
        }
    }
    assert_eq!(out.len(), 3, "three loaded frames");
    out
}

#[test]
fn tip_weight_intensity_is_within_two_percent_and_located_within_five_mm() {
    let errors = run(0.0);
    let mean = errors.iter().map(|e| e.0).sum::<f64>() / errors.len() as f64;
    eprintln!("mean magnitude error {:.2}%", 100.0 * mean);
    assert!(mean <= 0.02, "mean relative error {:.2}%", 100.0 * mean);
    assert!(errors.iter().all(|e| e.1 <= 0.005), "{errors:?}");
}

#[test]
fn tip_weight_with_thirty_percent_features_hidden_is_within_five_percent() {
    let errors = run(0.3);
    assert!(
        errors.iter().all(|e| e.0 <= 0.05 && e.1 <= 0.005),
        "{errors:?}"
    );
}

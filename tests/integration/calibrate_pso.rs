//! Simultaneous (PSO, thesis 3.3.1) and sequential (Algorithm 3.1 with Kabsch) calibration
//! on the bundled robot from nine markers: truth pose and tensions, a direct FE solve, the
//! markers seen with 0.1 mm noise, both methods from the same start 10° and 30 mm off with
//! the tensions 20-30% off. Issue 37's target: pose within 1 mm and 0.2°, tensions within
//! 2% (each cable, relative to its truth). Noise-free, both methods meet it. With 0.1 mm
//! noise no method can: nine markers bound the tensions only to about ±0.07 N (one σ,
//! σ²(JᵀJ)⁻¹ over pose and tensions; docs/calibration-pso.md).

use softsense::calibrate::{
    calibrate_pso, calibrate_sequential, observe_features, read_pose, surface_features,
    CalibrateParams, FeatureCalibration, FeatureStatus, PsoParams, ROBOT_MARKERS,
};
use softsense::fem::model::Model;
use softsense::math::{Iso3, Vec3};
use std::path::Path;

/// Bounds on what the noisy case reaches, both methods at the same least-squares optimum
/// (2.2 mm, 0.27°, 19.7%): translation (m), rotation (deg), tension (relative).
const MEASURED: (f64, f64, f64) = (3e-3, 0.4, 0.25);

const TRUTH_TENSIONS: [f64; 4] = [0.6, 0.35, 0.5, 0.25];

struct Case {
    model: Model,
    features: Vec<softsense::fem::solve::MappedPoint>,
    camera: Vec<[f64; 3]>,
    truth: Iso3,
    start: Iso3,
    start_tensions: Vec<f64>,
}

fn case(sigma: f64) -> Case {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let features = surface_features(&model.problem.mesh, &ROBOT_MARKERS, 0.01).unwrap();
    let truth = read_pose(&root.join("clouds/scenes/calib/camera_pose.json")).unwrap();
    let camera = observe_features(&model, &features, &truth, &TRUTH_TENSIONS, sigma, 7).unwrap();
    let turn = Iso3::new(
        Vec3::new(-2.0, 1.0, 2.0) / 3.0 * 0.03,
        Vec3::new(1.0, 2.0, -1.0).normalize() * 10f64.to_radians(),
    );
    let start_tensions = [1.3, 0.75, 1.2, 0.8]
        .iter()
        .zip(TRUTH_TENSIONS)
        .map(|(f, t)| f * t)
        .collect();
    Case {
        model,
        features,
        camera,
        truth,
        start: turn * truth,
        start_tensions,
    }
}

/// Translation error (m), rotation error (degrees), largest relative tension error.
fn errors(c: &Case, got: &FeatureCalibration) -> (f64, f64, f64) {
    let (dt, dr, dl) = got.errors(&c.truth, &TRUTH_TENSIONS);
    (dt, dr.to_degrees(), dl)
}

/// Both methods from the case's start: (name, errors, result).
fn both(c: &Case) -> Vec<(&'static str, (f64, f64, f64), FeatureCalibration)> {
    let pso = calibrate_pso(
        &c.model,
        &c.features,
        &c.camera,
        &c.start,
        &c.start_tensions,
        &PsoParams::default(),
    )
    .unwrap();
    let seq = calibrate_sequential(
        &c.model,
        &c.features,
        &c.camera,
        &c.start_tensions,
        &CalibrateParams::default(),
    )
    .unwrap();
    [("pso", pso), ("sequential", seq)]
        .into_iter()
        .map(|(name, got)| {
            let e = errors(c, &got);
            eprintln!("{name}: {e:?} (m, deg, rel) {got:?}");
            (name, e, got)
        })
        .collect()
}

#[test]
fn both_methods_recover_pose_and_tensions_from_noise_free_markers() {
    let c = case(0.0);
    for (name, (dt, dr, dl), got) in both(&c) {
        assert!(
            dt <= 1e-3 && dr <= 0.2 && dl <= 0.02,
            "{name}: {dt} m {dr} deg {dl}"
        );
        assert!(got.residual_rms < 1e-5, "{name}: {}", got.residual_rms);
    }
}

#[test]
fn both_methods_fit_noisy_markers_to_the_noise_with_the_pose_and_tensions_measured() {
    let c = case(1e-4);
    for (name, (dt, dr, dl), got) in both(&c) {
        // What they reach (docs/calibration-pso.md), with a margin.
        assert!(
            dt <= MEASURED.0 && dr <= MEASURED.1 && dl <= MEASURED.2,
            "{name}: {dt} m {dr} deg {dl}"
        );
        assert!(got.residual_rms < 2e-4, "{name}: {}", got.residual_rms);
        assert_eq!(got.status, FeatureStatus::Converged, "{name}");
    }
}

//! Calibration from perturbed starts on the noise-free scene `clouds/scenes/calib`
//! (issue 6 acceptance: camera pose within 1 mm and 0.2°, actuator inputs within 2%).
//! The truth (camera_pose.json, truth.json) is read only to build the starts and to check.

use softsense::calibrate::{pose_difference, read_pose};
use softsense::fem::model::Model;
use std::path::Path;

use crate::common::run_cli;

#[test]
fn calibrate_cli_writes_the_pose_and_inputs_from_the_committed_rough_start() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("clouds/scenes/calib");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("calibration.json");
    let o = run_cli(&[
        "calibrate",
        dir.to_str().unwrap(),
        root.join("meshes/models/robot.toml").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("touches the robot"), "{stderr}");
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(printed, written);
    assert_eq!(written["status"], "Converged");
    let m: [[f64; 4]; 4] = serde_json::from_value(written["robot_from_camera"].clone()).unwrap();
    let got = softsense::calibrate::pose_from_matrix(&m).unwrap();
    let truth = read_pose(&dir.join("camera_pose.json")).unwrap();
    let (dt, dr) = pose_difference(&got, &truth);
    assert!(dt <= 1e-3 && dr.to_degrees() <= 0.2, "{dt} m {dr} rad");
    assert_eq!(written["actuators"].as_array().unwrap().len(), 4);
    // The model it used, relative to the file's folder, for `sense` to find.
    let named = tmp.path().join(written["model"].as_str().unwrap());
    assert_eq!(
        std::fs::canonicalize(named).unwrap(),
        std::fs::canonicalize(root.join("meshes/models/robot.toml")).unwrap()
    );
}

#[test]
fn calibrate_cli_refuses_a_missing_start_or_model_with_a_clear_message() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("clouds/scenes/calib");
    let model = root.join("meshes/models/robot.toml");
    let o = run_cli(&[
        "calibrate",
        dir.to_str().unwrap(),
        model.to_str().unwrap(),
        "--start",
        "/nonexistent/pose.json",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/pose.json"));
    let o = run_cli(&[
        "calibrate",
        dir.to_str().unwrap(),
        "/nonexistent/model.toml",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/model.toml"));
}

#[test]
fn calibrated_inputs_of_another_model_are_refused_by_cable_name() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let pose = read_pose(&root.join("clouds/scenes/calib/camera_pose.json")).unwrap();
    let m = pose.to_homogeneous();
    let robot_from_camera = softsense::math::pose::Pose::from_matrix(
        &[0, 1, 2, 3].map(|r| [0, 1, 2, 3].map(|c| m[(r, c)])),
    )
    .unwrap();
    let mut sensor = softsense::sense::Sensor::new(model, robot_from_camera, Default::default());
    let cal = |name: &str, tension: f64| softsense::calibrate::ActuatorCalibration {
        name: name.into(),
        tension,
        shortening: 0.01,
    };
    use softsense::sense::SenseError;
    let e = sensor
        .use_calibrated_inputs(&[cal("north", 5.0), cal("tendon-7", 1.0)])
        .unwrap_err();
    assert!(
        matches!(&e, SenseError::UnknownCalibratedCable { cable, .. } if cable == "tendon-7"),
        "{e}"
    );
    let e = e.to_string();
    assert!(
        e.contains("\"tendon-7\"") && e.contains("north, west, south, east"),
        "{e}"
    );
    let e = sensor
        .use_calibrated_inputs(&[cal("east", f64::NAN)])
        .unwrap_err();
    assert!(
        matches!(&e, SenseError::NonFiniteCalibratedCable { cable, tension, .. } if cable == "east" && tension.is_nan()),
        "{e}"
    );
    let e = e.to_string();
    assert!(e.contains("\"east\"") && e.contains("not finite"), "{e}");
    // Refused inputs leave the model as it was; good ones take each cable's own control.
    assert_eq!(
        sensor.model_inputs(),
        softsense::sense::ModelInputs::ModelFile
    );
    sensor
        .use_calibrated_inputs(&[cal("north", 5.0), cal("east", 3.0)])
        .unwrap();
    let controls: Vec<_> = sensor
        .model
        .problem
        .cables
        .iter()
        .map(|c| c.control)
        .collect();
    use softsense::fem::solve::CableControl::{Displacement, Force};
    assert_eq!(
        controls,
        [Displacement(0.01), Force(0.0), Force(0.0), Force(3.0)]
    );
    assert_eq!(
        sensor.model_inputs(),
        softsense::sense::ModelInputs::Calibration
    );
}

//! `calibrate` on a folder of several cameras: every camera's pose from its own rough
//! start, written into its folder, and how well the cameras agree on the robot's surface.

use crate::common::{project_root, run_cli, two_camera_scene};
use softsense::calibrate::{pose_difference, pose_from_matrix, pose_to_matrix, read_pose};
use softsense::math::{Iso3, Vec3};
use softsense::scene::generate;

#[test]
fn calibrate_finds_each_cameras_pose_of_a_rig_and_says_how_well_they_agree() {
    // One untouched frame, noise-free like the calibration scene, at half resolution.
    let mut scene = two_camera_scene(2);
    scene.spec.frames.truncate(1);
    scene.spec.frames[0].loads.clear();
    scene.spec.sensor.enabled = false;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    generate(&scene, &out, |_, _| {}).unwrap();
    let off = Iso3::new(
        Vec3::new(0.008, -0.005, 0.006),
        Vec3::new(0.03, -0.02, 0.02),
    );
    for camera in ["front", "side"] {
        let truth = read_pose(&out.join(camera).join("camera_pose.json")).unwrap();
        let rough = serde_json::json!({ "robot_from_camera": pose_to_matrix(&(truth * off)) });
        std::fs::write(out.join(camera).join("rough_pose.json"), rough.to_string()).unwrap();
    }
    let model = project_root().join("meshes/models/robot.toml");
    let o = run_cli(&[
        "calibrate",
        out.to_str().unwrap(),
        model.to_str().unwrap(),
        "--json",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for camera in ["front", "side"] {
        let path = out.join(camera).join("calibration.json");
        let written: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(printed["cameras"][camera], written);
        let m: [[f64; 4]; 4] =
            serde_json::from_value(written["robot_from_camera"].clone()).unwrap();
        let truth = read_pose(&out.join(camera).join("camera_pose.json")).unwrap();
        let (dt, dr) = pose_difference(&pose_from_matrix(&m).unwrap(), &truth);
        assert!(
            dt <= 1.5e-3 && dr.to_degrees() <= 0.3,
            "{camera}: {dt} m {dr} rad"
        );
    }
    let pair = &printed["agreement"][0];
    assert_eq!(pair["cameras"], serde_json::json!(["front", "side"]));
    let g = &pair["agreement"];
    assert!(g["overlap_points"].as_u64().unwrap() > 100, "{g}");
    // Noise-free frames of one surface: the cameras agree to well under a millimetre.
    assert!(g["median"].as_f64().unwrap() < 0.5e-3, "{g}");
    // The calibrated rig senses as it is: its cameras' poses are read from their folders.
    let rig = softsense::recording::Rig::open(&out).unwrap();
    for c in &rig.cameras {
        assert!(c
            .recording
            .pose_file
            .as_ref()
            .unwrap()
            .ends_with("calibration.json"));
    }
}

#[test]
fn calibrate_on_a_rig_refuses_one_start_or_one_output_for_all_cameras() {
    let mut scene = two_camera_scene(8);
    scene.spec.frames.truncate(1);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    generate(&scene, &out, |_, _| {}).unwrap();
    let model = project_root().join("meshes/models/robot.toml");
    let (rig, model) = (out.to_str().unwrap(), model.to_str().unwrap());
    let o = run_cli(&["calibrate", rig, model, "--out", "x.json"]);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("front, side") && stderr.contains("NAME/rough_pose.json"),
        "{stderr}"
    );
    let o = run_cli(&["calibrate", rig, model]);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("front/rough_pose.json"), "{stderr}");
}

//! `sense` with several cameras: one estimate from all cameras' points, a camera without a
//! frame (or with an unreadable one) left out of that frame with its status, and the
//! errors a user meets.

use crate::common::two_camera_scene;
use softsense::fem::model::Model;
use softsense::recording::Rig;
use softsense::scene::generate;
use softsense::sense::{CameraState, SenseError, SenseParams, Sensor, SensorCamera};
use std::path::Path;

/// The bundled two-camera scene cut to frames 0 and 6 (0.35 and 0.50 N) at half the
/// resolution (the same field of view).
fn two_camera_recording(out: &Path) {
    let mut scene = two_camera_scene(2);
    let frames = &mut scene.spec.frames;
    *frames = vec![frames[0].clone(), frames[6].clone()];
    generate(&scene, out, |_, _| {}).unwrap();
}

fn rig_sensor(rig: &Rig) -> Sensor {
    let model = Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
    let cameras = (rig.cameras.iter())
        .map(|c| SensorCamera::new(&c.name, c.recording.robot_from_camera.unwrap()))
        .collect();
    Sensor::with_cameras(model, cameras, SenseParams::default())
}

#[test]
fn two_cameras_sense_one_probe_together_and_a_missing_frame_falls_back_to_the_other() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    // The side camera lost frame 1; the front camera's frame 0 is corrupt.
    for name in ["depth_0001.png", "color_0001.png"] {
        std::fs::remove_file(out.join("side").join(name)).unwrap();
    }
    std::fs::write(out.join("front/depth_0000.png"), b"not a png").unwrap();
    let rig = Rig::open(&out).unwrap();
    assert_eq!(rig.frames, [0, 1]);
    let sensor = rig_sensor(&rig);
    let mut reports = Vec::new();
    sensor
        .sense_frames(&rig, &rig.frames, 1, |_, r| {
            reports.push(r);
            Ok::<(), ()>(())
        })
        .unwrap();
    for r in &reports {
        let truth = rig.shared().truth_of(r.frame).unwrap();
        let e = softsense::sense::compare(r, truth);
        assert!(e[0].force_error < 0.05, "frame {}: {:?}", r.frame, e);
        assert_eq!(r.cameras.len(), 2, "{:?}", r.cameras);
        let left_out: Vec<&str> = (r.cameras.iter())
            .filter(|c| !c.is_seen())
            .map(|c| c.name.as_str())
            .collect();
        assert_eq!(left_out, [["front"], ["side"]][r.frame]);
        assert!(r
            .warnings
            .iter()
            .any(|w| w.contains("sensed from the other cameras")));
    }
    assert!(matches!(
        reports[0].cameras[0].state,
        CameraState::Unreadable { .. }
    ));
    assert_eq!(reports[1].cameras[1].state, CameraState::Missing);
    let seen = |r: &softsense::sense::FrameReport, k: usize| match r.cameras[k].state {
        CameraState::Seen { robot_points, .. } => robot_points,
        _ => 0,
    };
    assert_eq!(reports[0].robot_points, seen(&reports[0], 1));
    assert_eq!(reports[1].robot_points, seen(&reports[1], 0));
}

#[test]
fn both_cameras_together_pin_the_force_at_least_as_well_as_either_alone() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    let rig = Rig::open(&out).unwrap().select(&[1]).unwrap();
    let sigma_max = |rig: &Rig| {
        let sensor = rig_sensor(rig);
        let obs = sensor.observe(rig, 1).unwrap();
        let r = sensor.sense(1, &obs, rig.shared().inputs_of(1).as_ref());
        assert_eq!(r.forces.len(), 1, "{:?}", r.status);
        (r.forces[0].sigma_max, obs.views.len())
    };
    let (both, views) = sigma_max(&rig);
    assert_eq!(views, 2);
    for name in ["front", "side"] {
        let one = rig.clone().keep_cameras(&[name.to_string()]).unwrap();
        let (alone, views) = sigma_max(&one);
        assert_eq!(views, 1);
        // Twice the rows of independent noise: the fused 3-D sigma is not larger than one
        // camera's (a margin for the residual-based part of the covariance).
        assert!(both < 1.1 * alone, "{name}: {alone} N alone, {both} N both");
    }
}

#[test]
fn a_sensor_refuses_a_recording_of_other_cameras_and_a_frame_no_camera_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    let rig = Rig::open(&out).unwrap();
    let model = Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
    let pose = rig.cameras[0].recording.robot_from_camera.unwrap();
    let one = Sensor::new(model, pose, SenseParams::default());
    let err = one.observe(&rig, 0).unwrap_err();
    assert!(matches!(err, SenseError::Cameras { .. }), "{err}");
    assert!(err.to_string().contains("front, side"), "{err}");
    for camera in ["front", "side"] {
        std::fs::write(out.join(camera).join("color_0000.png"), b"").unwrap();
    }
    let err = rig_sensor(&rig).observe(&rig, 0).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, SenseError::NoCamera { .. }), "{text}");
    assert!(text.contains("front:") && text.contains("side:"), "{text}");
}

#[test]
fn sense_on_a_rig_refuses_pose_and_unknown_cameras_with_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    let bin = env!("CARGO_BIN_EXE_softsense");
    let run = |args: &[&str]| {
        let o = std::process::Command::new(bin)
            .arg("sense")
            .arg(&out)
            .args(args)
            .output();
        let o = o.unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).to_string(),
        )
    };
    let (code, err) = run(&["--pose", "x.json"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("pose file is for a one-camera folder") && err.contains("front, side"));
    let (code, err) = run(&["--cameras", "front,back"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("no camera \"back\""), "{err}");
    let (code, err) = run(&["--cameras", "side", "--json"]);
    assert_eq!(code, Some(0), "{err}");
}

#[test]
fn score_counts_frames_by_the_cameras_they_were_sensed_from() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    for name in ["depth_0001.png", "color_0001.png"] {
        std::fs::remove_file(out.join("side").join(name)).unwrap();
    }
    let bin = env!("CARGO_BIN_EXE_softsense");
    let sensed = std::process::Command::new(bin)
        .args(["sense", "--json"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(sensed.status.success());
    std::fs::write(out.join("sense.json"), &sensed.stdout).unwrap();
    let scored = std::process::Command::new(bin)
        .args(["score", "--json"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(scored.status.success());
    let v: serde_json::Value = serde_json::from_slice(&scored.stdout).unwrap();
    let groups: Vec<(u64, u64)> = (v["by_cameras"].as_array().unwrap().iter())
        .map(|g| {
            (
                g["cameras"].as_u64().unwrap(),
                g["summary"]["frames"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(groups, [(1, 1), (2, 1)]);
}

#[test]
fn batch_senses_a_rig_recording_as_sense_does() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    two_camera_recording(&out);
    let manifest = dir.path().join("m.toml");
    let text = format!("[[recording]]\npath = {:?}\n", out.display().to_string());
    std::fs::write(&manifest, text).unwrap();
    let bin = env!("CARGO_BIN_EXE_softsense");
    let results = dir.path().join("results");
    let run = std::process::Command::new(bin)
        .arg("batch")
        .arg(&manifest)
        .arg("--out")
        .arg(&results)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let batch = crate::common::batch::results(&results);
    let sensed = std::process::Command::new(bin)
        .args(["sense", "--json"])
        .arg(&out)
        .output()
        .unwrap();
    let lines: Vec<serde_json::Value> = (String::from_utf8_lossy(&sensed.stdout).lines())
        .map(|l| crate::common::batch::without_times(serde_json::from_str(l).unwrap()))
        .collect();
    assert_eq!(batch.len(), 1);
    assert_eq!(serde_json::Value::Array(lines), batch[0].1["frames"]);
    assert_eq!(
        batch[0].1["frames"][0]["cameras"].as_array().unwrap().len(),
        2
    );
}

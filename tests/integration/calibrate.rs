//! Calibration from perturbed starts on the noise-free scene `clouds/scenes/calib`
//! (issue 6 acceptance: camera pose within 1 mm and 0.2°, actuator inputs within 2%).
//! The truth (camera_pose.json, truth.json) is read only to build the starts and to check.

use softsense::calibrate::{
    calibrate, pose_difference, read_pose, read_scene_robot_points, CalibrateParams,
    CalibrationStatus,
};
use softsense::fem::model::Model;
use softsense::math::{Iso3, Vec3};
use softsense::scene::Truth;
use std::path::Path;

/// The true pose perturbed in the robot frame: `angle_deg` about `axis` (through the robot
/// origin) and `shift_mm` along `dir`.
fn perturbed(truth: &Iso3, axis: [f64; 3], angle_deg: f64, dir: [f64; 3], shift_mm: f64) -> Iso3 {
    let a = Vec3::from(axis).normalize() * angle_deg.to_radians();
    let t = Vec3::from(dir).normalize() * shift_mm * 1e-3;
    Iso3::new(t, a) * truth
}

#[test]
fn calibration_recovers_pose_and_inputs_from_perturbed_starts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("clouds/scenes/calib");
    let truth_pose = read_pose(&dir.join("camera_pose.json")).unwrap();
    let truth: Truth =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let params = CalibrateParams::default();
    let points = read_scene_robot_points(&dir, 0, &params).unwrap();
    let acts = &truth.frames[0].actuators;
    let max_tension = acts.iter().map(|a| a.tension).fold(0.0, f64::max);
    let starts = [
        ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([1.0, -1.0, 1.0], [-1.0, 1.0, 1.0]),
        ([-1.0, 1.0, 0.0], [1.0, 1.0, -1.0]),
        ([0.0, 1.0, 1.0], [1.0, -1.0, 0.0]),
    ];
    let mut failures = Vec::new();
    for (k, (axis, dir_t)) in starts.iter().enumerate() {
        for sign in [1.0, -1.0] {
            let start = perturbed(&truth_pose, *axis, sign * 10.0, *dir_t, sign * 30.0);
            let (t0, r0) = pose_difference(&start, &truth_pose);
            let t = std::time::Instant::now();
            let cal = calibrate(&model, &points, &start, &params, |i, r| {
                eprintln!(
                    "  iteration {i}: rms {:.3} mm, moved {:.3} mm {:.4} deg, tensions {:.4} N",
                    r.residual_rms * 1e3,
                    r.translation_change * 1e3,
                    r.rotation_change.to_degrees(),
                    r.tension_change
                )
            })
            .unwrap();
            let secs = t.elapsed().as_secs_f64();
            let got = softsense::calibrate::pose_from_matrix(&cal.robot_from_camera).unwrap();
            let (dt, dr) = pose_difference(&got, &truth_pose);
            let mut line = format!(
                "start {k}{}: from {:.1} mm {:.2} deg -> pose error {:.3} mm {:.4} deg, \
                 {} iterations, {:?}, rms {:.3} mm, {secs:.1} s; inputs",
                if sign > 0.0 { "+" } else { "-" },
                t0 * 1e3,
                r0.to_degrees(),
                dt * 1e3,
                dr.to_degrees(),
                cal.iterations,
                cal.status,
                cal.residual_rms * 1e3
            );
            let mut ok = dt <= 1e-3 && dr.to_degrees() <= 0.2;
            for (a, c) in acts.iter().zip(&cal.actuators) {
                assert_eq!(a.name, c.name);
                if a.tension > 0.0 {
                    let et = (c.tension - a.tension).abs() / a.tension;
                    let es = (c.shortening - a.shortening).abs() / a.shortening.abs();
                    line += &format!(
                        " {} tension {:.2}% shortening {:.2}%",
                        a.name,
                        et * 100.0,
                        es * 100.0
                    );
                    ok &= et <= 0.02 && es <= 0.02;
                } else {
                    let et = c.tension.abs() / max_tension;
                    line += &format!(" {} {:.4} N ({:.2}% of max)", a.name, c.tension, et * 100.0);
                    ok &= et <= 0.02;
                }
            }
            ok &= cal.status == CalibrationStatus::Converged;
            eprintln!("{line}");
            if !ok {
                failures.push(line);
            }
        }
    }
    assert!(
        failures.is_empty(),
        "failed starts:\n{}",
        failures.join("\n")
    );
}

fn run_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .output()
        .unwrap()
}

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
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
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

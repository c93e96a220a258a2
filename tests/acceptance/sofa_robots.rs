//! The SOFA tutorials' cable finger from its STL to sensed forces by the documented
//! commands (issue 54 item 5; docs/accuracy.md, "Robots designed by others (SOFA)"):
//! `tools/sofa/models.sh OUT` makes the four models with `softsense model new`, then
//! `tools/sweeps/run.sh` draws five one-probe scenes of the finger's sweep (a fixed seed),
//! senses and scores them. Needs SOFTSENSE_DATA (skipped, saying why, without it).
//!
//! What is checked: every model is made and solves, every scene is sensed with one JSON
//! line whose errors name each true load, and no load is a silent miss (the acceptance
//! line). The accuracy floors are the 50-scene sweep's measured result with margin, not
//! pass lines: located 44% there (at least 1 of 5 here), the magnitude within 2 sigma of the
//! truth for 46 of 49 estimates there (at least 60% here). The sweep had no load within 5%, so
//! there is no floor on that rate; a test of "at least 0" could not fail.
//! Seed 54's five scenes: 1 located (at the floor), none within 5%, no silent miss.

use crate::common;
use std::path::Path;
use std::process::Command;

fn run_tool(script: &str, args: &[&Path], extra: &[&str], data: &Path) -> String {
    let output = Command::new("bash")
        .arg(common::project_root().join(script))
        .args(args)
        .args(extra)
        .env("SOFTSENSE_DATA", data)
        .env("SOFTSENSE_BIN", env!("CARGO_BIN_EXE_softsense"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{script}: {stderr}");
    String::from_utf8_lossy(&output.stdout).into_owned()
}

#[test]
fn the_sofa_finger_goes_from_its_stl_to_sensed_forces_with_no_silent_miss() {
    let test = "the_sofa_finger_goes_from_its_stl_to_sensed_forces_with_no_silent_miss";
    let Some(data) = common::data_dir(test) else {
        return;
    };
    for f in [
        "finger/finger.stl",
        "finger/finger.vtk",
        "finger/cable.json",
    ] {
        let path = data.join("sofa-robots").join(f);
        assert!(
            path.exists(),
            "SOFTSENSE_DATA is set but {} is missing",
            path.display()
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let models = dir.path().join("models");
    let out = run_tool("tools/sofa/models.sh", &[&models], &[], &data);
    for m in ["finger_stl", "finger_vtk", "pneunet_stl", "pneunet_vtk"] {
        assert!(models.join(m).join("model.toml").is_file(), "{m}: {out}");
    }
    assert_eq!(out.matches("converged: true").count(), 4, "{out}");

    let sweep = dir.path().join("sweep");
    let count = 5;
    let score = run_tool(
        "tools/sweeps/run.sh",
        &[&models.join("finger_one_probe.toml"), &sweep],
        &[&count.to_string(), "54"],
        &data,
    );
    println!("{score}");
    let mut located = 0;
    let (mut estimates, mut within_2_sigma) = (0, 0);
    for k in 0..count {
        let scene = sweep.join(format!("scene_{k:04}"));
        let text = std::fs::read_to_string(scene.join("sense.json")).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1, "scene {k}: one frame, one line: {text}");
        let frame: serde_json::Value = serde_json::from_str(lines[0]).unwrap();
        assert_eq!(frame["status"], "sensed", "scene {k}: {frame}");
        let errors = frame["errors"].as_array().unwrap();
        assert_eq!(errors.len(), 1, "scene {k}: one true load: {frame}");
        let e = &errors[0];
        let Some(i) = e["estimate"].as_u64() else {
            // No estimate for the load: the frame must say so (else a silent miss).
            assert!(
                frame["reliable"] == false || !frame["warnings"].as_array().unwrap().is_empty(),
                "scene {k}: a load with no estimate and no flag: {frame}"
            );
            continue;
        };
        let location = e["location_error"].as_f64().unwrap();
        let force = e["force_error"].as_f64().unwrap();
        assert!(location.is_finite() && force.is_finite(), "scene {k}: {e}");
        located += usize::from(location <= 0.005);
        let f = &frame["forces"][i as usize];
        let truth: f64 = (e["truth_force"].as_array().unwrap().iter())
            .map(|c| c.as_f64().unwrap().powi(2))
            .sum::<f64>()
            .sqrt();
        let (magnitude, sigma) = (
            f["magnitude"].as_f64().unwrap(),
            f["sigma"].as_f64().unwrap(),
        );
        assert!(sigma.is_finite() && sigma > 0.0, "scene {k}: {f}");
        estimates += 1;
        within_2_sigma += usize::from((magnitude - truth).abs() <= 2.0 * sigma);
    }
    let text = std::fs::read_to_string(sweep.join("score.json")).unwrap();
    let all = &serde_json::from_str::<serde_json::Value>(&text).unwrap()["all"];
    assert_eq!(all["frames"], count, "{all}");
    assert_eq!(all["sensed"], count, "{all}");
    assert_eq!(all["silent"], 0, "no silent miss: {score}");
    assert!(located >= 1, "located {located} of {count}: {score}");
    assert!(
        estimates > 0 && within_2_sigma as f64 >= 0.6 * estimates as f64,
        "magnitude within 2 sigma for {within_2_sigma} of {estimates}: {score}"
    );
}

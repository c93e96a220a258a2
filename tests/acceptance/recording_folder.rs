//! One recording folder for every command: `calibrate`, `sense` and `explain` read the
//! same generated folder, run from another working directory with relative paths.

use std::path::Path;
use std::process::Command;

fn softsense(cwd: &Path, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the softsense binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn calibrate_sense_and_explain_read_the_same_folder_from_another_working_directory() {
    let root = tempfile::tempdir().unwrap();
    let (made_in, run_in) = (root.path().join("a"), root.path().join("b"));
    std::fs::create_dir_all(&made_in).unwrap();
    std::fs::create_dir_all(&run_in).unwrap();
    // The bundled meshes, copied: model files name their meshes relative to themselves.
    let meshes = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes");
    for sub in ["", "models"] {
        std::fs::create_dir_all(root.path().join("meshes").join(sub)).unwrap();
        for f in std::fs::read_dir(meshes.join(sub)).unwrap() {
            let f = f.unwrap().path();
            if f.is_file() {
                let to = root
                    .path()
                    .join("meshes")
                    .join(sub)
                    .join(f.file_name().unwrap());
                std::fs::copy(&f, to).unwrap();
            }
        }
    }
    let (ok, _, err) = softsense(
        &made_in,
        &[
            "hidden",
            "ds",
            "--model",
            "../meshes/models/robot.toml",
            "--frames",
            "4",
            "--effects",
            "young",
        ],
    );
    assert!(ok, "hidden: {err}");
    let frames = "../a/ds/frames";
    let (ok, _, err) = softsense(
        &run_in,
        &[
            "calibrate",
            frames,
            "../meshes/models/robot.toml",
            "--start",
            "../a/ds/frames/camera_pose.json",
        ],
    );
    assert!(ok, "calibrate: {err}");
    // No --model: calibration.json names it, relative to the folder.
    let (ok, out, err) = softsense(&run_in, &["sense", frames, "--json"]);
    assert!(ok, "sense: {err}");
    assert!(
        err.contains("calibration.json"),
        "the pose comes from the calibration: {err}"
    );
    let statuses: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["status"].clone())
        .collect();
    assert_eq!(statuses.len(), 4, "{out}");
    assert!(statuses.iter().all(|s| s == "sensed"), "{statuses:?}");
    // With no frame held out, the before/after figures are the training frames' (they read
    // "0.000 -> 0.000 mm", statistics over no frame, before).
    let (ok, out, err) = softsense(
        &run_in,
        &[
            "explain",
            "../meshes/models/robot.toml",
            frames,
            "--json",
            "--holdout",
            "0",
        ],
    );
    assert!(ok, "explain: {err}");
    assert!(err.contains("no frame held out"), "{err}");
    let x: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(x.get("outcome").is_some(), "{out}");
    let before = x["before"].as_array().unwrap().last().unwrap()["rms"]
        .as_f64()
        .unwrap();
    assert!(before > 0.0, "{out}");
}

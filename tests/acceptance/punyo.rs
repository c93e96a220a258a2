//! The Punyo press sensed by softsense (`tools/real/punyo.sh`, docs/real-data.md): the
//! issue's output files, its plateau accuracy, and a status (not a crash) for each kind of
//! bad frame. Needs SOFTSENSE_DATA (skipped, saying why, without it) and python3.

use crate::common;
use std::path::Path;
use std::process::Command;

fn punyo_sh(out: &Path, data: &Path) -> std::process::Output {
    let output = Command::new("bash")
        .arg(common::project_root().join("tools/real/punyo.sh"))
        .arg(out)
        .env("SOFTSENSE_DATA", data)
        .env("SOFTSENSE_BIN", env!("CARGO_BIN_EXE_softsense"))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "punyo.sh: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

#[test]
fn the_punyo_protocol_writes_every_frame_and_reads_the_plateau_within_10_percent() {
    let test = "the_punyo_protocol_writes_every_frame_and_reads_the_plateau_within_10_percent";
    let Some(data) = common::data_dir(test) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = punyo_sh(dir.path(), &data);
    println!("{}", String::from_utf8_lossy(&output.stdout));
    let lines = std::fs::read_to_string(dir.path().join("forces.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 150, "one JSON line per frame");
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let frames = summary["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 150);
    assert!(summary["stiffness"]["tension_n_per_m"].as_f64().unwrap() > 0.0);
    for f in frames {
        assert_eq!(f["status"], "ok", "{f}");
        let force: Vec<f64> = (f["net_force"].as_array().unwrap().iter())
            .map(|v| v.as_f64().unwrap())
            .collect();
        let norm = force.iter().map(|c| c * c).sum::<f64>().sqrt();
        let magnitude = f["magnitude"].as_f64().unwrap();
        assert!((norm - magnitude).abs() <= 1e-9 * (1.0 + magnitude), "{f}");
        assert!(f["sigma"].as_f64().unwrap() > 0.0, "{f}");
        assert!(f["measured"].as_f64().unwrap() >= 0.0, "{f}");
    }
    let get = |f: usize, key: &str| frames[f][key].as_f64().unwrap();
    let plateau = 76..=100;
    let mean = |key: &str| plateau.clone().map(|f| get(f, key)).sum::<f64>() / 25.0;
    let rel = mean("magnitude") / mean("measured") - 1.0;
    assert!(rel.abs() <= 0.10, "plateau mean off by {rel:+.3}");
    let timeline = image::open(dir.path().join("timeline.png")).unwrap();
    assert!(timeline.width() >= 600, "the timeline picture");
}

#[test]
fn a_missing_frame_a_corrupt_jpeg_and_a_nan_pressure_are_statuses_not_crashes() {
    let test = "a_missing_frame_a_corrupt_jpeg_and_a_nan_pressure_are_statuses_not_crashes";
    let Some(data) = common::data_dir(test) else {
        return;
    };
    let punyo = data.join("punyo");
    // Frames 0-11 of the recording, linked (never copied): frame 7's depth is missing,
    // frame 8's colour is not a JPEG, and frame 9's pressure is NaN.
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("punyo");
    std::fs::create_dir(&rec).unwrap();
    for f in 0..12 {
        for name in [format!("depth_{f:04}.png"), format!("color_{f:04}.jpg")] {
            let skip =
                (f == 7 && name.starts_with("depth")) || (f == 8 && name.starts_with("color"));
            if !skip {
                std::os::unix::fs::symlink(punyo.join(&name), rec.join(&name)).unwrap();
            }
        }
    }
    std::fs::write(rec.join("color_0008.jpg"), b"\xff\xd8 not a jpeg").unwrap();
    let text = std::fs::read_to_string(punyo.join("frames.json")).unwrap();
    let mut frames: serde_json::Value = serde_json::from_str(&text).unwrap();
    let list = frames["frames"].as_array_mut().unwrap();
    list.truncate(12);
    // frames.json as Python writes a NaN (serde_json cannot): the literal NaN.
    let json = serde_json::to_string(&frames).unwrap();
    let p9 = list_pressure(&frames, 9);
    let json = json.replacen(&format!("\"pressure_hpa\":{p9}"), "\"pressure_hpa\":NaN", 1);
    assert!(json.contains("NaN"));
    std::fs::write(rec.join("frames.json"), json).unwrap();
    std::os::unix::fs::symlink(punyo.join("rays.npy"), rec.join("rays.npy")).unwrap();
    std::os::unix::fs::symlink(punyo.join("equalized.vtk"), rec.join("equalized.vtk")).unwrap();
    let out = dir.path().join("out");
    // punyo.sh reads $SOFTSENSE_DATA/punyo: point it at the edited copy's parent.
    let status = Command::new("bash")
        .arg(common::project_root().join("tools/real/punyo.sh"))
        .arg(&out)
        .env("SOFTSENSE_DATA", dir.path())
        .env("SOFTSENSE_BIN", env!("CARGO_BIN_EXE_softsense"))
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&status.stderr).to_string();
    assert!(status.status.success(), "{log}");
    let lines = std::fs::read_to_string(out.join("forces.jsonl")).unwrap();
    let rows: Vec<serde_json::Value> = (lines.lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 12, "{log}");
    let status_of = |f: usize| rows[f]["status"].as_str().unwrap().to_string();
    assert_eq!(status_of(7), "missing_frame", "{log}");
    assert_eq!(status_of(8), "unreadable", "{log}");
    assert_eq!(status_of(9), "no_pressure", "{log}");
    for f in (0..12).filter(|f| ![7, 8, 9].contains(f)) {
        assert_eq!(status_of(f), "ok", "frame {f}: {log}");
    }
}

fn list_pressure(frames: &serde_json::Value, f: usize) -> String {
    frames["frames"][f]["pressure_hpa"].to_string()
}

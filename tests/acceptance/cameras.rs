//! Issue 34's acceptance line "a recording where one camera's frame 3 is deleted still
//! senses frame 3 from the other camera, with a per-camera status", on the bundled
//! two-camera scene at full resolution, through the command a user runs.

use crate::common::project_root;
use std::process::Command;

/// Runs the binary; its stdout, after checking it succeeded.
fn softsense(args: &[&str]) -> Vec<u8> {
    let o = Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o.stdout
}

#[test]
fn a_deleted_frame_of_one_camera_is_sensed_from_the_other_with_a_status_per_camera() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("two_cameras");
    let scene = project_root().join("clouds/scenes/two_cameras.toml");
    softsense(&[
        "scene",
        "generate",
        scene.to_str().unwrap(),
        out.to_str().unwrap(),
    ]);
    for name in ["depth_0003.png", "color_0003.png"] {
        std::fs::remove_file(out.join("side").join(name)).unwrap();
    }
    let sensed = softsense(&["sense", "--json", out.to_str().unwrap()]);
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&sensed)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 10);
    for r in &lines {
        let frame = r["frame"].as_u64().unwrap();
        let states: Vec<(&str, &str)> = (r["cameras"].as_array().unwrap().iter())
            .map(|c| (c["name"].as_str().unwrap(), c["status"].as_str().unwrap()))
            .collect();
        let side = if frame == 3 { "missing" } else { "seen" };
        assert_eq!(states, [("front", "seen"), ("side", side)], "frame {frame}");
        assert_eq!(r["status"], "sensed", "frame {frame}");
        let e = &r["errors"][0];
        let force_error = e["force_error"].as_f64().unwrap();
        eprintln!("frame {frame}: cameras {states:?}, force error {force_error:.4}");
        assert!(force_error < 0.05, "frame {frame}: {e}");
    }
    let warned = lines[3]["warnings"].as_array().unwrap();
    assert!(
        warned
            .iter()
            .any(|w| w.as_str().unwrap().contains("side: no such frame")),
        "{warned:?}"
    );
}

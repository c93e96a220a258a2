//! `softsense sense --rerun` (feature `rerun`): the `.rrd` holds every frame's entities and
//! reads back. Run with `cargo test --features rerun --test rerun`.
mod common;

use common::{project_root, run_cli, two_camera_scene};
use softsense::render::rrd::entities_per_frame;
use std::collections::BTreeSet;

/// What every frame logs but for its images and one plot per force.
const PER_FRAME: [&str; 10] = [
    "world/points/robot",
    "world/points/objects",
    "world/fe_surface",
    "world/features",
    "world/features/residuals",
    "world/contacts",
    "world/forces",
    "world/forces/sigma",
    "status",
    "plots/residual_mm",
];

/// Senses `dir` with `--json --rerun` and returns the reports and the file's entities.
fn sense_to_rrd(
    dir: &std::path::Path,
    rrd: &std::path::Path,
) -> (
    Vec<serde_json::Value>,
    std::collections::BTreeMap<Option<i64>, BTreeSet<String>>,
) {
    let out = run_cli(&[
        "sense",
        dir.to_str().unwrap(),
        "--json",
        "--rerun",
        rrd.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("open it with `rerun"), "{stderr}");
    let reports = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (reports, entities_per_frame(rrd).unwrap())
}

fn expected(cameras: &[&str], forces: usize) -> BTreeSet<String> {
    let mut e: BTreeSet<String> = PER_FRAME.iter().map(|s| s.to_string()).collect();
    e.extend(
        cameras
            .iter()
            .map(|c| format!("world/cameras/{c}/image/rgb")),
    );
    e.extend((0..forces).map(|i| format!("plots/force_{i}")));
    e
}

#[test]
fn every_frame_of_the_bundled_recording_is_in_the_rrd_with_its_entities() {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("tip_weight.rrd");
    let scene = project_root().join("clouds/scenes/tip_weight");
    let (reports, got) = sense_to_rrd(&scene, &rrd);
    assert_eq!(reports.len(), 4);
    let camera = "world/cameras/camera";
    let statics: BTreeSet<String> = ["world", camera, &format!("{camera}/image")]
        .map(String::from)
        .into();
    assert_eq!(got[&None], statics);
    for r in &reports {
        let frame = r["frame"].as_i64().unwrap();
        let forces = r["forces"].as_array().unwrap().len();
        assert!(forces > 0, "frame {frame} found no force");
        assert_eq!(
            got[&Some(frame)],
            expected(&["camera"], forces),
            "frame {frame}"
        );
    }
    assert_eq!(got.len(), 1 + reports.len());
}

#[test]
fn a_camera_without_the_frame_is_still_logged_for_it_and_the_other_is_sensed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    let mut scene = two_camera_scene(4);
    let frames = &mut scene.spec.frames;
    *frames = vec![frames[0].clone(), frames[6].clone()];
    softsense::scene::generate(&scene, &out, |_, _| {}).unwrap();
    for name in ["depth_0001.png", "color_0001.png"] {
        std::fs::remove_file(out.join("side").join(name)).unwrap();
    }
    let rrd = dir.path().join("rig.rrd");
    let (reports, got) = sense_to_rrd(&out, &rrd);
    assert_eq!(reports.len(), 2);
    for name in ["front", "side"] {
        assert!(got[&None].contains(&format!("world/cameras/{name}")));
        assert!(got[&None].contains(&format!("world/cameras/{name}/image")));
    }
    for r in &reports {
        let frame = r["frame"].as_i64().unwrap();
        assert_eq!(r["status"], "sensed", "{r}");
        let forces = r["forces"].as_array().unwrap().len();
        // The side camera's image is cleared in frame 1 rather than left showing frame 0.
        assert_eq!(
            got[&Some(frame)],
            expected(&["front", "side"], forces),
            "frame {frame}"
        );
    }
}

#[test]
fn an_rrd_that_cannot_be_written_is_an_error_naming_the_file() {
    let scene = project_root().join("clouds/scenes/tip_weight");
    let out = run_cli(&[
        "sense",
        scene.to_str().unwrap(),
        "--rerun",
        "/nonexistent-dir/x.rrd",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("/nonexistent-dir/x.rrd"), "{stderr}");
}

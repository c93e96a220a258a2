//! `softsense segment`, `cluster` and `contacts` as a user runs them: on the committed
//! demo scene and on small synthetic clouds written here. Checks the labelled output
//! (every input point kept, in order, with a `label` field that agrees with the JSON
//! summary), the JSON shapes, and that bad input gives a clear message and a non-zero
//! exit without a panic.

use super::cli::{assert_fails, assert_same_cloud, json_of, softsense};
use softsense::io::{read_cloud, write_cloud, Encoding};
use softsense::PointCloud;
use std::path::Path;

const DEMO: &str = "clouds/demo_scene.pcd";

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

fn write(path: &Path, cloud: &PointCloud) {
    write_cloud(path, cloud, Encoding::Binary).expect("write test cloud");
}

/// Reads OUT, checks it holds IN's points in order with a label per point, and returns
/// the labels.
fn labelled_output(input: &Path, output: &Path) -> Vec<u32> {
    let a = read_cloud(input).expect("read input");
    let b = read_cloud(output).expect("read output");
    assert_same_cloud(&a, &b);
    let labels = b.labels.expect("output has a label field");
    assert_eq!(labels.len(), a.len());
    for (i, p) in a.positions.iter().enumerate() {
        if !PointCloud::is_finite_point(p) {
            assert_eq!(labels[i], 0, "non-finite point {i} must have label 0");
        }
    }
    labels
}

/// Checks a `segments` JSON array against the labels: labels 1..=n in order, each with
/// as many points in the file as the JSON says, and the box and mean colour shapes.
fn check_segments(json: &serde_json::Value, labels: &[u32]) -> usize {
    let segs = json["segments"].as_array().expect("segments array");
    assert!(!segs.is_empty());
    for (k, seg) in segs.iter().enumerate() {
        assert_eq!(seg["label"].as_u64(), Some(k as u64 + 1));
        let n = labels.iter().filter(|&&l| l as usize == k + 1).count();
        assert_eq!(seg["points"].as_u64(), Some(n as u64), "segment {k}");
        for key in ["min", "max", "mean_color"] {
            assert_eq!(seg[key].as_array().map(Vec::len), Some(3), "{key}");
        }
    }
    let max = labels.iter().copied().max().unwrap_or(0) as usize;
    assert_eq!(max, segs.len(), "labels beyond the listed segments");
    let unsegmented = labels.iter().filter(|&&l| l == 0).count();
    assert_eq!(json["unsegmented"].as_u64(), Some(unsegmented as u64));
    segs.len()
}

#[test]
fn segment_writes_every_point_in_order_with_labels_matching_the_json() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("labelled.pcd");
    let args = [
        "segment",
        DEMO,
        s(&out),
        "--distance",
        "0.01",
        "--point-color",
        "6",
        "--region-color",
        "4",
        "--min-cluster",
        "100",
        "--json",
    ];
    let json = json_of(&softsense(&args));
    let labels = labelled_output(&crate::common::project_root().join(DEMO), &out);
    let n = check_segments(&json, &labels);
    assert_eq!(json["points"].as_u64(), Some(labels.len() as u64));
    assert_eq!(json["params"]["mode"], "pcl");
    assert_eq!(json["params"]["min_cluster_size"], 100);
    assert!(json["segments"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["support"] == false));
    assert!(
        n >= 2,
        "the demo scene has a robot and objects: {n} segments"
    );
}

/// `softsense segment DEMO OUT --mode geometric --json`.
fn segment_demo_geometric(out: &Path) -> serde_json::Value {
    json_of(&softsense(&[
        "segment",
        DEMO,
        s(out),
        "--mode",
        "geometric",
        "--json",
    ]))
}

#[test]
fn segment_geometric_mode_flags_the_support_and_keeps_every_point() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("geo.pcd");
    let json = segment_demo_geometric(&out);
    let labels = labelled_output(&crate::common::project_root().join(DEMO), &out);
    check_segments(&json, &labels);
    assert_eq!(json["params"]["mode"], "geometric");
    let support = json["segments"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["support"] == true)
        .count();
    assert_eq!(support, 1, "the demo table is one support part");
}

#[test]
fn segment_without_json_prints_nothing_on_stdout() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("quiet.pcd");
    let o = softsense(&["segment", DEMO, s(&out), "--min-cluster", "100"]);
    assert!(o.status.success());
    assert!(o.stdout.is_empty());
    assert!(String::from_utf8_lossy(&o.stderr).contains("segments"));
}

#[test]
fn segment_rejects_bad_input_with_a_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o.pcd");
    let o = s(&out);
    assert_fails(
        &softsense(&["segment", "no/such/scene.pcd", o]),
        1,
        &["no/such/scene.pcd"],
    );
    let bad = "tests/fixtures/malformed/pcd_binary_truncated.pcd";
    assert_fails(&softsense(&["segment", bad, o]), 1, &[bad]);
    let grey = tmp.path().join("xyz_only.pcd");
    write(
        &grey,
        &PointCloud::from_positions(vec![[0.0, 0.0, 1.0], [0.001, 0.0, 1.0]]),
    );
    assert_fails(&softsense(&["segment", s(&grey), o]), 1, &["rgb"]);
    assert_fails(
        &softsense(&["segment", DEMO, o, "--distance=-1"]),
        1,
        &["distance_m"],
    );
    assert_fails(
        &softsense(&["segment", DEMO, o, "--mode", "geometric", "--no-merge"]),
        2,
        &["--mode pcl only"],
    );
    assert_fails(
        &softsense(&["segment", DEMO, o, "--mode", "colour"]),
        2,
        &["colour"],
    );
    let unwritable = tmp.path().join("missing_dir/o.pcd");
    assert_fails(
        &softsense(&["segment", DEMO, s(&unwritable)]),
        1,
        &["missing_dir"],
    );
}

/// Two 1 cm grids of 5 x 5 points 5 cm apart, and a NaN point between them.
fn two_blobs() -> PointCloud {
    let mut pts = Vec::new();
    for (k, x0) in [0.0f32, 0.05].into_iter().enumerate() {
        for i in 0..5 {
            for j in 0..5 {
                pts.push([x0 + i as f32 * 0.002, j as f32 * 0.002, 1.0]);
            }
        }
        if k == 0 {
            pts.push([f32::NAN, f32::NAN, f32::NAN]);
        }
    }
    PointCloud::from_positions(pts)
}

#[test]
fn cluster_labels_two_blobs_and_reports_their_sizes() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("blobs.pcd");
    let out = tmp.path().join("clusters.pcd");
    write(&input, &two_blobs());
    let cluster = |extra: &[&str]| {
        let mut args = vec![
            "cluster",
            s(&input),
            s(&out),
            "--tolerance",
            "0.005",
            "--json",
        ];
        args.extend_from_slice(extra);
        json_of(&softsense(&args))
    };
    let json = cluster(&[]);
    assert_eq!(json["clusters"], serde_json::json!([25, 25]));
    assert_eq!(json["points"], 51);
    let labels = labelled_output(&input, &out);
    // Clusters are numbered by size, ties in discovery order: the first blob is 1.
    assert!(labels[..25].iter().all(|&l| l == 1));
    assert_eq!(labels[25], 0);
    assert!(labels[26..].iter().all(|&l| l == 2));
    // A minimum above both sizes drops every cluster: all labels 0.
    let json = cluster(&["--min", "26"]);
    assert_eq!(json["clusters"], serde_json::json!([]));
    assert!(labelled_output(&input, &out).iter().all(|&l| l == 0));
}

#[test]
fn cluster_rejects_bad_input_with_a_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("blobs.pcd");
    write(&input, &two_blobs());
    let out = tmp.path().join("o.pcd");
    let (i, o) = (s(&input), s(&out));
    assert_fails(
        &softsense(&["cluster", i, o, "--tolerance", "0"]),
        1,
        &["tolerance"],
    );
    assert_fails(&softsense(&["cluster", i, o]), 2, &["--tolerance"]);
    assert_fails(
        &softsense(&["cluster", "none.pcd", o, "--tolerance", "0.01"]),
        1,
        &["none.pcd"],
    );
}

/// A blue 8 x 8 cm "robot" sheet at z = 1 m and a red sheet 2 mm in front of it that
/// overlaps its last 1 cm in x: the overlap is the contact. 2 mm grid.
fn touching_sheets() -> PointCloud {
    let mut pts = Vec::new();
    let mut colors = Vec::new();
    for i in 0..40 {
        for j in 0..40 {
            pts.push([i as f32 * 0.002, j as f32 * 0.002, 1.0]);
            colors.push([20u8, 40, 230]);
        }
    }
    for i in 0..40 {
        for j in 0..40 {
            pts.push([0.07 + i as f32 * 0.002, j as f32 * 0.002, 0.998]);
            colors.push([230u8, 30, 20]);
        }
    }
    let mut c = PointCloud::from_positions(pts);
    c.colors = Some(colors);
    c
}

#[test]
fn contacts_finds_the_overlap_of_two_touching_sheets() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("sheets.pcd");
    write(&input, &touching_sheets());
    let json = json_of(&softsense(&[
        "contacts",
        s(&input),
        "--robot-color",
        "20,40,230:10",
        "--json",
    ]));
    assert_eq!(json["robot"]["chosen_by"]["rule"], "color");
    assert!(
        json["robot"]["chosen_by"]["hue_difference_deg"]
            .as_f64()
            .unwrap()
            < 10.0
    );
    assert_eq!(json["robot"]["points"], 1600);
    let contacts = json["contacts"].as_array().expect("contacts array");
    assert_eq!(contacts.len(), 1, "{json}");
    let c = &contacts[0];
    let centroid: Vec<f64> = c["centroid"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    // Red points within 4 mm of more than 3 blue points: x from 0.07 to 0.08 (the blue
    // sheet ends at 0.078), so the centroid is near x = 0.075, mid-height in y.
    assert!((centroid[0] - 0.075).abs() < 0.003, "{centroid:?}");
    assert!((centroid[1] - 0.039).abs() < 0.002, "{centroid:?}");
    assert!((centroid[2] - 0.998).abs() < 1e-4, "{centroid:?}");
    assert!(c["points"].as_u64().unwrap() >= 200);
    for key in ["min", "max"] {
        assert_eq!(c[key].as_array().map(Vec::len), Some(3));
    }
    assert!(c["extent"].as_f64().unwrap() > 0.07);
    // The plain output: one line per contact on stdout.
    let o = softsense(&["contacts", s(&input), "--robot-color", "20,40,230:10"]);
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 1);
}

#[test]
fn contacts_on_the_demo_scene_prints_json_with_a_robot() {
    let json = json_of(&softsense(&["contacts", DEMO, "--json"]));
    assert_eq!(json["robot"]["chosen_by"]["rule"], "largest");
    assert!(json["segments"].as_u64().unwrap() >= 1);
    assert!(json["contacts"].is_array());
}

#[test]
fn contacts_rejects_bad_input_with_a_clear_message() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("sheets.pcd");
    write(&input, &touching_sheets());
    let i = s(&input);
    assert_fails(
        &softsense(&["contacts", i, "--robot-color", "1,2"]),
        2,
        &["R,G,B"],
    );
    assert_fails(
        &softsense(&["contacts", i, "--robot-color", "0,255,0:5"]),
        1,
        &["no robot segment"],
    );
    assert_fails(
        &softsense(&["contacts", i, "--radius=-0.004"]),
        1,
        &["radius"],
    );
    let grey = tmp.path().join("xyz.pcd");
    write(&grey, &PointCloud::from_positions(vec![[0.0, 0.0, 1.0]; 3]));
    assert_fails(&softsense(&["contacts", s(&grey)]), 1, &["rgb"]);
    assert_fails(&softsense(&["contacts", "gone.pcd"]), 1, &["gone.pcd"]);
}

#[test]
fn contacts_geometric_mode_never_takes_the_support_as_the_robot() {
    let tmp = tempfile::tempdir().unwrap();
    let seg = segment_demo_geometric(&tmp.path().join("geo.pcd"));
    let segments = seg["segments"].as_array().unwrap();
    let support: Vec<u64> = segments
        .iter()
        .filter(|s| s["support"] == true)
        .map(|s| s["label"].as_u64().unwrap() - 1)
        .collect();
    assert!(!support.is_empty());
    let json = json_of(&softsense(&[
        "contacts",
        DEMO,
        "--mode",
        "geometric",
        "--json",
    ]));
    let robot = json["robot"]["segment"].as_u64().unwrap();
    assert!(!support.contains(&robot), "robot {robot} is a support part");
    assert_eq!(json["robot"]["chosen_by"]["rule"], "largest");
    // The largest non-support segment.
    let largest = segments
        .iter()
        .filter(|s| s["support"] == false)
        .map(|s| s["points"].as_u64().unwrap())
        .max()
        .unwrap();
    assert_eq!(json["robot"]["points"].as_u64(), Some(largest));
}

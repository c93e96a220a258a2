//! The oracle harness itself: both programs load a hand-written PCD and report errors as
//! `ok: false`, so a broken harness cannot pass the comparison tests vacuously.

use crate::common::oracle::{self, Lib};
use serde_json::json;

/// A 3-point binary PCD (x y z rgb) with one NaN point, written byte by byte.
fn handwritten_pcd(dir: &std::path::Path) -> std::path::PathBuf {
    let pts: [([f32; 3], u32); 3] = [
        ([0.5, -1.25, 2.0], 0x00ff_0001),
        ([f32::NAN, f32::NAN, f32::NAN], 0x0000_ff00),
        ([1.0e-3, 3.0, -7.5], 0x0001_0203),
    ];
    let mut bytes = b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\n\
COUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA binary\n"
        .to_vec();
    for (p, c) in pts {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    let path = dir.join("three.pcd");
    std::fs::write(&path, bytes).expect("write pcd");
    path
}

fn loads_handwritten_pcd(lib: Lib) {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = handwritten_pcd(dir.path());
    let Some(r) = oracle::run(lib, "load", &input, json!({})) else {
        return;
    };
    assert_eq!(r.json["library"], lib.name());
    assert_eq!(r.int("points"), 3);
    let cloud = r.raw_cloud();
    let p = cloud.positions();
    assert_eq!(p[0], [0.5, -1.25, 2.0]);
    assert!(p[1].iter().all(|v| v.is_nan()));
    assert_eq!(p[2], [1.0e-3, 3.0, -7.5]);
    let c = cloud.rgba().expect("colour");
    assert_eq!(
        c.iter().map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>(),
        [[255, 0, 1], [0, 255, 0], [1, 2, 3]]
    );
}

#[test]
fn pcl_oracle_loads_a_handwritten_pcd() {
    loads_handwritten_pcd(Lib::Pcl);
}

#[test]
fn open3d_oracle_loads_a_handwritten_pcd() {
    loads_handwritten_pcd(Lib::Open3d);
}

fn reports_unknown_stage(lib: Lib) {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = handwritten_pcd(dir.path());
    let Some(r) = oracle::run_job(lib, "no_such_stage", &input, json!({}), 1) else {
        return;
    };
    assert_eq!(r.json["ok"], false);
    assert!(
        r.json["error"]
            .as_str()
            .unwrap_or("")
            .contains("unknown stage"),
        "{}",
        r.json
    );
}

#[test]
fn pcl_oracle_reports_an_unknown_stage_as_an_error() {
    reports_unknown_stage(Lib::Pcl);
}

#[test]
fn open3d_oracle_reports_an_unknown_stage_as_an_error() {
    reports_unknown_stage(Lib::Open3d);
}

#[test]
fn oracles_agree_on_kept_indices_of_a_passthrough() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = handwritten_pcd(dir.path());
    let params = json!({"field": "z", "min": 0.0, "max": 3.0});
    let Some(pcl) = oracle::run(Lib::Pcl, "passthrough", &input, params.clone()) else {
        return;
    };
    let Some(o3d) = oracle::run(Lib::Open3d, "passthrough", &input, params) else {
        return;
    };
    assert_eq!(pcl.indices(), vec![0]);
    assert_eq!(o3d.indices(), vec![0]);
}

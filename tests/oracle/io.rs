//! Issue 2 acceptance: our PCD reader and writer against PCL's `loadPCDFile` and Open3D's
//! `read_point_cloud`, on every `.pcd` under `$SOFTSENSE_DATA`.

use crate::common::oracle::{self, Lib, RawPcd};
use crate::common::{data_dir, pcd_files_under};
use serde_json::json;
use softsense::cloud::PointCloud;
use softsense::io::pcd::{read_pcd, to_pcd_bytes};
use softsense::io::Encoding;
use std::path::Path;

fn data_pcds(test: &str) -> Option<Vec<std::path::PathBuf>> {
    let files = pcd_files_under(&data_dir(test)?);
    assert!(
        files.len() >= 20,
        "expected the 23 .pcd files of ../shared/data, found {}",
        files.len()
    );
    Some(files)
}

fn sorted(mut v: Vec<String>) -> Vec<String> {
    v.sort();
    v
}

/// Asserts that `ours` has exactly the content of the PCL-written `pcl` cloud: size,
/// organization, field set, coordinates bitwise (NaN at the same places), colours, alpha,
/// normals, curvature and labels.
fn assert_same_as_pcl(what: &str, ours: &PointCloud, pcl: &RawPcd) {
    assert_eq!(ours.len(), pcl.len(), "{what}: point count");
    assert_eq!(
        (ours.width as usize, ours.height as usize),
        (pcl.width, pcl.height),
        "{what}: organized size"
    );
    let our_fields: Vec<String> = ours.field_names().into_iter().map(String::from).collect();
    assert_eq!(
        sorted(our_fields),
        sorted(pcl.field_names()),
        "{what}: fields"
    );
    assert_f32_columns_bitwise(
        what,
        "xyz",
        &flatten3(&ours.positions),
        &flatten3(&pcl.positions()),
    );
    if let Some(rgba) = pcl.rgba() {
        let colors = ours.colors.as_ref().expect("colours");
        for (i, (c, p)) in colors.iter().zip(&rgba).enumerate() {
            assert_eq!(c[..], p[..3], "{what}: colour of point {i}");
        }
        if let Some(alpha) = &ours.alpha {
            for (i, (a, p)) in alpha.iter().zip(&rgba).enumerate() {
                assert_eq!(*a, p[3], "{what}: alpha of point {i}");
            }
        }
    }
    if let Some(normals) = pcl.normals() {
        let ours_n = ours.normals.as_ref().expect("normals");
        assert_f32_columns_bitwise(what, "normals", &flatten3(ours_n), &flatten3(&normals));
    }
    if let Some(curv) = pcl.f32s("curvature") {
        assert_f32_columns_bitwise(
            what,
            "curvature",
            ours.curvature.as_ref().expect("curvature"),
            &curv,
        );
    }
    if let Some(labels) = pcl.u32s("label") {
        assert_eq!(
            ours.labels.as_ref().expect("labels"),
            &labels,
            "{what}: labels"
        );
    }
}

fn flatten3(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

/// Equal bit patterns, except that any NaN matches any NaN (PCL keeps a file's NaN
/// payload; the place is what matters).
fn assert_f32_columns_bitwise(what: &str, column: &str, ours: &[f32], theirs: &[f32]) {
    assert_eq!(ours.len(), theirs.len(), "{what}: {column} length");
    for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
        let same = (a.is_nan() && b.is_nan()) || a.to_bits() == b.to_bits();
        assert!(
            same,
            "{what}: {column}[{i}] is {a:e} ({:#x}), PCL has {b:e} ({:#x})",
            a.to_bits(),
            b.to_bits()
        );
    }
}

/// Open3D flattens, keeps NaN, reads colours as bytes; its coordinates are double (from
/// ASCII via strtod), written back as float: compare within 1e-6 with NaN at the same
/// places, colours exactly, normals within 1e-6.
fn assert_same_as_open3d(what: &str, ours: &PointCloud, o3d: &RawPcd) {
    assert_eq!(ours.len(), o3d.len(), "{what}: point count");
    let close = |column: &str, a: &[f32], b: &[f32]| {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            let ok = (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-6;
            assert!(ok, "{what}: {column}[{i}] is {x:e}, Open3D has {y:e}");
        }
    };
    close(
        "xyz",
        &flatten3(&ours.positions),
        &flatten3(&o3d.positions()),
    );
    assert_eq!(
        ours.colors.is_some(),
        o3d.rgba().is_some(),
        "{what}: has colour"
    );
    if let (Some(colors), Some(rgba)) = (&ours.colors, o3d.rgba()) {
        for (i, (c, p)) in colors.iter().zip(&rgba).enumerate() {
            assert_eq!(c[..], p[..3], "{what}: colour of point {i}");
        }
    }
    assert_eq!(
        ours.normals.is_some(),
        o3d.normals().is_some(),
        "{what}: has normals"
    );
    if let (Some(n), Some(on)) = (&ours.normals, o3d.normals()) {
        close("normals", &flatten3(n), &flatten3(&on));
    }
}

fn load_with(lib: Lib, path: &Path) -> Option<(oracle::OracleResult, RawPcd)> {
    let r = oracle::run(lib, "load", path, json!({}))?;
    let raw = r.raw_cloud();
    assert_eq!(
        r.int("points") as usize,
        raw.len(),
        "{}: result.json points vs cloud.pcd",
        path.display()
    );
    Some((r, raw))
}

#[test]
fn every_data_pcd_reads_exactly_as_pcl_loads_it() {
    let Some(files) = data_pcds("every_data_pcd_reads_exactly_as_pcl_loads_it") else {
        return;
    };
    for path in files {
        let what = path.display().to_string();
        let ours = read_pcd(&path).unwrap_or_else(|e| panic!("{e}"));
        let Some((r, pcl)) = load_with(Lib::Pcl, &path) else {
            return;
        };
        assert_same_as_pcl(&what, &ours, &pcl);
        let origin = &r.json["header"]["origin"];
        let q = &r.json["header"]["orientation_wxyz"];
        for k in 0..3 {
            assert_eq!(
                f64::from(ours.viewpoint.origin[k]),
                origin[k].as_f64().unwrap(),
                "{what}: VIEWPOINT origin"
            );
        }
        for k in 0..4 {
            assert_eq!(
                f64::from(ours.viewpoint.orientation[k]),
                q[k].as_f64().unwrap(),
                "{what}: VIEWPOINT orientation"
            );
        }
    }
}

#[test]
fn every_data_pcd_reads_as_open3d_loads_it() {
    let Some(files) = data_pcds("every_data_pcd_reads_as_open3d_loads_it") else {
        return;
    };
    for path in files {
        let ours = read_pcd(&path).unwrap_or_else(|e| panic!("{e}"));
        let Some((_, o3d)) = load_with(Lib::Open3d, &path) else {
            return;
        };
        assert_same_as_open3d(&path.display().to_string(), &ours, &o3d);
    }
}

const ENCODINGS: [Encoding; 3] = [
    Encoding::Ascii,
    Encoding::Binary,
    Encoding::BinaryCompressed,
];

/// Writes each data cloud in each encoding with our writer and has `lib` load it.
fn files_we_write_load_in(lib: Lib, test: &str) {
    let Some(files) = data_pcds(test) else { return };
    if !oracle::available(lib, test) {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    for path in files {
        let ours = read_pcd(&path).unwrap_or_else(|e| panic!("{e}"));
        for enc in ENCODINGS {
            let what = format!("{} written as {enc:?}", path.display());
            let out = dir.path().join(format!("{enc:?}.pcd"));
            std::fs::write(&out, to_pcd_bytes(&ours, enc)).expect("write temp pcd");
            let (_, theirs) = load_with(lib, &out).expect("oracle available");
            match lib {
                Lib::Pcl => assert_same_as_pcl(&what, &ours, &theirs),
                Lib::Open3d => assert_same_as_open3d(&what, &ours, &theirs),
            }
        }
    }
}

#[test]
fn pcd_files_we_write_in_every_encoding_load_in_pcl_with_the_same_content() {
    files_we_write_load_in(
        Lib::Pcl,
        "pcd_files_we_write_in_every_encoding_load_in_pcl_with_the_same_content",
    );
}

#[test]
fn pcd_files_we_write_in_every_encoding_load_in_open3d_with_the_same_content() {
    files_we_write_load_in(
        Lib::Open3d,
        "pcd_files_we_write_in_every_encoding_load_in_open3d_with_the_same_content",
    );
}

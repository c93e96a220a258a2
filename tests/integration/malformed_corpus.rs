//! The per-format malformed corpus (tests/fixtures/malformed/<format>/, made by
//! tools/make_malformed_corpus.py): every file goes through the library's reader for its
//! format and must give what its folder's MANIFEST.txt says (`ok`, `err`, or `any`), and
//! never panic. All failures are collected and reported at once.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Reads `path` as `format`; `Ok(())` or the error's text.
fn read_as(format: &str, path: &Path) -> Result<(), String> {
    match format {
        "recording_json" => read_recording_with(path),
        _ => crate::common::corpus::read_as(format, path),
    }
}

/// Puts the corpus file in place of the file its name starts with (`truth__flip_3.json`
/// replaces `truth.json`) in a one-frame recording, then opens and reads it.
fn read_recording_with(path: &Path) -> Result<(), String> {
    let name = path.file_name().unwrap().to_string_lossy();
    let target = name.split("__").next().unwrap();
    let dir = crate::common::scene_copy(
        "probe_side",
        &[
            "intrinsics.json",
            "camera_pose.json",
            "depth_0000.png",
            "color_0000.png",
        ],
    );
    std::fs::copy(path, dir.path().join(format!("{target}.json"))).unwrap();
    crate::common::corpus::open_recording(dir.path())?;
    let rec = softsense::recording::Recording::open(dir.path()).map_err(|e| e.to_string())?;
    rec.read_frame(0).map(drop).map_err(|e| e.to_string())
}

#[test]
fn every_corpus_file_gives_its_expected_result_without_panicking() {
    let root = crate::common::project_root().join("tests/fixtures/malformed");
    let mut folders: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    assert!(folders.len() >= 17, "{} corpus folders", folders.len());
    let mut failures = Vec::new();
    let mut counts = Vec::new();
    for folder in &folders {
        let format = folder.file_name().unwrap().to_string_lossy().into_owned();
        let manifest = std::fs::read_to_string(folder.join("MANIFEST.txt")).unwrap();
        let mut n = 0;
        for line in manifest.lines().filter(|l| !l.starts_with('#')) {
            let Some((name, expect)) = line.split_once(' ') else {
                continue;
            };
            if expect == "aux" {
                continue;
            }
            n += 1;
            let path = folder.join(name);
            let got = catch_unwind(AssertUnwindSafe(|| read_as(&format, &path)));
            let wrong = match (&got, expect) {
                (Err(_), _) => Some("panicked".to_string()),
                (Ok(Ok(())), "err") => Some("read without error".into()),
                (Ok(Err(e)), "ok") => Some(format!("failed: {e}")),
                _ => None,
            };
            if let Some(w) = wrong {
                failures.push(format!("{format}/{name} (expected {expect}): {w}"));
            }
        }
        assert!(n >= 30, "{format}: only {n} corpus files");
        counts.push(format!("{format} {n}"));
    }
    println!("corpus files per format: {}", counts.join(", "));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

//! `softsense batch` as a user runs it: killed (SIGKILL) after its first result file and
//! restarted, it ends with one complete result per item, equal to an uninterrupted run
//! with another `--jobs`, and equal to `sense --json`; a failed item is kept, not retried.
use crate::common::batch::{kill_after_first, results, without_times};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Three cheap bundled recordings (1, 4 and 5 frames), the cheapest first.
const MANIFEST: &str = r#"
[[recording]]
path = "ROOT/clouds/scenes/calib"
[[recording]]
path = "ROOT/clouds/scenes/tip_weight"
[[recording]]
path = "ROOT/clouds/scenes/probe_side"
"#;

fn batch(manifest: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_softsense"));
    c.arg("batch")
        .arg(manifest)
        .arg("--out")
        .arg(out)
        .args(extra);
    c
}

fn ok(out: Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

fn manifest_in(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("m.toml");
    std::fs::write(&path, text.replace("ROOT", ROOT)).unwrap();
    path
}

#[test]
fn a_killed_batch_resumes_to_the_results_of_a_straight_run_for_any_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = manifest_in(dir.path(), MANIFEST);
    let (killed, straight) = (dir.path().join("killed"), dir.path().join("straight"));
    let before = kill_after_first(batch(&manifest, &killed, &["--jobs", "1"]), &killed, 1);
    assert!(before < 3, "{before}");
    let stderr = ok(batch(&manifest, &killed, &["--jobs", "1"])
        .output()
        .unwrap());
    assert!(
        stderr.contains(&format!(
            "skipped {before} items with a result from an earlier run"
        )),
        "{stderr}"
    );
    ok(batch(&manifest, &straight, &["--jobs", "2"])
        .output()
        .unwrap());
    let (resumed, straight_results) = (results(&killed), results(&straight));
    let ids: Vec<&str> = resumed.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["calib", "probe_side", "tip_weight"]);
    assert_eq!(resumed.len(), straight_results.len());
    for ((id, a), (_, b)) in resumed.iter().zip(&straight_results) {
        assert_eq!(a["status"], "done", "{id}: {a}");
        // Bit for bit: JSON prints every f64 so that it reads back to the same bits.
        assert_eq!(
            a, b,
            "{id}: resumed with --jobs 1 vs straight with --jobs 2"
        );
    }
    // A third run has nothing to do.
    let stderr = ok(batch(&manifest, &straight, &[]).output().unwrap());
    assert!(
        stderr.contains("0 run (0 done, 0 failed; 0 frames), 3 skipped"),
        "{stderr}"
    );
    // The frames are what `sense --json` prints for the folder.
    let sense = Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(["sense", "--json"])
        .arg(Path::new(ROOT).join("clouds/scenes/tip_weight"))
        .output()
        .unwrap();
    ok(sense.clone());
    let lines: Vec<Value> = String::from_utf8(sense.stdout)
        .unwrap()
        .lines()
        .map(|l| without_times(serde_json::from_str(l).unwrap()))
        .collect();
    assert_eq!(Value::Array(lines), resumed[2].1["frames"]);
}

#[test]
fn a_failed_item_keeps_its_error_and_is_rerun_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = manifest_in(
        dir.path(),
        "[[recording]]\npath = \"ROOT/clouds/scenes/calib\"\n\
         [[recording]]\npath = \"no_such_folder\"\n",
    );
    let out = dir.path().join("out");
    let run = batch(&manifest, &out, &["--jobs", "2"]).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("1 of 2 items failed"), "{stderr}");
    let all = results(&out);
    let failed = &all[1].1;
    assert_eq!(failed["status"], "failed");
    assert!(
        failed["error"].as_str().unwrap().contains("no_such_folder"),
        "{failed}"
    );
    let again = batch(&manifest, &out, &[]).output().unwrap();
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(
        stderr.contains("0 run (0 done, 0 failed; 0 frames), 2 skipped, 1 failed before"),
        "{stderr}"
    );
    assert!(
        stderr.contains("no_such_folder: failed in an earlier run"),
        "{stderr}"
    );
    let retried = batch(&manifest, &out, &["--retry-failed"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&retried.stderr);
    assert!(stderr.contains("1 run (0 done, 1 failed"), "{stderr}");
}

#[test]
fn a_bad_manifest_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = manifest_in(dir.path(), "[[recording]]\npath = \"a\"\nfeatres = 3\n");
    let run = batch(&manifest, &dir.path().join("out"), &[])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("m.toml") && stderr.contains("featres"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

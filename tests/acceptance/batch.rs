//! Issue 35's batch acceptance: the five bundled recordings plus a 20-scene sweep
//! (`scenarios/batch/bundled.toml`), killed (SIGKILL) halfway and restarted, ends with
//! every item's result exactly once, each complete and sensed.
use crate::common::batch::{kill_after_first, results};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

#[test]
fn batch_of_the_bundled_recordings_and_a_sweep_survives_a_kill_halfway() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let manifest = root.join("scenarios/batch/bundled.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = || {
        let mut c = Command::new(env!("CARGO_BIN_EXE_softsense"));
        c.arg("batch")
            .arg(&manifest)
            .arg("--out")
            .arg(&out)
            .args(["--jobs", "2"]);
        c
    };
    let clock = Instant::now();
    let before = kill_after_first(run(), &out, 12);
    let killed_at = clock.elapsed().as_secs_f64();
    let resumed = run().output().unwrap();
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    eprintln!("killed after {killed_at:.1} s with {before} results; then:\n{stderr}");
    assert!(resumed.status.success(), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "skipped {before} items with a result from an earlier run"
        )),
        "{stderr}"
    );
    let all = results(&out);
    let mut ids: Vec<String> = [
        "calib",
        "probe_press",
        "probe_side",
        "tip_weight",
        "two_probes",
    ]
    .map(String::from)
    .to_vec();
    ids.extend((0..20).map(|i| format!("one_probe_{i:04}")));
    ids.sort();
    let got: Vec<&String> = all.iter().map(|r| &r.0).collect();
    assert_eq!(got, ids.iter().collect::<Vec<_>>());
    for (id, v) in &all {
        assert_eq!(v["status"], "done", "{id}: {}", v["error"]);
        assert!(v["sensed"].as_u64().unwrap() >= 1, "{id}");
    }
    eprintln!(
        "25 items in {:.1} s (both runs)",
        clock.elapsed().as_secs_f64()
    );
}

//! `softsense batch` result folders: read back, compared without wall times, and a run
//! killed part way.
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Every result file in `out/results`, by id, with the wall times taken out; panics on a
/// file that is not a complete result or on any other file (a left temporary).
pub fn results(out: &Path) -> Vec<(String, Value)> {
    let mut all: Vec<(String, Value)> = std::fs::read_dir(out.join("results"))
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let id = name
                .strip_suffix(".json")
                .unwrap_or_else(|| panic!("{name}"));
            let text = std::fs::read_to_string(&path).unwrap();
            let v: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(v["id"], id);
            (id.to_string(), without_times(v))
        })
        .collect();
    all.sort_by(|a, b| a.0.cmp(&b.0));
    all
}

/// A result (or a `sense --json` line) without the wall-clock fields.
pub fn without_times(mut v: Value) -> Value {
    if let Some(o) = v.as_object_mut() {
        o.remove("seconds");
        o.remove("ms");
        o.remove("timings");
    }
    if let Some(frames) = v.get_mut("frames").and_then(Value::as_array_mut) {
        for f in frames {
            *f = without_times(f.take());
        }
    }
    v
}

/// Starts a `batch` run, kills it (SIGKILL) once `n` result files are there and the run
/// is still going, and returns the result files there were then.
pub fn kill_after_first(mut cmd: Command, out: &Path, n: usize) -> usize {
    let mut child = cmd.stderr(Stdio::null()).spawn().unwrap();
    let results = out.join("results");
    let start = Instant::now();
    let complete = |d: &Path| {
        std::fs::read_dir(d).map_or(0, |r| {
            r.flatten()
                .filter(|e| !e.file_name().to_string_lossy().starts_with('.'))
                .count()
        })
    };
    while complete(&results) < n {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before {n} results"
        );
        assert!(
            start.elapsed() < Duration::from_secs(600),
            "fewer than {n} results after 600 s"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run ended before the kill"
    );
    child.kill().unwrap();
    child.wait().unwrap();
    complete(&results)
}

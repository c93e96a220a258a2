//! Many recordings, scene files and sweep scenes sensed in one resumable run
//! (`softsense batch`).
//!
//! A [`Manifest`] lists the items; each item ends in exactly one result file,
//! `OUT/results/ID.json`, written atomically ([`crate::io::atomic`]), so a run killed at any
//! moment leaves complete result files only. A result file holds the item, its status
//! (`done` or `failed`, with the error) and the frame reports `softsense sense --json`
//! prints. [`plan`] skips the items whose result file is there and is of the same item
//! (and, unless asked, those that failed before); [`run`] does the rest, `jobs` items at a
//! time. An item's reports do not depend on `jobs`: frames are independent and each
//! stage's parallel sums are ordered ([`crate::sense::Sensor::sense_frames`]).
//!
//! Items that generate their recording (scene files, sweep scenes) write it to
//! `OUT/recordings/ID/`, anew on every attempt.

mod item;
pub mod manifest;

pub use item::{recording_dir, run_item, sense_recording};
pub use manifest::{Item, Manifest, SenseOptions, Source};

use crate::sense::{FrameReport, FrameStatus};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use thiserror::Error;

/// Errors of a batch run as a whole (an item's own failure is in its result file).
#[derive(Debug, Error)]
pub enum BatchError {
    /// The manifest cannot be read or is wrong.
    #[error("{path}: {message}")]
    Manifest {
        /// The manifest file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The output folder cannot be made or read.
    #[error("{path}: {source}")]
    Output {
        /// The folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A result file cannot be written.
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
}

/// `Result` of the batch module.
pub type BatchResult<T> = std::result::Result<T, BatchError>;

/// The result file of item `id`: `OUT/results/ID.json`.
pub fn result_path(out: &Path, id: &str) -> PathBuf {
    out.join("results").join(format!("{id}.json"))
}

/// What [`plan`] found in the output folder.
#[derive(Debug, Default)]
pub struct Plan {
    /// Items to run, in manifest order.
    pub todo: Vec<Item>,
    /// Items with a complete `done` result: skipped.
    pub done: usize,
    /// Items whose earlier attempt failed, with its error: skipped (not retried).
    pub failed: Vec<(String, String)>,
    /// Result files that were unreadable or of another item (the manifest changed): redone.
    pub replaced: usize,
}

/// Sorts `items` into those to run and those a result file already answers. An item
/// that failed before is run again only with `retry_failed`.
pub fn plan(items: &[Item], out: &Path, retry_failed: bool) -> Plan {
    let mut plan = Plan::default();
    for item in items {
        let path = result_path(out, &item.id);
        let Ok(text) = std::fs::read_to_string(&path) else {
            plan.todo.push(item.clone());
            continue;
        };
        match previous_status(&text, item) {
            Some(Previous::Done) => plan.done += 1,
            Some(Previous::Failed(_)) if retry_failed => plan.todo.push(item.clone()),
            Some(Previous::Failed(e)) => plan.failed.push((item.id.clone(), e)),
            None => {
                plan.replaced += 1;
                plan.todo.push(item.clone());
            }
        }
    }
    plan
}

enum Previous {
    Done,
    Failed(String),
}

/// The status of a result file's text if it is a complete result of `item`.
fn previous_status(text: &str, item: &Item) -> Option<Previous> {
    let v: Value = serde_json::from_str(text).ok()?;
    if v["id"] != item.id.as_str() || v["item"] != serde_json::to_value(item).ok()? {
        return None;
    }
    match v["status"].as_str()? {
        "done" if v["frames"].is_array() => Some(Previous::Done),
        "failed" => Some(Previous::Failed(v["error"].as_str()?.to_string())),
        _ => None,
    }
}

/// How one item ended.
#[derive(Debug, Clone)]
pub struct ItemOutcome {
    /// The item's id.
    pub id: String,
    /// Frames, and frames sensed, when it ran; the error when it failed.
    pub result: Result<(usize, usize), String>,
    /// Wall time (s).
    pub seconds: f64,
}

/// Runs `items`, `jobs` at a time, writing each one's result file as soon as it is done
/// and handing its outcome to `each` (on the calling thread, in the order they finish).
/// Stops taking new items at the first result file that cannot be written.
pub fn run(
    items: &[Item],
    out: &Path,
    jobs: usize,
    mut each: impl FnMut(&ItemOutcome),
) -> BatchResult<Vec<ItemOutcome>> {
    let results = out.join("results");
    std::fs::create_dir_all(&results).map_err(|source| BatchError::Output {
        path: results.clone(),
        source,
    })?;
    let jobs = jobs.clamp(1, items.len().max(1));
    // One item at a time: its frames side by side; else one frame at a time per item.
    let window = if jobs == 1 {
        crate::sense::default_window()
    } else {
        1
    };
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::channel::<BatchResult<ItemOutcome>>();
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            let (tx, next, stop) = (tx.clone(), &next, &stop);
            scope.spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    let Some(item) = items.get(next.fetch_add(1, Ordering::Relaxed)) else {
                        break;
                    };
                    let done = run_one(item, out, window);
                    if done.is_err() {
                        stop.store(true, Ordering::Relaxed);
                    }
                    if tx.send(done).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        let mut outcomes = Vec::with_capacity(items.len());
        let mut first_error = None;
        for done in rx {
            match done {
                Ok(o) => {
                    each(&o);
                    outcomes.push(o);
                }
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        first_error.map_or(Ok(outcomes), Err)
    })
}

/// Runs one item and writes its result file, as [`run`] does for each item: the unit of
/// work for running items elsewhere (the Python package's Ray example runs it as a task).
/// `window` frames are sensed side by side; the result does not depend on it.
pub fn run_one(item: &Item, out: &Path, window: usize) -> BatchResult<ItemOutcome> {
    let clock = std::time::Instant::now();
    // A bug in one item (a panic) fails that item, not the run.
    let ran =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_item(item, out, window)))
            .unwrap_or_else(|p| {
                Err(format!(
                    "internal error (a bug; please report it): {}",
                    panic_text(&p)
                ))
            });
    let seconds = clock.elapsed().as_secs_f64();
    let (value, result) = result_value(item, ran, seconds);
    let text = serde_json::to_string_pretty(&value).unwrap_or_else(|e| {
        json!({"id": item.id, "status": "failed", "error": e.to_string()}).to_string()
    });
    crate::io::atomic::write(&result_path(out, &item.id), format!("{text}\n").as_bytes())?;
    Ok(ItemOutcome {
        id: item.id.clone(),
        result,
        seconds,
    })
}

/// The result file's JSON and the outcome: `done` when a frame was sensed, else
/// `failed` (its frames kept).
fn result_value(
    item: &Item,
    ran: Result<Vec<FrameReport>, String>,
    seconds: f64,
) -> (Value, Result<(usize, usize), String>) {
    let mut v = json!({"id": item.id, "item": item});
    match ran {
        Ok(frames) => {
            let sensed = frames
                .iter()
                .filter(|r| matches!(r.status, FrameStatus::Sensed))
                .count();
            let result = match sensed {
                0 => Err("no frame could be sensed (see each frame's status)".to_string()),
                _ => Ok((frames.len(), sensed)),
            };
            v["status"] = json!(if result.is_ok() { "done" } else { "failed" });
            if let Err(e) = &result {
                v["error"] = json!(e);
            }
            v["sensed"] = json!(sensed);
            v["frames"] = serde_json::to_value(&frames).unwrap_or(Value::Null);
            v["seconds"] = json!(seconds);
            (v, result)
        }
        Err(e) => {
            v["status"] = json!("failed");
            v["error"] = json!(e);
            v["seconds"] = json!(seconds);
            (v, Err(e))
        }
    }
}

fn panic_text(p: &Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

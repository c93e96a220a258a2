//! Batch items one at a time, for running them elsewhere (Ray tasks): the plan of a
//! manifest against an output folder, and one item run with its result file written as
//! `softsense batch` writes it.

use crate::error;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use softsense::batch::{plan, run_one, Manifest};
use std::path::PathBuf;

/// The items of `manifest` still to run against `out` (ids, in manifest order), and the
/// counts of those a result file already answers: `(todo, done, failed, replaced)`, where
/// `failed` lists `(id, error)` of earlier failures that are not retried.
#[pyfunction]
#[pyo3(signature = (manifest, out, retry_failed=false))]
#[allow(clippy::type_complexity)]
fn batch_plan(
    manifest: PathBuf,
    out: PathBuf,
    retry_failed: bool,
) -> PyResult<(Vec<String>, usize, Vec<(String, String)>, usize)> {
    let m = Manifest::load(&manifest).map_err(error)?;
    let p = plan(&m.items, &out, retry_failed);
    Ok((
        p.todo.into_iter().map(|i| i.id).collect(),
        p.done,
        p.failed,
        p.replaced,
    ))
}

/// Runs the item `item_id` of `manifest` and writes `OUT/results/ID.json`; returns
/// `{"id", "frames", "sensed", "error", "seconds"}` (`error` None when it was done).
#[pyfunction]
#[pyo3(signature = (manifest, item_id, out, window=1))]
fn batch_run_item<'py>(
    py: Python<'py>,
    manifest: PathBuf,
    item_id: &str,
    out: PathBuf,
    window: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let m = Manifest::load(&manifest).map_err(error)?;
    let item = m.items.iter().find(|i| i.id == item_id).ok_or_else(|| {
        error(format!(
            "{}: no item {item_id:?} (it has {} items)",
            manifest.display(),
            m.items.len()
        ))
    })?;
    std::fs::create_dir_all(out.join("results"))
        .map_err(|e| error(format!("{}: {e}", out.display())))?;
    let outcome = py
        .detach(|| run_one(item, &out, window.max(1)))
        .map_err(error)?;
    let d = PyDict::new(py);
    d.set_item("id", &outcome.id)?;
    let (frames, sensed, err) = match &outcome.result {
        Ok((f, s)) => (*f, *s, None),
        Err(e) => (0, 0, Some(e.clone())),
    };
    d.set_item("frames", frames)?;
    d.set_item("sensed", sensed)?;
    d.set_item("error", err)?;
    d.set_item("seconds", outcome.seconds)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(batch_plan, m)?)?;
    m.add_function(wrap_pyfunction!(batch_run_item, m)?)
}

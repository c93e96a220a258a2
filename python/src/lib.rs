//! The native module `softsense._softsense`: a thin layer over the `softsense` library.
//!
//! Arrays cross as little-endian bytes (positions f32, colours u8, labels u32, FE values
//! f64) and the Python package views them as numpy arrays; parameters and reports cross as
//! JSON, so the names are the library's field names and a report is exactly what
//! `softsense sense --json` prints. Work runs with the GIL released.

mod batch;
mod cloud;
mod explain;
mod model;
mod scene;
mod sense;

use pyo3::prelude::*;

pyo3::create_exception!(
    _softsense,
    SoftsenseError,
    pyo3::exceptions::PyException,
    "An error of the softsense library; the message is the one the command line prints."
);

/// A library error as a Python exception, with the library's message.
pub(crate) fn error(e: impl std::fmt::Display) -> PyErr {
    SoftsenseError::new_err(e.to_string())
}

/// The parameters `T` (a `#[serde(default)]` struct) from the JSON object `overrides`,
/// absent names taking `T::default()`'s values: an unknown name is a `TypeError` that
/// lists the known ones, so a misspelt keyword argument is never ignored.
pub(crate) fn params<T>(overrides: Option<&str>, what: &str) -> PyResult<T>
where
    T: Default + serde::Serialize + serde::de::DeserializeOwned,
{
    let Some(text) = overrides else {
        return Ok(T::default());
    };
    let given: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(text).map_err(error)?;
    // Only the names of the defaults are used: a non-finite default serialises as null.
    let defaults = serde_json::to_value(T::default()).map_err(error)?;
    let known: Vec<&String> = defaults
        .as_object()
        .map(|o| o.keys().collect())
        .unwrap_or_default();
    if let Some(key) = given.keys().find(|k| !known.contains(k)) {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: unknown parameter {key:?} (known: {known:?})"
        )));
    }
    serde_json::from_value(serde_json::Value::Object(given))
        .map_err(|e| error(format!("{what}: {e}")))
}

#[pymodule]
fn _softsense(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SoftsenseError", m.py().get_type::<SoftsenseError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    batch::register(m)?;
    cloud::register(m)?;
    explain::register(m)?;
    model::register(m)?;
    scene::register(m)?;
    sense::register(m)?;
    Ok(())
}

//! The model-discrepancy workflow (`softsense explain`) and its hidden-effect datasets
//! (`softsense hidden`); results cross as the JSON the command line prints.

use crate::error;
use crate::model::Model;
use pyo3::prelude::*;
use softsense::discrepancy::data::load_frames;
use softsense::discrepancy::generate::{generate_dataset, layout, DatasetSpec, EFFECT_TYPES};
use softsense::discrepancy::{explain, DiscrepancyParams};
use softsense::segment::robot_color::RobotColorModel;
use std::path::PathBuf;

/// Where the model and the frames in `frames` disagree and which missing effect explains
/// it (`softsense explain MODEL FRAMES --json`); `holdout` is the share of frames held out
/// to confirm the explanation. Returns the explanation as JSON.
#[pyfunction]
#[pyo3(signature = (model, frames, robot_color=(40, 200, 60), holdout=0.25))]
fn explain_frames(
    py: Python<'_>,
    model: &Model,
    frames: PathBuf,
    robot_color: (u8, u8, u8),
    holdout: f64,
) -> PyResult<String> {
    let color = RobotColorModel::with_reference([robot_color.0, robot_color.1, robot_color.2]);
    let rec = load_frames(&frames, &color).map_err(error)?;
    let params = DiscrepancyParams {
        holdout,
        ..Default::default()
    };
    let x = py
        .detach(|| explain(&model.0, &rec, &params))
        .map_err(error)?;
    serde_json::to_string(&x).map_err(error)
}

/// Writes a dataset of `frames` frames of `model` with hidden `effects` into `out`
/// (`out/frames`, `out/truth_hidden.json`; `softsense hidden`); returns the hidden truth
/// as JSON.
#[pyfunction]
#[pyo3(signature = (out, model, effects, magnitude=0.5, seed=1, frames=8))]
fn hidden_dataset(
    py: Python<'_>,
    out: PathBuf,
    model: PathBuf,
    effects: Vec<String>,
    magnitude: f64,
    seed: u64,
    frames: usize,
) -> PyResult<String> {
    if let Some(e) = effects.iter().find(|e| !EFFECT_TYPES.contains(&e.as_str())) {
        return Err(error(format!(
            "effect {e:?}: use one of {}",
            EFFECT_TYPES.join(", ")
        )));
    }
    let spec = DatasetSpec {
        model,
        frames,
        seed,
        effects,
        magnitude,
        ..Default::default()
    };
    let (frames_dir, truth) = layout(&out);
    let made = py
        .detach(|| generate_dataset(&spec, &frames_dir, &truth))
        .map_err(error)?;
    serde_json::to_string(&made).map_err(error)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(explain_frames, m)?)?;
    m.add_function(wrap_pyfunction!(hidden_dataset, m)?)
}

//! Scenes and calibration: `scene generate`, `scene sweep` and `calibrate` with the
//! command line's options; results cross as the JSON those commands write.

use crate::error;
use crate::model::Model;
use pyo3::prelude::*;
use softsense::calibrate::{calibrate, read_pose, recording_robot_points, CalibrateParams};
use softsense::recording::Recording;
use softsense::scene::sweep::{self, Sweep};
use softsense::scene::{generate, Scene};
use softsense::segment::robot_color::RobotColorModel;
use std::path::PathBuf;

fn json(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(error)
}

/// Generates the recording a scene file describes into `out` (`softsense scene generate`);
/// returns its truth as the JSON of `truth.json`.
#[pyfunction]
fn scene_generate(py: Python<'_>, spec: PathBuf, out: PathBuf) -> PyResult<String> {
    let scene = Scene::load(&spec).map_err(error)?;
    let truth = py
        .detach(|| generate(&scene, &out, |_, _| {}))
        .map_err(|e| error(format!("{}: {e}", spec.display())))?;
    json(&truth)
}

/// Draws `count` scenes of a sweep file with `seed` into the new or empty folder `out`
/// (`softsense scene sweep`); returns what was drawn for each, as JSON.
#[pyfunction]
fn scene_sweep(
    py: Python<'_>,
    spec: PathBuf,
    out: PathBuf,
    count: usize,
    seed: u64,
) -> PyResult<String> {
    if std::fs::read_dir(&out).is_ok_and(|mut d| d.next().is_some()) {
        return Err(error(format!(
            "{} is not empty: a sweep writes into a new or empty folder",
            out.display()
        )));
    }
    let s = Sweep::load(&spec).map_err(error)?;
    let records = py
        .detach(|| sweep::run(&s, &out, count, seed, |_, _| {}))
        .map_err(|e| error(format!("{}: {e}", spec.display())))?;
    json(&records)
}

/// The camera pose and cable inputs from one frame of a recording and a rough start pose
/// (`softsense calibrate`, thesis 3.3.2); returns the calibration as JSON (the content of
/// `calibration.json` without the model's path). `start` defaults to the recording's
/// `rough_pose.json`. The recording is a path: it is opened as `softsense calibrate` opens
/// it (one camera).
#[pyfunction]
#[pyo3(signature = (recording, model, start=None, frame=0, robot_color=(40, 200, 60)))]
fn calibrate_recording(
    py: Python<'_>,
    recording: PathBuf,
    model: &Model,
    start: Option<PathBuf>,
    frame: usize,
    robot_color: (u8, u8, u8),
) -> PyResult<String> {
    let start = start.unwrap_or_else(|| recording.join("rough_pose.json"));
    if !start.exists() {
        return Err(error(format!(
            "no rough start pose: {} does not exist (give start=POSE.json with \
             {{\"robot_from_camera\": 4x4}})",
            start.display()
        )));
    }
    let params = CalibrateParams {
        color: RobotColorModel::with_reference([robot_color.0, robot_color.1, robot_color.2]),
        ..Default::default()
    };
    let start = read_pose(&start).map_err(error)?;
    let model = &model.0;
    let rec = Recording::open(&recording).map_err(error)?;
    let cal = py
        .detach(|| {
            let points = recording_robot_points(&rec, frame, &params)?;
            calibrate(model, &points, &start, &params, |_, _| {})
        })
        .map_err(error)?;
    json(&cal)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(scene_generate, m)?)?;
    m.add_function(wrap_pyfunction!(scene_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_recording, m)?)
}

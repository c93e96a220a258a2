//! One item's work: its recording (generated first for scenes and sweep scenes), sensed
//! frame by frame as `softsense sense --json` senses it.

use super::manifest::{Item, SenseOptions, Source};
use crate::fem::model::Model;
use crate::io::outputs::StagedDir;
use crate::scene::sweep::{self, Prepared, Sweep};
use crate::scene::{generate, Scene};
use crate::sense::{compare, FrameReport, Rig, SenseParams, Sensor};
use std::path::{Path, PathBuf};

/// The recording folder of an item that generates one: `OUT/recordings/ID`.
pub fn recording_dir(out: &Path, id: &str) -> PathBuf {
    out.join("recordings").join(id)
}

/// Runs `item`: its frame reports (in frame order), or why it failed. `window` frames
/// are sensed side by side; the reports do not depend on it.
pub fn run_item(item: &Item, out: &Path, window: usize) -> Result<Vec<FrameReport>, String> {
    let (dir, model) = match &item.source {
        Source::Recording { path } => (path.clone(), None),
        Source::Scene { spec } => {
            let scene = Scene::load(spec).map_err(|e| e.to_string())?;
            let staged = staged_dir(out, &item.id)?;
            generate(&scene, staged.path(), |_, _| {})
                .map_err(|e| format!("{}: {e}", spec.display()))?;
            (commit(staged, out, &item.id)?, Some(scene.model_path))
        }
        Source::SweepScene { spec, seed, index } => {
            let sweep = Sweep::load(spec).map_err(|e| e.to_string())?;
            let prepared = Prepared::new(&sweep).map_err(|e| format!("{}: {e}", spec.display()))?;
            let staged = staged_dir(out, &item.id)?;
            sweep::write_drawn(&sweep, &prepared, *seed, *index, staged.path())
                .map_err(|e| format!("{}: {e}", spec.display()))?;
            (commit(staged, out, &item.id)?, Some(sweep.model_path))
        }
    };
    sense_recording(&dir, &item.options, model.as_deref(), window)
}

/// The folder `OUT/recordings/ID` is generated in: a new one beside it, so a failed or
/// interrupted item leaves the old recording (or none) there, never half of one.
fn staged_dir(out: &Path, id: &str) -> Result<StagedDir, String> {
    StagedDir::new(&recording_dir(out, id)).map_err(|e| e.to_string())
}

/// Puts the generated recording at `OUT/recordings/ID`: the files an earlier run of the
/// item wrote there are replaced, and any other file (the user's) is kept, since batch
/// never deletes a file it did not write ([`StagedDir::commit_keeping`]).
fn commit(staged: StagedDir, out: &Path, id: &str) -> Result<PathBuf, String> {
    staged.commit_keeping().map_err(|e| e.to_string())?;
    Ok(recording_dir(out, id))
}

/// Senses every frame of the recording `dir` with `options`, as `softsense sense` does
/// (the same parameters, cable inputs and errors against `truth.json`). The model is
/// `options.model`, else `default_model`, else the one the recording names.
pub fn sense_recording(
    dir: &Path,
    options: &SenseOptions,
    default_model: Option<&Path>,
    window: usize,
) -> Result<Vec<FrameReport>, String> {
    let mut rec = Rig::open(dir).map_err(|e| e.to_string())?;
    if let Some(pose) = &options.pose {
        rec = rec.with_pose_file(pose).map_err(|e| e.to_string())?;
    }
    let model_path = options
        .model
        .clone()
        .or_else(|| default_model.map(Path::to_path_buf))
        .or_else(|| rec.shared().model_path())
        .ok_or_else(|| {
            format!(
                "{} has no truth.json or calibration.json naming its model: give `model = \
                 \"MODEL.toml\"` in the manifest",
                dir.display()
            )
        })?;
    let model = Model::load(&model_path, None).map_err(|e| e.to_string())?;
    let params = SenseParams::with_options(
        options.registration.map(Into::into).unwrap_or_default(),
        options.robot_color.unwrap_or([40, 200, 60]),
        options.max_contacts,
        options.features,
    );
    let mut sensor = Sensor::for_rig(model, &rec, params)
        .map_err(|e| format!("{e}: give `pose = \"POSE.json\"` in the manifest"))?;
    // As `sense`: recorded actuator inputs win, else a calibration's, else the model's.
    sensor
        .use_recording_inputs(rec.shared())
        .map_err(|e| e.to_string())?;
    let mut reports = Vec::with_capacity(rec.frames.len());
    sensor
        .sense_frames(&rec, &rec.frames, window, |_, mut report| {
            if let Some(t) = rec.shared().truth_of(report.frame) {
                report.errors = Some(compare(&report, t));
            }
            reports.push(report);
            Ok::<(), String>(())
        })
        .map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(reports)
}

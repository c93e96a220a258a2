//! `softsense sense --rerun OUT.rrd`: the frames as a rerun recording, when the binary was
//! built with the `rerun` feature; a usage error naming the feature otherwise.

use super::CliError;
use softsense::sense::{FrameReport, Observation, Rig, SenseResult, Sensor};
use std::path::Path;

/// Refuses an OUT.rrd that is a file the run reads: a frame, camera or truth file of one
/// of `rig`'s folders, or one of `named` (the model, the pose file).
pub fn check_path<'a>(
    path: &Path,
    rig: &Rig,
    named: impl Iterator<Item = &'a std::path::PathBuf>,
) -> Result<(), CliError> {
    let mut inputs: Vec<std::path::PathBuf> = (rig.cameras.iter())
        .flat_map(|c| super::recording_files(&c.recording.dir))
        .collect();
    inputs.extend(named.cloned());
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    super::check_output_file(path, &inputs)
}

/// Where the frames go.
pub struct RerunOut {
    #[cfg(feature = "rerun")]
    writer: softsense::render::rrd::RrdWriter,
    frames: usize,
}

impl RerunOut {
    /// Creates `path` and logs what holds for every frame: the axes and the cameras.
    #[cfg(feature = "rerun")]
    pub fn create(path: &Path, sensor: &Sensor, rig: &Rig) -> Result<Self, CliError> {
        use softsense::render::{rrd::RrdWriter, scene3d};
        let writer = RrdWriter::create(path, "softsense").map_err(result_error)?;
        let cameras: Vec<_> = rig.cameras.iter().map(|c| &c.recording).collect();
        writer
            .log(None, &scene3d::static_entities(sensor, &cameras))
            .map_err(result_error)?;
        Ok(RerunOut { writer, frames: 0 })
    }

    /// Without the feature: says how to get it.
    #[cfg(not(feature = "rerun"))]
    pub fn create(path: &Path, _: &Sensor, _: &Rig) -> Result<Self, CliError> {
        Err(CliError::Usage(format!(
            "--rerun {}: this softsense was built without rerun; build it with `cargo build \
             --release --features rerun` (or `cargo install --path . --features rerun`), or \
             log from Python with `softsense.rerun` (docs/rerun.md)",
            path.display()
        )))
    }

    /// Logs one frame.
    #[cfg(feature = "rerun")]
    pub fn frame(
        &mut self,
        sensor: &Sensor,
        obs: &SenseResult<Observation>,
        report: &FrameReport,
    ) -> Result<(), CliError> {
        use softsense::render::scene3d::{frame_entities, SceneParams};
        let entities = frame_entities(sensor, obs.as_ref().ok(), report, &SceneParams::default());
        self.writer
            .log(Some(report.frame), &entities)
            .map_err(result_error)?;
        self.frames += 1;
        Ok(())
    }

    /// Never called: `create` refused.
    #[cfg(not(feature = "rerun"))]
    pub fn frame(
        &mut self,
        _: &Sensor,
        _: &SenseResult<Observation>,
        _: &FrameReport,
    ) -> Result<(), CliError> {
        self.frames += 1;
        Ok(())
    }

    /// Completes the file; returns how many frames it holds.
    pub fn finish(self) -> Result<usize, CliError> {
        #[cfg(feature = "rerun")]
        self.writer.finish().map_err(result_error)?;
        Ok(self.frames)
    }
}

#[cfg(feature = "rerun")]
fn result_error(e: softsense::render::rrd::RrdError) -> CliError {
    CliError::Result(e.to_string())
}

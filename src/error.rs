//! The crate-level error: one variant per stage, each wrapping that stage's own enum.

use thiserror::Error;

/// Any error softsense can return. Each stage has its own enum; this gathers them.
#[derive(Debug, Error)]
pub enum Error {
    /// Reading or writing files (clouds, images, intrinsics).
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// A point-cloud operation was given inconsistent data.
    #[error(transparent)]
    Cloud(#[from] crate::cloud::CloudError),
    /// The finite-element core: meshes, models, solves.
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
    /// A filter was given invalid parameters.
    #[error(transparent)]
    Filter(#[from] crate::filter::FilterError),
    /// Normal estimation was given invalid parameters.
    #[error(transparent)]
    Features(#[from] crate::features::FeatureError),
    /// The filter chain could not run (bad configuration, unreadable sequence).
    #[error(transparent)]
    Pipeline(#[from] crate::pipeline::PipelineError),
    /// The inverse model: QPs and force intensities.
    #[error(transparent)]
    Inverse(#[from] crate::inverse::InverseError),
    /// Marker-based sensing: track and candidate files, binding, the per-frame forces.
    #[error(transparent)]
    Markers(#[from] crate::markers::MarkersError),
    /// Synthetic scenes: scene files, direct model, rendering.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The model-discrepancy workflow.
    #[error(transparent)]
    Discrepancy(#[from] crate::discrepancy::DiscrepancyError),
    /// Segmentation or clustering was given invalid parameters or data.
    #[error(transparent)]
    Segment(#[from] crate::segment::SegmentError),
    /// Drawing pictures: canvas sizes, meshes to render, PNG files.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Reading a recording folder.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
    /// A marker track file.
    #[error(transparent)]
    Tracks(#[from] crate::recording::tracks::TracksError),
    /// Importing a camera recording (rosbag v1, MCAP).
    #[error(transparent)]
    Import(#[from] crate::recording::import::ImportError),
    /// Force sensing.
    #[error(transparent)]
    Sense(#[from] crate::sense::SenseError),
    /// Batch runs: the manifest, the output folder, result files.
    #[error(transparent)]
    Batch(#[from] crate::batch::BatchError),
    /// Calibration of the camera pose and actuator inputs.
    #[error(transparent)]
    Calibrate(#[from] crate::calibrate::CalibrateError),
    /// The catheter workflow: its path, tube and control law.
    #[error(transparent)]
    Catheter(#[from] crate::catheter::CatheterError),
}

/// `Result` with the crate-level [`Error`](enum@Error).
pub type Result<T, E = Error> = std::result::Result<T, E>;

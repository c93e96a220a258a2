//! The model-discrepancy workflow (design section 6): find where simulation and measurement
//! disagree, name the missing effect from a library of candidates, add it to the model and
//! show the gap shrink on held-out frames.
//!
//! Residuals are measured per frame at feature points (surface-triangle centroids, face
//! normals, see [`features`]) as the offset of the measured surface along the model's normal
//! line, each with its noise from the sensor model (σ = k z² plus depth quantisation, along
//! the normal, averaged over the points the line gathers). Per region a chi-square-like
//! score z = (χ² − n)/√(2n) says whether the disagreement is above the noise floor.
//! Candidate effects ([`effects`]) are linearised about the nominal solution of every frame
//! (finite differences of FE solves for material, gravity and actuators; compliance rows,
//! with the cables' geometric stiffness, for point loads; closed forms for camera pose and
//! depth), fitted on training frames by least squares, compared by BIC, refined with
//! exact FE re-solves (chord iterations; Gauss-Newton for point loads, whose compliance is
//! re-linearised at the current estimate),
//! and kept only if they also lower the held-out χ². Stepwise: add the best candidate
//! (refitted jointly with the kept effects) while BIC and held-out χ² improve, drop kept
//! effects a later one made redundant, then try swapping each kept effect for another
//! candidate. When that path ends above the noise floor or with more than two effects,
//! every pair of candidates is fitted jointly (two effects at once can make the first
//! pick wrong) and the best pair, if it beats the path's answer by the same BIC and
//! held-out tests, is the new start. Every re-solve is warm-started from the frame's
//! nominal solution; a chord step that overshoots is halved.
//!
//! Files: [`params`](DiscrepancyParams), `workflow` (entry points, shared state), `frame`
//! (per-frame problem, nominal solve, sensitivities), `residual` (residuals, region
//! statistics), `fit` (linear and exact fits), `select` (the choice between effects),
//! `holdout` (split, confirmation), [`explanation`](Explanation) (what is reported),
//! [`effects`], [`features`], [`data`] (frames folder), [`generate`] (hidden-effect
//! datasets), [`truth`] (their body when it is not the model), [`report`] (report folder; its pictures are drawn by
//! [`crate::render::discrepancy`]).
//!
//! ```
//! use softsense::discrepancy::effects::{rotation, rotation_vector};
//! let w = [0.01, -0.02, 0.005];
//! let back = rotation_vector(&rotation(w));
//! assert!((0..3).all(|k| (back[k] - w[k]).abs() < 1e-12));
//! ```

pub mod body;
pub mod data;
pub mod effects;
mod explanation;
pub mod features;
mod fit;
mod frame;
pub mod generate;
mod holdout;
mod params;
pub mod report;
mod residual;
mod select;
pub mod truth;
mod workflow;

pub use explanation::{
    CandidateScore, Explanation, FittedEffect, Outcome, RegionStats, Residual, Step,
};
pub use frame::frame_problem;
pub use holdout::split_frames;
pub use params::DiscrepancyParams;
pub use workflow::{candidate_kinds, evaluate, explain, load_candidates};

use thiserror::Error;

/// Errors of the discrepancy workflow.
#[derive(Debug, Error)]
pub enum DiscrepancyError {
    /// An output file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// `hidden --truth`'s value cannot be used (it names the value and why).
    #[error("--truth {arg:?}: {problem}")]
    Truth {
        /// The value as given.
        arg: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The recording or the parameters are inconsistent.
    #[error("discrepancy: {0}")]
    Data(String),
    /// The FE model failed.
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
    /// Scene generation failed.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// The recording folder could not be read.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
    /// An image could not be read.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

/// `Result` of the discrepancy workflow.
pub type DiscrepancyResult<T> = std::result::Result<T, DiscrepancyError>;

//! The inverse model: a small QP layer over clarabel ([`qp`]), the normal-space intensity
//! QP of thesis 4.5.2 (equations 4.14-4.18, [`intensity`]), the least squares'
//! identifiability and covariance it shares with the markers ([`lsq`]), and the per-frame
//! sensing loop built on them: one entry, [`estimate`] (the loop, [`sensing`]), its
//! linearisation ([`linearise`]), the choice of contact locations ([`locations`]) and the
//! forces' uncertainty from shared points ([`uncertainty`]).
//!
//! ```
//! use softsense::inverse::qp::{QpProblem, QpStatus};
//! // minimise (x - 1)^2 subject to x >= 2  ->  x = 2
//! let mut p = QpProblem::new(1);
//! p.p[(0, 0)] = 2.0;
//! p.q[0] = -2.0;
//! p.lower[0] = 2.0;
//! let s = p.solve(&Default::default()).unwrap();
//! assert_eq!(s.status, QpStatus::Solved);
//! assert!((s.x[0] - 2.0).abs() < 1e-6);
//! ```

pub mod dense;
pub mod intensity;
pub mod linearise;
pub mod locations;
pub mod lsq;
pub mod qp;
pub mod sensing;
pub mod uncertainty;

pub use dense::{DenseInputs, DenseParams, DenseView};
pub use linearise::{Candidate, LinearisationPoint};
pub use locations::{choose_locations, Alternative, LocationChoice};
pub use sensing::{estimate, FrameEstimate, FrameInputs, FrameParams, LoopTimings, Start};
pub use uncertainty::SharedPoints;

use thiserror::Error;

/// Errors of the inverse stage.
#[derive(Debug, Error)]
pub enum InverseError {
    /// A QP was given inconsistent dimensions or non-finite data.
    #[error("invalid QP: {0}")]
    InvalidProblem(String),
    /// The QP solver ended without a solution; the status says why.
    #[error("QP not solved: {0:?}")]
    NotSolved(qp::QpStatus),
    /// clarabel refused the problem data or settings.
    #[error("QP solver setup failed: {0}")]
    Setup(String),
    /// The intensity problem is ill-posed (no rows, no unknowns, bad indices).
    #[error("intensity problem: {0}")]
    Intensity(String),
    /// The FE model failed while updating the state.
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
}

/// `Result` of the inverse stage.
pub type InverseResult<T> = std::result::Result<T, InverseError>;

/// `items.map(f)` in order, on rayon's pool with the `parallel` feature: each result depends
/// only on its item, so the output is the same for any number of threads.
pub(crate) fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync + Send) -> Vec<R> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        items.par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        items.iter().map(f).collect()
    }
}

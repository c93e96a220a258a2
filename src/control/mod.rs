//! Position control on the FE model (thesis chapter 3): the model as a predictor of the
//! Jacobian J = W_ea W_aa⁻¹ of a soft robot, the open-loop predictor (3.4), closed-loop
//! controls 1 (3.19) and 2 (3.28-3.29) with Theorem 2's robust-stability bound, and the
//! switched control for feature loss (3.43), on a simulated plant.
//!
//! There is no physical robot: the plant is a second FE model that differs from the
//! controller's ([`plant`]), seen through a sensor with noise, latency and lost frames.
//!
//! The package: [`scenario`] (the scenario file), [`task`] (targets along time),
//! [`predictor`] (the model's kinematics and the bounded input allocation), [`plant`] (the
//! simulated robot and sensor), [`law`] (one step of each law, Theorem 2), [`run`] (the
//! loop and its summary), [`output`] (CSV and JSON; the pictures are [`crate::render::control`]).
//!
//! ```no_run
//! use softsense::control::{run::run, scenario::Scenario};
//! let s = Scenario::load("scenarios/control/positioning.toml".as_ref())?;
//! let r = run(&s, &mut |_, _| {})?;
//! println!("settled error {:.3} mm", r.summary.settled_error_mm);
//! # Ok::<(), softsense::control::ControlError>(())
//! ```

pub mod law;
pub mod output;
pub mod plant;
pub mod predictor;
pub mod run;
pub mod scenario;
pub mod task;

use crate::fem::FemError;
use crate::inverse::InverseError;
use thiserror::Error;

/// Errors of the control package.
#[derive(Debug, Error)]
pub enum ControlError {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The scenario is invalid.
    #[error("invalid scenario: {0}")]
    Scenario(String),
    /// An FE model failed to load or solve.
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The allocation QP failed.
    #[error("input allocation: {0}")]
    Qp(#[from] InverseError),
    /// A Jacobian or W_aa could not be inverted.
    #[error("singular kinematics: {0}")]
    Singular(String),
    /// A static solve did not converge.
    #[error("the FE solve did not converge (residual {residual:e} N)")]
    NotConverged {
        /// The last residual (N).
        residual: f64,
    },
    /// An output file could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// The run could not be turned into JSON.
    #[error("the run as JSON: {0}")]
    Json(#[source] serde_json::Error),
}

/// `Result` with [`ControlError`].
pub type ControlResult<T> = std::result::Result<T, ControlError>;

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
use std::path::PathBuf;
use thiserror::Error;

/// Errors of the control package. Each names the file, field or effector it is about.
#[derive(Debug, Error)]
pub enum ControlError {
    /// A file could not be read or its folder created.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A scenario file is not valid TOML or has unknown or mistyped keys.
    #[error("{path}: {source}")]
    Toml {
        /// The scenario file.
        path: String,
        /// What the TOML reader said (with the line and key).
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A scenario field is out of its range.
    #[error("{}: {field} {problem}", scenario_name(file))]
    Field {
        /// The scenario file (empty for a scenario built in code).
        file: PathBuf,
        /// The field, as written in the file (`plant.young_factor`).
        field: &'static str,
        /// What is wrong with its value.
        problem: FieldProblem,
    },
    /// The model has no effector of that name (or none at all).
    #[error("the model has no effector {} (it has [{}])", name.as_deref().unwrap_or("(any)"), available.join(", "))]
    NoEffector {
        /// The name asked for (`controller.effector`); `None`: any.
        name: Option<String>,
        /// The effectors it has.
        available: Vec<String>,
    },
    /// The effector is not a 3-D point.
    #[error("effector {effector:?} has {rows} rows; control needs a 3-D point (no direction)")]
    NotAPoint {
        /// The effector.
        effector: String,
        /// How many rows it has.
        rows: usize,
    },
    /// The model has no cable to control.
    #[error("the model has no cables to control")]
    NoCables,
    /// The model has no cavity to control (pressure actuation).
    #[error("the model has no cavities ([[cavities]]) to control with actuation = \"pressure\"")]
    NoCavities,
    /// An FE model failed to load or solve.
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The plant's model failed to solve: with `plant.young_factor` this far from 1, the
    /// likely cause.
    #[error("the plant ({}): {source} (plant.young_factor = {young_factor}: a very soft or very stiff plant inverts elements under the same inputs)", scenario_name(file))]
    Plant {
        /// The scenario file.
        file: PathBuf,
        /// The plant's Young's modulus factor.
        young_factor: f64,
        /// The FE failure.
        #[source]
        source: FemError,
    },
    /// The allocation QP failed.
    #[error("input allocation: {0}")]
    Qp(#[from] InverseError),
    /// A matrix of the kinematics could not be inverted.
    #[error("singular kinematics: {what} cannot be inverted")]
    Singular {
        /// Which: `J` or `W_aa`.
        what: &'static str,
    },
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

/// A scenario's file for messages; "scenario" for one built in code.
fn scenario_name(file: &std::path::Path) -> String {
    match file.as_os_str().is_empty() {
        true => "scenario".into(),
        false => file.display().to_string(),
    }
}

/// What is wrong with a scenario field's value.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FieldProblem {
    /// NaN or infinite.
    #[error("must be finite, got {0}")]
    NotFinite(f64),
    /// Zero, negative or not finite where a positive number is needed.
    #[error("must be positive, got {0}")]
    NotPositive(f64),
    /// Negative or not finite where zero is allowed.
    #[error("must be >= 0, got {0}")]
    Negative(f64),
    /// Outside the open interval (0, 1).
    #[error("must be in (0, 1), got {0}")]
    NotInUnitInterval(f64),
    /// More than allowed, or zero where at least one is needed.
    #[error("must be in {min}..={max}, got {got}")]
    Count {
        /// The least allowed.
        min: usize,
        /// The most allowed.
        max: usize,
        /// The value given.
        got: usize,
    },
    /// Limits that are not finite or not increasing.
    #[error("must be [min, max] with min < max, got {0:?}")]
    Limits([f64; 2]),
    /// A value outside the limits.
    #[error("{value} is outside the limits {limits:?}")]
    OutsideLimits {
        /// The value.
        value: f64,
        /// `controller.limits`.
        limits: [f64; 2],
    },
    /// A step range whose end comes before its start.
    #[error("range {0:?} ends before it starts")]
    Backwards([usize; 2]),
    /// A direction of zero length or not finite.
    #[error("{0:?} has no length")]
    NoLength([f64; 3]),
    /// Exactly one of two keys must be given.
    #[error("give exactly one of {0} and {1}, finite")]
    ExactlyOne(&'static str, &'static str),
    /// An angle per step beyond half a turn: the path aliases.
    #[error(
        "must be at most π rad a step (a faster path aliases between steps), got {0:?} rad a step"
    )]
    TooFast(f64),
}

/// `Result` with [`ControlError`].
pub type ControlResult<T> = std::result::Result<T, ControlError>;

//! A cable-driven catheter controlled through contacts (thesis chapter 5): the path and
//! the tube it is inserted through with node-based collision detection ([`tube`]), the
//! mapping onto the bending plane (Algorithm 5.1, [`mapping`]) and the robot controller's
//! PD law with its Jacobian-rotation check (5.18-5.22, [`law`]); the coupled baseline that
//! shows that rotation ([`coupled`], 5.3.1); the catheter as a tetrahedral solid, the
//! beam's cross-check ([`tetra`]).
//!
//! The FE model of the catheter is [`crate::fem::beam`]; the contact LCP and the FEM
//! controller's QPCC (5.6-5.15) are [`crate::inverse::qpcc`].

// `!(x > 0.0)` is used on purpose: it also rejects NaN, which `x <= 0.0` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod coupled;
pub mod law;
pub mod mapping;
pub mod output;
pub mod rig;
pub mod run;
pub mod scenario;
pub mod soft_wall;
pub mod statics;
pub mod tetra;
pub mod tracker;
pub mod tube;

use thiserror::Error;

/// Errors of the catheter workflow.
#[derive(Debug, Error)]
pub enum CatheterError {
    /// A path or tube is not valid (too few points, a zero length, a bad radius).
    #[error("catheter path: {0}")]
    Path(String),
    /// Matrices or vectors of mismatched sizes.
    #[error("catheter: {0}")]
    Shape(String),
    /// A matrix the law inverts is singular.
    #[error("catheter: {what} is singular (rank {rank})")]
    Singular {
        /// Which matrix.
        what: &'static str,
        /// Its numerical rank.
        rank: usize,
    },
    /// The beam model failed (a bad section, a singular tangent).
    #[error("catheter model: {0}")]
    Fem(#[from] crate::fem::FemError),
    /// A contact or QPCC solve failed to set up.
    #[error("catheter contact: {0}")]
    Inverse(#[from] crate::inverse::InverseError),
    /// A scenario or output file could not be read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A scenario file is not valid TOML for a scenario.
    #[error("{path}: {source}")]
    Toml {
        /// The file.
        path: String,
        /// The parser's error.
        source: Box<toml::de::Error>,
    },
    /// A scenario field is out of range.
    #[error("{file}: {field} {problem}")]
    Field {
        /// The scenario file.
        file: String,
        /// The field, dotted.
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// An output could not be written.
    #[error("catheter output: {0}")]
    Output(#[from] crate::io::atomic::AtomicError),
}

/// Result of the catheter workflow.
pub type CatheterResult<T> = Result<T, CatheterError>;

//! A cable-driven catheter controlled through contacts (thesis chapter 5): the path and
//! the tube it is inserted through with node-based collision detection ([`tube`]), the
//! mapping onto the bending plane (Algorithm 5.1, [`mapping`]) and the robot controller's
//! PD law with its Jacobian-rotation check (5.18-5.22, [`law`]).
//!
//! The FE model of the catheter is [`crate::fem::beam`]; the contact LCP and the FEM
//! controller's QPCC (5.6-5.15) are [`crate::inverse::qpcc`].

// `!(x > 0.0)` is used on purpose: it also rejects NaN, which `x <= 0.0` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod law;
pub mod mapping;
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
}

/// Result of the catheter workflow.
pub type CatheterResult<T> = Result<T, CatheterError>;

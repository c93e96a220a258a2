//! The inverse model: a small QP layer over clarabel ([`qp`]), the normal-space intensity
//! QP of thesis 4.5.2 (equations 4.14-4.18, [`intensity`]), the least squares'
//! identifiability and covariance it shares with the markers ([`lsq`]), and the per-frame
//! sensing loop built on them: the candidate forces and their loads ([`candidate`]), one entry, [`estimate`] (the loop, [`sensing`]), its
//! linearisation ([`linearise`]), the choice of contact locations ([`locations`]) and the
//! forces' uncertainty from shared points ([`uncertainty`]). The contact LCP and the FEM
//! controller's QP with complementarity constraints of thesis chapter 5 are in [`qpcc`].
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

pub mod candidate;
pub mod dense;
pub mod intensity;
pub mod linearise;
pub mod locations;
pub mod lsq;
pub mod pushes;
pub mod qp;
pub mod qpcc;
pub mod sensing;
pub mod tare;
pub mod uncertainty;

pub use candidate::{loads_of, total_force, Candidate};
pub use dense::{DenseInputs, DenseParams, DenseView};
pub use linearise::LinearisationPoint;
pub use locations::{choose_locations, Alternative, LocationChoice};
pub use sensing::{estimate, FrameEstimate, FrameInputs, FrameParams, LoopTimings, Start};
pub use tare::{Tare, TareFit, TareParams};
pub use uncertainty::SharedPoints;

use thiserror::Error;

/// Errors of the inverse stage.
#[derive(Debug, Error)]
pub enum InverseError {
    /// A least-squares QP whose matrix and targets differ in rows.
    #[error("invalid QP: least squares: {rows} rows but {targets} targets")]
    LeastSquaresShape {
        /// Rows of the matrix.
        rows: usize,
        /// Targets given.
        targets: usize,
    },
    /// A QP whose P is not unknowns x unknowns.
    #[error("invalid QP: P is {rows}x{cols}, q has {unknowns}")]
    ObjectiveShape {
        /// Rows of P.
        rows: usize,
        /// Columns of P.
        cols: usize,
        /// Unknowns (q's length).
        unknowns: usize,
    },
    /// A QP's constraint rows and right-hand side disagree (`kind`: equality or inequality).
    #[error("invalid QP: {kind} rows and right-hand side disagree")]
    ConstraintShape {
        /// "equality" or "inequality".
        kind: &'static str,
    },
    /// A QP's bounds are not one per unknown.
    #[error("invalid QP: bounds must have one entry per unknown ({lower} lower, {upper} upper for {unknowns})")]
    BoundsShape {
        /// Lower bounds given.
        lower: usize,
        /// Upper bounds given.
        upper: usize,
        /// Unknowns.
        unknowns: usize,
    },
    /// A second-order cone whose G, h and the unknowns disagree (or h has fewer than 2 rows).
    #[error("invalid QP: second-order cone {cone} with bad dimensions")]
    ConeShape {
        /// The cone's index.
        cone: usize,
    },
    /// A QP with a non-finite matrix or vector entry (bounds aside).
    #[error("invalid QP: non-finite data")]
    NonFiniteQp,
    /// A QP with a NaN bound.
    #[error("invalid QP: NaN bound")]
    NanBound,
    /// The QP solver ended without a solution; the status says why.
    #[error("QP not solved: {0:?}")]
    NotSolved(qp::QpStatus),
    /// clarabel refused the settings.
    #[error("QP solver setup failed: {0}")]
    Settings(#[from] clarabel::solver::DefaultSettingsBuilderError),
    /// clarabel refused the problem data.
    #[error("QP solver setup failed: {0}")]
    Solver(#[from] clarabel::solver::SolverError),
    /// An intensity problem whose blocks disagree in size.
    #[error("intensity problem: inconsistent dimensions (rows {rows}, actuators {actuators}, forces {forces})")]
    IntensityShape {
        /// Feature rows (δ_measured's length).
        rows: usize,
        /// Actuators.
        actuators: usize,
        /// Candidate forces.
        forces: usize,
    },
    /// A push problem whose parts disagree in size.
    #[error(
        "push problem: {rows} compliance rows, {free} free values, {observed} observed, \
         {sigma} sigmas; {pushes} pushes, {directions} directions, {positions} positions"
    )]
    PushShape {
        /// Rows of the compliance.
        rows: usize,
        /// Free values given.
        free: usize,
        /// Observed values given.
        observed: usize,
        /// Sigmas given.
        sigma: usize,
        /// Columns of the compliance.
        pushes: usize,
        /// Directions given.
        directions: usize,
        /// Positions given.
        positions: usize,
    },
    /// A push problem row whose sigma is not positive and finite.
    #[error("push problem: row {row} has sigma {sigma} m (must be positive)")]
    PushSigma {
        /// The row.
        row: usize,
        /// Its sigma.
        sigma: f64,
    },
    /// No feature row is visible: nothing to fit.
    #[error("intensity problem: no visible feature rows")]
    NoVisibleRows,
    /// A contact without any candidate location.
    #[error("intensity problem: contact {contact} has no location option")]
    NoLocationOption {
        /// The contact's index.
        contact: usize,
    },
    /// Actuator forces that are not one per cable and cavity of the model.
    #[error("intensity problem: {tensions} actuator forces for {cables} cables and cavities")]
    CableTensions {
        /// Tensions given.
        tensions: usize,
        /// The model's actuators (cables and cavities).
        cables: usize,
    },
    /// Every combination of location options was excluded.
    #[error("intensity problem: every combination of location options was excluded")]
    AllLocationsExcluded,
    /// A sensing loop with `max_updates` 0.
    #[error("intensity problem: max_updates is zero")]
    NoUpdates,
    /// A loop asked to go on from one with another number of candidates.
    #[error("intensity problem: a loop of {from} candidates cannot go on with {candidates}")]
    OnwardsCandidates {
        /// The earlier loop's candidates.
        from: usize,
        /// This loop's.
        candidates: usize,
    },
    /// Starting forces that are not one finite value per candidate.
    #[error(
        "intensity problem: {forces} starting forces for {candidates} candidates (or not finite)"
    )]
    StartingForces {
        /// Forces given.
        forces: usize,
        /// Candidates.
        candidates: usize,
    },
    /// A contact LCP whose W_cc is not n_c x n_c for n_c gaps.
    #[error("contact LCP: W_cc is {rows}x{cols} for {gaps} gaps")]
    ContactLcpShape {
        /// Rows of W_cc.
        rows: usize,
        /// Columns of W_cc.
        cols: usize,
        /// Gaps given.
        gaps: usize,
    },
    /// A contact compliance W_cc that is not symmetric positive semi-definite.
    #[error("contact LCP: W_cc not symmetric PSD (asymmetry {asymmetry}, smallest eigenvalue {min_eigenvalue})")]
    ContactCompliance {
        /// max |W_cc − W_ccᵀ|.
        asymmetry: f64,
        /// Smallest eigenvalue of sym(W_cc).
        min_eigenvalue: f64,
    },
    /// A QPCC whose matrices, vectors and bounds disagree in size.
    #[error(
        "QPCC: inconsistent dimensions ({effectors} effectors, {actuators} actuators, \
         {contacts} contacts; W_e and W_c have {columns:?} columns)"
    )]
    QpccShape {
        /// Rows of W_e.
        effectors: usize,
        /// n_a.
        actuators: usize,
        /// Rows of W_c.
        contacts: usize,
        /// Columns of W_e and of W_c.
        columns: (usize, usize),
    },
    /// A QPCC bound that is NaN, empty (lower > upper) or infinite on the wrong side.
    #[error("QPCC: unknown {index} has bounds [{lower}, {upper}]")]
    QpccBounds {
        /// Index into λ = [λ_a; λ_c].
        index: usize,
        /// Its lower bound.
        lower: f64,
        /// Its upper bound.
        upper: f64,
    },
    /// The exhaustive QPCC oracle asked for more contacts than it enumerates.
    #[error("QPCC oracle: {contacts} contacts, at most {max} are enumerated")]
    OracleContacts {
        /// Contacts in the problem.
        contacts: usize,
        /// The oracle's limit.
        max: usize,
    },
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

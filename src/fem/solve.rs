//! The public face of the static solver: [`Solver`] (a prepared problem with its tangent,
//! factor and reusable buffers), and re-exports of what it solves ([`Problem`],
//! [`Cable`]), prepares once ([`SolverSetup`]), carries between solvers ([`SolverState`])
//! and returns ([`Solution`]).
//!
//! Symbolic analysis is done once per mesh and held nodes ([`SolverSetup`]); the numeric
//! factorization is redone at every Newton iteration, with faer's sparse Cholesky.

pub use super::cable::{apply_cable_inputs, Cable, CableControl};
pub use super::cavity::{apply_cavity_inputs, Cavity, CavityControl};
pub use super::factor::SEQUENTIAL_FACTOR_LEN;
pub use super::newton::{norm_vec, NewtonParams, Solution, MAX_ITERATIONS, MAX_LOAD_STEPS};
pub use super::problem::{Formulation, MappedPoint, PointLoad, Problem};
pub use super::setup::SolverSetup;
pub use super::workspace::SolverState;

use super::assembly::{DofMap, Pattern};
use super::pool::Pooled;
use super::tet4::{ElementState, Tangent, TetRest};
use super::{FemError, FemResult};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use std::sync::Arc;

/// A prepared solver: free-DOF map, pattern, symbolic Cholesky, current tangent and factor.
pub struct Solver<'p> {
    /// The problem.
    pub problem: &'p Problem,
    /// Free-DOF numbering.
    pub dofs: Arc<DofMap>,
    /// Sparsity pattern of K.
    pub pattern: Arc<Pattern>,
    pub(super) rest: Arc<Vec<TetRest>>,
    /// Symbolic Cholesky (AMD ordering and supernodal structure), computed once.
    pub(super) symbolic: Arc<SymbolicCholesky<usize>>,
    pub(super) setup: Arc<SolverSetup>,
    /// Values of the supernodal factor L (reused between factorizations).
    pub(super) l_values: Arc<Pooled<f64>>,
    /// Values of K (upper triangle) after the last assembly.
    pub values: Vec<f64>,
    /// Internal forces (node-major 3n) after the last assembly.
    pub internal_force: Vec<f64>,
    /// Element states of the last assembly (corotational: only the tangent blocks of
    /// [`Pattern::block_mask`] are computed, the others hold whatever the buffer held:
    /// the scatter reads no others).
    pub(super) elements: Arc<Pooled<ElementState>>,
    /// Node positions at which `elements` and `internal_force` were evaluated, and with
    /// which tangent (empty: none yet).
    pub(super) elements_at: Vec<[f64; 3]>,
    pub(super) elements_tangent: Tangent,
    /// K as scattered from `elements` (empty: not yet): assembling again at `elements_at`
    /// with the same tangent copies it instead of scattering again (the values a Newton
    /// step or a linearisation added the cables to are restored for the next one).
    pub(super) scattered: Vec<f64>,
    /// Whether `l_values` holds the factor of the current `values`.
    pub(super) factored: bool,
    /// The values `l_values` is the factor of (empty: none). A factorization of the same
    /// values, bit for bit, is skipped: the sensing loop's next FE update starts with
    /// exactly the matrix its last linearisation factorised.
    pub(super) factor_of: Vec<f64>,
    /// The values whose last factorization failed (empty: none): the same values fail
    /// again without the work (a state at the free equilibrium meets its indefinite
    /// consistent tangent once per frame, see [`Solver::tangent_at`]).
    pub(super) failed_of: Vec<f64>,
    /// faer's non-positive pivot in the factorization of `failed_of`.
    pub(super) failed_pivot: usize,
    /// Numeric factorizations attempted by this solver (failed ones included).
    pub(super) factorizations: usize,
    /// Point loads acting besides the problem's own ([`Solver::with_loads`]).
    pub(super) extra_loads: Vec<PointLoad>,
}

impl<'p> Solver<'p> {
    /// Checks supports and mesh, builds the pattern and the symbolic factorization.
    pub fn new(problem: &'p Problem) -> FemResult<Self> {
        Self::with_setup(problem, Arc::new(SolverSetup::new(problem)?))
    }

    /// A solver on a prepared `setup` (rebuilt if it does not fit `problem`); only the loads,
    /// cables and prescribed displacements are checked again.
    pub fn with_setup(problem: &'p Problem, setup: Arc<SolverSetup>) -> FemResult<Self> {
        let setup = if setup.fits(problem) {
            setup
        } else {
            Arc::new(SolverSetup::new(problem)?)
        };
        let l_values = Arc::new(Pooled::fresh(&setup.pool, setup.symbolic.len_val(), 0.0));
        let values = vec![0.0; setup.pattern.nnz()];
        Self::with_buffers(problem, setup, l_values, values)
    }

    /// A solver on `setup` (which fits `problem`) with the factor and matrix buffers given:
    /// [`Problem::solver_from`] hands over a state's instead of zeroing new ones it would
    /// drop (the factor's is the largest buffer of a solver).
    pub(super) fn with_buffers(
        problem: &'p Problem,
        setup: Arc<SolverSetup>,
        l_values: Arc<Pooled<f64>>,
        values: Vec<f64>,
    ) -> FemResult<Self> {
        let points = (problem.loads.iter().map(|l| &l.at))
            .chain(problem.cables.iter().flat_map(|c| &c.attach))
            .chain(problem.cavities.iter().flat_map(|c| &c.vertices));
        check_nodes(problem, points)?;
        let n = problem.mesh.num_nodes();
        if let Some((v, _)) = problem
            .prescribed
            .iter()
            .find(|(v, u)| *v >= n || u.iter().any(|c| !c.is_finite()))
        {
            return Err(FemError::Model(format!(
                "prescribed displacement of node {v} is invalid"
            )));
        }
        if let Some(k) = problem.base_stiffness {
            if !(k > 0.0 && k.is_finite()) {
                return Err(FemError::Model(format!(
                    "base stiffness {k} N/m must be positive and finite"
                )));
            }
        }
        Ok(Self {
            problem,
            dofs: setup.dofs.clone(),
            pattern: setup.pattern.clone(),
            rest: setup.rest.clone(),
            symbolic: setup.symbolic.clone(),
            l_values,
            values,
            internal_force: Vec::new(),
            elements: Arc::new(Pooled::empty(&setup.pool)),
            setup,
            elements_at: Vec::new(),
            elements_tangent: Tangent::default(),
            scattered: Vec::new(),
            factored: false,
            factor_of: Vec::new(),
            failed_of: Vec::new(),
            failed_pivot: 0,
            factorizations: 0,
            extra_loads: Vec::new(),
        })
    }

    /// The same solver with `loads` acting besides the problem's own, which they follow
    /// (sums in that order: the same values as the problem with `loads` pushed onto its
    /// own). A problem solved under changing loads is then not copied, mesh included, per
    /// change. Replaces loads given before.
    pub fn with_loads(mut self, loads: Vec<PointLoad>) -> FemResult<Self> {
        check_nodes(self.problem, loads.iter().map(|l| &l.at))?;
        self.extra_loads = loads;
        Ok(self)
    }

    /// Numeric factorizations this solver attempted, failed ones included (not those of
    /// a state it took over): [`Solver::factorize`] skips values it has factorized, or
    /// failed to factorize, last.
    pub fn factorizations(&self) -> usize {
        self.factorizations
    }

    /// The problem's body forces ([`Problem::body_forces`], the same values), the lumped
    /// masses computed once per setup and density.
    pub fn body_forces(&self) -> Vec<f64> {
        let p = self.problem;
        let bits = p.density.to_bits();
        // Kept for the first density asked for (a problem's density rarely changes).
        match self.setup.lumped.get_or_init(|| (bits, p.lumped_masses())) {
            (b, masses) if *b == bits => p.body_forces_of(masses),
            _ => p.body_forces(),
        }
    }

    /// The external forces: the problem's ([`Problem::external_forces`], the same values)
    /// plus the loads given to [`Solver::with_loads`].
    pub fn external_forces(&self) -> Vec<f64> {
        let f = self.problem.add_point_loads(self.body_forces());
        super::problem::add_loads(f, &self.extra_loads)
    }

    /// Number of free DOFs.
    pub fn ndof(&self) -> usize {
        self.dofs.ndof
    }
}

/// Checks that the `points` a load or cable acts on refer to nodes of `problem`'s mesh.
fn check_nodes<'a>(
    problem: &Problem,
    points: impl Iterator<Item = &'a MappedPoint>,
) -> FemResult<()> {
    let n = problem.mesh.num_nodes();
    for at in points {
        if let Some(v) = at.nodes.iter().find(|&&v| v >= n) {
            return Err(FemError::Model(format!(
                "a load or cable refers to node {v} ({n} nodes)"
            )));
        }
    }
    Ok(())
}

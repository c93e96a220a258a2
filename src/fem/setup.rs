//! What a [`Solver`] prepares once per mesh, held nodes and cable attachments: support and
//! quality checks, element rest data, the free-DOF map, the sparsity pattern, the symbolic
//! Cholesky, and the pool of spare buffers its solvers share.

use super::assembly::{DofMap, Pattern};
use super::pool::BufferPool;
use super::problem::Problem;
use super::tet4::TetRest;
use super::FemResult;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::SymbolicSparseColMatRef;
use faer::Side;
use std::sync::{Arc, OnceLock};

#[cfg(doc)]
use super::solve::Solver;

/// What a [`Solver`] prepares from the mesh, the held nodes and the cable attachments alone
/// (support and quality checks, element rest data, free-DOF map, sparsity pattern, AMD
/// ordering and symbolic Cholesky). Problems differing only in loads, cable controls,
/// material or gravity share it.
pub struct SolverSetup {
    nodes: Vec<[f64; 3]>,
    tets: Vec<[usize; 4]>,
    held: Vec<usize>,
    /// The nodes the support check passed with (held ones and a compliant base's).
    supports: Vec<usize>,
    groups: Vec<Vec<usize>>,
    pub(super) rest: Arc<Vec<TetRest>>,
    pub(super) dofs: Arc<DofMap>,
    pub(super) pattern: Arc<Pattern>,
    pub(super) symbolic: Arc<SymbolicCholesky<usize>>,
    /// [`Problem::lumped_masses`] at one density (its bits, the masses): every Newton
    /// iteration and linearisation needs the body forces.
    pub(super) lumped: OnceLock<(u64, Vec<f64>)>,
    /// Spare factor and element buffers of this setup's solvers (all of one length each).
    pub(super) pool: Arc<BufferPool>,
}

impl std::fmt::Debug for SolverSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SolverSetup")
            .field("nodes", &self.nodes.len())
            .field("tets", &self.tets.len())
            .field("ndof", &self.dofs.ndof)
            .finish_non_exhaustive()
    }
}

fn cable_groups(problem: &Problem) -> Vec<Vec<usize>> {
    problem
        .cables
        .iter()
        .map(|c| c.attach.iter().flat_map(|a| a.nodes).collect())
        // A pressure couples the nodes of each face (mapped vertices reach beyond a tet).
        .chain(problem.cavities.iter().flat_map(|c| c.face_nodes()))
        .collect()
}

impl SolverSetup {
    /// Checks supports and mesh, builds the pattern and the symbolic factorization.
    pub fn new(problem: &Problem) -> FemResult<Self> {
        problem.check_supports()?;
        let rest = (0..problem.mesh.tets.len())
            .map(|t| TetRest::new(t, problem.mesh.corners(t)))
            .collect::<FemResult<Vec<_>>>()?;
        problem.mesh.quality()?;
        let held = problem.held_nodes();
        let dofs = DofMap::new(problem.mesh.num_nodes(), &held);
        let groups = cable_groups(problem);
        let pattern = Pattern::new(&problem.mesh, &dofs, &groups)?;
        let sym = SymbolicSparseColMatRef::new_checked(
            dofs.ndof,
            dofs.ndof,
            &pattern.col_ptr,
            None,
            &pattern.row_idx,
        );
        // Always supernodal: the constraint-space forward solves (constraint.rs) walk the
        // supernodes, and the diamond-sized systems are supernodal under AUTO anyway.
        let symbolic = factorize_symbolic_cholesky(
            sym,
            Side::Upper,
            Default::default(),
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )?;
        Ok(Self {
            nodes: problem.mesh.nodes_in_rest.clone(),
            tets: problem.mesh.tets.clone(),
            held,
            supports: problem.support_nodes(),
            groups,
            rest: Arc::new(rest),
            dofs: Arc::new(dofs),
            pattern: Arc::new(pattern),
            symbolic: Arc::new(symbolic),
            lumped: OnceLock::new(),
            pool: Arc::default(),
        })
    }

    /// Whether this setup was made for `problem`'s mesh, held nodes, supports (a compliant
    /// base's nodes are checked, not held) and cable attachments.
    pub fn fits(&self, problem: &Problem) -> bool {
        self.nodes == problem.mesh.nodes_in_rest
            && self.tets == problem.mesh.tets
            && self.held == problem.held_nodes()
            && self.supports == problem.support_nodes()
            && self.groups == cable_groups(problem)
    }
}

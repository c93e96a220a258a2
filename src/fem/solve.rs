//! The static problem and its Newton solver with faer's sparse Cholesky (symbolic analysis
//! once per mesh and fixed set, numeric refactorization at every iteration).

use super::assembly::{eval_elements, DofMap, Pattern};
use super::material::{von_mises, Material};
use super::mesh::{norm, sub, TetMesh};
use super::tet4::{ElementState, Tangent, TetRest};
use super::{FemError, FemResult};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Side};
use serde::Serialize;
use std::sync::{Arc, OnceLock};

/// Small-strain linear or corotational tetrahedra.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum Formulation {
    /// Linear elasticity about the rest shape (K constant).
    SmallStrain,
    /// Corotational (large displacement, small strain), rotation by polar decomposition.
    #[default]
    Corotational,
}

/// A point attached to the mesh: a weighted sum of (up to) four nodes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MappedPoint {
    /// Node indices.
    pub nodes: [usize; 4],
    /// Barycentric weights (sum 1).
    pub weights: [f64; 4],
}

impl MappedPoint {
    /// A point on node `v`.
    pub fn node(v: usize) -> Self {
        Self {
            nodes: [v; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// Locates `p` in the rest mesh (see [`TetMesh::locate`]).
    pub fn locate(mesh: &TetMesh, p: [f64; 3], max_distance: f64) -> FemResult<Self> {
        let (t, w) = mesh.locate(p, max_distance)?;
        Ok(Self {
            nodes: mesh.tets[t],
            weights: w,
        })
    }

    /// Position for node positions `x`.
    pub fn position(&self, x: &[[f64; 3]]) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (n, w) in self.nodes.iter().zip(self.weights) {
            for k in 0..3 {
                p[k] += w * x[*n][k];
            }
        }
        p
    }
}

/// A force on a mapped point (N).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointLoad {
    /// Where it acts.
    pub at: MappedPoint,
    /// Force vector (N).
    pub force: [f64; 3],
}

/// How a cable is driven.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum CableControl {
    /// Given tension (N, >= 0 pulls).
    Force(f64),
    /// Given shortening of the cable length from rest (m).
    Displacement(f64),
}

/// A cable actuator: from a fixed pull point through attach points on the mesh.
/// Its length is |p1 - pull| + sum |p(i+1) - p(i)|; the actuator value is the shortening
/// L0 - L(x) and the tension lambda >= 0 pulls the attach points along the cable.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cable {
    /// Name (for reports).
    pub name: String,
    /// Fixed pull point in space.
    pub pull: [f64; 3],
    /// Attach points along the cable, from the pull point outward.
    pub attach: Vec<MappedPoint>,
    /// Force or displacement control.
    pub control: CableControl,
}

impl Cable {
    /// Cable length for node positions `x`.
    pub fn length(&self, x: &[[f64; 3]]) -> f64 {
        let mut prev = self.pull;
        let mut l = 0.0;
        for a in &self.attach {
            let p = a.position(x);
            l += norm(sub(p, prev));
            prev = p;
        }
        l
    }

    /// d(shortening)/dx as (node, 3-vector) pairs: minus the length gradient.
    pub fn row(&self, x: &[[f64; 3]]) -> Vec<(usize, [f64; 3])> {
        let pts: Vec<[f64; 3]> = self.attach.iter().map(|a| a.position(x)).collect();
        let unit = |a: [f64; 3], b: [f64; 3]| {
            let d = sub(a, b);
            let l = norm(d);
            if l > 0.0 {
                d.map(|c| c / l)
            } else {
                [0.0; 3]
            }
        };
        let mut out = Vec::new();
        for (i, a) in self.attach.iter().enumerate() {
            let prev = if i == 0 { self.pull } else { pts[i - 1] };
            let mut g = unit(pts[i], prev);
            if i + 1 < pts.len() {
                let u = unit(pts[i + 1], pts[i]);
                for k in 0..3 {
                    g[k] -= u[k];
                }
            }
            for (n, w) in a.nodes.iter().zip(a.weights) {
                if w != 0.0 {
                    out.push((*n, g.map(|c| -w * c)));
                }
            }
        }
        out
    }
}

/// Newton options.
#[derive(Debug, Clone, Serialize)]
pub struct NewtonParams {
    /// Maximum iterations.
    pub max_iterations: usize,
    /// Relative residual tolerance (against the applied force scale).
    pub rel_tol: f64,
    /// Absolute residual tolerance (N).
    pub abs_tol: f64,
    /// Equal load increments (1 = apply everything at once).
    pub load_steps: usize,
    /// Converged when a correction is smaller than this times the displacement norm.
    pub step_tol: f64,
    /// Tolerance on the gaps of displacement-controlled cables (m): 0 means 1e-12 of the
    /// mesh's largest coordinate.
    pub gap_tol: f64,
    /// Corotational tangent (the rotated K0 is used as fallback if the consistent one is indefinite).
    #[serde(skip)]
    pub tangent: Tangent,
}

impl Default for NewtonParams {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            rel_tol: 1e-10,
            abs_tol: 1e-12,
            load_steps: 1,
            step_tol: 1e-10,
            gap_tol: 0.0,
            tangent: Tangent::Consistent,
        }
    }
}

/// The static FE problem: mesh, material, boundary conditions, loads and cables. SI units.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The rest mesh.
    pub mesh: TetMesh,
    /// Material.
    pub material: Material,
    /// Small-strain or corotational.
    pub formulation: Formulation,
    /// Fixed nodes (removed from the system).
    pub fixed: Vec<usize>,
    /// Nodes held at a prescribed displacement (removed from the system as well).
    pub prescribed: Vec<(usize, [f64; 3])>,
    /// Mass density (kg/m^3) for gravity.
    pub density: f64,
    /// Gravity acceleration (m/s^2).
    pub gravity: [f64; 3],
    /// Point loads (N).
    pub loads: Vec<PointLoad>,
    /// Cable actuators.
    pub cables: Vec<Cable>,
    /// Per-tetrahedron factor on Young's modulus (regional stiffness); empty means all 1.
    pub young_scale: Vec<f64>,
    /// The solver setup of the first [`Problem::solver`] call, shared by clones: reused by
    /// later solvers while the mesh, held nodes and cable attachments are unchanged.
    setup_cache: Arc<OnceLock<Arc<SolverSetup>>>,
}

/// What a [`Solver`] prepares from the mesh, the held nodes and the cable attachments alone
/// (support and quality checks, element rest data, free-DOF map, sparsity pattern, AMD
/// ordering and symbolic Cholesky). Problems differing only in loads, cable controls,
/// material or gravity share it: computing it was a fifth of a sensed frame.
pub struct SolverSetup {
    nodes: Vec<[f64; 3]>,
    tets: Vec<[usize; 4]>,
    held: Vec<usize>,
    groups: Vec<Vec<usize>>,
    rest: Arc<Vec<TetRest>>,
    dofs: Arc<DofMap>,
    pattern: Arc<Pattern>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// [`Problem::lumped_masses`] at one density (its bits, the masses): every Newton
    /// iteration and linearisation needs the body forces.
    lumped: OnceLock<(u64, Vec<f64>)>,
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
        )
        .map_err(|e| FemError::Linalg(format!("{e:?}")))?;
        Ok(Self {
            nodes: problem.mesh.nodes_in_rest.clone(),
            tets: problem.mesh.tets.clone(),
            held,
            groups,
            rest: Arc::new(rest),
            dofs: Arc::new(dofs),
            pattern: Arc::new(pattern),
            symbolic: Arc::new(symbolic),
            lumped: OnceLock::new(),
        })
    }

    /// Whether this setup was made for `problem`'s mesh, held nodes and cable attachments.
    pub fn fits(&self, problem: &Problem) -> bool {
        self.nodes == problem.mesh.nodes_in_rest
            && self.tets == problem.mesh.tets
            && self.held == problem.held_nodes()
            && self.groups == cable_groups(problem)
    }
}

/// The result of a static solve.
#[derive(Debug, Clone, Serialize)]
pub struct Solution {
    /// Node positions.
    pub positions: Vec<[f64; 3]>,
    /// Node displacements from rest.
    pub displacement: Vec<[f64; 3]>,
    /// External nodal forces at equilibrium (loads, gravity, cables; reactions at fixed nodes excluded).
    pub external_force: Vec<[f64; 3]>,
    /// Cable tensions (N), in model order.
    pub cable_tension: Vec<f64>,
    /// Displacement-controlled cables that went slack (they would have had to push).
    pub cable_slack: Vec<bool>,
    /// Cable shortenings (m), in model order.
    pub cable_shortening: Vec<f64>,
    /// Von Mises stress per tetrahedron (Pa).
    pub von_mises: Vec<f64>,
    /// Newton iterations done.
    pub iterations: usize,
    /// Residual norm per iteration (N).
    pub residuals: Vec<f64>,
    /// Whether Newton converged.
    pub converged: bool,
}

impl Problem {
    /// A problem with no fixed nodes, loads or gravity yet.
    pub fn new(mesh: TetMesh, material: Material, formulation: Formulation) -> Self {
        Self {
            mesh,
            material,
            formulation,
            fixed: Vec::new(),
            prescribed: Vec::new(),
            density: 0.0,
            gravity: [0.0; 3],
            loads: Vec::new(),
            cables: Vec::new(),
            young_scale: Vec::new(),
            setup_cache: Arc::default(),
        }
    }

    /// Fixed and prescribed nodes, sorted, without repeats.
    pub fn held_nodes(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self
            .fixed
            .iter()
            .copied()
            .chain(self.prescribed.iter().map(|p| p.0))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// Node positions at rest, with prescribed nodes moved to their prescribed place.
    pub fn initial_positions(&self) -> Vec<[f64; 3]> {
        let mut x = self.mesh.nodes_in_rest.clone();
        for (v, u) in &self.prescribed {
            if let Some(p) = x.get_mut(*v) {
                *p = [p[0] + u[0], p[1] + u[1], p[2] + u[2]];
            }
        }
        x
    }

    /// Checks that every connected component has fixed nodes spanning a plane (no rigid motion).
    pub fn check_supports(&self) -> FemResult<()> {
        let n = self.mesh.num_nodes();
        let held = self.held_nodes();
        if held.is_empty() {
            return Err(FemError::Singular(
                "no fixed nodes: rigid motions are free".into(),
            ));
        }
        if let Some(&v) = held.iter().find(|&&v| v >= n) {
            return Err(FemError::Model(format!(
                "fixed node {v} does not exist ({n} nodes)"
            )));
        }
        let mut parent: Vec<usize> = (0..n).collect();
        fn find(p: &mut [usize], mut v: usize) -> usize {
            while p[v] != v {
                p[v] = p[p[v]];
                v = p[v];
            }
            v
        }
        for t in &self.mesh.tets {
            for k in 1..4 {
                let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut fixed_by_root: std::collections::BTreeMap<usize, Vec<[f64; 3]>> =
            Default::default();
        for &v in &held {
            let r = find(&mut parent, v);
            fixed_by_root
                .entry(r)
                .or_default()
                .push(self.mesh.nodes_in_rest[v]);
        }
        let scale = {
            let [lo, hi] = self.mesh.bbox();
            norm(sub(hi, lo))
        };
        let mut seen = vec![false; n];
        for t in &self.mesh.tets {
            let r = find(&mut parent, t[0]);
            if seen[r] {
                continue;
            }
            seen[r] = true;
            let pts = fixed_by_root.get(&r).map(|v| v.as_slice()).unwrap_or(&[]);
            if !spans_plane(pts, scale) {
                return Err(FemError::Singular(format!(
                    "the part containing node {r} has {} fixed node(s), not enough to stop rigid rotation",
                    pts.len()
                )));
            }
        }
        Ok(())
    }

    /// Lumped nodal masses (kg): a quarter of each element's mass to each node.
    pub fn lumped_masses(&self) -> Vec<f64> {
        let mut m = vec![0.0; self.mesh.num_nodes()];
        for (t, v) in self.mesh.tets.iter().zip(self.mesh.signed_volumes()) {
            for &a in t {
                m[a] += 0.25 * self.density * v;
            }
        }
        m
    }

    /// Body forces: gravity on the lumped masses (node-major 3n).
    pub fn body_forces(&self) -> Vec<f64> {
        self.body_forces_of(&self.lumped_masses())
    }

    /// [`Problem::body_forces`] on the lumped masses `masses`.
    fn body_forces_of(&self, masses: &[f64]) -> Vec<f64> {
        let mut f = vec![0.0; 3 * self.mesh.num_nodes()];
        if self.density != 0.0 && self.gravity != [0.0; 3] {
            for (v, m) in masses.iter().enumerate() {
                for k in 0..3 {
                    f[3 * v + k] += m * self.gravity[k];
                }
            }
        }
        f
    }

    /// External forces from gravity and point loads (node-major 3n).
    pub fn external_forces(&self) -> Vec<f64> {
        self.add_point_loads(self.body_forces())
    }

    /// `f` (node-major 3n) plus the point loads.
    fn add_point_loads(&self, mut f: Vec<f64>) -> Vec<f64> {
        for l in &self.loads {
            for (n, w) in l.at.nodes.iter().zip(l.at.weights) {
                for k in 0..3 {
                    f[3 * n + k] += w * l.force[k];
                }
            }
        }
        f
    }

    /// A copy without the point loads (body forces, cables and supports kept).
    pub fn without_loads(&self) -> Problem {
        let mut p = self.clone();
        p.loads.clear();
        p
    }

    /// Prepares a solver (checks, rest data, pattern, symbolic factorization). The setup is
    /// computed once and shared by clones of this problem while it still fits them (same
    /// mesh, held nodes and cable attachments; see [`SolverSetup::fits`]).
    pub fn solver(&self) -> FemResult<Solver<'_>> {
        let setup = match self.setup_cache.get() {
            Some(s) if s.fits(self) => s.clone(),
            Some(_) => Arc::new(SolverSetup::new(self)?),
            None => {
                let s = Arc::new(SolverSetup::new(self)?);
                // Another thread may have set it meanwhile: either is the same setup.
                let _ = self.setup_cache.set(s.clone());
                s
            }
        };
        Solver::with_setup(self, setup)
    }

    /// A solver for this problem that takes over `state` (left by a solver of a problem
    /// with the same mesh, held nodes, cable attachments, material, formulation and
    /// regional stiffness; otherwise only the setup, or nothing, is reused): assembling at
    /// the positions the state's elements were evaluated at gives the same values without
    /// evaluating them again.
    pub fn solver_from(&self, state: SolverState) -> FemResult<Solver<'_>> {
        if !state.setup.fits(self) {
            return self.solver();
        }
        let setup = state.setup;
        let reusable = state.material == self.material
            && state.formulation == self.formulation
            && state.young_scale == self.young_scale
            && state.values.len() == setup.pattern.nnz()
            && state.l_values.len() == setup.symbolic.len_val();
        if !reusable {
            return Solver::with_setup(self, setup);
        }
        let mut solver = Solver::with_buffers(self, setup, state.l_values, state.values)?;
        solver.internal_force = state.internal_force;
        solver.elements = state.elements;
        solver.elements_at = state.elements_at;
        solver.elements_tangent = state.elements_tangent;
        solver.scattered = state.scattered;
        solver.factor_of = state.factor_of;
        solver.failed_of = state.failed_of;
        Ok(solver)
    }

    /// Static equilibrium under the loads and cable actuation.
    pub fn solve_static(&self, params: &NewtonParams) -> FemResult<Solution> {
        self.solver()?.solve_static(params)
    }

    /// As [`Problem::solve_static`], starting Newton from a nearby equilibrium `start`
    /// (positions and cable tensions, e.g. the previous solution) in one load step: a warm
    /// start for sequences of nearby problems.
    pub fn solve_static_from(
        &self,
        params: &NewtonParams,
        start: &Solution,
    ) -> FemResult<Solution> {
        self.solver()?.solve_static_from(params, Some(start))
    }
}

fn spans_plane(pts: &[[f64; 3]], scale: f64) -> bool {
    let tol = 1e-9 * scale;
    let Some(&a) = pts.first() else { return false };
    let Some(&b) = pts
        .iter()
        .max_by(|p, q| norm(sub(**p, a)).total_cmp(&norm(sub(**q, a))))
    else {
        return false;
    };
    let ab = sub(b, a);
    let lab = norm(ab);
    if lab <= tol {
        return false;
    }
    pts.iter()
        .any(|p| norm(super::mesh::cross(ab, sub(*p, a))) / lab > tol)
}

/// Factors with fewer stored values than this are factorized and solved sequentially.
pub const SEQUENTIAL_FACTOR_LEN: usize = 1 << 21;

/// A prepared solver: free-DOF map, pattern, symbolic Cholesky, current tangent and factor.
pub struct Solver<'p> {
    /// The problem.
    pub problem: &'p Problem,
    /// Free-DOF numbering.
    pub dofs: Arc<DofMap>,
    /// Sparsity pattern of K.
    pub pattern: Arc<Pattern>,
    rest: Arc<Vec<TetRest>>,
    /// Symbolic Cholesky (AMD ordering and supernodal structure), computed once.
    pub(crate) symbolic: Arc<SymbolicCholesky<usize>>,
    setup: Arc<SolverSetup>,
    /// Values of the supernodal factor L (reused between factorizations).
    pub(crate) l_values: Arc<Pooled<f64>>,
    /// Values of K (upper triangle) after the last assembly.
    pub values: Vec<f64>,
    /// Internal forces (node-major 3n) after the last assembly.
    pub internal_force: Vec<f64>,
    /// Element states of the last assembly (corotational: only the tangent blocks of
    /// [`Pattern::block_mask`] are computed, the others hold whatever the buffer held:
    /// the scatter reads no others).
    pub(crate) elements: Arc<Pooled<ElementState>>,
    /// Node positions at which `elements` and `internal_force` were evaluated, and with
    /// which tangent (empty: none yet).
    elements_at: Vec<[f64; 3]>,
    elements_tangent: Tangent,
    /// K as scattered from `elements` (empty: not yet): assembling again at `elements_at`
    /// with the same tangent copies it instead of scattering again (the values a Newton
    /// step or a linearisation added the cables to are restored for the next one).
    scattered: Vec<f64>,
    /// Whether `l_values` holds the factor of the current `values`.
    factored: bool,
    /// The values `l_values` is the factor of (empty: none). A factorization of the same
    /// values, bit for bit, is skipped: the sensing loop's next FE update starts with
    /// exactly the matrix its last linearisation factorised.
    factor_of: Vec<f64>,
    /// The values whose last factorization failed (empty: none): the same values fail
    /// again without the work (a state at the free equilibrium meets its indefinite
    /// consistent tangent once per frame, see [`Solver::tangent_at`]).
    failed_of: Vec<f64>,
    /// Numeric factorizations attempted by this solver (failed ones included).
    factorizations: usize,
}

/// A large buffer of a solver (a factor's values, the element states) that joins its
/// type's pool of spares when the last solver or state holding it lets go, for the next
/// solver that needs a fresh one. A shared buffer is never overwritten, and a frame's FE
/// updates start from shared states (the free solve's, a location choice's): without the
/// pools each made and filled a new factor-sized and element-sized buffer (on the bundled
/// robot 12% of a probe frame went to filling and faulting in those pages).
#[derive(Clone, Debug, Default)]
pub(crate) struct Pooled<T: Spare>(Vec<T>);

/// A buffer element type with a pool of spare buffers ([`Pooled`]).
pub(crate) trait Spare: Clone + Send + Sized + 'static {
    /// The spare buffers (stale contents; every use overwrites what it reads: faer zeroes
    /// a factor's values before it factorizes, and an element evaluation writes every
    /// element's force, stress, rotation and stored tangent blocks).
    fn pool() -> &'static std::sync::Mutex<Vec<Vec<Self>>>;
}

impl Spare for f64 {
    fn pool() -> &'static std::sync::Mutex<Vec<Vec<Self>>> {
        static POOL: std::sync::Mutex<Vec<Vec<f64>>> = std::sync::Mutex::new(Vec::new());
        &POOL
    }
}

impl Spare for ElementState {
    fn pool() -> &'static std::sync::Mutex<Vec<Vec<Self>>> {
        static POOL: std::sync::Mutex<Vec<Vec<ElementState>>> = std::sync::Mutex::new(Vec::new());
        &POOL
    }
}

/// At most this many spares are kept per type (a frame's solvers, two frames at once).
const SPARES_MAX: usize = 6;

/// Smaller buffers are not kept: filling them costs less than the lock.
const SPARE_MIN_BYTES: usize = 1 << 17;

impl<T: Spare> Pooled<T> {
    /// A spare buffer of `len` items (stale contents), if the pool has one.
    fn spare(len: usize) -> Option<Self> {
        if len * std::mem::size_of::<T>() < SPARE_MIN_BYTES {
            return None;
        }
        let mut pool = T::pool().lock().ok()?;
        let i = pool.iter().position(|b| b.len() == len)?;
        Some(Self(pool.swap_remove(i)))
    }

    /// A buffer of `len` items to be overwritten whole: a spare one (stale contents), else
    /// `len` copies of `fill`.
    fn fresh(len: usize, fill: T) -> Self {
        Self::spare(len).unwrap_or_else(|| Self(vec![fill; len]))
    }
}

impl<T: Spare> std::ops::Deref for Pooled<T> {
    type Target = Vec<T>;
    fn deref(&self) -> &Vec<T> {
        &self.0
    }
}

impl<T: Spare> std::ops::DerefMut for Pooled<T> {
    fn deref_mut(&mut self) -> &mut Vec<T> {
        &mut self.0
    }
}

impl<T: Spare> Drop for Pooled<T> {
    fn drop(&mut self) {
        if self.0.len() * std::mem::size_of::<T>() < SPARE_MIN_BYTES {
            return;
        }
        if let Ok(mut pool) = T::pool().lock() {
            if pool.len() < SPARES_MAX {
                pool.push(std::mem::take(&mut self.0));
            }
        }
    }
}

/// `buf` to be overwritten whole: taken over if no other state shares it, else a fresh
/// buffer of the same length (no copy of contents about to be lost).
fn overwritten(buf: &mut Arc<Pooled<f64>>) -> &mut [f64] {
    if Arc::get_mut(buf).is_none() {
        *buf = Arc::new(Pooled::fresh(buf.len(), 0.0));
    }
    // Not shared now: no copy.
    &mut Arc::make_mut(buf).0
}

/// What a [`Solver`] leaves for the next solver of a problem that differs only in its
/// loads, cable controls or prescribed displacements ([`Solver::into_state`],
/// [`Problem::solver_from`]): the element states at the last assembled positions (so a
/// Newton solve warm-started there does not evaluate the elements again) and the buffers.
/// A clone serves several solvers from the same state (e.g. every frame's first FE update
/// at the free equilibrium); the large buffers (element states, factor) are shared, and a
/// solver that overwrites one starts a fresh buffer instead of copying the shared one.
#[derive(Clone)]
pub struct SolverState {
    setup: Arc<SolverSetup>,
    material: Material,
    formulation: Formulation,
    young_scale: Vec<f64>,
    l_values: Arc<Pooled<f64>>,
    values: Vec<f64>,
    internal_force: Vec<f64>,
    elements: Arc<Pooled<ElementState>>,
    elements_at: Vec<[f64; 3]>,
    elements_tangent: Tangent,
    scattered: Vec<f64>,
    factor_of: Vec<f64>,
    failed_of: Vec<f64>,
}

impl std::fmt::Debug for SolverState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SolverState")
            .field("setup", &self.setup)
            .field("evaluated", &!self.elements_at.is_empty())
            .field("factorized", &!self.factor_of.is_empty())
            .finish_non_exhaustive()
    }
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
        let l_values = Arc::new(Pooled::fresh(setup.symbolic.len_val(), 0.0));
        let values = vec![0.0; setup.pattern.nnz()];
        Self::with_buffers(problem, setup, l_values, values)
    }

    /// A solver on `setup` (which fits `problem`) with the factor and matrix buffers given:
    /// [`Problem::solver_from`] hands over a state's instead of zeroing new ones it would
    /// drop (the factor's is the largest buffer of a solver).
    fn with_buffers(
        problem: &'p Problem,
        setup: Arc<SolverSetup>,
        l_values: Arc<Pooled<f64>>,
        values: Vec<f64>,
    ) -> FemResult<Self> {
        let n = problem.mesh.num_nodes();
        let points = problem
            .loads
            .iter()
            .map(|l| &l.at)
            .chain(problem.cables.iter().flat_map(|c| &c.attach));
        for at in points {
            if let Some(v) = at.nodes.iter().find(|&&v| v >= n) {
                return Err(FemError::Model(format!(
                    "a load or cable refers to node {v} ({n} nodes)"
                )));
            }
        }
        if let Some((v, _)) = problem
            .prescribed
            .iter()
            .find(|(v, u)| *v >= n || u.iter().any(|c| !c.is_finite()))
        {
            return Err(FemError::Model(format!(
                "prescribed displacement of node {v} is invalid"
            )));
        }
        Ok(Self {
            problem,
            dofs: setup.dofs.clone(),
            pattern: setup.pattern.clone(),
            rest: setup.rest.clone(),
            symbolic: setup.symbolic.clone(),
            setup,
            l_values,
            values,
            internal_force: Vec::new(),
            elements: Arc::default(),
            elements_at: Vec::new(),
            elements_tangent: Tangent::default(),
            scattered: Vec::new(),
            factored: false,
            factor_of: Vec::new(),
            failed_of: Vec::new(),
            factorizations: 0,
        })
    }

    /// The element states and buffers of this solver, for [`Problem::solver_from`].
    pub fn into_state(self) -> SolverState {
        SolverState {
            setup: self.setup,
            material: self.problem.material,
            formulation: self.problem.formulation,
            young_scale: self.problem.young_scale.clone(),
            l_values: self.l_values,
            values: self.values,
            internal_force: self.internal_force,
            elements: self.elements,
            elements_at: self.elements_at,
            elements_tangent: self.elements_tangent,
            scattered: self.scattered,
            factor_of: self.factor_of,
            failed_of: self.failed_of,
        }
    }

    /// Forgets what lets work be skipped: where the element states were evaluated, the
    /// kept scatter of K, and which values the factor (or a failed factorization) was
    /// of. The next [`Solver::assemble`] evaluates every element and the next
    /// [`Solver::factorize`] factorizes, whatever they were given before. The results are
    /// the same either way; this is for timing the work itself (the FE benchmarks call it
    /// before each repetition, which would otherwise time the reuse).
    ///
    /// ```
    /// # use softsense::fem::model::Model;
    /// # use softsense::fem::tet4::Tangent;
    /// # let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    /// # let model = Model::load(&root.join("meshes/models/robot.toml"), None)?;
    /// let x = model.problem.mesh.nodes_in_rest.clone();
    /// let mut solver = model.problem.solver()?;
    /// solver.tangent_at(&x, Tangent::Rotated)?;
    /// let before = solver.factorizations();
    /// solver.tangent_at(&x, Tangent::Rotated)?; // the same values: skipped
    /// assert_eq!(solver.factorizations(), before);
    /// solver.forget_reuse();
    /// solver.tangent_at(&x, Tangent::Rotated)?; // done again
    /// assert_eq!(solver.factorizations(), before + 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn forget_reuse(&mut self) {
        self.elements_at.clear();
        self.scattered.clear();
        self.factor_of.clear();
        self.failed_of.clear();
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

    /// The problem's external forces ([`Problem::external_forces`], the same values).
    pub fn external_forces(&self) -> Vec<f64> {
        self.problem.add_point_loads(self.body_forces())
    }

    /// Number of free DOFs.
    pub fn ndof(&self) -> usize {
        self.dofs.ndof
    }

    /// faer's parallelism for the factor: sequential for factors below
    /// [`SEQUENTIAL_FACTOR_LEN`] values, where threads cost more than they save (the
    /// diamond's 4.7k-DOF factor: 7.4 ms with 2 rayon threads vs 4.5 ms sequential on the
    /// shared 2-core machine), else faer's global setting.
    pub fn linalg_par(&self) -> faer::Par {
        if self.factor_len() < SEQUENTIAL_FACTOR_LEN {
            faer::Par::Seq
        } else {
            faer::get_global_parallelism()
        }
    }

    /// Number of stored values of the Cholesky factor (supernodal blocks, fill included).
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// Assembles internal forces and the tangent at node positions `x`. At the positions
    /// of the previous assembly the element states are reused (the same values, bit for
    /// bit): with the same tangent they are only scattered again, and the rotated tangent
    /// after a consistent one is built from the stored rotations (no polar decomposition),
    /// leaving the element states as they were.
    pub fn assemble(&mut self, x: &[[f64; 3]], tangent: Tangent) -> FemResult<()> {
        let same_x = self.elements.len() == self.rest.len()
            && self.elements_at.len() == x.len()
            && self
                .elements_at
                .iter()
                .flatten()
                .zip(x.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits());
        if same_x {
            if tangent == self.elements_tangent {
                self.scatter_elements();
                return Ok(());
            }
            if tangent == Tangent::Rotated && self.problem.formulation == Formulation::Corotational
            {
                self.scatter_rotated();
                return Ok(());
            }
        }
        self.evaluate(x, tangent)?;
        self.scatter_elements();
        // `evaluate` emptied it (a failed evaluation leaves no reusable states).
        self.elements_at.extend_from_slice(x);
        self.elements_tangent = tangent;
        Ok(())
    }

    /// Evaluates every element at `x` (forces, stress, rotation, `tangent`) into
    /// `elements` and sums the internal forces.
    fn evaluate(&mut self, x: &[[f64; 3]], tangent: Tangent) -> FemResult<()> {
        self.elements_at.clear();
        self.scattered.clear();
        let p = self.problem;
        let tets = &p.mesh.tets;
        let rest_nodes = &p.mesh.nodes_in_rest;
        let m = &p.material;
        let form = p.formulation;
        // Overwritten whole: a buffer shared with another state is left to it, not copied.
        let n = self.rest.len();
        let mut states = Arc::try_unwrap(std::mem::take(&mut self.elements))
            .unwrap_or_else(|_| Pooled::spare(n).unwrap_or_default());
        let pattern = &self.pattern;
        eval_elements(&self.rest, &mut states, |e, r, out| {
            let t = tets[e];
            match form {
                Formulation::SmallStrain => {
                    let u = [0, 1, 2, 3].map(|a| sub(x[t[a]], rest_nodes[t[a]]));
                    *out = r.small_strain(m, &u);
                    Ok(())
                }
                // Only the stored (upper-triangle, free) blocks: the scatter reads no others.
                Formulation::Corotational => {
                    r.corotational_into(e, m, &t.map(|a| x[a]), tangent, pattern.block_mask(e), out)
                }
            }
        })?;
        // Linear elasticity: force, tangent and stress all scale with Young's modulus.
        for (s, &f) in states.iter_mut().zip(&p.young_scale) {
            if f != 1.0 {
                s.force.iter_mut().for_each(|v| *v *= f);
                s.tangent.iter_mut().flatten().for_each(|v| *v *= f);
                s.stress *= f;
            }
        }
        self.internal_force.clear();
        self.internal_force.resize(3 * p.mesh.num_nodes(), 0.0);
        for (t, s) in tets.iter().zip(states.iter()) {
            for (a, &v) in t.iter().enumerate() {
                for k in 0..3 {
                    self.internal_force[3 * v + k] += s.force[3 * a + k];
                }
            }
        }
        self.elements = Arc::new(states);
        Ok(())
    }

    /// K from the element tangents of the last evaluation (serial, in element order).
    /// Kept in `scattered`; a copy of it if it is there already.
    fn scatter_elements(&mut self) {
        if self.scattered.len() == self.values.len() {
            self.values.copy_from_slice(&self.scattered);
            return;
        }
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for (e, s) in self.elements.iter().enumerate() {
            self.pattern.scatter(e, &s.tangent, &mut self.values);
        }
        self.scattered.clone_from(&self.values);
    }

    /// K from the rotated tangents R K0 Rᵀ of the stored element rotations (the values
    /// [`Solver::evaluate`] gives with [`Tangent::Rotated`]); the element states are kept.
    fn scatter_rotated(&mut self) {
        let m = &self.problem.material;
        let scale = &self.problem.young_scale;
        self.values.iter_mut().for_each(|v| *v = 0.0);
        let mut k = [[0.0; 12]; 12];
        for (e, (s, r)) in self.elements.iter().zip(self.rest.iter()).enumerate() {
            r.rotated_tangent(m, &s.rotation, self.pattern.block_mask(e), &mut k);
            if let Some(&f) = scale.get(e) {
                if f != 1.0 {
                    k.iter_mut().flatten().for_each(|v| *v *= f);
                }
            }
            self.pattern.scatter(e, &k, &mut self.values);
        }
    }

    /// Numeric Cholesky of the assembled tangent (reusing the symbolic analysis).
    pub fn factorize(&mut self) -> FemResult<()> {
        let sym = SymbolicSparseColMatRef::new_checked(
            self.dofs.ndof,
            self.dofs.ndof,
            &self.pattern.col_ptr,
            None,
            &self.pattern.row_idx,
        );
        let mat = SparseColMatRef::new(sym, &self.values);
        let bits_eq = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits())
        };
        if bits_eq(&self.factor_of, &self.values) {
            self.factored = true;
            return Ok(());
        }
        self.factored = false;
        if bits_eq(&self.failed_of, &self.values) {
            // `l_values` still holds the factor of `factor_of`.
            return Err(FemError::Singular(
                "tangent stiffness is not positive definite (these values failed before)".into(),
            ));
        }
        self.factor_of.clear();
        self.factorizations += 1;
        let par = self.linalg_par();
        let mut mem = MemBuffer::try_new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        )
        .map_err(|e| FemError::Linalg(format!("{e:?}")))?;
        match self.symbolic.factorize_numeric_llt(
            overwritten(&mut self.l_values),
            mat,
            Side::Upper,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        ) {
            Ok(_) => {
                self.factored = true;
                self.factor_of.clone_from(&self.values);
                Ok(())
            }
            Err(e) => {
                self.failed_of.clone_from(&self.values);
                Err(FemError::Singular(format!(
                    "tangent stiffness is not positive definite ({e:?})"
                )))
            }
        }
    }

    /// The current factor, or an error if the last factorization failed or none was done.
    pub(crate) fn factor(&self) -> FemResult<LltRef<'_, usize, f64>> {
        if !self.factored {
            return Err(FemError::Linalg("no factorization".into()));
        }
        Ok(LltRef::new(&self.symbolic, &self.l_values))
    }

    /// The supernodal structure of the factor (always supernodal, see [`Solver::new`]), or
    /// an error if the last factorization failed or none was done.
    pub(crate) fn supernodal(
        &self,
    ) -> FemResult<&faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>>
    {
        // Its callers read `l_values`: only a factor of the current values will do.
        if !self.factored {
            return Err(FemError::Linalg("no factorization".into()));
        }
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Ok(s),
            SymbolicCholeskyRaw::Simplicial(_) => {
                Err(FemError::Linalg("expected a supernodal factor".into()))
            }
        }
    }

    /// Solves K X = B in place for free-DOF right-hand sides (columns of `b`).
    pub fn solve_in_place(&self, b: &mut Mat<f64>) -> FemResult<()> {
        let llt = self.factor()?;
        let par = self.linalg_par();
        let mut mem =
            MemBuffer::try_new(self.symbolic.solve_in_place_scratch::<f64>(b.ncols(), par))
                .map_err(|e| FemError::Linalg(format!("{e:?}")))?;
        llt.solve_in_place_with_conj(Conj::No, b.as_mut(), par, MemStack::new(&mut mem));
        Ok(())
    }

    /// Assembles and factorizes at `x`, falling back to the rotated tangent when the
    /// consistent one is not positive definite.
    pub fn tangent_at(&mut self, x: &[[f64; 3]], tangent: Tangent) -> FemResult<()> {
        self.assemble(x, tangent)?;
        self.factorize_assembled(x, tangent)
    }

    /// Factorizes the tangent the last [`Solver::assemble`] left at `x` with `tangent`, with
    /// the fallback of [`Solver::tangent_at`]. A converged [`Solver::solve_static_from`]
    /// ends with exactly that assembly (at its solution, `params.tangent`, no cable
    /// stiffness), so the linearisation there needs no second assembly.
    pub fn factorize_assembled(&mut self, x: &[[f64; 3]], tangent: Tangent) -> FemResult<()> {
        match self.factorize() {
            Err(FemError::Singular(_))
                if tangent == Tangent::Consistent
                    && self.problem.formulation == Formulation::Corotational =>
            {
                self.assemble(x, Tangent::Rotated)?;
                self.factorize()
            }
            r => r,
        }
    }

    /// [`Solver::factorize_assembled`] with the geometric stiffness of the cables under
    /// `tensions` (one per cable) added to the last assembly: the matrix of a Newton step at
    /// `x`. Falls back to the rotated tangent, with the cables, when it is not positive
    /// definite.
    pub fn factorize_assembled_with_cables(
        &mut self,
        x: &[[f64; 3]],
        tensions: &[f64],
    ) -> FemResult<()> {
        let cables = &self.problem.cables;
        for (c, t) in cables.iter().zip(tensions) {
            self.add_cable_stiffness(c, *t, x);
        }
        match self.factorize() {
            Err(FemError::Singular(_))
                if self.elements_tangent == Tangent::Consistent
                    && self.problem.formulation == Formulation::Corotational =>
            {
                self.assemble(x, Tangent::Rotated)?;
                for (c, t) in cables.iter().zip(tensions) {
                    self.add_cable_stiffness(c, *t, x);
                }
                self.factorize()
            }
            r => r,
        }
    }

    /// Assembles and factorizes the tangent at `x` including the geometric stiffness of the
    /// cables under `tensions` (one per cable), falling back to the rotated tangent when
    /// the consistent one is not positive definite.
    pub fn factorize_with_cables(&mut self, x: &[[f64; 3]], tensions: &[f64]) -> FemResult<()> {
        self.assemble(x, Tangent::Consistent)?;
        self.factorize_assembled_with_cables(x, tensions)
    }

    /// Adds the geometric stiffness of a cable under tension `t` at positions `x`:
    /// t d2L/dx2, with (I - u u^T) / l for each straight segment of length l.
    pub fn add_cable_stiffness(&mut self, cable: &Cable, t: f64, x: &[[f64; 3]]) {
        if t == 0.0 {
            return;
        }
        let pts: Vec<[f64; 3]> = cable.attach.iter().map(|a| a.position(x)).collect();
        for i in 0..pts.len() {
            let prev = if i == 0 { cable.pull } else { pts[i - 1] };
            let d = sub(pts[i], prev);
            let l = norm(d);
            if !(l > 0.0) {
                continue;
            }
            let u = d.map(|c| c / l);
            let mut blk = [[0.0; 3]; 3];
            for (r, row) in blk.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = t * ((if r == c { 1.0 } else { 0.0 }) - u[r] * u[c]) / l;
                }
            }
            // Segment between attach i-1 (if any) and attach i: [[A, -A], [-A, A]].
            let mut ends: Vec<(&MappedPoint, f64)> = vec![(&cable.attach[i], 1.0)];
            if i > 0 {
                ends.push((&cable.attach[i - 1], -1.0));
            }
            for (pa, sa) in &ends {
                for (pb, sb) in &ends {
                    for (na, wa) in pa.nodes.iter().zip(pa.weights) {
                        for (nb, wb) in pb.nodes.iter().zip(pb.weights) {
                            let f = sa * sb * wa * wb;
                            if f != 0.0 {
                                let k = blk.map(|r| r.map(|v| v * f));
                                self.pattern
                                    .add_block(&self.dofs, *na, *nb, &k, &mut self.values);
                            }
                        }
                    }
                }
            }
        }
    }

    /// Scatters a (node, 3-vector) row into a free-DOF column.
    pub fn row_to_dofs(&self, row: &[(usize, [f64; 3])], out: &mut [f64]) {
        for (n, v) in row {
            if let Some(d) = self.dofs.node_dof.get(*n).copied().flatten() {
                for k in 0..3 {
                    out[d + k] += v[k];
                }
            }
        }
    }

    /// Static equilibrium by Newton iterations (with optional load stepping).
    pub fn solve_static(&mut self, params: &NewtonParams) -> FemResult<Solution> {
        self.solve_static_from(params, None)
    }

    /// Static equilibrium by Newton iterations, from `start` (one load step) when given.
    pub fn solve_static_from(
        &mut self,
        params: &NewtonParams,
        start: Option<&Solution>,
    ) -> FemResult<Solution> {
        let p = self.problem;
        let nn = p.mesh.num_nodes();
        let warm =
            start.filter(|s| s.positions.len() == nn && s.cable_tension.len() == p.cables.len());
        let mut x = match warm {
            Some(s) => {
                let mut x = s.positions.clone();
                // Held nodes keep their prescribed positions.
                let x0 = p.initial_positions();
                for v in p.held_nodes() {
                    x[v] = x0[v];
                }
                x
            }
            None => p.initial_positions(),
        };
        let f_ext_full = self.external_forces();
        let l0: Vec<f64> = p
            .cables
            .iter()
            .map(|c| c.length(&p.mesh.nodes_in_rest))
            .collect();
        let mut tension: Vec<f64> = p
            .cables
            .iter()
            .enumerate()
            .map(|(i, c)| match c.control {
                CableControl::Force(f) => f,
                CableControl::Displacement(_) => warm.map_or(0.0, |s| s.cable_tension[i]),
            })
            .collect();
        let mut slack = vec![false; p.cables.len()];
        let mut disp_cables: Vec<usize> = (0..p.cables.len())
            .filter(|&i| matches!(p.cables[i].control, CableControl::Displacement(_)))
            .collect();
        let steps = if warm.is_some() {
            1
        } else {
            params.load_steps.max(1)
        };
        let mut residuals = Vec::new();
        let mut iterations = 0;
        let mut converged = false;
        for step in 1..=steps {
            let s = step as f64 / steps as f64;
            converged = false;
            let mut last_step = f64::INFINITY;
            for _ in 0..params.max_iterations {
                self.assemble(&x, params.tangent)?;
                // residual r = s f_ext + sum H^T lambda - f_int on free DOFs
                let mut full: Vec<f64> = f_ext_full.iter().map(|f| s * f).collect();
                let rows: Vec<Vec<(usize, [f64; 3])>> =
                    p.cables.iter().map(|c| c.row(&x)).collect();
                for (ci, row) in rows.iter().enumerate() {
                    let lam = match p.cables[ci].control {
                        CableControl::Force(f) => s * f,
                        CableControl::Displacement(_) => tension[ci],
                    };
                    tension[ci] = lam;
                    for (n, v) in row {
                        for k in 0..3 {
                            full[3 * n + k] += lam * v[k];
                        }
                    }
                }
                // Force scale: applied and internal forces, including reactions at held nodes.
                let scale = norm_vec(&full) + norm_vec(&self.internal_force);
                for (f, fi) in full.iter_mut().zip(&self.internal_force) {
                    *f -= fi;
                }
                let r = self.dofs.gather(&full);
                let rn = norm_vec(&r);
                if !rn.is_finite() {
                    return Err(FemError::NoConvergence {
                        iterations,
                        residual: rn,
                    });
                }
                let gaps: Vec<f64> = disp_cables
                    .iter()
                    .map(|&ci| match p.cables[ci].control {
                        CableControl::Displacement(d) => s * d - (l0[ci] - p.cables[ci].length(&x)),
                        CableControl::Force(_) => 0.0,
                    })
                    .collect();
                let gap_scale = if params.gap_tol > 0.0 {
                    params.gap_tol
                } else {
                    1e-12
                        * p.mesh
                            .bbox()
                            .iter()
                            .flatten()
                            .fold(0.0f64, |m, c| m.max(c.abs()))
                            .max(1e-300)
                };
                residuals.push(rn);
                let gaps_ok = gaps
                    .iter()
                    .all(|g| g.abs() <= gap_scale.max(1e-10 * g.abs()));
                // Converged: residual small, or the last correction is at round-off level
                // (ill-conditioned systems cannot reduce the residual further).
                let small =
                    rn <= params.abs_tol + params.rel_tol * scale || last_step <= params.step_tol;
                // A cold start takes at least one step; a warm start already in equilibrium
                // (e.g. the free state when the loads added to it are still zero) is kept.
                if small && gaps_ok && (iterations > 0 || warm.is_some()) {
                    // A cable can only pull (lambda >= 0): a displacement-controlled cable
                    // that would have to push goes slack (zero tension) and Newton goes on.
                    if let Some(pos) = disp_cables.iter().position(|&ci| tension[ci] < 0.0) {
                        let ci = disp_cables.remove(pos);
                        tension[ci] = 0.0;
                        slack[ci] = true;
                        last_step = f64::INFINITY;
                        continue;
                    }
                    converged = true;
                    break;
                }
                iterations += 1;
                for (ci, c) in p.cables.iter().enumerate() {
                    self.add_cable_stiffness(c, tension[ci], &x);
                }
                match self.factorize() {
                    Err(FemError::Singular(_))
                        if params.tangent == Tangent::Consistent
                            && p.formulation == Formulation::Corotational =>
                    {
                        self.assemble(&x, Tangent::Rotated)?;
                        for (ci, c) in p.cables.iter().enumerate() {
                            self.add_cable_stiffness(c, tension[ci], &x);
                        }
                        self.factorize()?;
                    }
                    other => other?,
                }
                let nd = self.dofs.ndof;
                let nc = disp_cables.len();
                let mut b = Mat::<f64>::zeros(nd, 1 + nc);
                for (i, v) in r.iter().enumerate() {
                    b[(i, 0)] = *v;
                }
                for (j, &ci) in disp_cables.iter().enumerate() {
                    let mut col = vec![0.0; nd];
                    self.row_to_dofs(&rows[ci], &mut col);
                    for (i, v) in col.iter().enumerate() {
                        b[(i, 1 + j)] = *v;
                    }
                }
                let hd: Vec<Vec<f64>> = (0..nc)
                    .map(|j| (0..nd).map(|i| b[(i, 1 + j)]).collect())
                    .collect();
                self.solve_in_place(&mut b)?;
                let mut dx: Vec<f64> = (0..nd).map(|i| b[(i, 0)]).collect();
                if nc > 0 {
                    // W dlambda = gap - H u0
                    let w = nalgebra::DMatrix::from_fn(nc, nc, |i, j| {
                        (0..nd).map(|k| hd[i][k] * b[(k, 1 + j)]).sum::<f64>()
                    });
                    let rhs = nalgebra::DVector::from_fn(nc, |i, _| {
                        gaps[i] - (0..nd).map(|k| hd[i][k] * dx[k]).sum::<f64>()
                    });
                    let dl = w.lu().solve(&rhs).ok_or_else(|| {
                        FemError::Singular("cable compliance matrix is singular".into())
                    })?;
                    for (j, &ci) in disp_cables.iter().enumerate() {
                        tension[ci] += dl[j];
                        for (k, d) in dx.iter_mut().enumerate() {
                            *d += dl[j] * b[(k, 1 + j)];
                        }
                    }
                }
                for (v, d) in self.dofs.node_dof.iter().enumerate() {
                    if let Some(d) = d {
                        for k in 0..3 {
                            x[v][k] += dx[d + k];
                        }
                    }
                }
                let un = (0..nn)
                    .map(|v| norm(sub(x[v], p.mesh.nodes_in_rest[v])).powi(2))
                    .sum::<f64>()
                    .sqrt();
                last_step = norm_vec(&dx) / un.max(f64::MIN_POSITIVE);
            }
            if !converged {
                return Err(FemError::NoConvergence {
                    iterations,
                    residual: residuals.last().copied().unwrap_or(f64::NAN),
                });
            }
        }
        let mut external_force = vec![[0.0; 3]; nn];
        for v in 0..nn {
            for k in 0..3 {
                external_force[v][k] = f_ext_full[3 * v + k];
            }
        }
        for (ci, c) in p.cables.iter().enumerate() {
            for (n, v) in c.row(&x) {
                for k in 0..3 {
                    external_force[n][k] += tension[ci] * v[k];
                }
            }
        }
        let displacement = (0..nn)
            .map(|v| sub(x[v], p.mesh.nodes_in_rest[v]))
            .collect();
        Ok(Solution {
            cable_shortening: p
                .cables
                .iter()
                .zip(&l0)
                .map(|(c, l)| l - c.length(&x))
                .collect(),
            positions: x,
            displacement,
            external_force,
            cable_tension: tension,
            cable_slack: slack,
            von_mises: self.elements.iter().map(|e| von_mises(&e.stress)).collect(),
            iterations,
            residuals,
            converged,
        })
    }
}

/// Euclidean norm of a slice.
pub fn norm_vec(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

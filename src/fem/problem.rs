//! What is solved: the static FE problem (mesh, material, supports, loads, cables), the
//! points it attaches loads to, and the checks and forces that depend on it alone.

use super::cable::Cable;
use super::cavity::Cavity;
use super::material::Material;
use super::mesh::{norm, sub, TetMesh};
use super::newton::{NewtonParams, Solution};
use super::setup::SolverSetup;
use super::solve::Solver;
use super::workspace::SolverState;
use super::{FemError, FemResult};
use serde::Serialize;
use std::sync::{Arc, OnceLock};

/// Small-strain linear, corotational or Neo-Hookean tetrahedra (one Lamé pair for all).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum Formulation {
    /// Linear elasticity about the rest shape (K constant).
    SmallStrain,
    /// Corotational (large displacement, small strain), rotation by polar decomposition.
    #[default]
    Corotational,
    /// Compressible Neo-Hookean (large displacement and strain; [`crate::fem::neohookean`]).
    NeoHookean,
}

impl Formulation {
    /// The formulation a model file names: `"corotational"` (or `"large"`), `"small-strain"`
    /// (or `"linear"`), `"neo-hookean"`; `None` for any other name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "corotational" | "large" => Some(Self::Corotational),
            "small-strain" | "linear" => Some(Self::SmallStrain),
            "neo-hookean" => Some(Self::NeoHookean),
            _ => None,
        }
    }

    /// The name model files write for it.
    pub fn name(&self) -> &'static str {
        match self {
            Self::SmallStrain => "small-strain",
            Self::Corotational => "corotational",
            Self::NeoHookean => "neo-hookean",
        }
    }
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

/// The static FE problem: mesh, material, boundary conditions, loads and cables. SI units.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The rest mesh.
    pub mesh: TetMesh,
    /// Material.
    pub material: Material,
    /// Small-strain, corotational or Neo-Hookean.
    pub formulation: Formulation,
    /// Fixed nodes: clamped (removed from the system), or on springs with `base_stiffness`.
    pub fixed: Vec<usize>,
    /// Total stiffness of a compliant base (N/m, each axis), shared equally by the fixed
    /// nodes, each tied to its rest position by a linear spring; `None` (default) clamps them.
    pub base_stiffness: Option<f64>,
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
    /// Pressure cavities: actuators after the cables.
    pub cavities: Vec<Cavity>,
    /// Per-tetrahedron factor on Young's modulus (regional stiffness); empty means all 1.
    pub young_scale: Vec<f64>,
    /// Per-tetrahedron initial stress (Pa; [`super::prestress`]): the stiffening of a stress
    /// carried at rest, such as an inflated membrane's tension; empty means none.
    pub prestress: Vec<super::prestress::Stress>,
    /// The shell the mesh was extruded as (SI, placed; `None` for a solid): what a moved
    /// rest surface needs to move its layers and its pre-tension with it
    /// ([`super::shell::move_surface`]).
    pub shell: Option<super::shell::ShellParams>,
    /// The solver setup of the first [`Problem::solver`] call, shared by clones: reused by
    /// later solvers while the mesh, held nodes and cable attachments are unchanged.
    setup_cache: Arc<OnceLock<Arc<SolverSetup>>>,
}

impl Problem {
    /// A problem with no fixed nodes, loads or gravity yet.
    pub fn new(mesh: TetMesh, material: Material, formulation: Formulation) -> Self {
        Self {
            mesh,
            material,
            formulation,
            fixed: Vec::new(),
            base_stiffness: None,
            prescribed: Vec::new(),
            density: 0.0,
            gravity: [0.0; 3],
            loads: Vec::new(),
            cables: Vec::new(),
            cavities: Vec::new(),
            young_scale: Vec::new(),
            prestress: Vec::new(),
            shell: None,
            setup_cache: Arc::default(),
        }
    }

    /// The nodes removed from the system: fixed ones (unless on springs) and prescribed
    /// ones, sorted, without repeats.
    pub fn held_nodes(&self) -> Vec<usize> {
        let clamped = match self.base_stiffness {
            None => &self.fixed[..],
            Some(_) => &[],
        };
        sorted_nodes(clamped, &self.prescribed)
    }

    /// The nodes that stop rigid motion: fixed ones (clamped or on springs) and prescribed
    /// ones, sorted, without repeats.
    pub fn support_nodes(&self) -> Vec<usize> {
        sorted_nodes(&self.fixed, &self.prescribed)
    }

    /// The stiffness of each base spring (N/m, each axis): `base_stiffness` over the number
    /// of fixed nodes; `None` for a clamped base (or no fixed nodes).
    pub fn node_spring_stiffness(&self) -> Option<f64> {
        let k = self.base_stiffness?;
        (!self.fixed.is_empty()).then(|| k / self.fixed.len() as f64)
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
        let supports = self.support_nodes();
        if supports.is_empty() {
            return Err(FemError::Singular(
                "no fixed nodes: rigid motions are free".into(),
            ));
        }
        if let Some(&v) = supports.iter().find(|&&v| v >= n) {
            return Err(FemError::Model(format!(
                "fixed node {v} does not exist ({n} nodes)"
            )));
        }
        if held.len() == n {
            return Err(FemError::Model(format!(
                "all {n} nodes are fixed: no degree of freedom is left to solve for \
                 (fix fewer nodes)"
            )));
        }
        // A free node in no element has zero stiffness: the factorization would fail with
        // a pivot number that says nothing about why.
        let mut in_element = vec![false; n];
        for t in &self.mesh.tets {
            for &v in t {
                in_element[v] = true;
            }
        }
        if let Some(v) = (0..n).find(|&v| !in_element[v] && held.binary_search(&v).is_err()) {
            return Err(FemError::InvalidMesh(format!(
                "node {v} belongs to no element: remove it from the mesh (or fix it in place)"
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
        // Springs in x, y and z on nodes spanning a plane stop rigid motion as clamps do.
        for &v in &supports {
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
    pub(super) fn body_forces_of(&self, masses: &[f64]) -> Vec<f64> {
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
    pub(super) fn add_point_loads(&self, f: Vec<f64>) -> Vec<f64> {
        add_loads(f, &self.loads)
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
        Solver::from_state(self, state)
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

    /// As [`Problem::solve_static`], calling `step_done(step, steps)` after each load step.
    pub fn solve_static_observed(
        &self,
        params: &NewtonParams,
        step_done: &mut dyn FnMut(usize, usize),
    ) -> FemResult<Solution> {
        self.solver()?
            .solve_static_observed(params, None, step_done)
    }
}

/// `a` and the nodes of `b`, sorted, without repeats.
fn sorted_nodes(a: &[usize], b: &[(usize, [f64; 3])]) -> Vec<usize> {
    let mut v: Vec<usize> = a.iter().copied().chain(b.iter().map(|p| p.0)).collect();
    v.sort_unstable();
    v.dedup();
    v
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

/// `f` (node-major 3n) plus `loads`, in their order.
pub(super) fn add_loads(mut f: Vec<f64>, loads: &[PointLoad]) -> Vec<f64> {
    for l in loads {
        for (n, w) in l.at.nodes.iter().zip(l.at.weights) {
            for k in 0..3 {
                f[3 * n + k] += w * l.force[k];
            }
        }
    }
    f
}

//! A solver's reusable work: the element states at the last assembled positions, K as
//! scattered from them, and what a [`SolverState`] carries from one solver to the next
//! (the buffers, and which values the factor is of) so repeated work is skipped.

use super::assembly::eval_elements;
use super::material::Material;
use super::mesh::sub;
use super::pool::Pooled;
use super::prestress;
use super::problem::{Formulation, Problem};
use super::setup::SolverSetup;
use super::solve::Solver;
use super::tet4::{ElementState, Tangent};
use super::{FemError, FemResult};
use std::sync::Arc;

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
    prestress: Vec<super::prestress::Stress>,
    base_stiffness: Option<f64>,
    l_values: Arc<Pooled<f64>>,
    values: Vec<f64>,
    internal_force: Vec<f64>,
    elements: Arc<Pooled<ElementState>>,
    elements_at: Vec<[f64; 3]>,
    elements_tangent: Tangent,
    scattered: Vec<f64>,
    factor_of: Vec<f64>,
    failed_of: Vec<f64>,
    failed_pivot: usize,
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
    /// A solver for `problem` that takes over `state` where it fits (see
    /// [`Problem::solver_from`]).
    pub(super) fn from_state(problem: &'p Problem, state: SolverState) -> FemResult<Self> {
        if !state.setup.fits(problem) {
            return problem.solver();
        }
        let setup = state.setup;
        let reusable = state.material == problem.material
            && state.formulation == problem.formulation
            && state.young_scale == problem.young_scale
            && state.prestress == problem.prestress
            && state.base_stiffness == problem.base_stiffness
            && state.values.len() == setup.pattern.nnz()
            && state.l_values.len() == setup.symbolic.len_val();
        if !reusable {
            return Solver::with_setup(problem, setup);
        }
        let mut solver = Solver::with_buffers(problem, setup, state.l_values, state.values)?;
        solver.internal_force = state.internal_force;
        solver.elements = state.elements;
        solver.elements_at = state.elements_at;
        solver.elements_tangent = state.elements_tangent;
        solver.scattered = state.scattered;
        solver.factor_of = state.factor_of;
        solver.failed_of = state.failed_of;
        solver.failed_pivot = state.failed_pivot;
        Ok(solver)
    }

    /// The element states and buffers of this solver, for [`Problem::solver_from`].
    pub fn into_state(self) -> SolverState {
        SolverState {
            setup: self.setup,
            material: self.problem.material,
            formulation: self.problem.formulation,
            young_scale: self.problem.young_scale.clone(),
            prestress: self.problem.prestress.clone(),
            base_stiffness: self.problem.base_stiffness,
            l_values: self.l_values,
            values: self.values,
            internal_force: self.internal_force,
            elements: self.elements,
            elements_at: self.elements_at,
            elements_tangent: self.elements_tangent,
            scattered: self.scattered,
            factor_of: self.factor_of,
            failed_of: self.failed_of,
            failed_pivot: self.failed_pivot,
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
    /// solver.tangent_at(&x, Tangent::Definite)?;
    /// let before = solver.factorizations();
    /// solver.tangent_at(&x, Tangent::Definite)?; // the same values: skipped
    /// assert_eq!(solver.factorizations(), before);
    /// solver.forget_reuse();
    /// solver.tangent_at(&x, Tangent::Definite)?; // done again
    /// assert_eq!(solver.factorizations(), before + 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn forget_reuse(&mut self) {
        self.elements_at.clear();
        self.scattered.clear();
        self.factor_of.clear();
        self.failed_of.clear();
    }

    /// Assembles internal forces and the tangent at node positions `x`. At the positions
    /// of the previous assembly the element states are reused (the same values, bit for
    /// bit): with the same tangent they are only scattered again, and the rotated tangent
    /// after a consistent one is built from the stored rotations (no polar decomposition),
    /// leaving the element states as they were. A compliant base's springs are in both.
    pub fn assemble(&mut self, x: &[[f64; 3]], tangent: Tangent) -> FemResult<()> {
        let same_x = self.elements.len() == self.rest.len()
            && self.elements_at.len() == x.len()
            && self
                .elements_at
                .iter()
                .flatten()
                .zip(x.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits());
        let rotated =
            tangent == Tangent::Definite && self.problem.formulation == Formulation::Corotational;
        if same_x && tangent == self.elements_tangent {
            self.scatter_elements();
        } else if same_x && rotated {
            self.scatter_rotated();
        } else {
            self.evaluate(x, tangent)?;
            self.scatter_elements();
            // `evaluate` emptied it (a failed evaluation leaves no reusable states).
            self.elements_at.extend_from_slice(x);
            self.elements_tangent = tangent;
        }
        self.add_base_stiffness();
        Ok(())
    }

    /// Adds the base springs' stiffness k I to the fixed nodes' diagonal blocks of K.
    fn add_base_stiffness(&mut self) {
        let Some(k) = self.problem.node_spring_stiffness() else {
            return;
        };
        let block = [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]];
        for &v in &self.problem.fixed {
            (self.pattern).add_block(&self.dofs, v, v, &block, &mut self.values);
        }
    }

    /// Adds the base springs' forces k (x − X) at the fixed nodes to the internal forces.
    fn add_base_forces(&mut self, x: &[[f64; 3]]) {
        let Some(k) = self.problem.node_spring_stiffness() else {
            return;
        };
        let rest = &self.problem.mesh.nodes_in_rest;
        for &v in &self.problem.fixed {
            for c in 0..3 {
                self.internal_force[3 * v + c] += k * (x[v][c] - rest[v][c]);
            }
        }
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
        let pool = &self.setup.pool;
        let mut states = Arc::try_unwrap(std::mem::replace(
            &mut self.elements,
            Arc::new(Pooled::empty(pool)),
        ))
        .unwrap_or_else(|_| Pooled::spare(pool, n).unwrap_or_else(|| Pooled::empty(pool)));
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
                Formulation::NeoHookean => {
                    let f = r.neo_hookean_gradient(e, &t.map(|a| x[a]))?;
                    r.neo_hookean_into(m, &f, tangent, pattern.block_mask(e), out);
                    Ok(())
                }
            }
        })?;
        // Force, tangent and stress are linear in (lambda, mu), so they all scale with
        // Young's modulus (Neo-Hookean too: W is linear in them).
        for (s, &f) in states.iter_mut().zip(&p.young_scale) {
            if f != 1.0 {
                s.force.iter_mut().for_each(|v| *v *= f);
                s.tangent.iter_mut().flatten().for_each(|v| *v *= f);
                s.stress *= f;
            }
        }
        if !p.prestress.is_empty() {
            if p.prestress.len() != tets.len() {
                return Err(FemError::Model(format!(
                    "{} initial stresses for {} tetrahedra",
                    p.prestress.len(),
                    tets.len()
                )));
            }
            for (e, (s, t)) in states.iter_mut().zip(tets).enumerate() {
                let u = t.map(|a| sub(x[a], rest_nodes[a]));
                prestress::add_to_state(&self.rest[e], &p.prestress[e], &u, s);
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
        self.add_base_forces(x);
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
    /// [`Solver::evaluate`] gives with [`Tangent::Definite`]); the element states are kept.
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
            if let Some(s0) = self.problem.prestress.get(e) {
                prestress::add_tangent(r, s0, &mut k);
            }
            self.pattern.scatter(e, &k, &mut self.values);
        }
    }
}

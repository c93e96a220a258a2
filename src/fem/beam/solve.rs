//! Assembly over the free nodes, the static Newton solve, and the linearisation: the
//! factorised tangent at a configuration and compliance W = H K⁻¹ Hᵀ over [`BeamRow`]s.

use super::element::{log, Ends, Mat12, Vec12};
use super::{
    BeamCable, BeamLoads, BeamModel, BeamParams, BeamSolution, BeamState, BeamStatus, NodeLoad,
    NodeSpring,
};
use crate::fem::{FemError, FemResult};
use crate::math::Vec3;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::linalg::LltError as SparseLltError;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use nalgebra::{DMatrix, DVector, UnitQuaternion};

/// A constraint row: a 6-vector per node (translation then rotation, world frame). Its
/// value is Σ h·(x − x_rest) + h_r·log(R R_restᵀ); the force it carries under λ is λ h at
/// each node (force then moment).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BeamRow {
    /// (node, [h_x, h_y, h_z, h_rx, h_ry, h_rz]) entries; a node may appear once.
    pub entries: Vec<(usize, [f64; 6])>,
}

impl BeamRow {
    /// The displacement of `node` along `direction` (world frame, taken as given).
    pub fn translation(node: usize, direction: [f64; 3]) -> Self {
        let [x, y, z] = direction;
        Self {
            entries: vec![(node, [x, y, z, 0.0, 0.0, 0.0])],
        }
    }

    /// The rotation of `node` about `axis` (world frame, taken as given).
    pub fn rotation(node: usize, axis: [f64; 3]) -> Self {
        let [x, y, z] = axis;
        Self {
            entries: vec![(node, [0.0, 0.0, 0.0, x, y, z])],
        }
    }

    /// The row's value at `state`, relative to the model's rest configuration (m or rad).
    pub fn measure(&self, model: &BeamModel, state: &BeamState) -> f64 {
        self.entries
            .iter()
            .map(|(n, h)| {
                let u = state.nodes_in_world[*n] - model.rest.nodes_in_world[*n];
                let turn = state.world_from_node[*n] * model.rest.world_from_node[*n].inverse();
                let w = log(&turn);
                (0..3).map(|k| h[k] * u[k] + h[k + 3] * w[k]).sum::<f64>()
            })
            .sum()
    }

    /// The nodal loads of `lambda` along this row (λ h per node).
    pub fn loads(&self, lambda: f64) -> Vec<NodeLoad> {
        self.entries
            .iter()
            .map(|(n, h)| NodeLoad {
                node: *n,
                force: Vec3::new(h[0], h[1], h[2]) * lambda,
                moment: Vec3::new(h[3], h[4], h[5]) * lambda,
            })
            .collect()
    }
}

/// Free-DOF numbering: 6 per node not clamped, in node order.
struct DofMap {
    first: Vec<Option<usize>>,
    ndof: usize,
}

impl DofMap {
    fn new(model: &BeamModel) -> Self {
        let mut ndof = 0;
        let first = (0..model.node_count())
            .map(|n| {
                (!model.clamped.contains(&n)).then(|| {
                    ndof += 6;
                    ndof - 6
                })
            })
            .collect();
        Self { first, ndof }
    }

    /// The free-DOF part of an all-node vector.
    fn restrict(&self, all: &DVector<f64>) -> Mat<f64> {
        let mut out = Mat::zeros(self.ndof, 1);
        for (n, f) in self.first.iter().enumerate() {
            if let Some(f) = f {
                for k in 0..6 {
                    out[(f + k, 0)] = all[6 * n + k];
                }
            }
        }
        out
    }
}

impl BeamModel {
    fn ends<'a>(&self, state: &'a BeamState, e: usize) -> Ends<'a> {
        Ends {
            x: [&state.nodes_in_world[e], &state.nodes_in_world[e + 1]],
            world_from_node: [&state.world_from_node[e], &state.world_from_node[e + 1]],
        }
    }

    /// Internal forces at every node: 6 per node, force then moment (N, N m; world frame).
    pub fn internal_force(&self, state: &BeamState) -> DVector<f64> {
        let mut f = DVector::zeros(6 * self.node_count());
        for (e, el) in self.elements.iter().enumerate() {
            let fe = el.force(&self.stiffness, &self.ends(state, e));
            let mut block = f.fixed_rows_mut::<12>(6 * e);
            block += fe;
        }
        f
    }

    /// Element forces and symmetrised tangents at `state`.
    fn element_tangents(&self, state: &BeamState, geometric: bool) -> Vec<(Vec12, Mat12)> {
        self.elements
            .iter()
            .enumerate()
            .map(|(e, el)| {
                let (f, k) = el.force_and_tangent(&self.stiffness, &self.ends(state, e), geometric);
                (f, 0.5 * (k + k.transpose()))
            })
            .collect()
    }

    /// The symmetrised tangent over every node's 6 DOFs (dense; for checks and small
    /// models, clamped nodes included).
    pub fn tangent_dense(&self, state: &BeamState) -> DMatrix<f64> {
        let geometric = true;
        let n = 6 * self.node_count();
        let mut k = DMatrix::zeros(n, n);
        for (e, (_, ke)) in self.element_tangents(state, geometric).iter().enumerate() {
            let mut block = k.fixed_view_mut::<12, 12>(6 * e, 6 * e);
            block += ke;
        }
        k
    }

    /// The free-DOF tangent as a sparse matrix (every element block stored, so the pattern
    /// is the same at every configuration).
    fn tangent_sparse(
        &self,
        dofs: &DofMap,
        state: &BeamState,
        geometric: bool,
        cables: &[(BeamCable, f64)],
        springs: &[NodeSpring],
    ) -> FemResult<SparseColMat<usize, f64>> {
        let mut triplets = Vec::with_capacity(144 * self.elements.len());
        if geometric {
            self.cable_stiffness(dofs, state, cables, &mut triplets);
        }
        // Inside each node's own block, so the sparsity pattern does not change.
        for spring in springs {
            let Some(f) = dofs.first.get(spring.node).copied().flatten() else {
                continue;
            };
            if spring.depth(&state.nodes_in_world[spring.node]) <= 0.0 {
                continue;
            }
            let (n, k) = (spring.direction, spring.stiffness);
            for i in 0..3 {
                for j in 0..3 {
                    triplets.push(Triplet::new(f + i, f + j, k * n[i] * n[j]));
                }
            }
        }
        for (e, (_, ke)) in self.element_tangents(state, geometric).iter().enumerate() {
            for (a, fa) in [dofs.first[e], dofs.first[e + 1]].iter().enumerate() {
                for (b, fb) in [dofs.first[e], dofs.first[e + 1]].iter().enumerate() {
                    let (Some(fa), Some(fb)) = (fa, fb) else {
                        continue;
                    };
                    for i in 0..6 {
                        for j in 0..6 {
                            triplets.push(Triplet::new(fa + i, fb + j, ke[(6 * a + i, 6 * b + j)]));
                        }
                    }
                }
            }
        }
        SparseColMat::try_new_from_triplets(dofs.ndof, dofs.ndof, &triplets).map_err(|e| match e {
            faer::sparse::CreationError::Generic(g) => FemError::Linalg(g),
            faer::sparse::CreationError::OutOfBounds { row, col } => {
                FemError::Model(format!("beam DOF ({row}, {col}) out of bounds"))
            }
        })
    }

    /// External forces at every node at `state`: node loads and cable loads, times `scale`.
    fn external_force(&self, state: &BeamState, loads: &BeamLoads, scale: f64) -> DVector<f64> {
        let mut f = DVector::zeros(6 * self.node_count());
        let cable_loads = loads
            .cables
            .iter()
            .flat_map(|(c, t)| c.row(state).loads(*t));
        for l in loads.nodes.iter().copied().chain(cable_loads) {
            let mut block = f.rows_mut(6 * l.node, 6);
            for k in 0..3 {
                block[k] += scale * l.force[k];
                block[k + 3] += scale * l.moment[k];
            }
        }
        for spring in &loads.springs {
            let push = spring.force(&state.nodes_in_world[spring.node]);
            let mut block = f.fixed_rows_mut::<3>(6 * spring.node);
            block += push;
        }
        f
    }

    /// Puts the clamped nodes at their rest pose moved by `loads.base_from_rest`, first
    /// carrying the whole rod rigidly with node 0's change of pose (a start whose base
    /// jumped would be crushed or stretched past what Newton can recover).
    fn place_base(&self, state: &mut BeamState, loads: &BeamLoads) {
        let base = self.clamped.first().copied().unwrap_or(0);
        let to = loads.base_from_rest.rotation * self.rest.world_from_node[base];
        let turn = to * state.world_from_node[base].inverse();
        let (from_x, to_x) = (
            state.nodes_in_world[base],
            (loads.base_from_rest * nalgebra::Point3::from(self.rest.nodes_in_world[base])).coords,
        );
        for (x, q) in state
            .nodes_in_world
            .iter_mut()
            .zip(&mut state.world_from_node)
        {
            *x = to_x + turn * (*x - from_x);
            *q = turn * *q;
        }
        for &n in &self.clamped {
            state.nodes_in_world[n] =
                (loads.base_from_rest * nalgebra::Point3::from(self.rest.nodes_in_world[n])).coords;
            state.world_from_node[n] = loads.base_from_rest.rotation * self.rest.world_from_node[n];
        }
    }

    /// Static equilibrium under `loads` from `start` (its clamped nodes are first put at
    /// the base pose), by Newton in `params.load_steps` increments of the loads.
    /// Setup problems are errors; how Newton ended is the solution's status.
    pub fn solve_static(
        &self,
        start: &BeamState,
        loads: &BeamLoads,
        params: &BeamParams,
    ) -> FemResult<BeamSolution> {
        let dofs = DofMap::new(self);
        if dofs.ndof == self.node_count() * 6 {
            return Err(FemError::Singular("a beam needs a clamped node".into()));
        }
        let mut state = start.clone();
        self.place_base(&mut state, loads);
        let mut symbolic: Option<SymbolicLlt<usize>> = None;
        let (mut iterations, mut residual) = (0, f64::INFINITY);
        let steps = params.load_steps.max(1);
        for step in 1..=steps {
            let scale = step as f64 / steps as f64;
            let mut converged = false;
            for _ in 0..params.max_iterations {
                let r = dofs.restrict(
                    &(self.external_force(&state, loads, scale) - self.internal_force(&state)),
                );
                residual = r.norm_l2();
                let Some(llt) = self.factor_with_fallback(&dofs, &state, loads, &mut symbolic)?
                else {
                    return Ok(self.ended(
                        state,
                        BeamStatus::NotPositiveDefinite,
                        iterations,
                        residual,
                    ));
                };
                let mut delta = r;
                llt.solve_in_place(delta.as_mut());
                iterations += 1;
                let size = self.apply_step(&dofs, &mut state, &delta, params.max_rotation_step);
                if size <= params.tolerance {
                    converged = true;
                    break;
                }
            }
            if !converged {
                return Ok(self.ended(state, BeamStatus::MaxIterations, iterations, residual));
            }
        }
        let r =
            dofs.restrict(&(self.external_force(&state, loads, 1.0) - self.internal_force(&state)));
        residual = r.norm_l2();
        Ok(self.ended(state, BeamStatus::Converged, iterations, residual))
    }

    fn ended(
        &self,
        state: BeamState,
        status: BeamStatus,
        iterations: usize,
        residual: f64,
    ) -> BeamSolution {
        BeamSolution {
            state,
            status,
            iterations,
            residual,
        }
    }

    /// Applies a Newton step (translations added, spins by the exponential map), scaled so
    /// no node turns by more than `max_rotation`; returns the step's size: the largest
    /// translation over the rod's length or rotation (rad).
    fn apply_step(
        &self,
        dofs: &DofMap,
        state: &mut BeamState,
        delta: &Mat<f64>,
        max_rotation: f64,
    ) -> f64 {
        let at = |f: usize| Vec3::new(delta[(f, 0)], delta[(f + 1, 0)], delta[(f + 2, 0)]);
        let largest_turn = dofs
            .first
            .iter()
            .flatten()
            .map(|&f| at(f + 3).norm())
            .fold(0.0, f64::max);
        let scale = if largest_turn > max_rotation {
            max_rotation / largest_turn
        } else {
            1.0
        };
        let length = self.length();
        let mut size: f64 = 0.0;
        for (n, f) in dofs.first.iter().enumerate() {
            let Some(f) = *f else { continue };
            let (dx, dw) = (scale * at(f), scale * at(f + 3));
            state.nodes_in_world[n] += dx;
            state.world_from_node[n] =
                UnitQuaternion::from_scaled_axis(dw) * state.world_from_node[n];
            size = size.max(dx.norm() / length).max(dw.norm());
        }
        size
    }

    /// The cables' load stiffness −T ∂g/∂q (g: a cable's row, the gradient of its
    /// shortening) by central differences of the analytic row, as triplets on the free
    /// DOFs. A row's entries at node i depend on nodes i−1..i+1 only, so the pattern stays
    /// inside the element blocks'.
    fn cable_stiffness(
        &self,
        dofs: &DofMap,
        state: &BeamState,
        cables: &[(BeamCable, f64)],
        triplets: &mut Vec<Triplet<usize, usize, f64>>,
    ) {
        let h = 1e-7;
        for (cable, tension) in cables.iter().filter(|(_, t)| *t != 0.0) {
            for (j, fj) in dofs.first.iter().enumerate() {
                let Some(fj) = *fj else { continue };
                for k in 0..6 {
                    let step = |sign: f64| {
                        let mut s = state.clone();
                        let mut d = Vec3::zeros();
                        d[k % 3] = sign * h * if k < 3 { self.length() } else { 1.0 };
                        match k < 3 {
                            true => s.nodes_in_world[j] += d,
                            false => {
                                s.world_from_node[j] =
                                    UnitQuaternion::from_scaled_axis(d) * s.world_from_node[j]
                            }
                        }
                        (cable.row(&s), d[k % 3])
                    };
                    let ((plus, dp), (minus, dm)) = (step(1.0), step(-1.0));
                    for ((i, gp), (_, gm)) in plus.entries.iter().zip(&minus.entries) {
                        let Some(fi) = dofs.first[*i] else { continue };
                        if i.abs_diff(j) > 1 {
                            continue;
                        }
                        for r in 0..6 {
                            let v = -tension * (gp[r] - gm[r]) / (dp - dm);
                            // Half here and half transposed: the symmetric part.
                            triplets.push(Triplet::new(fi + r, fj + k, 0.5 * v));
                            triplets.push(Triplet::new(fj + k, fi + r, 0.5 * v));
                        }
                    }
                }
            }
        }
    }

    /// Factorises the consistent tangent at `state`, or, when it is not positive definite
    /// (compression past buckling: a cable's own compression, whose load stiffness the
    /// tangent omits, or a large end moment), the material part alone (Newton then
    /// converges linearly, to the same equilibrium). `None` if neither is definite.
    fn factor_with_fallback(
        &self,
        dofs: &DofMap,
        state: &BeamState,
        loads: &BeamLoads,
        symbolic: &mut Option<SymbolicLlt<usize>>,
    ) -> FemResult<Option<Llt<usize, f64>>> {
        for geometric in [true, false] {
            let k = self.tangent_sparse(dofs, state, geometric, &loads.cables, &loads.springs)?;
            let sym = match symbolic {
                Some(s) => s.clone(),
                None => {
                    SymbolicLlt::try_new(k.symbolic(), Side::Lower).map_err(FemError::Linalg)?
                }
            };
            *symbolic = Some(sym.clone());
            match Llt::try_new_with_symbolic(sym, k.as_ref(), Side::Lower) {
                Ok(l) => return Ok(Some(l)),
                Err(SparseLltError::Numeric(_)) => continue,
                Err(e) => return Err(sparse_llt_error(e)),
            }
        }
        Ok(None)
    }

    /// Factorises the tangent at `state` (one factorisation, for many compliance solves):
    /// the consistent one, or its material part when that is not positive definite (as in
    /// Newton: under the cables' own compression, whose follower-load stiffness the tangent
    /// omits; `BeamLinearisation::geometric` says which). An error if neither is definite.
    pub fn linearise(&self, state: &BeamState) -> FemResult<BeamLinearisation> {
        self.linearise_loaded(state, &[])
    }

    /// [`Self::linearise`] with the load stiffness of cables under tension in the geometric
    /// part: the tangent Newton used for the equilibrium under those cables.
    pub fn linearise_loaded(
        &self,
        state: &BeamState,
        cables: &[(BeamCable, f64)],
    ) -> FemResult<BeamLinearisation> {
        let dofs = DofMap::new(self);
        let mut last = None;
        for geometric in [true, false] {
            let k = self.tangent_sparse(&dofs, state, geometric, cables, &[])?;
            match k.as_ref().sp_cholesky(Side::Lower) {
                Ok(llt) => {
                    return Ok(BeamLinearisation {
                        dofs,
                        llt,
                        geometric,
                    })
                }
                Err(SparseLltError::Numeric(e)) => last = Some(e),
                Err(e) => return Err(sparse_llt_error(e)),
            }
        }
        Err(last.expect("both tangents were tried").into())
    }
}

fn sparse_llt_error(e: SparseLltError) -> FemError {
    match e {
        SparseLltError::Numeric(n) => n.into(),
        SparseLltError::Generic(g) => FemError::Linalg(g),
    }
}

/// The factorised free-DOF tangent at one configuration.
pub struct BeamLinearisation {
    dofs: DofMap,
    llt: Llt<usize, f64>,
    /// Whether the geometric part of the tangent is in (false: the material part alone).
    pub geometric: bool,
}

impl std::fmt::Debug for BeamLinearisation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BeamLinearisation")
            .field("ndof", &self.dofs.ndof)
            .finish_non_exhaustive()
    }
}

impl BeamLinearisation {
    /// Hᵀ as free-DOF columns (entries on clamped nodes drop out).
    fn columns(&self, rows: &[BeamRow]) -> Mat<f64> {
        let mut h = Mat::zeros(self.dofs.ndof, rows.len());
        for (c, row) in rows.iter().enumerate() {
            for (n, e) in &row.entries {
                if let Some(f) = self.dofs.first[*n] {
                    for k in 0..6 {
                        h[(f + k, c)] += e[k];
                    }
                }
            }
        }
        h
    }

    /// W = H K⁻¹ Hᵀ (rows' units: m or rad per N or N m).
    pub fn compliance(&self, rows: &[BeamRow]) -> DMatrix<f64> {
        let h = self.columns(rows);
        let mut x = h.clone();
        self.llt.solve_in_place(x.as_mut());
        let w: Mat<f64> = h.as_ref().transpose() * x.as_ref();
        DMatrix::from_fn(rows.len(), rows.len(), |i, j| 0.5 * (w[(i, j)] + w[(j, i)]))
    }
}

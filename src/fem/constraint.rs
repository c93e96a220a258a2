//! Constraint space (thesis 2.4-2.6, 3.8): mapping rows H for effectors, actuators and
//! external forces; compliance W = H K^-1 H^T from solves on the columns of H^T; the free
//! motion delta^free; the Jacobian J = W_ea W_aa^-1.

use super::solve::{Cable, MappedPoint, Solver};
use super::{FemError, FemResult};
use faer::Mat;
use nalgebra::DMatrix;
use serde::Serialize;

/// What a constraint row stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum RowKind {
    /// An effector (feature point) coordinate.
    Effector,
    /// An actuator (cable shortening).
    Actuator,
    /// An external force at a candidate location, along a direction.
    Force,
}

/// One row of H: a linear functional of the node positions, as (node, coefficient) pairs.
#[derive(Debug, Clone, Serialize)]
pub struct ConstraintRow {
    /// Kind of the row.
    pub kind: RowKind,
    /// Coefficients per node (3-vectors).
    pub entries: Vec<(usize, [f64; 3])>,
}

impl ConstraintRow {
    /// A row measuring the mapped point `at` along `direction` (normalised).
    pub fn along(kind: RowKind, at: &MappedPoint, direction: [f64; 3]) -> FemResult<Self> {
        let l = super::mesh::norm(direction);
        if !(l > 0.0 && l.is_finite()) {
            return Err(FemError::Model(format!(
                "row direction {direction:?} has no length"
            )));
        }
        let d = direction.map(|c| c / l);
        let entries = at
            .nodes
            .iter()
            .zip(at.weights)
            .filter(|(_, w)| *w != 0.0)
            .map(|(n, w)| (*n, d.map(|c| w * c)))
            .collect();
        Ok(Self { kind, entries })
    }

    /// Three rows (x, y, z) for a 3-D point.
    pub fn point3(kind: RowKind, at: &MappedPoint) -> Vec<Self> {
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .iter()
            .filter_map(|d| Self::along(kind, at, *d).ok())
            .collect()
    }

    /// The actuator row of a cable at node positions `x` (d shortening / dx).
    pub fn cable(cable: &Cable, x: &[[f64; 3]]) -> Self {
        Self {
            kind: RowKind::Actuator,
            entries: cable.row(x),
        }
    }

    /// The row's value for node positions `x` (sum of coefficient . position).
    pub fn value(&self, x: &[[f64; 3]]) -> f64 {
        self.entries
            .iter()
            .map(|(n, c)| c[0] * x[*n][0] + c[1] * x[*n][1] + c[2] * x[*n][2])
            .sum()
    }
}

/// Compliance in constraint space.
#[derive(Debug, Clone, Serialize)]
pub struct Compliance {
    /// W = H K^-1 H^T (rows x rows), m/N.
    pub w: DMatrix<f64>,
    /// Linearised row values after a free step (lambda = 0): H x + H K^-1 r(x).
    pub delta_free: Vec<f64>,
    /// Row kinds.
    pub kinds: Vec<RowKind>,
}

impl Solver<'_> {
    /// Compliance of `rows` with the current factorization, at positions `x` with free
    /// residual `residual` (free-DOF space, e.g. f_ext - f_int), which gives delta^free.
    pub fn compliance(
        &self,
        rows: &[ConstraintRow],
        x: &[[f64; 3]],
        residual: &[f64],
    ) -> FemResult<Compliance> {
        let nd = self.ndof();
        let m = rows.len();
        let mut ht = Mat::<f64>::zeros(nd, m + 1);
        let mut cols = vec![vec![0.0; nd]; m];
        for (j, row) in rows.iter().enumerate() {
            self.row_to_dofs(&row.entries, &mut cols[j]);
            for (i, v) in cols[j].iter().enumerate() {
                ht[(i, j)] = *v;
            }
        }
        for (i, v) in residual.iter().enumerate().take(nd) {
            ht[(i, m)] = *v;
        }
        self.solve_in_place(&mut ht)?;
        // Sparse rows: (dof, coefficient) pairs, so W costs rows x rows x (row length).
        let sparse: Vec<Vec<(usize, f64)>> = cols
            .iter()
            .map(|c| {
                c.iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(k, v)| (k, *v))
                    .collect()
            })
            .collect();
        let mut w = DMatrix::zeros(m, m);
        let mut delta_free = Vec::with_capacity(m);
        for (i, hi) in sparse.iter().enumerate() {
            for j in 0..m {
                w[(i, j)] = hi.iter().map(|(k, v)| v * ht[(*k, j)]).sum();
            }
            let du: f64 = hi.iter().map(|(k, v)| v * ht[(*k, m)]).sum();
            delta_free.push(rows[i].value(x) + du);
        }
        Ok(Compliance {
            w,
            delta_free,
            kinds: rows.iter().map(|r| r.kind).collect(),
        })
    }

    /// Assembles and factorizes the tangent at `x` and returns the compliance of `rows`
    /// together with delta^free for the problem's external forces (gravity, loads).
    pub fn compliance_at(
        &mut self,
        x: &[[f64; 3]],
        rows: &[ConstraintRow],
    ) -> FemResult<Compliance> {
        self.tangent_at(x, Default::default())?;
        let mut full = self.problem.external_forces();
        for (f, fi) in full.iter_mut().zip(&self.internal_force) {
            *f -= fi;
        }
        let r = self.dofs.gather(&full);
        self.compliance(rows, x, &r)
    }
}

impl Compliance {
    /// Indices of rows of a kind.
    pub fn rows_of(&self, kind: RowKind) -> Vec<usize> {
        (0..self.kinds.len())
            .filter(|&i| self.kinds[i] == kind)
            .collect()
    }

    /// The sub-block W[rows_a, rows_b].
    pub fn block(&self, a: &[usize], b: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(a.len(), b.len(), |i, j| self.w[(a[i], b[j])])
    }

    /// J = W_ea W_aa^-1 (3.8): effector motion per actuator motion.
    pub fn jacobian(&self) -> FemResult<DMatrix<f64>> {
        let e = self.rows_of(RowKind::Effector);
        let a = self.rows_of(RowKind::Actuator);
        let waa = self.block(&a, &a);
        let inv = waa
            .try_inverse()
            .ok_or_else(|| FemError::Singular("W_aa is singular (dependent actuators)".into()))?;
        Ok(self.block(&e, &a) * inv)
    }
}

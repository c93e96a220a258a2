//! Constraint space (thesis 2.4-2.6, 3.8): mapping rows H for effectors, actuators and
//! external forces; compliance W = H K^-1 H^T from solves on the columns of H^T; the free
//! motion delta^free; the Jacobian J = W_ea W_aa^-1.

use super::solve::{Cable, MappedPoint, Solver};
use super::{FemError, FemResult};
use faer::perm::PermRef;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::Mat;
use nalgebra::DMatrix;
use serde::Serialize;

/// What a constraint row stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum RowKind {
    /// An effector (feature point) coordinate.
    Effector,
    /// An actuator (cable shortening, cavity volume change).
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
            return Err(no_length(direction));
        }
        Self::along_unit(kind, at, direction.map(|c| c / l))
    }

    /// As [`ConstraintRow::along`] with `direction` taken as unit, not normalised again:
    /// a direction normalised once (by [`crate::math::unit`]) gives `along`'s very values.
    pub fn along_unit(kind: RowKind, at: &MappedPoint, direction: [f64; 3]) -> FemResult<Self> {
        let l = super::mesh::norm(direction);
        if !(l > 0.0 && l.is_finite()) {
            return Err(no_length(direction));
        }
        let entries = at
            .nodes
            .iter()
            .zip(at.weights)
            .filter(|(_, w)| *w != 0.0)
            .map(|(n, w)| (*n, direction.map(|c| w * c)))
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

    /// The actuator row of a pressure cavity at node positions `x` (d volume change / dx).
    pub fn cavity(cavity: &super::cavity::Cavity, x: &[[f64; 3]]) -> Self {
        Self {
            kind: RowKind::Actuator,
            entries: cavity.row(x),
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
    ///
    /// With K = Pᵀ L Lᵀ P, W = H K⁻¹ Hᵀ = Yᵀ Y for Y = L⁻¹ P Hᵀ: only forward solves, and
    /// each column of Hᵀ (a few nonzeros) only reaches the supernodes on its paths to the
    /// root of the elimination tree. Supernode rows are final right after their diagonal
    /// solve, so Yᵀ Y is accumulated block by block on the way. The residual is carried
    /// as one more column, H K⁻¹ r = Yᵀ (L⁻¹ P r).
    pub fn compliance(
        &self,
        rows: &[ConstraintRow],
        x: &[[f64; 3]],
        residual: &[f64],
    ) -> FemResult<Compliance> {
        self.compliance_skipping(rows, x, residual, 0)
    }

    /// [`Solver::compliance`] without the block of W among the first `skip` rows (left
    /// zero), which the intensity QP does not use (W_ee): with hundreds of feature rows and
    /// a few actuator and force rows, only the columns from `skip` on are solved for,
    /// Z = K⁻¹ [H_oᵀ r] (full solves), and every entry that is needed is a sparse row of H
    /// against Z: W_io = H_i Z, H K⁻¹ r = H Z_r. The block among the rows from `skip` on
    /// is symmetrised (the mean of W_ij and W_ji, equal up to rounding).
    pub fn compliance_skipping(
        &self,
        rows: &[ConstraintRow],
        x: &[[f64; 3]],
        residual: &[f64],
        skip: usize,
    ) -> FemResult<Compliance> {
        let nd = self.ndof();
        let m = rows.len();
        let k = m + 1;
        if residual.len() != nd {
            return Err(FemError::Model(format!(
                "residual has {} entries, the system {nd}",
                residual.len()
            )));
        }
        if skip > 0 {
            return self.compliance_solving(rows, x, residual, skip.min(m));
        }
        let gram = self.forward_gram(
            |add| {
                for (j, row) in rows.iter().enumerate() {
                    for (n, v) in &row.entries {
                        if let Some(d) = self.dofs.node_dof.get(*n).copied().flatten() {
                            for (c, vc) in v.iter().enumerate() {
                                if *vc != 0.0 {
                                    add(d + c, j, *vc);
                                }
                            }
                        }
                    }
                }
                for (r, v) in residual.iter().enumerate() {
                    if *v != 0.0 {
                        add(r, m, *v);
                    }
                }
            },
            k,
        )?;
        // Upper triangle mirrored: W is symmetric to the last bit.
        let w = DMatrix::from_fn(m, m, |i, j| gram[(i.min(j), i.max(j))]);
        let delta_free = (0..m).map(|i| rows[i].value(x) + gram[(i, m)]).collect();
        Ok(Compliance {
            w,
            delta_free,
            kinds: rows.iter().map(|r| r.kind).collect(),
        })
    }

    /// The `skip > 0` path of [`Solver::compliance_skipping`].
    fn compliance_solving(
        &self,
        rows: &[ConstraintRow],
        x: &[[f64; 3]],
        residual: &[f64],
        skip: usize,
    ) -> FemResult<Compliance> {
        let m = rows.len();
        let (cols, delta_free) = self.compliance_columns(rows, x, residual, skip)?;
        let mut w = DMatrix::<f64>::zeros(m, m);
        for c in 0..m - skip {
            let j = skip + c;
            for i in 0..m {
                w[(i, j)] = cols[(i, c)];
                w[(j, i)] = cols[(i, c)];
            }
        }
        Ok(Compliance {
            w,
            delta_free,
            kinds: rows.iter().map(|r| r.kind).collect(),
        })
    }

    /// The columns of W from row `skip` on (rows x (rows − skip): column c is W's column
    /// `skip + c`, the block among the rows from `skip` on symmetrised) and δ^free, as
    /// [`Solver::compliance_skipping`] computes them, without forming W: with thousands of
    /// rows before `skip` (one per measured point) W itself would be most of the cost.
    pub fn compliance_columns(
        &self,
        rows: &[ConstraintRow],
        x: &[[f64; 3]],
        residual: &[f64],
        skip: usize,
    ) -> FemResult<(DMatrix<f64>, Vec<f64>)> {
        let m = rows.len();
        let skip = skip.min(m);
        if residual.len() != self.ndof() {
            return Err(FemError::Model(format!(
                "residual has {} entries, the system {}",
                residual.len(),
                self.ndof()
            )));
        }
        let ko = m - skip + 1;
        let dof = |n: usize| self.dofs.node_dof.get(n).copied().flatten();
        let mut z = Mat::<f64>::zeros(self.ndof(), ko);
        for (c, row) in rows[skip..].iter().enumerate() {
            for (n, v) in &row.entries {
                if let Some(d) = dof(*n) {
                    for (a, va) in v.iter().enumerate() {
                        z[(d + a, c)] += va;
                    }
                }
            }
        }
        for (r, v) in residual.iter().enumerate() {
            z[(r, ko - 1)] = *v;
        }
        self.solve_in_place(&mut z)?;
        // Z by rows, so a row of H meets its nodes' `ko` values in adjacent memory: with
        // thousands of rows this product, not the solve, is what strided reads would slow.
        let mut z_rows = vec![0.0; self.ndof() * ko];
        for (d, z_d) in z_rows.chunks_exact_mut(ko).enumerate() {
            for (c, v) in z_d.iter_mut().enumerate() {
                *v = z[(d, c)];
            }
        }
        // hz[(i, c)] = H_i Z_c, row i at hz[i * ko..].
        let mut hz = vec![0.0; m * ko];
        for (row, hz_i) in rows.iter().zip(hz.chunks_exact_mut(ko)) {
            for (n, v) in &row.entries {
                if let Some(d) = dof(*n) {
                    let z3 = &z_rows[d * ko..(d + 3) * ko];
                    let (z0, rest) = z3.split_at(ko);
                    let (z1, z2) = rest.split_at(ko);
                    for c in 0..ko {
                        hz_i[c] += v[0] * z0[c] + v[1] * z1[c] + v[2] * z2[c];
                    }
                }
            }
        }
        let hz = |i: usize, c: usize| hz[i * ko + c];
        let cols = DMatrix::<f64>::from_fn(m, ko - 1, |i, c| {
            if i >= skip {
                0.5 * (hz(i, c) + hz(skip + c, i - skip))
            } else {
                hz(i, c)
            }
        });
        let delta_free = (0..m).map(|i| rows[i].value(x) + hz(i, ko - 1)).collect();
        Ok((cols, delta_free))
    }

    /// Yᵀ Y (upper triangle valid) for Y = L⁻¹ P B, B (ndof x `k`) given by `fill`, which
    /// calls `add(dof, column, value)` for each nonzero of B.
    fn forward_gram(
        &self,
        fill: impl FnOnce(&mut dyn FnMut(usize, usize, f64)),
        k: usize,
    ) -> FemResult<Mat<f64>> {
        let sn = self.supernodal()?;
        let mut walk = ForwardWalk::new(sn, self.symbolic.perm(), self.ndof(), k);
        fill(&mut |r, j, v| walk.add(r, j, v));
        let llt = SupernodalLltRef::new(sn, &self.l_values);
        let mut gram = Mat::<f64>::zeros(k, k);
        let mut cols = Vec::with_capacity(k);
        let mut scratch = GramScratch::default();
        for s in 0..sn.n_supernodes() {
            walk.columns_at(s, &mut cols);
            if cols.is_empty() {
                continue;
            }
            walk.supernode_step(&llt, s, &cols, self.linalg_par(), &mut gram, &mut scratch);
        }
        Ok(gram)
    }

    /// Assembles and factorizes the tangent at `x` and returns the compliance of `rows`
    /// together with delta^free for the solver's external forces (gravity, the problem's
    /// loads and those given to [`Solver::with_loads`]).
    pub fn compliance_at(
        &mut self,
        x: &[[f64; 3]],
        rows: &[ConstraintRow],
    ) -> FemResult<Compliance> {
        self.tangent_at(x, Default::default())?;
        let mut full = self.external_forces();
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

/// Y = L⁻¹ P B solved supernode by supernode, only where B's columns reach.
struct ForwardWalk {
    /// Supernode of each (permuted) row.
    sup_of: Vec<usize>,
    /// The fill-reducing permutation's inverse: permuted row of each DOF.
    inv: Vec<usize>,
    /// 64-bit words per supernode in `active`.
    words: usize,
    /// Y (permuted rows).
    y: Mat<f64>,
    /// Per supernode, a bitset of the columns that reach it.
    active: Vec<u64>,
}

/// Buffers of [`ForwardWalk::supernode_step`], reused across supernodes.
#[derive(Default)]
struct GramScratch {
    buf: Vec<f64>,
    upd: Vec<f64>,
    g: Vec<f64>,
}

impl ForwardWalk {
    fn new(
        sn: &SymbolicSupernodalCholesky<usize>,
        perm: Option<PermRef<'_, usize>>,
        nd: usize,
        k: usize,
    ) -> Self {
        let ns = sn.n_supernodes();
        let (begin, end) = (sn.supernode_begin(), sn.supernode_end());
        let mut sup_of = vec![0usize; nd];
        for s in 0..ns {
            sup_of[begin[s]..end[s]].iter_mut().for_each(|v| *v = s);
        }
        let inv: Vec<usize> = match perm {
            Some(p) => p.arrays().1.to_vec(),
            None => (0..nd).collect(),
        };
        let words = k.div_ceil(64);
        Self {
            sup_of,
            inv,
            words,
            y: Mat::<f64>::zeros(nd, k),
            active: vec![0u64; ns * words],
        }
    }

    /// Adds `v` to B's entry (`r`, `j`), r a DOF.
    fn add(&mut self, r: usize, j: usize, v: f64) {
        let pr = self.inv[r];
        self.y[(pr, j)] += v;
        self.active[self.sup_of[pr] * self.words + j / 64] |= 1 << (j % 64);
    }

    /// The columns that reach supernode `s`, ascending, into `cols`.
    fn columns_at(&self, s: usize, cols: &mut Vec<usize>) {
        cols.clear();
        for w in 0..self.words {
            let mut bits = self.active[s * self.words + w];
            while bits != 0 {
                cols.push(w * 64 + bits.trailing_zeros() as usize);
                bits &= bits - 1;
            }
        }
    }

    /// Solves supernode `s`'s rows of Y for the columns `cols`, adds their share of Yᵀ Y
    /// to `gram` and updates the rows of later supernodes they reach.
    fn supernode_step(
        &mut self,
        llt: &SupernodalLltRef<'_, usize, f64>,
        s: usize,
        cols: &[usize],
        linalg_par: faer::Par,
        gram: &mut Mat<f64>,
        scratch: &mut GramScratch,
    ) {
        let node = llt.supernode(s);
        let (start, ls, pattern) = (node.start(), node.val(), node.pattern());
        let size = ls.ncols();
        let ka = cols.len();
        let (ltop, lbot) = ls.split_at_row(size);
        let GramScratch { buf, upd, g } = scratch;
        buf.clear();
        buf.resize(size * ka, 0.0);
        let mut xt = faer::MatMut::from_column_major_slice_mut(buf, size, ka);
        for (c, &j) in cols.iter().enumerate() {
            for i in 0..size {
                xt[(i, c)] = self.y[(start + i, j)];
            }
        }
        let par = if size * ka > 64 * 64 {
            linalg_par
        } else {
            faer::Par::Seq
        };
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(ltop, xt.rb_mut(), par);
        // These rows of Y are final: add their share of Yᵀ Y.
        g.clear();
        g.resize(ka * ka, 0.0);
        let mut gm = faer::MatMut::from_column_major_slice_mut(g, ka, ka);
        faer::linalg::matmul::matmul(
            gm.rb_mut(),
            faer::Accum::Replace,
            xt.rb().transpose(),
            xt.rb(),
            1.0,
            par,
        );
        for (b, &jb) in cols.iter().enumerate() {
            for (a, &ja) in cols.iter().enumerate().take(b + 1) {
                gram[(ja, jb)] += gm[(a, b)];
            }
        }
        if pattern.is_empty() {
            return;
        }
        upd.clear();
        upd.resize(pattern.len() * ka, 0.0);
        let mut um = faer::MatMut::from_column_major_slice_mut(upd, pattern.len(), ka);
        faer::linalg::matmul::matmul(um.rb_mut(), faer::Accum::Replace, lbot, xt.rb(), 1.0, par);
        for (c, &j) in cols.iter().enumerate() {
            for (idx, &r) in pattern.iter().enumerate() {
                self.y[(r, j)] -= um[(idx, c)];
            }
        }
        // The updated rows belong to later supernodes: they are reached too.
        let mut last = usize::MAX;
        for &r in pattern {
            let t = self.sup_of[r];
            if t != last {
                for w in 0..self.words {
                    self.active[t * self.words + w] |= self.active[s * self.words + w];
                }
                last = t;
            }
        }
    }
}

/// The error of a row direction without a length.
fn no_length(direction: [f64; 3]) -> FemError {
    FemError::Model(format!("row direction {direction:?} has no length"))
}

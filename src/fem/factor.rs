//! The numeric Cholesky factor of a solver's tangent: factorizing (skipping values already
//! factorized or already failed), the one fallback from the consistent to the definite
//! tangent (corotational: the rotated one; Neo-Hookean: the projected one), and solves
//! with the factor.

use super::problem::Formulation;
use super::solve::Solver;
use super::tet4::Tangent;
use super::{FemError, FemResult};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholeskyRaw};
use faer::sparse::{FaerError, SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Side};

/// Factors with fewer stored values than this are factorized and solved sequentially.
pub const SEQUENTIAL_FACTOR_LEN: usize = 1 << 21;

/// Whether two slices hold the same values, bit for bit.
fn bits_eq(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits())
}

impl Solver<'_> {
    /// faer's parallelism for the factor: sequential for factors below
    /// [`SEQUENTIAL_FACTOR_LEN`] values, else faer's global setting.
    pub fn linalg_par(&self) -> faer::Par {
        // Below that size threads cost more than they save on a small shared machine.
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

    /// Numeric Cholesky of the assembled tangent (reusing the symbolic analysis). Values
    /// factorized last are not factorized again, and values whose factorization failed last
    /// fail again without the work.
    pub fn factorize(&mut self) -> FemResult<()> {
        if bits_eq(&self.factor_of, &self.values) {
            self.factored = true;
            return Ok(());
        }
        self.factored = false;
        if bits_eq(&self.failed_of, &self.values) {
            // `l_values` still holds the factor of `factor_of`.
            return Err(FemError::NotPositiveDefinite {
                pivot: self.failed_pivot,
            });
        }
        self.factor_of.clear();
        self.factorizations += 1;
        match self.factorize_numeric() {
            Ok(()) => {
                self.factored = true;
                self.factor_of.clone_from(&self.values);
                Ok(())
            }
            Err(e) => {
                if let FemError::NotPositiveDefinite { pivot } = e {
                    self.failed_of.clone_from(&self.values);
                    self.failed_pivot = pivot;
                }
                Err(e)
            }
        }
    }

    /// faer's numeric factorization of `values` into `l_values`.
    fn factorize_numeric(&mut self) -> FemResult<()> {
        let sym = SymbolicSparseColMatRef::new_checked(
            self.dofs.ndof,
            self.dofs.ndof,
            &self.pattern.col_ptr,
            None,
            &self.pattern.row_idx,
        );
        let mat = SparseColMatRef::new(sym, &self.values);
        let par = self.linalg_par();
        let mut mem = MemBuffer::try_new(
            self.symbolic
                .factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        )
        .map_err(FaerError::from)?;
        self.symbolic.factorize_numeric_llt(
            super::pool::overwritten(&mut self.l_values),
            mat,
            Side::Upper,
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        )?;
        Ok(())
    }

    /// The current factor, or an error if the last factorization failed or none was done.
    pub(crate) fn factor(&self) -> FemResult<LltRef<'_, usize, f64>> {
        if !self.factored {
            return Err(FemError::NoFactor);
        }
        Ok(LltRef::new(&self.symbolic, &self.l_values))
    }

    /// The supernodal structure of the factor (always supernodal, see [`Solver::new`]), or
    /// an error if the last factorization failed or none was done.
    pub(crate) fn supernodal(&self) -> FemResult<&SymbolicSupernodalCholesky<usize>> {
        // Its callers read `l_values`: only a factor of the current values will do.
        if !self.factored {
            return Err(FemError::NoFactor);
        }
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => Ok(s),
            SymbolicCholeskyRaw::Simplicial(_) => Err(FemError::NotSupernodal),
        }
    }

    /// Solves K X = B in place for free-DOF right-hand sides (columns of `b`).
    pub fn solve_in_place(&self, b: &mut Mat<f64>) -> FemResult<()> {
        let llt = self.factor()?;
        let par = self.linalg_par();
        let mut mem =
            MemBuffer::try_new(self.symbolic.solve_in_place_scratch::<f64>(b.ncols(), par))
                .map_err(FaerError::from)?;
        llt.solve_in_place_with_conj(Conj::No, b.as_mut(), par, MemStack::new(&mut mem));
        Ok(())
    }

    /// Factorizes the last assembly (made at `x` with `tangent`) plus the geometric
    /// stiffness of the cables under `tensions` (one per cable, possibly fewer). If it is
    /// not positive definite and was the consistent corotational (or Neo-Hookean) tangent,
    /// the rotated tangent R K0 Rᵀ (the projected one) is assembled at `x`, the cables
    /// added again, and that factorized.
    pub(super) fn factorize_or_rotated(
        &mut self,
        x: &[[f64; 3]],
        tangent: Tangent,
        tensions: &[f64],
    ) -> FemResult<()> {
        self.add_cables_stiffness(x, tensions);
        let r = match self.factorize() {
            Err(FemError::NotPositiveDefinite { .. })
                if tangent == Tangent::Consistent
                    && self.problem.formulation != Formulation::SmallStrain =>
            {
                self.assemble(x, Tangent::Definite)?;
                self.add_cables_stiffness(x, tensions);
                self.factorize()
            }
            r => r,
        };
        // A pressure's tangent −p d²V/dx² is indefinite on its own and may outweigh a
        // coarse, thin wall's stiffness: then Newton goes on without it (a modified
        // Newton step, linear convergence, the same equilibrium).
        let nc = self.problem.cables.len();
        let pressurised = tensions
            .get(nc..)
            .is_some_and(|p| p.iter().any(|&p| p != 0.0));
        match r {
            Err(FemError::NotPositiveDefinite { .. }) if pressurised => {
                self.assemble(x, Tangent::Definite)?;
                self.add_cables_stiffness(x, &tensions[..nc]);
                self.factorize()
            }
            r => r,
        }
    }

    /// Assembles and factorizes at `x`, falling back to the definite tangent when the
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
        self.factorize_or_rotated(x, tangent, &[])
    }

    /// [`Solver::factorize_assembled`] with the geometric stiffness of the cables under
    /// `tensions` (one per cable) added to the last assembly: the matrix of a Newton step at
    /// `x`. Falls back to the definite tangent, with the cables, when it is not positive
    /// definite.
    pub fn factorize_assembled_with_cables(
        &mut self,
        x: &[[f64; 3]],
        tensions: &[f64],
    ) -> FemResult<()> {
        self.factorize_or_rotated(x, self.elements_tangent, tensions)
    }

    /// Assembles and factorizes the tangent at `x` including the geometric stiffness of the
    /// cables under `tensions` (one per cable), falling back to the definite tangent when
    /// the consistent one is not positive definite.
    pub fn factorize_with_cables(&mut self, x: &[[f64; 3]], tensions: &[f64]) -> FemResult<()> {
        self.assemble(x, Tangent::Consistent)?;
        self.factorize_assembled_with_cables(x, tensions)
    }
}

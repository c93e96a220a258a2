//! FE helpers shared by the FE tests.

use softsense::fem::solve::Solver;
use softsense::fem::tet4::Tangent;

/// K (upper triangle as assembled) as a dense symmetric matrix.
pub fn dense_tangent(s: &Solver) -> nalgebra::DMatrix<f64> {
    let n = s.ndof();
    let mut k = nalgebra::DMatrix::zeros(n, n);
    for c in 0..n {
        for i in s.pattern.col_ptr[c]..s.pattern.col_ptr[c + 1] {
            let r = s.pattern.row_idx[i];
            (k[(r, c)], k[(c, r)]) = (s.values[i], s.values[i]);
        }
    }
    k
}

/// The largest difference between the consistent tangent at `x` and central differences
/// (step 1e-7 m) of the internal forces, over the free DOFs, and the largest |K| entry.
pub fn tangent_fd_error(s: &mut Solver, x: &[[f64; 3]]) -> (f64, f64) {
    s.assemble(x, Tangent::Consistent).unwrap();
    let k = dense_tangent(s);
    let forces = |s: &mut Solver, x: &[[f64; 3]]| {
        s.assemble(x, Tangent::Consistent).unwrap();
        s.dofs.gather(&s.internal_force)
    };
    let h = 1e-7;
    let mut err = 0.0f64;
    for v in 0..x.len() {
        for c in 0..3 {
            let Some(d) = s.dofs.dof(v, c) else { continue };
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[v][c] += h;
            xm[v][c] -= h;
            let (fp, fm) = (forces(s, &xp), forces(s, &xm));
            for r in 0..fp.len() {
                err = err.max(((fp[r] - fm[r]) / (2.0 * h) - k[(r, d)]).abs());
            }
        }
    }
    (err, k.amax())
}

//! Distributed pushes (`inverse::pushes`): the NNLS against every active set by brute force,
//! and a tensioned sheet's pushes recovered from its displacements through the FE
//! compliance.

use softsense::fem::constraint::{ConstraintRow, RowKind};
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::prestress::in_plane_tension;
use softsense::fem::solve::{Formulation, MappedPoint, PointLoad, Problem};
use softsense::fem::tet4::Tangent;
use softsense::inverse::pushes::{solve_pushes, PushParams, PushProblem};
use softsense::math::rand::uniform;

/// min ½‖M λ − r‖² over λ ≥ 0 by trying every active set (the oracle).
fn brute_force(m: &nalgebra::DMatrix<f64>, r: &nalgebra::DVector<f64>) -> Vec<f64> {
    let n = m.ncols();
    let mut best = (f64::INFINITY, vec![0.0; n]);
    for set in 0..(1usize << n) {
        let cols: Vec<usize> = (0..n).filter(|i| set >> i & 1 == 1).collect();
        let mut lam = vec![0.0; n];
        if !cols.is_empty() {
            let ma = m.select_columns(&cols);
            let Some(x) = (ma.transpose() * &ma)
                .cholesky()
                .map(|c| c.solve(&(ma.transpose() * r)))
            else {
                continue;
            };
            if x.iter().any(|&v| v < 0.0) {
                continue;
            }
            for (k, &c) in cols.iter().enumerate() {
                lam[c] = x[k];
            }
        }
        let res = (m * nalgebra::DVector::from_column_slice(&lam) - r).norm_squared();
        if res < best.0 {
            best = (res, lam);
        }
    }
    best.1
}

#[test]
fn pushes_equal_the_best_active_set_found_by_brute_force() {
    for case in 0..20u64 {
        let mut k = 0u64;
        let mut draw = |lo: f64, hi: f64| {
            k += 1;
            lo + (hi - lo) * uniform(7, case, k, 0)
        };
        let (rows, n) = (9, 5);
        let w = nalgebra::DMatrix::from_fn(rows, n, |_, _| draw(-1.0, 1.0) * 1e-3);
        let observed: Vec<f64> = (0..rows).map(|_| draw(-1.0, 1.0) * 1e-3).collect();
        let sigma: Vec<f64> = (0..rows).map(|_| draw(0.5, 2.0) * 1e-4).collect();
        let problem = PushProblem {
            compliance: w.clone(),
            free: vec![0.0; rows],
            observed: observed.clone(),
            sigma: sigma.clone(),
            directions: vec![[0.0, 0.0, -1.0]; n],
            positions: vec![[0.0; 3]; n],
        };
        let got = solve_pushes(&problem, &PushParams::default()).unwrap();
        let m = nalgebra::DMatrix::from_fn(rows, n, |i, j| w[(i, j)] / sigma[i]);
        let r = nalgebra::DVector::from_fn(rows, |i, _| observed[i] / sigma[i]);
        let want = brute_force(&m, &r);
        let scale = want.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        for (g, w) in got.pushes.iter().zip(&want) {
            assert!(
                (g - w).abs() < 1e-6 * scale,
                "case {case}: {:?} vs {want:?}",
                got.pushes
            );
        }
    }
}

#[test]
fn a_tensioned_sheets_pushes_are_recovered_from_its_displacements() {
    // A 100 mm sheet, 2 mm thick, clamped on its edges, 200 N/m of tension; three pushes
    // on its top face. Rows: every free top-face node's z; pushes: the same nodes, -z.
    let (side, t, n) = (0.1, 0.002, 8);
    let h = side / 2.0;
    let mesh = TetMesh::structured_box([-h, -h, 0.0], [h, h, t], [n, n, 1]).unwrap();
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(1e3, 0.3).unwrap(),
        Formulation::SmallStrain,
    );
    let edge = |x: &[f64; 3]| x[0].abs() > h - 1e-9 || x[1].abs() > h - 1e-9;
    p.fixed = (0..mesh.num_nodes())
        .filter(|&v| edge(&mesh.nodes_in_rest[v]))
        .collect();
    p.prestress = vec![in_plane_tension(200.0, t, [0.0, 0.0, 1.0]); mesh.tets.len()];
    let top: Vec<usize> = (0..mesh.num_nodes())
        .filter(|&v| mesh.nodes_in_rest[v][2] > t - 1e-9 && !edge(&mesh.nodes_in_rest[v]))
        .collect();
    let truth = [(top[20], 0.8), (top[21], 0.5), (top[28], 0.3)];
    let mut loaded = p.clone();
    for &(v, f) in &truth {
        loaded.loads.push(PointLoad {
            at: MappedPoint::node(v),
            force: [0.0, 0.0, -f],
        });
    }
    let sol = loaded.solve_static(&Default::default()).unwrap();
    let x = mesh.nodes_in_rest.clone();
    let mut rows: Vec<ConstraintRow> = (top.iter())
        .map(|&v| {
            ConstraintRow::along(RowKind::Effector, &MappedPoint::node(v), [0.0, 0.0, 1.0]).unwrap()
        })
        .collect();
    rows.extend(top.iter().map(|&v| {
        ConstraintRow::along(RowKind::Force, &MappedPoint::node(v), [0.0, 0.0, -1.0]).unwrap()
    }));
    let mut solver = p.solver().unwrap();
    solver.tangent_at(&x, Tangent::Definite).unwrap();
    let zero = vec![0.0; solver.ndof()];
    let (cols, free) = solver
        .compliance_columns(&rows, &x, &zero, top.len())
        .unwrap();
    let problem = PushProblem {
        compliance: cols.rows(0, top.len()).into_owned(),
        free: free[..top.len()].to_vec(),
        observed: top.iter().map(|&v| sol.positions[v][2]).collect(),
        sigma: vec![1e-6; top.len()],
        directions: vec![[0.0, 0.0, -1.0]; top.len()],
        positions: top.iter().map(|&v| x[v]).collect(),
    };
    let got = solve_pushes(&problem, &PushParams::default()).unwrap();
    assert!(
        (got.magnitude - 1.6).abs() < 1e-4,
        "net {:?}",
        got.net_force
    );
    for &(v, f) in &truth {
        let i = top.iter().position(|&u| u == v).unwrap();
        assert!(
            (got.pushes[i] - f).abs() < 1e-4,
            "node {v}: {} vs {f}",
            got.pushes[i]
        );
    }
    let want_centre: f64 = truth.iter().map(|&(v, f)| x[v][0] * f).sum::<f64>() / 1.6;
    assert!((got.centre_of_pressure[0] - want_centre).abs() < 1e-4);
    assert_eq!(got.patch.len(), 3, "the patch is the three pushed nodes");
}

#[test]
fn nnls_with_two_identical_columns_converges_to_the_best_fit() {
    use softsense::inverse::pushes::nnls_gram;
    // Columns 0 and 1 are the same: the Gram matrix is singular on any set holding both,
    // so the solver must stop at one of them, not cycle.
    let m = nalgebra::DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 0.0, 2.0, 2.0, 1.0, 0.0, 0.0, 1.0]);
    let r = nalgebra::DVector::from_column_slice(&[1.0, 2.0, 0.5]);
    let (x, converged) = nnls_gram(&(m.transpose() * &m), &(m.transpose() * &r), 100);
    assert!(converged);
    let best = brute_force(&m, &r);
    let res = |l: &nalgebra::DVector<f64>| (&m * l - &r).norm_squared();
    let want = res(&nalgebra::DVector::from_column_slice(&best));
    assert!(x.iter().all(|&v| v >= 0.0), "{x}");
    assert!((res(&x) - want).abs() < 1e-12, "{} against {want}", res(&x));
}

#[test]
fn nnls_of_a_target_that_every_push_moves_away_from_is_zero() {
    use softsense::inverse::pushes::nnls_gram;
    let m = nalgebra::DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.2, 1.0]);
    let r = nalgebra::DVector::from_column_slice(&[-1.0, -2.0]);
    let (x, converged) = nnls_gram(&(m.transpose() * &m), &(m.transpose() * &r), 100);
    assert!(converged);
    assert_eq!(x.as_slice(), &[0.0, 0.0]);
}

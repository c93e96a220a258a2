//! Constraint space: W symmetric positive definite, W lambda equals a full solve, J.

use softsense::fem::constraint::{ConstraintRow, RowKind};
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::solve::{
    Cable, CableControl, Formulation, MappedPoint, NewtonParams, PointLoad, Problem,
};
use softsense::fem::FemError;

/// A small soft column with gravity, two cables, and rows of every kind.
fn setup() -> (Problem, Vec<ConstraintRow>) {
    let mesh = TetMesh::structured_box([-0.02, -0.02, 0.0], [0.02, 0.02, 0.12], [3, 3, 8]).unwrap();
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(2e5, 0.45).unwrap(),
        Formulation::SmallStrain,
    );
    p.fixed = mesh.nodes_in_box([-1.0, -1.0, -1e-9], [1.0, 1.0, 1e-9]);
    p.density = 1100.0;
    p.gravity = [0.0, 0.0, -9.81];
    let at = |q: [f64; 3]| MappedPoint::locate(&mesh, q, 1e-3).unwrap();
    for (name, pull, attach) in [
        ("a", [0.0, 0.015, 0.0], [0.0, 0.02, 0.1]),
        ("b", [0.015, 0.0, 0.0], [0.02, 0.0, 0.07]),
    ] {
        p.cables.push(Cable {
            name: name.into(),
            pull,
            attach: vec![at(attach)],
            control: CableControl::Force(0.0),
        });
    }
    let surface = mesh.surface();
    let tip = at([0.003, -0.004, 0.12]);
    let mut rows = ConstraintRow::point3(RowKind::Effector, &tip);
    let side = at([-0.02, 0.005, 0.06]);
    let mut normal = [0.0; 3];
    for (v, w) in side.nodes.iter().zip(side.weights) {
        for (nk, sk) in normal.iter_mut().zip(surface.vertex_normals[*v]) {
            *nk += w * sk;
        }
    }
    rows.push(ConstraintRow::along(RowKind::Effector, &side, normal).unwrap());
    let x = p.mesh.nodes_in_rest.clone();
    for c in &p.cables {
        rows.push(ConstraintRow::cable(c, &x));
    }
    rows.push(
        ConstraintRow::along(RowKind::Force, &at([0.02, 0.01, 0.09]), [-1.0, 0.0, 0.2]).unwrap(),
    );
    rows.push(
        ConstraintRow::along(RowKind::Force, &at([0.0, -0.02, 0.05]), [0.0, 1.0, 0.0]).unwrap(),
    );
    (p, rows)
}

#[test]
fn compliance_is_symmetric_positive_definite() {
    let (p, rows) = setup();
    let mut s = p.solver().unwrap();
    let c = s
        .compliance_at(&p.mesh.nodes_in_rest.clone(), &rows)
        .unwrap();
    let w = &c.w;
    let scale = w.amax();
    for i in 0..w.nrows() {
        for j in 0..w.ncols() {
            assert!((w[(i, j)] - w[(j, i)]).abs() < 1e-12 * scale, "W[{i},{j}]");
        }
    }
    let eig = w.clone().symmetric_eigen().eigenvalues;
    assert!(eig.min() > 1e-9 * scale, "eigenvalues {eig}");
    assert_eq!(c.rows_of(RowKind::Actuator).len(), 2);
}

#[test]
fn w_lambda_reproduces_a_full_solve_in_constraint_space() {
    let (p, rows) = setup();
    let x0 = p.mesh.nodes_in_rest.clone();
    let mut s = p.solver().unwrap();
    let c = s.compliance_at(&x0, &rows).unwrap();
    let lambda: Vec<f64> = (0..rows.len())
        .map(|i| 0.01 * ((i as f64 * 1.7).sin() + 0.3))
        .collect();
    // Full solve: the same forces H^T lambda as fixed-direction nodal loads, with gravity.
    let mut full = p.clone();
    full.cables.clear();
    for (row, l) in rows.iter().zip(&lambda) {
        for (n, coef) in &row.entries {
            full.loads.push(PointLoad {
                at: MappedPoint::node(*n),
                force: coef.map(|c| c * l),
            });
        }
    }
    let sol = full.solve_static(&NewtonParams::default()).unwrap();
    let wl = &c.w * nalgebra::DVector::from_vec(lambda.clone());
    let mut max_err: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for (i, row) in rows.iter().enumerate() {
        let solved = row.value(&sol.positions);
        let predicted = c.delta_free[i] + wl[i];
        max_err = max_err.max((solved - predicted).abs());
        scale = scale.max((solved - row.value(&x0)).abs());
    }
    assert!(scale > 1e-4, "the forces move the rows: {scale}");
    assert!(
        max_err < 1e-9 * scale,
        "error {max_err:e} vs motion {scale:e}"
    );
}

#[test]
fn jacobian_maps_actuator_motion_to_effector_motion() {
    let (p, rows) = setup();
    let mut s = p.solver().unwrap();
    let c = s
        .compliance_at(&p.mesh.nodes_in_rest.clone(), &rows)
        .unwrap();
    let j = c.jacobian().unwrap();
    let e = c.rows_of(RowKind::Effector);
    let a = c.rows_of(RowKind::Actuator);
    assert_eq!((j.nrows(), j.ncols()), (4, 2));
    let back = &j * c.block(&a, &a);
    let wea = c.block(&e, &a);
    assert!((back - &wea).amax() < 1e-12 * wea.amax());
}

#[test]
fn displacement_controlled_cable_reaches_its_shortening() {
    let (mut p, _) = setup();
    p.formulation = Formulation::Corotational;
    p.cables[0].control = CableControl::Displacement(0.004);
    p.cables[1].control = CableControl::Force(0.05);
    let sol = p.solve_static(&NewtonParams::default()).unwrap();
    assert!(sol.converged);
    assert!((sol.cable_shortening[0] - 0.004).abs() < 1e-12);
    assert!(sol.cable_tension[0] > 0.0);
    assert_eq!(sol.cable_tension[1], 0.05);
    assert!(sol.residuals.last().unwrap() < &1e-9);
}

#[test]
fn a_cable_asked_to_push_goes_slack_with_zero_tension() {
    let (mut p, _) = setup();
    p.formulation = Formulation::Corotational;
    p.cables[0].control = CableControl::Displacement(-0.004);
    let sol = p.solve_static(&NewtonParams::default()).unwrap();
    assert!(sol.converged);
    assert_eq!(sol.cable_slack, vec![true, false]);
    assert_eq!(sol.cable_tension[0], 0.0);
    assert!(
        sol.cable_shortening[0] > -0.004,
        "the slack cable is longer than its attach path"
    );
}

#[test]
fn loads_on_missing_nodes_are_model_errors_not_panics() {
    let (mut p, _) = setup();
    p.loads.push(PointLoad {
        at: MappedPoint::node(100_000),
        force: [1.0, 0.0, 0.0],
    });
    assert!(matches!(
        p.solve_static(&NewtonParams::default()),
        Err(softsense::fem::FemError::Model(_))
    ));
}

#[test]
fn loads_given_to_the_solver_act_as_loads_pushed_onto_a_copy_of_the_problem() {
    let (mut p, _) = setup();
    p.loads.push(PointLoad {
        at: MappedPoint::node(40),
        force: [0.01, 0.0, -0.02],
    });
    let extra = vec![
        PointLoad {
            at: MappedPoint::node(60),
            force: [0.0, 0.03, 0.0],
        },
        PointLoad {
            at: MappedPoint::node(40),
            force: [-0.004, 0.0, 0.01],
        },
    ];
    let mut copy = p.clone();
    copy.loads.extend(extra.iter().copied());
    let newton = NewtonParams::default();
    let mut given = p.solver().unwrap().with_loads(extra).unwrap();
    assert_eq!(given.external_forces(), copy.external_forces());
    let (a, b) = (
        given.solve_static(&newton).unwrap(),
        copy.solve_static(&newton).unwrap(),
    );
    assert_eq!(a.positions, b.positions);
    let missing = vec![PointLoad {
        at: MappedPoint::node(100_000),
        force: [1.0, 0.0, 0.0],
    }];
    assert!(matches!(
        p.solver().unwrap().with_loads(missing),
        Err(FemError::Model(_))
    ));
}

/// W and delta^free by full solves K X = [H^T r] and products H X (the straightforward path
/// the forward-only supernodal compliance replaces).
fn compliance_by_full_solves(
    s: &softsense::fem::solve::Solver<'_>,
    rows: &[ConstraintRow],
    x: &[[f64; 3]],
    r: &[f64],
) -> (nalgebra::DMatrix<f64>, Vec<f64>) {
    let nd = s.ndof();
    let m = rows.len();
    let cols: Vec<Vec<f64>> = rows
        .iter()
        .map(|row| {
            let mut c = vec![0.0; nd];
            s.row_to_dofs(&row.entries, &mut c);
            c
        })
        .collect();
    let mut b = faer::Mat::<f64>::from_fn(nd, m + 1, |i, j| if j < m { cols[j][i] } else { r[i] });
    s.solve_in_place(&mut b).unwrap();
    let dot = |c: &[f64], j: usize| (0..nd).map(|k| c[k] * b[(k, j)]).sum::<f64>();
    let w = nalgebra::DMatrix::from_fn(m, m, |i, j| dot(&cols[i], j));
    let d = (0..m)
        .map(|i| rows[i].value(x) + dot(&cols[i], m))
        .collect();
    (w, d)
}

fn assert_close_relative(a: &[f64], b: &[f64], what: &str) {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0, "{what} is all zero");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-10 * scale,
            "{what}[{i}]: {x:e} vs {y:e}"
        );
    }
}

#[test]
fn forward_only_compliance_equals_full_solves() {
    // A larger corotational column so the rows reach only part of the elimination tree,
    // deformed (nonzero residual), with rows of every kind and one on fixed nodes only.
    let (small, mut rows) = setup();
    let mesh =
        TetMesh::structured_box([-0.02, -0.02, 0.0], [0.02, 0.02, 0.12], [5, 5, 14]).unwrap();
    let mut p = Problem::new(mesh.clone(), small.material, Formulation::Corotational);
    p.fixed = mesh.nodes_in_box([-1.0, -1.0, -1e-9], [1.0, 1.0, 1e-9]);
    p.density = small.density;
    p.gravity = small.gravity;
    for row in &mut rows {
        for (n, _) in &mut row.entries {
            // Same points located on the finer mesh would need relocation; use nodes instead.
            *n %= mesh.num_nodes();
        }
    }
    rows.push(
        ConstraintRow::along(
            RowKind::Force,
            &MappedPoint::node(p.fixed[0]),
            [0.0, 0.0, 1.0],
        )
        .unwrap(),
    );
    let x: Vec<[f64; 3]> = p
        .mesh
        .nodes_in_rest
        .iter()
        .map(|q| {
            [
                q[0] + 0.1 * q[2] * q[2],
                q[1] - 0.05 * q[2] * q[2],
                q[2] * 1.01,
            ]
        })
        .collect();
    let mut s = p.solver().unwrap();
    let c = s.compliance_at(&x, &rows).unwrap();
    let mut full = p.external_forces();
    for (f, fi) in full.iter_mut().zip(&s.internal_force) {
        *f -= fi;
    }
    let r = s.dofs.gather(&full);
    assert!(
        r.iter().any(|v| v.abs() > 1e-6),
        "the deformed state has a residual"
    );
    let (w_ref, d_ref) = compliance_by_full_solves(&s, &rows, &x, &r);
    assert_close_relative(c.w.as_slice(), w_ref.as_slice(), "W");
    assert_close_relative(&c.delta_free, &d_ref, "delta_free");
    let last = rows.len() - 1;
    assert!(
        c.w.row(last).iter().all(|v| *v == 0.0),
        "a row on fixed nodes has no compliance"
    );
    // Skipping the block among the first 3 rows (the effector rows, W_ee) leaves it zero and
    // everything else as the full solves give it.
    let skip = 3;
    let k = s.compliance_skipping(&rows, &x, &r, skip).unwrap();
    assert_close_relative(&k.delta_free, &d_ref, "delta_free (skipping)");
    let scale = w_ref.amax();
    for i in 0..rows.len() {
        for j in 0..rows.len() {
            if i < skip && j < skip {
                assert_eq!(k.w[(i, j)], 0.0, "W[{i},{j}] is skipped");
            } else {
                let (a, b) = (k.w[(i, j)], w_ref[(i, j)]);
                assert!((a - b).abs() <= 1e-10 * scale, "W[{i},{j}]: {a:e} vs {b:e}");
            }
        }
    }
}

/// Row values predicted by `c` for the extra force `eps` on row `j`, against a full solve.
fn extra_load_errors(
    p: &Problem,
    rows: &[ConstraintRow],
    c: &softsense::fem::constraint::Compliance,
    x0: &[[f64; 3]],
    j: usize,
    eps: f64,
) -> (f64, f64) {
    let mut loaded = p.clone();
    for (n, coef) in &rows[j].entries {
        loaded.loads.push(PointLoad {
            at: MappedPoint::node(*n),
            force: coef.map(|v| v * eps),
        });
    }
    let sol = loaded.solve_static(&NewtonParams::default()).unwrap();
    let (mut err, mut motion) = (0.0f64, 0.0f64);
    for i in c.rows_of(RowKind::Effector) {
        let solved = rows[i].value(&sol.positions);
        err = err.max((solved - (c.delta_free[i] + c.w[(i, j)] * eps)).abs());
        motion = motion.max((solved - rows[i].value(x0)).abs());
    }
    (err, motion)
}

#[test]
fn compliance_on_newtons_matrix_with_the_cables_is_the_derivative_of_the_loaded_solution() {
    // Corotational column with both cables pulling 1.5 N. At that equilibrium the
    // compliance of Newton's matrix (material tangent plus the cables' geometric stiffness)
    // predicts a small extra load to second order; without the cables it is off to first
    // order (this is what the sensing loop linearises with).
    let (mut p, rows) = setup();
    p.formulation = Formulation::Corotational;
    for c in &mut p.cables {
        c.control = CableControl::Force(1.5);
    }
    let mut s = p.solver().unwrap();
    let sol = s.solve_static_from(&NewtonParams::default(), None).unwrap();
    let x0 = sol.positions.clone();
    // At equilibrium the residual with the cables is zero: delta_free = H x0.
    let zero = vec![0.0; s.dofs.ndof];
    s.factorize_assembled_with_cables(&x0, &sol.cable_tension)
        .unwrap();
    let with = s.compliance(&rows, &x0, &zero).unwrap();
    s.tangent_at(&x0, Default::default()).unwrap();
    let without = s.compliance(&rows, &x0, &zero).unwrap();
    let forces = with.rows_of(RowKind::Force);
    for &j in &forces {
        let (err, motion) = extra_load_errors(&p, &rows, &with, &x0, j, 2e-3);
        assert!(motion > 1e-6, "the load moves the effectors: {motion:e}");
        assert!(
            err < 1e-3 * motion,
            "with the cables: error {err:e} vs motion {motion:e}"
        );
        let (err0, _) = extra_load_errors(&p, &rows, &without, &x0, j, 2e-3);
        assert!(
            err0 > 2e-2 * motion,
            "without the cables: error {err0:e} vs motion {motion:e}"
        );
    }
}

#[test]
fn a_refactorization_of_changed_values_is_redone_and_of_the_same_values_gives_the_same_factor() {
    let (p, rows) = setup();
    let x0 = p.mesh.nodes_in_rest.clone();
    let mut s = p.solver().unwrap();
    let zero = vec![0.0; s.dofs.ndof];
    s.tangent_at(&x0, Default::default()).unwrap();
    let w1 = s.compliance(&rows, &x0, &zero).unwrap().w;
    // Twice the stiffness: half the compliance (the skip must see a changed matrix).
    for v in &mut s.values {
        *v *= 2.0;
    }
    s.factorize().unwrap();
    let w2 = s.compliance(&rows, &x0, &zero).unwrap().w;
    assert!((&w2 * 2.0 - &w1).amax() < 1e-12 * w1.amax());
    // Back to the first values, bit for bit: the first factor again.
    for v in &mut s.values {
        *v *= 0.5;
    }
    s.factorize().unwrap();
    let w3 = s.compliance(&rows, &x0, &zero).unwrap().w;
    assert_eq!(w3, w1);
}

#[test]
fn values_that_failed_to_factorize_fail_again_without_a_new_attempt() {
    let (p, rows) = setup();
    let x0 = p.mesh.nodes_in_rest.clone();
    let mut s = p.solver().unwrap();
    let zero = vec![0.0; s.dofs.ndof];
    s.tangent_at(&x0, Default::default()).unwrap();
    let good = s.values.clone();
    let bad: Vec<f64> = good.iter().map(|v| -v).collect();
    let w1 = s.compliance(&rows, &x0, &zero).unwrap().w;
    assert_eq!(s.factorizations(), 1);
    // Negative definite: the factorization fails, and no factor is left to use.
    s.values.clone_from(&bad);
    assert!(matches!(
        s.factorize(),
        Err(FemError::NotPositiveDefinite { .. })
    ));
    assert!(s.compliance(&rows, &x0, &zero).is_err());
    assert_eq!(s.factorizations(), 2);
    s.values.clone_from(&good);
    s.factorize().unwrap();
    assert_eq!(s.factorizations(), 3);
    // The failed values again: an error without an attempt, and the good factor kept.
    s.values.clone_from(&bad);
    assert!(matches!(
        s.factorize(),
        Err(FemError::NotPositiveDefinite { .. })
    ));
    assert!(s.compliance(&rows, &x0, &zero).is_err());
    s.values.clone_from(&good);
    s.factorize().unwrap();
    assert_eq!(s.factorizations(), 3);
    assert_eq!(s.compliance(&rows, &x0, &zero).unwrap().w, w1);
    // The memory goes with the state to the next solver.
    let mut s = p.solver_from(s.into_state()).unwrap();
    s.values.clone_from(&bad);
    assert!(matches!(
        s.factorize(),
        Err(FemError::NotPositiveDefinite { .. })
    ));
    assert_eq!(s.factorizations(), 0);
    // Other values are tried afresh.
    s.values = good.iter().map(|v| 2.0 * v).collect();
    s.factorize().unwrap();
    assert_eq!(s.factorizations(), 1);
    let w2 = s.compliance(&rows, &x0, &zero).unwrap().w;
    assert!((&w2 * 2.0 - &w1).amax() < 1e-12 * w1.amax());
}

#[test]
fn a_solver_state_handed_over_at_the_same_positions_gives_the_same_factor_without_work_and_stays_intact(
) {
    let (p, rows) = setup();
    let x0 = p.mesh.nodes_in_rest.clone();
    let mut fresh = p.solver().unwrap();
    fresh.tangent_at(&x0, Default::default()).unwrap();
    let zero = vec![0.0; fresh.dofs.ndof];
    let w = fresh.compliance(&rows, &x0, &zero).unwrap().w;
    // A clone of the state serves two solvers; each reuses it bit for bit.
    let state = fresh.into_state();
    for _ in 0..2 {
        let mut s = p.solver_from(state.clone()).unwrap();
        s.tangent_at(&x0, Default::default()).unwrap();
        assert_eq!(s.factorizations(), 0);
        assert_eq!(s.compliance(&rows, &x0, &zero).unwrap().w, w);
    }
    // The clones share the element states and the factor. A solver that evaluates the
    // elements elsewhere and factorizes other values writes both into buffers of its own;
    // the state it came from is untouched.
    let x1: Vec<[f64; 3]> = x0
        .iter()
        .map(|p| [p[0] + 0.01 * p[2], p[1], p[2]])
        .collect();
    let mut moved = p.solver_from(state.clone()).unwrap();
    moved.tangent_at(&x1, Default::default()).unwrap();
    moved.values.iter_mut().for_each(|v| *v *= 2.0);
    moved.factorize().unwrap();
    assert!(moved.factorizations() >= 1);
    let half = moved.compliance(&rows, &x1, &zero).unwrap().w;
    assert!((&half * 2.0 - &w).amax() < 1e-9 * w.amax());
    let mut s = p.solver_from(state).unwrap();
    s.tangent_at(&x0, Default::default()).unwrap();
    assert_eq!(s.factorizations(), 0);
    assert_eq!(s.compliance(&rows, &x0, &zero).unwrap().w, w);
}

//! A compliant base: the fixed nodes on springs (`Problem::base_stiffness`). The tangent with
//! the springs by central differences, the base's mean motion by force balance, the
//! clamped answer as the stiffness grows, a model file's key, and the compliance W as the
//! derivative of the loaded solve; for both large-displacement formulations.

use crate::common::fem::tangent_fd_error;
use softsense::fem::constraint::{ConstraintRow, RowKind};
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::model::Model;
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};
use softsense::math::dist;
use std::path::PathBuf;

const FORMULATIONS: [Formulation; 2] = [Formulation::Corotational, Formulation::NeoHookean];

/// A 40 x 40 x 120 mm soft column, its bottom face on springs of total stiffness `k` (N/m).
fn column(formulation: Formulation, k: Option<f64>) -> Problem {
    let mesh = TetMesh::structured_box([-0.02, -0.02, 0.0], [0.02, 0.02, 0.12], [2, 2, 6]).unwrap();
    let mut p = Problem::new(mesh.clone(), Material::new(2e5, 0.45).unwrap(), formulation);
    p.fixed = mesh.nodes_in_box([-1.0, -1.0, -1e-9], [1.0, 1.0, 1e-9]);
    p.base_stiffness = k;
    p
}

/// A load on the column's top corner (N).
fn tip_load(p: &Problem, force: [f64; 3]) -> PointLoad {
    let at = MappedPoint::locate(&p.mesh, [0.02, 0.02, 0.12], 1e-6).unwrap();
    PointLoad { at, force }
}

#[test]
fn base_springs_tangent_equals_central_differences_of_the_internal_forces() {
    for form in FORMULATIONS {
        let p = column(form, Some(800.0));
        // Away from rest, base nodes included, so that the springs carry force.
        let x: Vec<[f64; 3]> = (p.mesh.nodes_in_rest.iter().enumerate())
            .map(|(v, q)| {
                let w = (v as f64 * 0.7).sin();
                [
                    q[0] + 1e-3 * w,
                    q[1] - 5e-4 * w,
                    q[2] + 2e-3 * q[2] + 3e-4 * w,
                ]
            })
            .collect();
        let mut s = p.solver().unwrap();
        assert_eq!(s.ndof(), 3 * p.mesh.num_nodes(), "base nodes are free DOFs");
        let (err, scale) = tangent_fd_error(&mut s, &x);
        assert!(err < 1e-6 * scale, "{form:?}: error {err:e}, |K| {scale:e}");
    }
}

#[test]
fn the_base_moves_the_load_over_its_stiffness_on_average() {
    // At equilibrium the springs carry the whole load (elastic forces sum to zero), so the
    // base nodes' mean displacement is F / K exactly, whatever the body does above them.
    let (k, f) = (500.0, [0.3, -0.2, -0.5]);
    for form in FORMULATIONS {
        let mut p = column(form, Some(k));
        p.loads.push(tip_load(&p, f));
        let sol = p.solve_static(&NewtonParams::default()).unwrap();
        let n = p.fixed.len() as f64;
        let mean =
            [0, 1, 2].map(|c| p.fixed.iter().map(|&v| sol.displacement[v][c]).sum::<f64>() / n);
        for c in 0..3 {
            let want = f[c] / k;
            assert!(
                (mean[c] - want).abs() < 1e-9 * want.abs(),
                "{form:?} axis {c}: {mean:?}"
            );
        }
        // The same load spread over the base nodes, F / n on each: a rigid translation.
        let mut p = column(form, Some(k));
        p.loads = (p.fixed.iter())
            .map(|&v| PointLoad {
                at: MappedPoint::node(v),
                force: f.map(|c| c / n),
            })
            .collect();
        let sol = p.solve_static(&NewtonParams::default()).unwrap();
        for d in &sol.displacement {
            assert!(
                (0..3).all(|c| (d[c] - f[c] / k).abs() < 1e-9 * (f[c] / k).abs()),
                "{d:?}"
            );
        }
    }
}

/// The largest distance between the nodes of two solutions.
fn largest_gap(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| dist(*p, *q))
        .fold(0.0, f64::max)
}

#[test]
fn a_stiff_base_tends_to_the_clamped_answer() {
    // The base's share of the motion falls as 1/K: two decades of stiffness, two of gap.
    for form in FORMULATIONS {
        let solve = |k: Option<f64>| {
            let mut p = column(form, k);
            p.loads.push(tip_load(&p, [0.2, 0.0, -0.3]));
            p.solve_static(&NewtonParams::default()).unwrap().positions
        };
        let clamped = solve(None);
        let gaps = [1e5, 1e7, 1e9].map(|k| largest_gap(&solve(Some(k)), &clamped));
        println!("{form:?}: gaps to clamped {gaps:?} m");
        for w in gaps.windows(2) {
            let ratio = w[0] / w[1];
            assert!((80.0..120.0).contains(&ratio), "{form:?}: {gaps:?}");
        }
        assert!(
            gaps[2] < 1e-7,
            "{form:?}: 1e8 N/m base {:e} m from clamped",
            gaps[2]
        );
    }
}

#[test]
fn a_compliance_with_the_base_is_the_derivative_of_the_loaded_solve() {
    for form in FORMULATIONS {
        let mut p = column(form, Some(800.0));
        p.loads.push(tip_load(&p, [0.0, 0.0, -0.5]));
        let params = NewtonParams::default();
        let mut s = p.solver().unwrap();
        let sol = s.solve_static(&params).unwrap();
        let x0 = sol.positions.clone();
        s.factorize_assembled(&x0, params.tangent).unwrap();
        let tip = MappedPoint::locate(&p.mesh, [0.0, 0.0, 0.12], 1e-6).unwrap();
        let base = MappedPoint::node(p.fixed[0]);
        let mut rows = ConstraintRow::point3(RowKind::Effector, &tip);
        rows.extend(ConstraintRow::point3(RowKind::Effector, &base));
        rows.push(ConstraintRow::along(RowKind::Force, &tip, [1.0, 0.0, 0.0]).unwrap());
        let w = s.compliance(&rows, &x0, &vec![0.0; s.ndof()]).unwrap().w;
        // A small extra load along the force row, solved in full.
        let eps = 1e-3;
        let mut loaded = p.clone();
        loaded.loads.push(PointLoad {
            at: tip,
            force: [eps, 0.0, 0.0],
        });
        let x1 = loaded.solve_static(&params).unwrap().positions;
        let f = rows.len() - 1;
        let (mut err, mut motion) = (0.0f64, 0.0f64);
        for i in 0..f {
            let moved = rows[i].value(&x1) - rows[i].value(&x0);
            err = err.max((moved - w[(i, f)] * eps).abs());
            motion = motion.max(moved.abs());
        }
        println!("{form:?}: W predicts {motion:e} m of motion within {err:e} m");
        assert!(
            err < 1e-3 * motion,
            "{form:?}: error {err:e} of {motion:e} m"
        );
        // The base node moves: its rows are not zero as on a clamped base.
        assert!(w[(3, f)].abs() > 1e-6, "{form:?}: base row {:e}", w[(3, f)]);
    }
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn a_model_files_base_stiffness_is_read_in_its_units_and_a_bad_one_refused() {
    let robot = std::fs::read_to_string(root().join("meshes/models/robot.toml")).unwrap();
    let mesh = root().join("meshes/robot.vtu").display().to_string();
    let dir = tempfile::tempdir().unwrap();
    let write = |head: &str| {
        let text = robot.replace("path = \"../robot.vtu\"", &format!("path = {mesh:?}"));
        let path = dir.path().join("model.toml");
        std::fs::write(&path, format!("{head}\n{text}")).unwrap();
        path
    };
    // mm-kg-s: mN/mm is N/m.
    let m = Model::load(&write("base_stiffness = 2500.0"), None).unwrap();
    assert_eq!(m.problem.base_stiffness, Some(2500.0));
    let clamped = Model::load(&write(""), None).unwrap();
    assert_eq!(clamped.problem.base_stiffness, None);
    assert_eq!(clamped.problem.fixed, m.problem.fixed);
    for bad in [
        "base_stiffness = 0.0",
        "base_stiffness = -5.0",
        "base_stiffness = nan",
    ] {
        let e = Model::load(&write(bad), None).unwrap_err().to_string();
        assert!(e.contains("base_stiffness"), "{bad}: {e}");
    }
}

#[test]
fn a_clone_with_other_base_nodes_is_checked_again() {
    // The springs' nodes are not held, so the shared setup must still see them change: a
    // line of base nodes cannot stop the column turning about it.
    let p = column(Formulation::Corotational, Some(800.0));
    p.solve_static(&NewtonParams::default()).unwrap();
    let mut line = p.clone();
    line.fixed = line
        .mesh
        .nodes_in_box([-1.0, -1e-9, -1e-9], [1.0, 1e-9, 1e-9]);
    assert!(matches!(
        line.solver().map(|_| ()),
        Err(softsense::fem::FemError::Singular(_))
    ));
    let mut missing = p.clone();
    missing.fixed.push(10_000);
    assert!(missing.solver().is_err(), "a base node outside the mesh");
}

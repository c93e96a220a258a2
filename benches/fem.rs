//! FE update benchmark: one Newton step (assembly + numeric Cholesky) plus the compliance
//! W for 51 normal effector rows, 4 cable actuators and 6 force rows, on the diamond mesh
//! ($SOFTSENSE_DATA/sofa/diamond.vtu, 4147 tets) or, without the data, the project's robot.

use criterion::{criterion_group, criterion_main, Criterion};
use softsense::fem::constraint::{ConstraintRow, RowKind};
use softsense::fem::model::Model;
use softsense::fem::solve::MappedPoint;
use softsense::fem::tet4::Tangent;
use std::path::PathBuf;

fn load() -> (String, Model) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    if let Some(data) = std::env::var_os("SOFTSENSE_DATA") {
        let mesh = PathBuf::from(data).join("sofa/diamond.vtu");
        let m = Model::load(&root.join("meshes/models/diamond.toml"), Some(&mesh))
            .expect("diamond model");
        ("diamond".into(), m)
    } else {
        eprintln!(
            "SOFTSENSE_DATA unset: benchmarking the project's robot mesh instead of the diamond"
        );
        (
            "robot".into(),
            Model::load(&root.join("meshes/models/robot.toml"), None).expect("robot model"),
        )
    }
}

fn rows(m: &Model, x: &[[f64; 3]]) -> Vec<ConstraintRow> {
    let mesh = &m.problem.mesh;
    let s = mesh.surface();
    let free: Vec<usize> = s
        .nodes
        .iter()
        .copied()
        .filter(|v| !m.problem.fixed.contains(v))
        .collect();
    let step = free.len() / 51;
    let mut rows: Vec<ConstraintRow> = (0..51)
        .map(|i| {
            let v = free[i * step];
            ConstraintRow::along(
                RowKind::Effector,
                &MappedPoint::node(v),
                s.vertex_normals[v],
            )
            .expect("normal row")
        })
        .collect();
    rows.extend(m.problem.cables.iter().map(|c| ConstraintRow::cable(c, x)));
    for v in [free[step / 2], free[free.len() - 1 - step / 2]] {
        rows.extend(ConstraintRow::point3(RowKind::Force, &MappedPoint::node(v)));
    }
    rows
}

fn bench(c: &mut Criterion) {
    // SOFTSENSE_FAER_SEQ=1 runs faer single-threaded (to compare on a loaded machine).
    if std::env::var_os("SOFTSENSE_FAER_SEQ").is_some() {
        faer::set_global_parallelism(faer::Par::Seq);
    }
    let (name, m) = load();
    let x = m
        .problem
        .solve_static(&m.newton)
        .expect("static solve")
        .positions;
    let rows = rows(&m, &x);
    assert_eq!(rows.len(), 61);
    let mut solver = m.problem.solver().expect("solver");
    let residual = vec![0.0; solver.ndof()];
    eprintln!(
        "{name}: {} tets, {} free DOFs, {} nnz(K upper), {} values in L",
        m.problem.mesh.tets.len(),
        solver.ndof(),
        solver.pattern.nnz(),
        solver.factor_len()
    );
    solver.assemble(&x, Tangent::Consistent).expect("assemble");
    eprintln!(
        "consistent tangent positive definite at the benchmark state: {}",
        solver.factorize().is_ok()
    );
    let mut g = c.benchmark_group(format!("fem_{name}"));
    // Each repetition forgets what the solver keeps to skip work at the same positions and
    // values (`Solver::forget_reuse`): without it these would time the reuse (an
    // 18 µs "assembly" and a 53 µs "Cholesky" on the robot, against milliseconds).
    g.bench_function("newton_step_plus_compliance_61_rows", |b| {
        b.iter(|| {
            solver.forget_reuse();
            // Consistent tangent, or SOFA's R K0 R^T when it is indefinite (as Newton does).
            solver.tangent_at(&x, Tangent::Consistent).expect("tangent");
            solver.compliance(&rows, &x, &residual).expect("compliance")
        })
    });
    g.bench_function("assembly", |b| {
        b.iter(|| {
            solver.forget_reuse();
            solver.assemble(&x, Tangent::Consistent).expect("assemble")
        })
    });
    // The factorization benchmark uses the always-definite rotated tangent.
    solver.assemble(&x, Tangent::Definite).expect("assemble");
    g.bench_function("numeric_cholesky", |b| {
        b.iter(|| {
            solver.forget_reuse();
            solver.factorize().expect("factorize")
        })
    });
    g.bench_function("compliance_61_rows", |b| {
        b.iter(|| solver.compliance(&rows, &x, &residual).expect("compliance"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

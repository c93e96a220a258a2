//! Independent oracle: small-strain displacements against scikit-fem on the same meshes,
//! supports and loads (tools/oracle/skfem_oracle.py, driven by a JSON job).

use crate::common;
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::meshio::read_mesh;
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};
use std::path::Path;
use std::process::Command;

/// Runs the scikit-fem oracle on `problem`; None (with a SKIPPED line) when python3 or
/// scikit-fem is missing and SOFTSENSE_ORACLES is unset.
fn skfem_displacements(
    test: &str,
    p: &Problem,
    forces: &[(usize, [f64; 3])],
) -> Option<Vec<[f64; 3]>> {
    let script = common::project_root().join("tools/oracle/skfem_oracle.py");
    let available = Command::new("python3")
        .args(["-c", "import skfem"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !available {
        if std::env::var_os("SOFTSENSE_ORACLES").is_some() {
            panic!("SOFTSENSE_ORACLES is set but python3 with scikit-fem is not available");
        }
        crate::common::skipped(
            test,
            "python3 with scikit-fem is not available (pip install scikit-fem)",
        );
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("problem.json");
    let problem = serde_json::json!({
        "nodes": p.mesh.nodes_in_rest, "tets": p.mesh.tets,
        "young": p.material.young(), "poisson": p.material.poisson(),
        "fixed": p.fixed,
        "prescribed": p.prescribed.iter().map(|(v, u)| vec![*v as f64, u[0], u[1], u[2]]).collect::<Vec<_>>(),
        "forces": forces.iter().map(|(v, f)| vec![*v as f64, f[0], f[1], f[2]]).collect::<Vec<_>>(),
    });
    std::fs::write(&input, problem.to_string()).unwrap();
    let out = dir.path().join("out");
    let job = serde_json::json!({"stage": "linear_elastic", "input": input, "output_dir": out, "params": {}, "repeat": 1});
    let job_path = dir.path().join("job.json");
    std::fs::write(&job_path, job.to_string()).unwrap();
    let status = Command::new("python3")
        .arg(&script)
        .arg(&job_path)
        .status()
        .unwrap();
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    assert!(
        status.success() && result["ok"] == true,
        "oracle failed: {}",
        result["error"]
    );
    eprintln!(
        "{test}: scikit-fem {} in {:?} ms",
        result["version"], result["timings_ms"]
    );
    Some(serde_json::from_value(result["displacement"].clone()).unwrap())
}

fn compare(test: &str, p: Problem, forces: Vec<(usize, [f64; 3])>) {
    let mut ours = p.clone();
    for (v, f) in &forces {
        ours.loads.push(PointLoad {
            at: MappedPoint::node(*v),
            force: *f,
        });
    }
    let sol = ours.solve_static(&NewtonParams::default()).unwrap();
    let Some(theirs) = skfem_displacements(test, &p, &forces) else {
        return;
    };
    assert_eq!(theirs.len(), sol.displacement.len());
    let scale = sol
        .displacement
        .iter()
        .flatten()
        .fold(0.0f64, |a, c| a.max(c.abs()));
    let err = sol
        .displacement
        .iter()
        .zip(&theirs)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0f64, f64::max);
    eprintln!(
        "{test}: max |u| = {scale:e} m, max difference to scikit-fem = {err:e} m (relative {:e})",
        err / scale
    );
    assert!(scale > 0.0);
    assert!(err <= 1e-8 * scale, "relative difference {:e}", err / scale);
}

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

#[test]
fn small_strain_matches_scikit_fem_on_a_distorted_block() {
    let mut mesh = TetMesh::structured_box([0.0; 3], [0.04, 0.03, 0.1], [4, 3, 10]).unwrap();
    let mut s = 11;
    for q in &mut mesh.nodes_in_rest {
        if q[0] > 1e-9
            && q[0] < 0.04 - 1e-9
            && q[1] > 1e-9
            && q[1] < 0.03 - 1e-9
            && q[2] > 1e-9
            && q[2] < 0.1 - 1e-9
        {
            for c in q.iter_mut() {
                *c += 0.003 * lcg(&mut s);
            }
        }
    }
    mesh.quality().unwrap();
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(2.2e5, 0.45).unwrap(),
        Formulation::SmallStrain,
    );
    p.fixed = mesh.nodes_in_box([-1.0, -1.0, -1e-9], [1.0, 1.0, 1e-9]);
    let top = mesh.nodes_in_box([-1.0, -1.0, 0.1 - 1e-9], [1.0, 1.0, 1.0]);
    p.prescribed = top
        .iter()
        .take(3)
        .map(|&v| (v, [0.001, -0.0005, 0.002]))
        .collect();
    let forces: Vec<(usize, [f64; 3])> = top
        .iter()
        .skip(3)
        .map(|&v| (v, [0.02, 0.01, -0.03]))
        .collect();
    compare(
        "small_strain_matches_scikit_fem_on_a_distorted_block",
        p,
        forces,
    );
}

#[test]
fn small_strain_matches_scikit_fem_on_the_project_robot_mesh() {
    let path = common::project_root().join("meshes/robot.vtu");
    let mut mesh = read_mesh(Path::new(&path)).unwrap();
    mesh.place(&softsense::fem::mesh::Placement {
        scale: Some(1e-3),
        ..Default::default()
    });
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(1.8e5, 0.45).unwrap(),
        Formulation::SmallStrain,
    );
    p.fixed = mesh.nodes_in_box([-0.015, -0.015, -0.001], [0.015, 0.015, 0.0125]);
    let surface = mesh.surface();
    let forces: Vec<(usize, [f64; 3])> = surface
        .nodes
        .iter()
        .step_by(97)
        .map(|&v| (v, surface.vertex_normals[v].map(|c| -0.01 * c)))
        .collect();
    compare(
        "small_strain_matches_scikit_fem_on_the_project_robot_mesh",
        p,
        forces,
    );
}

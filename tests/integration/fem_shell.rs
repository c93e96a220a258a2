//! Thin bodies from triangle surfaces: the Punyo membrane model (`meshes/models/punyo.toml`)
//! and Hencky's clamped membrane.

use softsense::fem::model::Model;
use softsense::fem::solve::{MappedPoint, PointLoad};

#[test]
fn the_punyo_model_loads_as_a_clamped_shell_and_takes_a_press_at_its_top() {
    let test = "the_punyo_model_loads_as_a_clamped_shell_and_takes_a_press_at_its_top";
    if crate::common::data_file(test, "punyo/equalized.vtk").is_none() {
        return;
    }
    let path = crate::common::project_root().join("meshes/models/punyo.toml");
    let mut model = Model::load(&path, None).unwrap();
    let p = &model.problem;
    let n = 390;
    assert_eq!(
        p.mesh.num_nodes(),
        2 * n,
        "one layer: two copies of the surface"
    );
    assert!(p.mesh.signed_volumes().iter().all(|&v| v > 0.0));
    // The rim: both layer copies of the 64 marked nodes, all on the plane z = 0.054 m.
    assert_eq!(p.fixed.len(), 2 * 64);
    let x = p.mesh.nodes_in_rest.clone();
    for &i in p.fixed.iter().filter(|&&i| i < n) {
        assert!((x[i][2] - 0.054).abs() < 1e-6, "rim node {i} at {:?}", x[i]);
    }
    // The dome's top: the surface node farthest from the rim plane. `outside` grows the
    // layer away from the rim plane there, i.e. the file's triangles face out of the bubble.
    let top = (0..n)
        .max_by(|&a, &b| (x[a][2] - 0.054).abs().total_cmp(&(x[b][2] - 0.054).abs()))
        .unwrap();
    let height = x[top][2] - 0.054;
    let out = [0, 1, 2].map(|k| x[n + top][k] - x[top][k]);
    let thickness = out.iter().map(|c| c * c).sum::<f64>().sqrt();
    assert!((thickness - 0.0004).abs() < 1e-9, "{thickness}");
    assert!(
        out[2] * height > 0.0,
        "outward {out:?}, dome height {height}"
    );
    // A tenth of a newton pushed into the bubble at the top.
    let inward = out.map(|c| -0.1 * c / thickness);
    model.problem.loads = vec![PointLoad {
        at: MappedPoint::node(n + top),
        force: inward,
    }];
    let sol = model.problem.solve_static(&model.newton).unwrap();
    assert!(sol.converged);
    let d = sol.displacement[top];
    let along = (0..3).map(|k| d[k] * inward[k]).sum::<f64>() / 0.1;
    println!(
        "punyo: top node {top} at {:?}, dome height {height:.4} m, pushed in {along:.3e} m \
         in {} iterations",
        x[top], sol.iterations
    );
    assert!(along > 0.0 && along < 0.01, "{along}");
}

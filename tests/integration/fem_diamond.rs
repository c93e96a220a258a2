//! The real diamond robot mesh with the SOFA tutorial scene parameters.

use crate::common;
use softsense::fem::model::Model;

fn diamond_model(test: &str) -> Option<Model> {
    let mesh = common::data_file(test, "sofa/diamond.vtu")?;
    let model = common::project_root().join("meshes/models/diamond.toml");
    Some(Model::load(&model, Some(&mesh)).expect("diamond model loads"))
}

#[test]
fn diamond_north_cable_moves_tip_north() {
    let Some(m) = diamond_model("diamond_north_cable_moves_tip_north") else {
        return;
    };
    assert_eq!(m.problem.mesh.tets.len(), 4147);
    assert_eq!(m.problem.mesh.num_nodes(), 1628);
    for c in &m.problem.cables {
        eprintln!(
            "cable {} attach {:?} at {:?}",
            c.name,
            c.attach[0],
            c.attach[0].position(&m.problem.mesh.nodes_in_rest)
        );
    }
    eprintln!("fixed nodes: {}", m.problem.fixed.len());
    let sol = m.problem.solve_static(&m.newton).expect("solves");
    let tip = &m.effectors[0];
    let d = {
        let p = tip.point.position(&sol.positions);
        let r = tip.point.position(&m.problem.mesh.nodes_in_rest);
        [p[0] - r[0], p[1] - r[1], p[2] - r[2]]
    };
    eprintln!(
        "diamond: tip displacement {:?} mm, {} Newton iterations, north tension {} N, shortening {:?} m",
        d.map(|c| c * 1e3),
        sol.iterations,
        sol.cable_tension[0],
        sol.cable_shortening
    );
    assert!(sol.converged);
    assert!((sol.cable_shortening[0] - 0.020).abs() < 1e-9);
    assert!(sol.cable_tension[0] > 0.0, "the cable pulls");
    assert!(d[1] > 0.005, "tip moves towards +y (north)");
}

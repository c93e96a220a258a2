//! `softsense model new`: a CAD surface (or a volume mesh) to a model folder that loads,
//! with each refusal in one line naming its reason.

use crate::common::{oracle::gmsh_python, project_root, run_cli};
use std::path::Path;

/// The 12 triangles of a box, as an ASCII STL (outward), less the triangle `skip`.
fn box_stl(lo: [f64; 3], hi: [f64; 3], skip: Option<usize>) -> String {
    let tris = softsense::geometry::triangle::box_triangles(lo, hi);
    let mut s = String::from("solid box\n");
    for (k, t) in tris.iter().enumerate() {
        if Some(k) == skip {
            continue;
        }
        s += "facet normal 0 0 0\nouter loop\n";
        for p in t {
            s += &format!("vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += "endloop\nendfacet\n";
    }
    s + "endsolid box\n"
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn new_model(dir: &Path, surface: &Path, extra: &[&str]) -> std::process::Output {
    let out = dir.join("model");
    let mut args = vec![
        "model",
        "new",
        surface.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_cli(&args)
}

#[test]
fn a_surface_with_a_hole_is_refused_in_one_line_naming_the_hole() {
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("open.stl");
    std::fs::write(&stl, box_stl([0.0; 3], [20.0, 20.0, 60.0], Some(4))).unwrap();
    let o = new_model(
        dir.path(),
        &stl,
        &["--young", "100", "--fixed-below", "z=1"],
    );
    let err = stderr(&o);
    assert!(!o.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("not closed") && err.contains("hole"), "{err}");
    assert!(
        !dir.path().join("model").exists(),
        "nothing is written on a refusal"
    );
}

#[test]
fn a_self_intersecting_surface_is_refused_in_one_line_naming_two_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("crossing.stl");
    let two =
        box_stl([0.0; 3], [20.0, 20.0, 60.0], None) + &box_stl([10.0; 3], [30.0, 30.0, 70.0], None);
    std::fs::write(&stl, two).unwrap();
    let o = new_model(
        dir.path(),
        &stl,
        &["--young", "100", "--fixed-below", "z=1"],
    );
    let err = stderr(&o);
    assert!(!o.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("intersects itself: triangles"), "{err}");
}

#[test]
fn a_volume_mesh_becomes_a_model_that_loads_with_its_fixed_nodes_and_cable() {
    let dir = tempfile::tempdir().unwrap();
    let vtu = project_root().join("meshes/robot.vtu");
    let cable = dir.path().join("knee.json");
    // From near the base up the first leg to the knee, as robot.toml's north cable.
    std::fs::write(
        &cable,
        r#"{"name": "north", "pull": [0.0, 30.0, 0.0], "attach": [[0.0, 97.0, 45.0]]}"#,
    )
    .unwrap();
    let o = new_model(
        dir.path(),
        &vtu,
        &[
            "--young",
            "180",
            "--fixed-below",
            "z=2",
            "--cable",
            cable.to_str().unwrap(),
            "--region=-200,-200,0,200,200,20=360",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let model =
        softsense::fem::model::Model::load(&dir.path().join("model/model.toml"), None).unwrap();
    let want = model
        .problem
        .mesh
        .nodes_in_rest
        .iter()
        .filter(|p| p[2] <= 2e-3 + 1e-9)
        .count();
    assert_eq!(model.problem.fixed.len(), want);
    assert_eq!(model.problem.cables.len(), 1);
    assert!((model.problem.material.young() - 180e3).abs() < 1e-6);
    // The region's tetrahedra (centroid below z = 20 mm) at twice the modulus, the rest at 1.
    let scale = &model.problem.young_scale;
    assert_eq!(scale.len(), model.problem.mesh.tets.len());
    assert!(scale.contains(&2.0) && scale.contains(&1.0));
    let text = std::fs::read_to_string(dir.path().join("model/model.toml")).unwrap();
    assert!(text.contains("young = 180.0   # kPa"), "{text}");
}

#[test]
fn a_fixed_selection_of_no_node_or_every_node_is_refused_with_the_mesh_extent() {
    let dir = tempfile::tempdir().unwrap();
    let vtu = project_root().join("meshes/robot.vtu");
    let none = new_model(
        dir.path(),
        &vtu,
        &["--young", "180", "--fixed-box=500,500,500,600,600,600"],
    );
    assert!(
        stderr(&none).contains("--fixed-box 1 selects no node: the mesh spans x"),
        "{}",
        stderr(&none)
    );
    let all = new_model(
        dir.path(),
        &vtu,
        &["--young", "180", "--fixed-below", "z=1000"],
    );
    assert!(
        stderr(&all).contains("selects every node"),
        "{}",
        stderr(&all)
    );
    let free = new_model(dir.path(), &vtu, &["--young", "180"]);
    assert!(
        stderr(&free).contains("no fixed nodes"),
        "{}",
        stderr(&free)
    );
}

#[test]
fn a_cable_point_outside_the_body_is_refused_with_its_number() {
    let dir = tempfile::tempdir().unwrap();
    let vtu = project_root().join("meshes/robot.vtu");
    let cable = dir.path().join("c.json");
    std::fs::write(&cable, "[[0, 30, 0], [0, 97, 45], [0, 97, 400]]").unwrap();
    let o = new_model(
        dir.path(),
        &vtu,
        &[
            "--young",
            "180",
            "--fixed-below",
            "z=2",
            "--cable",
            cable.to_str().unwrap(),
        ],
    );
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("point 2 (0, 97, 400) is outside the body"),
        "{err}"
    );
}

#[test]
fn a_mesh_in_metres_under_millimetre_units_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    // robot.vtu is in mm: scaled by 1/1000 into metres through a written copy.
    let mesh = softsense::fem::meshio::read_mesh(&project_root().join("meshes/robot.vtu")).unwrap();
    let metres: Vec<[f64; 3]> = mesh
        .nodes_in_rest
        .iter()
        .map(|p| p.map(|c| c * 1e-3))
        .collect();
    let vtu = dir.path().join("robot_m.vtu");
    softsense::fem::meshio::write_vtu(&vtu, &metres, &mesh.tets, &[], &[]).unwrap();
    let o = new_model(
        dir.path(),
        &vtu,
        &["--young", "180", "--fixed-below", "z=0.002"],
    );
    assert!(
        stderr(&o).contains("if the surface is in metres, give --units SI"),
        "{}",
        stderr(&o)
    );
    let pa = new_model(
        &dir.path().join("b"),
        &vtu,
        &[
            "--young",
            "180",
            "--units",
            "SI",
            "--fixed-below",
            "z=0.002",
        ],
    );
    assert!(
        stderr(&pa).contains("softer than any silicone"),
        "{}",
        stderr(&pa)
    );
}

#[test]
fn a_closed_box_is_meshed_by_gmsh_into_a_model_that_solves_under_gravity() {
    let Some(py) =
        gmsh_python("a_closed_box_is_meshed_by_gmsh_into_a_model_that_solves_under_gravity")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("bar.stl");
    std::fs::write(&stl, box_stl([0.0; 3], [20.0, 20.0, 60.0], None)).unwrap();
    let o = new_model(
        dir.path(),
        &stl,
        &[
            "--young",
            "100",
            "--fixed-below",
            "z=0",
            "--size",
            "5",
            "--python",
            &py,
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("model/report.json")).unwrap(),
    )
    .unwrap();
    assert!(
        report["min_dihedral_deg"].as_f64().unwrap() > 5.0,
        "{report}"
    );
    assert!(
        report["max_radius_edge"].as_f64().unwrap() < 3.0,
        "{report}"
    );
    let model =
        softsense::fem::model::Model::load(&dir.path().join("model/model.toml"), None).unwrap();
    let q = model.problem.mesh.quality().unwrap();
    // The box's volume, 24 cm^3, filled exactly (in m^3).
    assert!((q.volume - 24e-6).abs() < 1e-12, "{}", q.volume);
    let sol = model.problem.solve_static(&model.newton).unwrap();
    assert!(sol.converged);
    // Gravity along the bar shortens it by its own weight: w = rho g L^2 / (2E), 0.19 um
    // (a bar free to thin: the clamped base adds a little stiffness, within 10%).
    let tip = sol.displacement.iter().map(|u| u[2]).fold(0.0, f64::min);
    let want = 1070.0 * 9.81 * 0.06f64.powi(2) / (2.0 * 100e3);
    assert!((tip.abs() - want).abs() < 0.1 * want, "{tip} vs {want}");
}

#[test]
fn a_ply_box_of_quads_reads_as_the_closed_surface_of_twelve_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("box.ply");
    let mut text = String::from("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n");
    for i in 0..8 {
        text += &format!(
            "{} {} {}\n",
            (i & 1) * 2,
            (i >> 1 & 1) * 3,
            (i >> 2 & 1) * 4
        );
    }
    for q in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        text += &format!("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    std::fs::write(&ply, text).unwrap();
    let soup = softsense::fem::surfaceio::read_triangles(&ply).unwrap();
    assert_eq!(soup.len(), 12);
    let closed = softsense::geometry::closed::close_surface(&soup, 0.0).unwrap();
    assert!((closed.shells[0].volume - 24.0).abs() < 1e-9);
    // And back through the binary STL writer, corner for corner.
    let stl = softsense::fem::surfaceio::stl_bytes(&closed.vertices, &closed.triangles);
    let again = softsense::fem::surfaceio::parse_stl(&stl).unwrap();
    assert_eq!(again.len(), 12);
    let closed_again = softsense::geometry::closed::close_surface(&again, 0.0).unwrap();
    assert!((closed_again.shells[0].volume - 24.0).abs() < 1e-9);
}

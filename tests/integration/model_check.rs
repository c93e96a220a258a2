//! `softsense model check`: the robot's numbers, each refusal (naming the key and the
//! file), the sag against beam theory, and the picture.

use crate::cli::{assert_fails, json_of, softsense, stderr};
use crate::common::project_root;
use softsense::fem::mesh::TetMesh;
use softsense::fem::meshio::write_vtu;
use softsense::fem::model::check::check_file;
use softsense::fem::model::Model;
use softsense::render::model::{CABLES, CAVITY, FIXED};
use softsense::render::Canvas;
use std::path::{Path, PathBuf};

/// A stiff (E = 1 GPa) bar 1 x 0.05 x 0.1 m along x, clamped at x = 0, under gravity along -z.
const BAR: &str = "units = \"SI\"
formulation = \"small-strain\"
gravity = [0.0, 0.0, -9.81]
[mesh]
path = \"bar.vtu\"
[material]
young = 1.0e9
poisson = 0.3
[mass]
density = 1000.0
[[fixed]]
box = [[-0.001, -1.0, -1.0], [0.001, 1.0, 1.0]]
";

/// Writes the bar mesh (`cells` along x, y, z) and `BAR` + `extra` as model.toml in `dir`.
fn bar_model(dir: &Path, cells: [usize; 3], extra: &str) -> PathBuf {
    let mesh = TetMesh::structured_box_with([0.0; 3], [1.0, 0.05, 0.1], cells, true).unwrap();
    write_vtu(
        &dir.join("bar.vtu"),
        &mesh.nodes_in_rest,
        &mesh.tets,
        &[],
        &[],
    )
    .unwrap();
    let file = dir.join("model.toml");
    std::fs::write(&file, format!("{BAR}{extra}")).unwrap();
    file
}

/// An ASCII STL of `tris`.
fn write_stl(path: &Path, tris: &[[[f64; 3]; 3]]) {
    let mut s = String::from("solid s\n");
    for t in tris {
        s.push_str("facet normal 0 0 0\nouter loop\n");
        for p in t {
            s.push_str(&format!("vertex {} {} {}\n", p[0], p[1], p[2]));
        }
        s.push_str("endloop\nendfacet\n");
    }
    s.push_str("endsolid s\n");
    std::fs::write(path, s).unwrap();
}

/// `softsense model check FILE ARGS...` with absolute paths.
fn model_check(file: &Path, args: &[&str]) -> std::process::Output {
    let mut all = vec!["model", "check", file.to_str().unwrap()];
    all.extend_from_slice(args);
    softsense(&all)
}

#[test]
fn model_check_prints_the_robot_s_mesh_mass_fixed_nodes_cables_points_and_sag() {
    let o = softsense(&["model", "check", "meshes/models/robot.toml"]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    for needle in [
        "1520 nodes, 4632 tetrahedra",
        "dihedral angles",
        "0.5 kg",
        "nodes, clamped",
        "cable:      north: 1 attach point, rest length",
        "shortened 10 mm",
        "effector:   tip at [0, 0, 125] mm, 3 rows",
        "force point: hook",
        "sag:",
        "under gravity alone",
        "picture:    none",
    ] {
        assert!(text.contains(needle), "no {needle:?} in:\n{text}");
    }
}

#[test]
fn the_json_report_of_the_robot_is_si_with_a_sag_at_a_free_node() {
    let v = json_of(&softsense(&[
        "model",
        "check",
        "meshes/models/robot.toml",
        "--json",
    ]));
    assert_eq!(v["quality"]["nodes"], 1520);
    assert_eq!(v["quality"]["tets"], 4632);
    assert!((v["mass"].as_f64().unwrap() - 0.5).abs() < 1e-9);
    assert!(
        (v["young"].as_f64().unwrap() - 180e3).abs() < 1e-6,
        "180 kPa in Pa"
    );
    assert_eq!(v["cables"].as_array().unwrap().len(), 4);
    assert!((v["cables"][0]["control"]["Displacement"].as_f64().unwrap() - 0.01).abs() < 1e-12);
    let sag = &v["sag"];
    let d = sag["displacement"].as_f64().unwrap();
    assert!(d > 0.0 && d < 0.125, "sag {d} m");
    let m = Model::load(&project_root().join("meshes/models/robot.toml"), None).unwrap();
    let node = sag["node"].as_u64().unwrap() as usize;
    assert!(
        m.problem.fixed.binary_search(&node).is_err(),
        "a fixed node cannot sag"
    );
}

#[test]
fn a_fixed_box_that_selects_no_node_is_refused_on_loading_naming_the_key_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = bar_model(
        dir.path(),
        [10, 1, 1],
        "[[fixed]]\nbox = [[2.0, 2.0, 2.0], [3.0, 3.0, 3.0]]\n",
    );
    let e = Model::load(&file, None).unwrap_err().to_string();
    assert!(
        e.contains("fixed[1].box") && e.contains("selects no node"),
        "{e}"
    );
    assert!(e.contains("model.toml"), "{e}");
    let o = model_check(&file, &[]);
    assert_fails(&o, 1, &["fixed[1].box", "model.toml"]);
}

#[test]
fn a_model_that_fixes_no_node_is_refused_by_check_though_it_loads() {
    let dir = tempfile::tempdir().unwrap();
    let file = bar_model(dir.path(), [10, 1, 1], "");
    let text = std::fs::read_to_string(&file).unwrap();
    let unfixed = text.split("[[fixed]]").next().unwrap().to_string();
    std::fs::write(&file, unfixed).unwrap();
    assert!(Model::load(&file, None).is_ok());
    let e = check_file(&file).unwrap_err().to_string();
    assert!(e.contains("fixed: the model fixes no node"), "{e}");
    assert!(e.contains("model.toml"), "{e}");
}

#[test]
fn a_cable_point_outside_the_body_is_refused_by_check_with_its_distance_though_it_loads() {
    let dir = tempfile::tempdir().unwrap();
    // 2 mm above the bar's top face (z = 0.1): within the loader's 5% of the diagonal.
    let cable = "[[cables]]\nname = \"c\"\npull = [0.0, 0.025, 0.05]\n\
                 attach = [[0.3, 0.025, 0.05], [0.9, 0.025, 0.102]]\n";
    let file = bar_model(dir.path(), [10, 1, 1], cable);
    assert!(Model::load(&file, None).is_ok());
    let e = check_file(&file).unwrap_err().to_string();
    assert!(e.contains("cables[0].attach[1]"), "{e}");
    assert!(e.contains("lies 0.002 m outside the body"), "{e}");
    assert!(e.contains("model.toml"), "{e}");
    let inside = cable.replace("0.102", "0.098");
    let file = bar_model(dir.path(), [10, 1, 1], &inside);
    let (_, r) = check_file(&file).unwrap();
    let want = 0.3 + (0.6f64.powi(2) + 0.048f64.powi(2)).sqrt();
    assert!(
        (r.cables[0].length - want).abs() < 1e-12,
        "{}",
        r.cables[0].length
    );
}

#[test]
fn an_open_cavity_is_refused_by_check_naming_the_key_and_its_rim_edges() {
    let dir = tempfile::tempdir().unwrap();
    // A square across the bar at x = 0.5: two triangles, four rim edges.
    let (a, b, c, d) = (
        [0.5, 0.01, 0.03],
        [0.5, 0.04, 0.03],
        [0.5, 0.04, 0.07],
        [0.5, 0.01, 0.07],
    );
    write_stl(&dir.path().join("open.stl"), &[[a, b, c], [a, c, d]]);
    let cavity = "[[cavities]]\nname = \"flap\"\nsurface = \"open.stl\"\n";
    let file = bar_model(dir.path(), [10, 1, 1], cavity);
    assert!(Model::load(&file, None).is_ok(), "loaders take a membrane");
    let e = check_file(&file).unwrap_err().to_string();
    for needle in [
        "cavities[0].surface",
        "\"flap\"",
        "open.stl",
        "4 rim edges",
        "model.toml",
    ] {
        assert!(e.contains(needle), "no {needle:?} in {e}");
    }
    // The top face's mesh faces: open too, named by its box.
    let cavity = "[[cavities]]\nname = \"top\"\nbox = [[-1.0, -1.0, 0.099], [2.0, 1.0, 0.101]]\n";
    let file = bar_model(dir.path(), [10, 1, 1], cavity);
    let e = check_file(&file).unwrap_err().to_string();
    assert!(
        e.contains("cavities[0].box") && e.contains("rim edges"),
        "{e}"
    );
}

#[test]
fn a_closed_cavity_is_reported_with_its_faces_and_rest_volume() {
    let dir = tempfile::tempdir().unwrap();
    let (lo, hi) = ([0.48, 0.005, 0.03], [0.52, 0.045, 0.07]);
    let v = |i: usize| [0, 1, 2].map(|k| if (i >> k) & 1 == 1 { hi[k] } else { lo[k] });
    // Corners 0..8 by bits (x, y, z); the faces turn outward.
    let faces = [
        [0, 3, 1],
        [0, 2, 3],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    let tris: Vec<[[f64; 3]; 3]> = faces.iter().map(|f| f.map(v)).collect();
    write_stl(&dir.path().join("box.stl"), &tris);
    let cavity = "[[cavities]]\nname = \"chamber\"\nsurface = \"box.stl\"\n";
    let file = bar_model(dir.path(), [10, 1, 1], cavity);
    let (_, r) = check_file(&file).unwrap();
    let c = &r.cavities[0];
    assert_eq!((c.name.as_str(), c.faces, c.closed), ("chamber", 12, true));
    assert!(
        (c.rest_volume - 0.04f64.powi(3)).abs() < 1e-12,
        "{}",
        c.rest_volume
    );
}

#[test]
fn the_sag_of_a_cantilever_bar_under_its_weight_is_euler_bernoulli_s_within_seven_percent() {
    let dir = tempfile::tempdir().unwrap();
    // 8 cells through the depth: linear tetrahedra are stiff in bending, and a tip-loaded
    // cantilever of these cells reads 95% of beam theory
    // (tests/fixtures/fem/cantilever_convergence.json).
    let file = bar_model(dir.path(), [80, 4, 8], "");
    let (m, r) = check_file(&file).unwrap();
    let (e, rho, g, b, h, l) = (1.0e9, 1000.0, 9.81, 0.05, 0.1, 1.0);
    let q = rho * g * b * h;
    let w = q * l * l * l * l / (8.0 * e * b * h * h * h / 12.0);
    let sag = r.sag.as_ref().unwrap();
    let ratio = sag.displacement / w;
    eprintln!(
        "sag {} m, Euler-Bernoulli {w} m, ratio {ratio}",
        sag.displacement
    );
    assert!(
        (0.93..1.0).contains(&ratio),
        "sag {} m, beam {w} m, ratio {ratio}",
        sag.displacement
    );
    assert!(
        (sag.at[0] - l).abs() < 1e-12,
        "at the free end: {:?}",
        sag.at
    );
    assert!((sag.fraction_of_length - sag.displacement / l).abs() < 1e-15);
    // The same as `fem solve` on the same model, which has nothing but gravity.
    let sol = m.problem.solve_static(&m.newton).unwrap();
    let d = sol.displacement[sag.node];
    assert!((sag.displacement - d.iter().map(|c| c * c).sum::<f64>().sqrt()).abs() < 1e-15);
}

#[test]
fn the_picture_is_a_960_pixel_square_png_with_the_fixed_nodes_and_cables_and_no_cavity() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("robot.png");
    let model = project_root().join("meshes/models/robot.toml");
    let o = model_check(&model, &["--picture", out.to_str().unwrap()]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("picture:    written to"));
    let c = Canvas::from_png(&out).unwrap();
    assert_eq!((c.width(), c.height()), (960, 960));
    let count = |rgb| c.pixels().iter().filter(|p| **p == rgb).count();
    assert!(count(FIXED) > 50, "fixed nodes drawn");
    assert!(count(CABLES[0]) > 50, "the first cable drawn");
    assert_eq!(
        count(CAVITY),
        0,
        "the robot has no cavity, and none is drawn"
    );
}

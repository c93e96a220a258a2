//! Binary legacy VTK, triangle surfaces with marked nodes, and their extrusion into thin
//! tetrahedral layers (`fem::meshio`, `fem::shell`).

use softsense::fem::mesh::signed_volume;
use softsense::fem::meshio::{parse_cells, read_mesh, read_surface, MeshCells};
use softsense::fem::shell::{extrude, ShellParams, ShellSide, SurfaceMesh};
use softsense::fem::FemError;

/// VTK cells as (type, nodes).
type Cells = Vec<(i32, Vec<i64>)>;

/// A small surface: two triangles of a unit square, a line on its edge, nodes 0 and 1
/// marked by vertex cells.
fn square() -> (Vec<[f64; 3]>, Cells) {
    let nodes = vec![
        [0.0, 0.0, 0.5],
        [1.0, 0.0, 0.5],
        [1.0, 1.0, 0.5],
        [0.0, 1.0, 0.5],
    ];
    let cells = vec![
        (5, vec![0, 1, 2]),
        (5, vec![0, 2, 3]),
        (3, vec![0, 1]),
        (1, vec![0]),
        (1, vec![1]),
    ];
    (nodes, cells)
}

/// Appends `values` big-endian at `width` bytes (4: int32 or float32, 8: int64 or double).
fn be(out: &mut Vec<u8>, values: impl IntoIterator<Item = f64>, width: usize, float: bool) {
    for v in values {
        match (width, float) {
            (4, true) => out.extend((v as f32).to_be_bytes()),
            (8, true) => out.extend(v.to_be_bytes()),
            (4, false) => out.extend((v as i32).to_be_bytes()),
            _ => out.extend((v as i64).to_be_bytes()),
        }
    }
}

/// A binary legacy VTK file of `square()`, in the 5.1 layout (int64 offsets and
/// connectivity, double points) or the 4.x one (int32 cells, float points).
fn binary_vtk(v51: bool) -> Vec<u8> {
    let (nodes, cells) = square();
    let version = if v51 { "5.1" } else { "4.2" };
    let mut f =
        format!("# vtk DataFile Version {version}\nsquare\nBINARY\nDATASET UNSTRUCTURED_GRID\n")
            .into_bytes();
    let coords = nodes.iter().flatten().copied();
    if v51 {
        f.extend(b"POINTS 4 double\n");
        be(&mut f, coords, 8, true);
        let conn: Vec<f64> = cells
            .iter()
            .flat_map(|c| c.1.iter().map(|&i| i as f64))
            .collect();
        let mut offsets = vec![0.0];
        for c in &cells {
            offsets.push(offsets.last().unwrap() + c.1.len() as f64);
        }
        f.extend(
            format!(
                "\nCELLS {} {}\nOFFSETS vtktypeint64\n",
                offsets.len(),
                conn.len()
            )
            .bytes(),
        );
        be(&mut f, offsets, 8, false);
        f.extend(b"\nCONNECTIVITY vtktypeint64\n");
        be(&mut f, conn, 8, false);
    } else {
        f.extend(b"POINTS 4 float\n");
        be(&mut f, coords, 4, true);
        let data: Vec<f64> = (cells.iter())
            .flat_map(|c| std::iter::once(c.1.len() as f64).chain(c.1.iter().map(|&i| i as f64)))
            .collect();
        f.extend(format!("\nCELLS {} {}\n", cells.len(), data.len()).bytes());
        be(&mut f, data, 4, false);
    }
    f.extend(format!("\nCELL_TYPES {}\n", cells.len()).bytes());
    be(&mut f, cells.iter().map(|c| c.0 as f64), 4, false);
    f.push(b'\n');
    f
}

fn expected_square() -> MeshCells {
    MeshCells {
        nodes: square().0,
        tets: vec![],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        marked: vec![0, 1],
    }
}

#[test]
fn binary_legacy_vtk_in_the_5_1_layout_reads_back_what_was_written() {
    assert_eq!(parse_cells(&binary_vtk(true)).unwrap(), expected_square());
}

#[test]
fn binary_legacy_vtk_in_the_4_x_layout_reads_back_what_was_written() {
    assert_eq!(parse_cells(&binary_vtk(false)).unwrap(), expected_square());
}

#[test]
fn ascii_legacy_vtk_in_the_5_1_layout_reads_like_the_binary() {
    let text = "# vtk DataFile Version 5.1\nsquare\nASCII\nDATASET UNSTRUCTURED_GRID\n\
                POINTS 4 double\n0 0 0.5 1 0 0.5 1 1 0.5 0 1 0.5\n\
                CELLS 6 10\nOFFSETS vtktypeint64\n0 3 6 8 9 10\n\
                CONNECTIVITY vtktypeint64\n0 1 2 0 2 3 0 1 0 1\n\
                CELL_TYPES 5\n5 5 3 1 1\n";
    assert_eq!(parse_cells(text.as_bytes()).unwrap(), expected_square());
}

#[test]
fn a_truncated_binary_vtk_is_refused_not_read_short() {
    let full = binary_vtk(true);
    for cut in [full.len() / 3, full.len() / 2, full.len() - 3] {
        assert!(parse_cells(&full[..cut]).is_err(), "cut at {cut}");
    }
}

#[test]
fn a_surface_given_as_a_volume_mesh_points_at_the_shell_key() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("square.vtk");
    std::fs::write(&path, binary_vtk(true)).unwrap();
    let err = read_mesh(&path).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("triangle surface") && text.contains("shell"),
        "{text}"
    );
    assert!(text.contains("square.vtk"), "{text}");
    let s = read_surface(&path).unwrap();
    assert_eq!((s.triangles.len(), s.marked.clone()), (2, vec![0, 1]));
}

#[test]
fn the_punyo_membrane_reads_as_390_nodes_714_triangles_and_a_rim_of_64() {
    let Some(path) = crate::common::data_file(
        "the_punyo_membrane_reads_as_390_nodes_714_triangles_and_a_rim_of_64",
        "punyo/equalized.vtk",
    ) else {
        return;
    };
    let s = read_surface(&path).unwrap();
    assert_eq!(s.nodes.len(), 390);
    assert_eq!(s.triangles.len(), 714);
    assert_eq!(s.marked.len(), 64);
    for &m in &s.marked {
        assert!(
            (s.nodes[m][2] - 0.054).abs() < 1e-6,
            "rim node {m} at {:?}",
            s.nodes[m]
        );
    }
    assert!(matches!(
        read_mesh(&path),
        Err(FemError::InFile { source, .. }) if matches!(*source, FemError::SurfaceNotVolume { triangles: 714 })
    ));
}

/// Faces of the tetrahedra used once: the boundary of the extruded body.
fn boundary_faces(tets: &[[usize; 4]]) -> usize {
    let mut faces = std::collections::HashMap::new();
    for t in tets {
        for skip in 0..4 {
            let mut f: Vec<usize> = (0..4).filter(|&k| k != skip).map(|k| t[k]).collect();
            f.sort_unstable();
            *faces.entry(f).or_insert(0) += 1;
        }
    }
    assert!(
        faces.values().all(|&c| c <= 2),
        "a face shared by three tetrahedra"
    );
    faces.values().filter(|&&c| c == 1).count()
}

#[test]
fn an_extruded_disk_is_conforming_positive_and_has_the_prisms_volume() {
    let s = SurfaceMesh::disk(0.1, 5).unwrap();
    let area: f64 = (s.triangles.iter())
        .map(|t| {
            let [a, b, c] = t.map(|i| s.nodes[i]);
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        })
        .sum();
    // The triangles tile the outer ring's 30-gon exactly.
    let polygon = 0.5 * 30.0 * 0.1 * 0.1 * (std::f64::consts::TAU / 30.0).sin();
    assert!((area - polygon).abs() < 1e-14, "{area} vs {polygon}");
    assert!(s.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| s.nodes[i]);
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0.0
    }));
    let rim_edges = 30;
    for layers in [1, 3] {
        let p = ShellParams {
            thickness: 0.002,
            layers,
            side: ShellSide::Outside,
            tension: 0.0,
        };
        let shell = extrude(&s, &p).unwrap();
        let m = &shell.mesh;
        assert_eq!(m.num_nodes(), s.nodes.len() * (layers + 1));
        assert_eq!(m.tets.len(), 3 * layers * s.triangles.len());
        let vols = m.signed_volumes();
        assert!(vols.iter().all(|&v| v > 0.0));
        let total: f64 = vols.iter().sum();
        assert!((total - area * 0.002).abs() < 1e-12 * area, "{total}");
        // Top, bottom, and two triangles per layer on each rim quad: no interior face left
        // unmatched (a non-conforming split would leave some).
        assert_eq!(
            boundary_faces(&m.tets),
            2 * s.triangles.len() + 2 * layers * rim_edges
        );
        assert_eq!(shell.marked.len(), (layers + 1) * 30);
        assert!(shell.marked.iter().all(|&i| {
            let p = m.nodes_in_rest[i];
            ((p[0] * p[0] + p[1] * p[1]).sqrt() - 0.1).abs() < 1e-12
        }));
    }
}

#[test]
fn the_side_puts_the_surface_at_the_shells_inner_outer_or_middle_face() {
    let s = SurfaceMesh::disk(0.1, 2).unwrap();
    for (side, lo) in [
        (ShellSide::Outside, 0.0),
        (ShellSide::Inside, -0.01),
        (ShellSide::Centred, -0.005),
    ] {
        let shell = extrude(
            &s,
            &ShellParams {
                thickness: 0.01,
                layers: 2,
                side,
                tension: 0.0,
            },
        )
        .unwrap();
        let z: Vec<f64> = shell.mesh.nodes_in_rest.iter().map(|p| p[2]).collect();
        let min = z.iter().copied().fold(f64::INFINITY, f64::min);
        let max = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(
            (min - lo).abs() < 1e-15 && (max - lo - 0.01).abs() < 1e-15,
            "{side:?}"
        );
    }
}

#[test]
fn a_clockwise_triangle_extrudes_to_positive_tetrahedra_on_its_own_outward_side() {
    // Node order chosen so sorting is an odd permutation for one triangle.
    let nodes = vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
    let s = SurfaceMesh::new(nodes, vec![[0, 1, 2]], vec![]).unwrap();
    let shell = extrude(
        &s,
        &ShellParams {
            thickness: 0.1,
            layers: 1,
            side: ShellSide::Outside,
            tension: 0.0,
        },
    )
    .unwrap();
    // (0,1,2) is clockwise seen from +z: outward is -z.
    assert!(shell.mesh.nodes_in_rest[3][2] < 0.0);
    for t in &shell.mesh.tets {
        let [a, b, c, d] = t.map(|i| shell.mesh.nodes_in_rest[i]);
        assert!((signed_volume(a, b, c, d) - 0.1 / 6.0).abs() < 1e-12);
    }
}

#[test]
fn triangles_oriented_opposite_ways_are_refused() {
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let err = SurfaceMesh::new(nodes, vec![[0, 1, 2], [0, 3, 2]], vec![]).unwrap_err();
    assert!(err.to_string().contains("oriented opposite"), "{err}");
}

#[test]
fn a_shell_too_thick_for_its_curvature_on_the_inside_is_refused() {
    // A cap of radius 0.01 m: 0.02 m inward folds the layers through the centre.
    let mut s = SurfaceMesh::disk(0.009, 3).unwrap();
    for p in &mut s.nodes {
        p[2] = (0.01f64.powi(2) - p[0] * p[0] - p[1] * p[1]).sqrt();
    }
    let p = ShellParams {
        thickness: 0.02,
        layers: 1,
        side: ShellSide::Inside,
        tension: 0.0,
    };
    assert!(matches!(
        extrude(&s, &p),
        Err(FemError::InvertedElement { .. })
    ));
}

#[test]
fn a_model_extrudes_its_surface_to_the_placed_thickness_and_fixes_the_marked_nodes() {
    use softsense::fem::model::Model;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("square.vtk"), binary_vtk(false)).unwrap();
    // The file is in metres, placed in mm: 2 mm is the thickness after placement.
    let model = |fixed: &str| {
        format!(
            "units = \"mm-kg-s\"\n[mesh]\npath = \"square.vtk\"\n\
             shell = {{ thickness = 2.0, layers = 2, side = \"inside\" }}\n\
             [placement]\nscale = 1000.0\n[material]\nyoung = 1000.0\npoisson = 0.3\n{fixed}"
        )
    };
    let path = dir.path().join("m.toml");
    std::fs::write(&path, model("[[fixed]]\nmarked = true\n")).unwrap();
    let m = Model::load(&path, None).unwrap();
    let x = &m.problem.mesh.nodes_in_rest;
    assert_eq!(x.len(), 3 * 4);
    let z: Vec<f64> = x.iter().map(|p| p[2]).collect();
    let (lo, hi) = (
        z.iter().copied().fold(1.0, f64::min),
        z.iter().copied().fold(-1.0, f64::max),
    );
    // SI inside: the surface at 0.5 m is the outer face, 2 mm below it the inner one.
    assert!(
        (hi - 0.5).abs() < 1e-12 && (hi - lo - 0.002).abs() < 1e-12,
        "{lo} {hi}"
    );
    assert_eq!(m.problem.fixed, vec![0, 1, 4, 5, 8, 9]);
    assert!(
        m.problem.prestress.is_empty(),
        "no tension, no initial stress"
    );
    // A tension of 50 N/m (= mN/mm) over the placed 2 mm: 25 kPa in the square's plane
    // (its normal is z), none through the thickness.
    let tensioned = model("").replace("side = \"inside\" }", "side = \"inside\", tension = 50.0 }");
    std::fs::write(&path, tensioned).unwrap();
    let m = Model::load(&path, None).unwrap();
    assert_eq!(m.problem.prestress.len(), m.problem.mesh.tets.len());
    for s in &m.problem.prestress {
        let want = [[25e3, 0.0, 0.0], [0.0, 25e3, 0.0], [0.0, 0.0, 0.0]];
        for (row, w) in s.iter().zip(&want) {
            for (v, w) in row.iter().zip(w) {
                assert!((v - w).abs() < 1e-6, "{s:?}");
            }
        }
    }
    // Without `shell` the surface is refused, naming the key.
    std::fs::write(
        &path,
        model("").replace(
            "shell = { thickness = 2.0, layers = 2, side = \"inside\" }\n",
            "",
        ),
    )
    .unwrap();
    let err = Model::load(&path, None).unwrap_err().to_string();
    assert!(err.contains("shell"), "{err}");
}

#[test]
fn fixing_marked_nodes_of_a_file_that_marks_none_is_refused() {
    use softsense::fem::mesh::TetMesh;
    use softsense::fem::model::{Model, ModelSpec};
    let spec: ModelSpec = toml::from_str(
        "[mesh]\npath = \"x.vtu\"\n[material]\nyoung = 1e4\npoisson = 0.3\n[[fixed]]\nmarked = true\n",
    )
    .unwrap();
    let mesh = TetMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
    let err = Model::from_spec(&spec, mesh).unwrap_err().to_string();
    assert!(err.contains("marks no nodes"), "{err}");
}

#[test]
fn a_pretensioned_disk_shell_sags_as_a_tensioned_membrane_under_a_uniform_load() {
    // T ∇²w = -q on a clamped disk of radius a: w0 = q a² / (4 T). The shell's own
    // modulus is negligible (E t = 0.3 N/m against T = 300 N/m): the tension carries it.
    use softsense::fem::material::Material;
    use softsense::fem::shell::shell_prestress;
    use softsense::fem::solve::{Formulation, MappedPoint, PointLoad, Problem};
    let (a, t, tension, q) = (0.05, 3e-4, 300.0, 200.0);
    let want = q * a * a / (4.0 * tension);
    let surface = SurfaceMesh::disk(a, 12).unwrap();
    let params = ShellParams {
        thickness: t,
        layers: 1,
        side: ShellSide::Centred,
        tension,
    };
    let shell = extrude(&surface, &params).unwrap();
    let n = surface.nodes.len();
    let mut p = Problem::new(
        shell.mesh.clone(),
        Material::new(1e3, 0.3).unwrap(),
        Formulation::SmallStrain,
    );
    p.fixed = shell.marked.clone();
    p.prestress = shell_prestress(&shell.mesh, 1, tension, t).unwrap();
    let mut area = vec![0.0; n];
    for tri in &surface.triangles {
        let [x, y, z] = tri.map(|i| surface.nodes[i]);
        let twice = (y[0] - x[0]) * (z[1] - x[1]) - (y[1] - x[1]) * (z[0] - x[0]);
        for &i in tri {
            area[i] += twice.abs() / 6.0;
        }
    }
    p.loads = (0..2 * n)
        .map(|v| PointLoad {
            at: MappedPoint::node(v),
            force: [0.0, 0.0, -0.5 * q * area[v % n]],
        })
        .collect();
    let sol = p.solve_static(&Default::default()).unwrap();
    let w0 = -0.5 * (sol.displacement[0][2] + sol.displacement[n][2]);
    let error = w0 / want - 1.0;
    eprintln!("pre-tensioned disk: w0 {w0:.4e} m, membrane theory {want:.4e} m ({error:+.4})");
    assert!(error.abs() < 0.03, "{error:+.4}");
}

#[test]
fn moving_a_shells_surface_node_moves_every_layer_copy_and_retakes_the_tension() {
    use softsense::fem::model::{Model, ModelSpec};
    use softsense::fem::shell::move_surface;
    let spec: ModelSpec = toml::from_str(
        "[mesh]\npath = \"unused.vtk\"\nshell = { thickness = 0.001, layers = 2, tension = 100.0 }\n\
         [material]\nyoung = 1e4\npoisson = 0.3\n[[fixed]]\nmarked = true\n",
    )
    .unwrap();
    let surface = SurfaceMesh::disk(0.05, 3).unwrap();
    let n = surface.nodes.len();
    let body = extrude(&surface, &spec.mesh.shell.unwrap()).unwrap();
    let model = Model::from_body(&spec, body).unwrap();
    let d = [0.0, 0.0, 0.004];
    let moved = move_surface(&model.problem, &[(0, d)]).unwrap();
    let (x0, x1) = (&model.problem.mesh.nodes_in_rest, &moved.mesh.nodes_in_rest);
    for v in 0..x0.len() {
        let want = if v % n == 0 { d } else { [0.0; 3] };
        for c in 0..3 {
            assert!((x1[v][c] - x0[v][c] - want[c]).abs() < 1e-15, "node {v}");
        }
    }
    // The centre's triangles now tilt: their tension has a z part; far ones do not.
    let tilted = (moved.prestress.iter().zip(&model.problem.prestress))
        .filter(|(a, b)| (a[2][2] - b[2][2]).abs() > 1.0)
        .count();
    assert!(tilted > 0 && tilted < moved.prestress.len(), "{tilted}");
    // Moving surface node n (not one: the shell's surface has n nodes) is refused.
    assert!(move_surface(&model.problem, &[(n, d)]).is_err());
}

#[test]
fn a_solid_has_no_shell_surface_to_move() {
    use softsense::fem::material::Material;
    use softsense::fem::mesh::TetMesh;
    use softsense::fem::shell::move_surface;
    use softsense::fem::solve::{Formulation, Problem};
    let mesh = TetMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
    let p = Problem::new(
        mesh,
        Material::new(1e4, 0.3).unwrap(),
        Formulation::Corotational,
    );
    let e = move_surface(&p, &[(0, [0.0, 0.0, 0.1])])
        .unwrap_err()
        .to_string();
    assert!(e.contains("no [mesh] shell"), "{e}");
}

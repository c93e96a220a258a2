//! Mesh files, quality, surface and placement.

use proptest::prelude::*;
use softsense::fem::mesh::{Placement, TetMesh};
use softsense::fem::meshio::{parse_mesh, vtu_string, Field};
use softsense::fem::FemError;

fn cube() -> TetMesh {
    TetMesh::structured_box([0.0; 3], [2.0, 2.0, 2.0], [2, 2, 2]).unwrap()
}

#[test]
fn vtu_written_then_read_gives_the_same_mesh() {
    let m = cube();
    let u: Vec<f64> = (0..3 * m.num_nodes()).map(|i| i as f64 * 0.1).collect();
    let vm: Vec<f64> = (0..m.tets.len()).map(|i| i as f64).collect();
    let text = vtu_string(
        &m.nodes_in_rest,
        &m.tets,
        &[Field {
            name: "displacement",
            components: 3,
            values: &u,
        }],
        &[Field {
            name: "von_mises",
            components: 1,
            values: &vm,
        }],
    );
    let back = parse_mesh(&text).unwrap();
    assert_eq!(back, m);
}

#[test]
fn vtu_with_big_endian_declaration_and_float32_int32_is_read() {
    let text = r#"<VTKFile type="UnstructuredGrid" version="0.1" byte_order="BigEndian">
  <UnstructuredGrid>
    <Piece NumberOfPoints="4" NumberOfCells="1">
      <Points>
        <DataArray type="Float32" NumberOfComponents="3" format="ascii">
        0 0 0 1 0 0 0 1 0 0 0 1
        </DataArray>
      </Points>
      <Cells>
        <DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
        <DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">10</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>"#;
    let m = parse_mesh(text).unwrap();
    assert_eq!(m.tets, vec![[0, 1, 2, 3]]);
    assert_eq!(m.nodes_in_rest[3], [0.0, 0.0, 1.0]);
    // A hexahedron is rejected with its cell index and type.
    let hex = text.replace(">10<", ">12<");
    assert!(matches!(
        parse_mesh(&hex),
        Err(FemError::UnsupportedCell {
            cell: 0,
            cell_type: 12
        })
    ));
    let bin = text.replace("format=\"ascii\">0 1 2 3", "format=\"binary\">0 1 2 3");
    assert!(matches!(parse_mesh(&bin), Err(FemError::Unsupported(_))));
    let lying = text.replace("NumberOfPoints=\"4\"", "NumberOfPoints=\"5\"");
    assert!(matches!(parse_mesh(&lying), Err(FemError::Parse(_))));
    let bad_index = text.replace(">0 1 2 3<", ">0 1 2 7<");
    assert!(matches!(
        parse_mesh(&bad_index),
        Err(FemError::BadIndex {
            tet: 0,
            node: 7,
            ..
        })
    ));
}

#[test]
fn gmsh_vertex_line_and_triangle_cells_beside_tets_are_skipped() {
    // As Gmsh writes them (SOFA's PneuNet): the boundary's cells after the tets.
    let text = "# vtk DataFile Version 2.0\ntet\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 4 14\n1 0\n2 0 1\n3 0 1 2\n4 0 1 2 3\nCELL_TYPES 4\n1\n3\n5\n10\n";
    assert_eq!(parse_mesh(text).unwrap().tets, vec![[0, 1, 2, 3]]);
    // Without a tetrahedron they are still refused.
    let flat = text.replace("CELL_TYPES 4\n1\n3\n5\n10", "CELL_TYPES 4\n1\n3\n5\n5");
    assert!(parse_mesh(&flat).is_err());
}

#[test]
fn vtk_legacy_ascii_is_read_and_other_cells_rejected() {
    let text = "# vtk DataFile Version 2.0\ntet\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 1 1 1\nCELLS 2 10\n4 0 1 2 3\n4 1 2 3 4\nCELL_TYPES 2\n10\n10\n";
    let m = parse_mesh(text).unwrap();
    assert_eq!(m.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
    let hex = text.replace("CELL_TYPES 2\n10\n10", "CELL_TYPES 2\n10\n12");
    assert!(matches!(
        parse_mesh(&hex),
        Err(FemError::UnsupportedCell {
            cell: 1,
            cell_type: 12
        })
    ));
    // Triangles are read (a shell's surface), but not with four nodes.
    let tri = text.replace("CELL_TYPES 2\n10\n10", "CELL_TYPES 2\n10\n5");
    assert!(matches!(parse_mesh(&tri), Err(FemError::Parse(_))));
    let short = text.replace("POINTS 5", "POINTS 50");
    assert!(matches!(parse_mesh(&short), Err(FemError::Parse(_))));
}

#[test]
fn gmsh_22_and_41_give_the_same_tets_and_skip_lower_dimensions() {
    let v22 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n$EndNodes\n$Elements\n4\n1 15 2 0 1 10\n2 2 2 0 1 10 20 30\n3 4 2 0 1 10 20 30 40\n4 4 2 0 1 20 30 40 50\n$EndElements\n";
    let v41 = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n2 5 10 50\n0 1 0 1\n10\n0 0 0\n3 1 0 4\n20\n30\n40\n50\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n$Elements\n2 3 1 3\n2 1 2 1\n1 10 20 30\n3 1 4 2\n2 10 20 30 40\n3 20 30 40 50\n$EndElements\n";
    let a = parse_mesh(v22).unwrap();
    let b = parse_mesh(v41).unwrap();
    assert_eq!(a.tets, vec![[0, 1, 2, 3], [1, 2, 3, 4]]);
    assert_eq!(a, b);
    let hex = v22.replace("4 4 2 0 1 20 30 40 50", "4 5 2 0 1 20 30 40 50 10 10 10 10");
    assert!(matches!(
        parse_mesh(&hex),
        Err(FemError::UnsupportedCell {
            cell: 3,
            cell_type: 5
        })
    ));
    let unknown = v22.replace("4 4 2 0 1 20 30 40 50", "4 4 2 0 1 20 30 40 99");
    assert!(matches!(parse_mesh(&unknown), Err(FemError::Parse(_))));
}

proptest! {
    #[test]
    fn truncated_or_corrupted_mesh_files_never_panic(cut in 0usize..2000, flip in 0usize..2000, byte in 0u8..128) {
        let m = cube();
        let text = vtu_string(&m.nodes_in_rest, &m.tets, &[], &[]);
        let cut = cut.min(text.len());
        let _ = parse_mesh(&text[..cut]);
        let mut bytes = text.into_bytes();
        let i = flip % bytes.len();
        bytes[i] = byte;
        if let Ok(s) = String::from_utf8(bytes) {
            let _ = parse_mesh(&s);
        }
    }
}

#[test]
fn quality_names_inverted_and_degenerate_elements() {
    let mut m = cube();
    let q = m.quality().unwrap();
    assert!((q.volume - 8.0).abs() < 1e-12);
    assert_eq!(q.tets, 48);
    m.tets[5].swap(0, 1);
    assert!(matches!(
        m.quality(),
        Err(FemError::InvertedElement { tet: 5, .. })
    ));
    let mut flat = TetMesh::new(
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
        vec![[0, 1, 2, 3]],
    )
    .unwrap();
    assert!(matches!(
        flat.quality(),
        Err(FemError::DegenerateElement { tet: 0, .. })
    ));
    flat.nodes_in_rest[3] = [f64::NAN, 0.0, 0.0];
    assert!(TetMesh::new(flat.nodes_in_rest.clone(), flat.tets.clone()).is_err());
    assert!(matches!(
        TetMesh::new(vec![[0.0; 3]; 4], vec![[0, 1, 2, 2]]),
        Err(FemError::DegenerateElement { .. })
    ));
}

#[test]
fn surface_of_a_cube_is_closed_and_points_outward() {
    let m = cube();
    let s = m.surface();
    assert_eq!(s.triangles.len(), 6 * 4 * 2);
    let center = [1.0, 1.0, 1.0];
    let mut total = [0.0; 3];
    for tri in &s.triangles {
        let [a, b, c] = tri.map(|v| m.nodes_in_rest[v]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let g = [
            (a[0] + b[0] + c[0]) / 3.0 - center[0],
            (a[1] + b[1] + c[1]) / 3.0 - center[1],
            (a[2] + b[2] + c[2]) / 3.0 - center[2],
        ];
        assert!(
            n[0] * g[0] + n[1] * g[1] + n[2] * g[2] > 0.0,
            "triangle {tri:?} points inward"
        );
        for k in 0..3 {
            total[k] += n[k];
        }
    }
    assert!(
        total.iter().all(|t| t.abs() < 1e-12),
        "closed surface: {total:?}"
    );
    assert_eq!(s.nodes.len(), 27 - 1);
    let centre_node = 13;
    assert!(!s.nodes.contains(&centre_node));
    assert_eq!(s.vertex_normals[centre_node], [0.0; 3]);
    // Face-centre node of the z = 2 face has normal +z; a corner has (1,1,1)/sqrt 3 by symmetry.
    let top = 4 + 9 * 2;
    assert!((s.vertex_normals[top][2] - 1.0).abs() < 1e-12);
    for &v in &s.nodes {
        let n = s.vertex_normals[v];
        assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn placement_rotates_then_translates_and_scales_first() {
    let p = Placement {
        scale: Some(0.001),
        rotate_deg: Some([90.0, 0.0, 0.0]),
        translate: Some([0.0, 0.0, 0.035]),
    };
    let q = p.apply([0.0, 1000.0, 0.0]);
    assert!(q[0].abs() < 1e-15 && q[1].abs() < 1e-15 && (q[2] - 1.035).abs() < 1e-12);
    let mut m = cube();
    m.place(&Placement {
        scale: Some(-1.0),
        rotate_deg: None,
        translate: None,
    });
    assert!(
        m.quality().is_ok(),
        "a mirroring placement keeps positive orientation"
    );
}

#[test]
fn locate_finds_the_containing_tet_and_rejects_far_points() {
    let m = cube();
    let (t, l) = m.locate([0.3, 1.2, 1.7], 0.1).unwrap();
    assert!(l.iter().all(|&x| x >= -1e-12));
    let c = m.corners(t);
    let p: Vec<f64> = (0..3)
        .map(|k| (0..4).map(|i| l[i] * c[i][k]).sum())
        .collect();
    assert!((p[0] - 0.3).abs() < 1e-12 && (p[1] - 1.2).abs() < 1e-12 && (p[2] - 1.7).abs() < 1e-12);
    assert!(m.locate([2.05, 1.0, 1.0], 0.1).is_ok());
    assert!(matches!(
        m.locate([5.0, 1.0, 1.0], 0.1),
        Err(FemError::PointOutside { .. })
    ));
}

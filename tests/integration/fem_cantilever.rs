//! Cantilever under a tip shear load: tip deflection converges to beam theory under mesh
//! refinement. The convergence table is a golden file (tests/fixtures/fem/cantilever_convergence.json).

use crate::common;
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};

const L: f64 = 1.0;
const H: f64 = 0.1;
/// Width (y) of the cross-section (cubic cells: k/2 across the width, k through the depth).
const B: f64 = 0.05;
const E: f64 = 1.0e6;
const NU: f64 = 0.3;
const P: f64 = 1.0e-3;
/// Cells along the length per cell through the depth (elements 10/NX_PER_K times longer than deep).
const NX_PER_K: usize = 10;

/// Timoshenko beam: bending plus shear (shear coefficient of a rectangle, Cowper).
fn beam_theory() -> f64 {
    let i = B * H * H * H / 12.0;
    let g = E / (2.0 * (1.0 + NU));
    let kappa = 10.0 * (1.0 + NU) / (12.0 + 11.0 * NU);
    P * L * L * L / (3.0 * E * i) + P * L / (kappa * g * B * H)
}

/// Area-weighted mean tip deflection of the mesh with k cells through the depth.
/// (Linear tetrahedra are stiff in bending: the error falls roughly as h^1.7, hence the
/// fine meshes; 2% needs about 16 cells through the depth.)
fn tip_deflection(k: usize) -> (usize, f64) {
    let mesh =
        TetMesh::structured_box_with([0.0; 3], [L, B, H], [NX_PER_K * k, (k / 2).max(1), k], true)
            .unwrap();
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(E, NU).unwrap(),
        Formulation::SmallStrain,
    );
    p.fixed = mesh.nodes_in_box([-1e-9, -1.0, -1.0], [1e-9, 1.0, 1.0]);
    // Consistent loads of a uniform shear traction on the tip face: area / 3 per triangle corner.
    let s = mesh.surface();
    let mut weight = vec![0.0; mesh.num_nodes()];
    for tri in &s.triangles {
        let pts = tri.map(|v| mesh.nodes_in_rest[v]);
        if pts.iter().all(|q| (q[0] - L).abs() < 1e-9) {
            let a = 0.5
                * ((pts[1][1] - pts[0][1]) * (pts[2][2] - pts[0][2])
                    - (pts[1][2] - pts[0][2]) * (pts[2][1] - pts[0][1]))
                    .abs();
            for &v in tri {
                weight[v] += a / 3.0 / (B * H);
            }
        }
    }
    for (v, w) in weight.iter().enumerate() {
        if *w > 0.0 {
            p.loads.push(PointLoad {
                at: MappedPoint::node(v),
                force: [0.0, 0.0, P * w],
            });
        }
    }
    let sol = p.solve_static(&NewtonParams::default()).unwrap();
    let w: f64 = weight
        .iter()
        .enumerate()
        .map(|(v, w)| w * sol.displacement[v][2])
        .sum();
    (mesh.tets.len(), w)
}

#[derive(serde::Serialize, serde::Deserialize, Debug)]
struct Row {
    cells_through_depth: usize,
    tets: usize,
    tip_deflection_m: f64,
    ratio_to_beam_theory: f64,
}

#[derive(serde::Serialize, serde::Deserialize, Debug)]
struct Table {
    description: String,
    beam_theory_m: f64,
    rows: Vec<Row>,
}

#[test]
fn cantilever_tip_deflection_converges_to_beam_theory() {
    let reference = beam_theory();
    let rows: Vec<Row> = [2, 4, 8, 12, 16]
        .iter()
        .map(|&k| {
            let (tets, w) = tip_deflection(k);
            Row {
                cells_through_depth: k,
                tets,
                tip_deflection_m: w,
                ratio_to_beam_theory: w / reference,
            }
        })
        .collect();
    let table = Table {
        description: format!(
            "Cantilever {L} x {B} (width) x {H} (depth) m, E = {E} Pa, nu = {NU}, tip shear {P} N (uniform traction), clamped at x = 0; \
             small-strain linear tetrahedra (6 Kuhn tets per cube, mirrored cube to cube, 10k x k/2 x k cubes); area-weighted mean tip deflection; \
             reference: Timoshenko beam with Cowper's shear coefficient"
        ),
        beam_theory_m: reference,
        rows,
    };
    let json = serde_json::to_string_pretty(&table).unwrap();
    eprintln!("{json}");
    for pair in table.rows.windows(2) {
        assert!(
            pair[1].tip_deflection_m > pair[0].tip_deflection_m,
            "stiff elements converge from below"
        );
    }
    let finest = table.rows.last().unwrap();
    assert!(
        (finest.ratio_to_beam_theory - 1.0).abs() < 0.02,
        "finest mesh ratio {}",
        finest.ratio_to_beam_theory
    );
    let golden_path = common::project_root().join("tests/fixtures/fem/cantilever_convergence.json");
    if std::env::var_os("SOFTSENSE_BLESS").is_some() {
        std::fs::write(&golden_path, json + "\n").unwrap();
    }
    let golden: Table =
        serde_json::from_str(&std::fs::read_to_string(&golden_path).unwrap()).unwrap();
    assert_eq!(golden.rows.len(), table.rows.len());
    assert!((golden.beam_theory_m - reference).abs() < 1e-15);
    for (g, r) in golden.rows.iter().zip(&table.rows) {
        assert_eq!(
            (g.cells_through_depth, g.tets),
            (r.cells_through_depth, r.tets)
        );
        assert!(
            (g.tip_deflection_m - r.tip_deflection_m).abs() < 1e-9 * g.tip_deflection_m,
            "{g:?} vs {r:?}"
        );
    }
}

//! Initial stress (`Problem::prestress`): its tangent by central differences, no force at
//! rest or under a rigid translation, and a tensioned sheet against the membrane equation.

use crate::common::fem::tangent_fd_error;
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::prestress::in_plane_tension;
use softsense::fem::solve::{Formulation, MappedPoint, NewtonParams, PointLoad, Problem};
use softsense::fem::tet4::Tangent;

const FORMULATIONS: [Formulation; 3] = [
    Formulation::SmallStrain,
    Formulation::Corotational,
    Formulation::NeoHookean,
];

/// A square sheet `side` wide and `thickness` thick in the xy plane, `n` x `n` cubes of
/// one layer, its four edges clamped, in-plane tension `tension` (N/m).
fn sheet(form: Formulation, side: f64, thickness: f64, n: usize, tension: f64) -> Problem {
    let h = side / 2.0;
    let mesh = TetMesh::structured_box([-h, -h, 0.0], [h, h, thickness], [n, n, 1]).unwrap();
    let mut p = Problem::new(mesh.clone(), Material::new(1e3, 0.3).unwrap(), form);
    let e = 1e-9;
    let mut fixed = Vec::new();
    for (lo, hi) in [
        ([-1.0, -h - e, -1.0], [1.0, -h + e, 1.0]),
        ([-1.0, h - e, -1.0], [1.0, h + e, 1.0]),
        ([-h - e, -1.0, -1.0], [-h + e, 1.0, 1.0]),
        ([h - e, -1.0, -1.0], [h + e, 1.0, 1.0]),
    ] {
        fixed.extend(mesh.nodes_in_box(lo, hi));
    }
    fixed.sort_unstable();
    fixed.dedup();
    p.fixed = fixed;
    p.prestress = vec![in_plane_tension(tension, thickness, [0.0, 0.0, 1.0]); mesh.tets.len()];
    p
}

#[test]
fn prestress_tangent_equals_central_differences_of_the_internal_forces() {
    for form in FORMULATIONS {
        let p = sheet(form, 0.04, 0.002, 3, 50.0);
        let x: Vec<[f64; 3]> = (p.mesh.nodes_in_rest.iter().enumerate())
            .map(|(v, q)| {
                let w = (v as f64 * 0.7).sin();
                [q[0] + 1e-4 * w, q[1] - 5e-5 * w, q[2] + 3e-4 * w]
            })
            .collect();
        let mut s = p.solver().unwrap();
        let (err, scale) = tangent_fd_error(&mut s, &x);
        assert!(err < 1e-6 * scale, "{form:?}: error {err:e}, |K| {scale:e}");
    }
}

#[test]
fn prestress_adds_no_force_at_rest_or_under_a_rigid_translation() {
    let p = sheet(Formulation::Corotational, 0.04, 0.002, 3, 50.0);
    let mut s = p.solver().unwrap();
    for shift in [[0.0; 3], [1e-3, -2e-3, 5e-4]] {
        let x: Vec<[f64; 3]> = (p.mesh.nodes_in_rest.iter())
            .map(|q| [q[0] + shift[0], q[1] + shift[1], q[2] + shift[2]])
            .collect();
        s.assemble(&x, Tangent::Consistent).unwrap();
        let worst = s.internal_force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        assert!(worst < 1e-12, "shift {shift:?}: force {worst:e} N");
    }
}

#[test]
fn a_tensioned_sheet_deflects_as_the_membrane_equation_says() {
    // T ∇²w = -q on a clamped square of side L: centre deflection 0.07367 q L² / T
    // (the Poisson problem's series). The sheet's own modulus is made negligible
    // (E t = 2 N/m against T = 200 N/m) so that tension carries the load.
    let (side, thickness, tension, q) = (0.1, 0.002, 200.0, 50.0);
    let want = 0.07367 * q * side * side / tension;
    let mut errors = Vec::new();
    for n in [8, 16] {
        let mut p = sheet(Formulation::SmallStrain, side, thickness, n, tension);
        let nodes = p.mesh.nodes_in_rest.clone();
        let cell = side / n as f64;
        // Half the load on each face's node, by its tributary area.
        for (v, x) in nodes.iter().enumerate() {
            let share = |c: f64| {
                if (c.abs() - side / 2.0).abs() < 1e-9 {
                    0.5
                } else {
                    1.0
                }
            };
            let area = cell * cell * share(x[0]) * share(x[1]);
            p.loads.push(PointLoad {
                at: MappedPoint::node(v),
                force: [0.0, 0.0, -0.5 * q * area],
            });
        }
        let sol = p.solve_static(&NewtonParams::default()).unwrap();
        let centre = (0..nodes.len())
            .filter(|&v| nodes[v][0].abs() < 1e-9 && nodes[v][1].abs() < 1e-9)
            .map(|v| -sol.displacement[v][2])
            .sum::<f64>()
            / 2.0;
        errors.push((centre / want - 1.0).abs());
    }
    eprintln!("tensioned sheet: errors {errors:?} (n = 8, 16)");
    assert!(errors[1] < 0.03, "n = 16: {:.4}", errors[1]);
    assert!(errors[1] < errors[0], "refining helps: {errors:?}");
}

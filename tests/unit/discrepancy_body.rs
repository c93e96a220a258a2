//! The body frame the discrepancy workflow's regions come from: it reproduces the
//! four-legged robot's hard-coded base, legs, platform and heights, and finds feature
//! points, sides and load candidates on a finger lying along x (where z-based rules found
//! none).

use softsense::discrepancy::body::{Body, FEATURE_HEIGHT, LOAD_HEIGHT, TOP_REGION};
use softsense::discrepancy::effects::tet_legs;
use softsense::discrepancy::features::{choose_features, region_of};
use softsense::discrepancy::load_candidates;
use softsense::fem::material::Material;
use softsense::fem::mesh::TetMesh;
use softsense::fem::model::Model;
use softsense::fem::solve::{Formulation, Problem};

/// The rules the workflow had for the four-legged robot (z up, base at z = 0, metres).
fn old_leg(p: [f64; 3]) -> usize {
    if p[1].abs() >= p[0].abs() {
        if p[1] >= 0.0 {
            0
        } else {
            2
        }
    } else if p[0] >= 0.0 {
        1
    } else {
        3
    }
}

fn centroid(c: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|k| c.iter().map(|q| q[k]).sum::<f64>() / c.len() as f64)
}

#[test]
fn the_body_frame_reproduces_the_four_legged_robots_regions() {
    let root = env!("CARGO_MANIFEST_DIR");
    let model = Model::load(
        std::path::Path::new(&format!("{root}/meshes/models/robot.toml")),
        None,
    )
    .unwrap();
    let p = &model.problem;
    let body = Body::of(p).unwrap();
    assert!((body.axis()[2] - 1.0).abs() < 1e-9, "{:?}", body.axis());
    let old: Vec<Option<usize>> = (0..p.mesh.tets.len())
        .map(|t| {
            let c = centroid(&p.mesh.corners(t));
            let base = c[0].abs() <= 0.015 && c[1].abs() <= 0.015 && c[2] <= 0.0125;
            (!base && c[2] < 0.11).then(|| old_leg(c))
        })
        .collect();
    let new = tet_legs(p, &body);
    let differ: Vec<_> = (0..new.len())
        .filter(|&t| old[t] != new[t])
        .map(|t| (centroid(&p.mesh.corners(t)), old[t], new[t]))
        .collect();
    assert!(differ.is_empty(), "of {}: {differ:?}", new.len());
    // Every surface triangle's feature height and region, and every surface node's load
    // candidacy, as the z rules had them.
    let s = p.mesh.surface();
    let x = &p.mesh.nodes_in_rest;
    for t in &s.triangles {
        let c = centroid(&t.map(|v| x[v]));
        assert_eq!(c[2] > 0.02, body.height(c) > FEATURE_HEIGHT, "{c:?}");
        // Regions only matter for features; the base's bottom face has ties on the
        // diagonal |x| = |y| that a base centroid 1e-19 off zero breaks the other way.
        if c[2] <= 0.02 {
            continue;
        }
        let old_region = if c[2] >= 0.105 { 0 } else { old_leg(c) + 1 };
        assert_eq!(
            region_of(&body, c),
            old_region,
            "{c:?} (top from {TOP_REGION})"
        );
    }
    for &v in &s.nodes {
        assert_eq!(
            x[v][2] > 0.03,
            body.height(x[v]) > LOAD_HEIGHT,
            "{:?}",
            x[v]
        );
    }
}

#[test]
fn explain_finds_feature_points_on_a_finger_lying_along_x() {
    // A 100 x 15 x 15 mm finger along -x from a clamp at x = 0, within 15 mm of z = 0.
    let mesh = TetMesh::structured_box([-0.1, 0.0, 0.0], [0.0, 0.015, 0.015], [20, 3, 3]).unwrap();
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(1e5, 0.3).unwrap(),
        Formulation::Corotational,
    );
    p.fixed = mesh.nodes_in_box([-0.005 - 1e-9, -1.0, -1.0], [1.0, 1.0, 1.0]);
    let body = Body::of(&p).unwrap();
    assert!((body.axis()[0] + 1.0).abs() < 1e-9, "{:?}", body.axis());
    let s = mesh.surface();
    let f = choose_features(&mesh.nodes_in_rest, &s, 60, &body, FEATURE_HEIGHT, 0.002);
    assert!(f.len() >= 30, "{} features", f.len());
    // None near the clamp; some near the tip; every side of the finger has some.
    assert!(f.iter().all(|q| q.rest[0] < -0.005 - 0.0095 * 0.99));
    assert!(f.iter().any(|q| q.rest[0] < -0.09));
    for region in 1..5 {
        assert!(f.iter().any(|q| q.region == region), "side {region}");
    }
    let legs = tet_legs(&p, &body);
    for leg in 0..4 {
        assert!(legs.contains(&Some(leg)), "leg {leg}");
    }
    assert!(legs.iter().any(Option::is_none), "the clamp");
    let loads = load_candidates(&p, &body, 24);
    assert_eq!(loads.len(), 24);
    assert!(loads.iter().all(|&v| mesh.nodes_in_rest[v][0] < -0.02));
}

#[test]
fn hidden_keeps_the_four_legged_robots_tensions_and_stretches_a_stiff_fingers() {
    use softsense::discrepancy::generate::{input_ranges, DatasetSpec};
    let root = env!("CARGO_MANIFEST_DIR");
    let spec = DatasetSpec::default();
    let robot = Model::load(
        std::path::Path::new(&format!("{root}/meshes/models/robot.toml")),
        None,
    )
    .unwrap();
    let r = input_ranges(&spec, &robot).unwrap();
    assert_eq!(r, vec![spec.tension; 4]);
    // A finger 1000 times stiffer than the robot's rubber hardly bends at 2 N.
    let mut finger = robot.clone();
    let m = finger.problem.material;
    finger.problem.material = Material::new(m.young() * 1e3, m.poisson()).unwrap();
    let r = input_ranges(&spec, &finger).unwrap();
    assert!(r.iter().all(|q| q[0] == 0.0 && q[1] > 10.0), "{r:?}");
}

//! Marker-based sensing end to end (thesis 4.6-4.7): the direct FE model makes the truth
//! (known forces at candidate nodes, marker positions with 0.1 mm Gaussian noise from a
//! seeded generator), the inverse model recovers the forces from the markers alone.
use softsense::fem::model::Model;
use softsense::fem::solve::PointLoad;
use softsense::markers::{bind_markers, Directions, ForceCandidate, MarkerSensor, MarkersParams};
use softsense::scene::sensor::normal;
use std::path::Path;

const SIGMA: f64 = 1e-4;

fn model(name: &str) -> Model {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Model::load(&root.join("meshes/models").join(name), None).unwrap()
}

/// A sensor with markers at `markers_mm` and candidates at `candidates_mm` (rest, mm).
fn sensor(
    model: &Model,
    markers_mm: &[[f64; 3]],
    candidates_mm: &[[f64; 3]],
    dirs: Directions,
) -> MarkerSensor {
    let mesh = &model.problem.mesh;
    let surface = mesh.surface();
    let names: Vec<String> = (0..markers_mm.len()).map(|i| format!("m{i}")).collect();
    let at: Vec<[f64; 3]> = markers_mm.iter().map(|p| p.map(|c| c * 1e-3)).collect();
    let markers = bind_markers(mesh, &surface, &names, &at, 0.005).unwrap();
    let candidates = (candidates_mm.iter().enumerate())
        .map(|(i, p)| {
            ForceCandidate::snapped(&format!("c{i}"), mesh, &surface, p.map(|c| c * 1e-3), dirs)
                .unwrap()
        })
        .collect();
    MarkerSensor::new(
        &model.problem,
        model.newton.clone(),
        markers,
        candidates,
        MarkersParams::default(),
    )
    .unwrap()
}

/// Marker positions under `forces` (one vector per candidate, N) with noise from `seed`.
fn measure(s: &MarkerSensor, forces: &[[f64; 3]], seed: u64) -> Vec<Option<[f64; 3]>> {
    let mut p = s.problem.clone();
    for (c, f) in s.candidates.iter().zip(forces) {
        p.loads.push(PointLoad {
            at: c.at,
            force: *f,
        });
    }
    let sol = p.solve_static(&s.newton).unwrap();
    (s.markers.iter().enumerate())
        .map(|(m, mk)| {
            let q = mk.at.position(&sol.positions);
            Some([0, 1, 2].map(|k| q[k] + SIGMA * normal(seed, 0, m as u64, k as u64)))
        })
        .collect()
}

fn grid(xs: &[f64], ys: &[f64], z: f64) -> Vec<[f64; 3]> {
    xs.iter()
        .flat_map(|x| ys.iter().map(move |y| [*x, *y, z]))
        .collect()
}

#[test]
fn two_hanging_weights_on_the_sheet_are_recovered_within_two_percent() {
    let m = model("sheet.toml");
    let s = sensor(
        &m,
        &grid(
            &[-75.0, -25.0, 25.0, 75.0],
            &[-75.0, -25.0, 25.0, 75.0],
            4.0,
        ),
        &[[-40.0, 0.0, 4.0], [40.0, 0.0, 4.0]],
        Directions::Normal,
    );
    // Thesis Table 4.4's weights (N), hanging along -z.
    let pairs = [(0.559, 0.559), (0.559, 0.359), (0.359, 0.359)];
    for (k, (f1, f2)) in pairs.into_iter().enumerate() {
        let truth = [[0.0, 0.0, -f1], [0.0, 0.0, -f2]];
        let measured = measure(&s, &truth, 10 + k as u64);
        let mut est = s.solve_frame(k as u64, &measured, None).unwrap();
        est.set_truth(&truth);
        for (i, w) in [f1, f2].into_iter().enumerate() {
            let err = (est.forces[i][2] + w).abs() / w;
            eprintln!("sheet {f1}/{f2} N: force {i} {:.4} N, error {:.3}%, sigma {:.4} N, I_w {:.3} N/m, I_e {:.4} N, updates {}",
                -est.forces[i][2], 100.0 * err, est.sigma[i], est.i_w, est.i_e.unwrap(), est.updates);
            assert!(err < 0.02, "force {i}: {:?} against {w}", est.forces[i]);
        }
        assert_eq!(est.status, softsense::markers::MarkersStatus::Converged);
    }
}

//! Marker-sensing helpers shared by the integration and acceptance tests: the bundled
//! sheet and robot with markers and candidates, and measurements made by the direct FE model.
use softsense::fem::model::Model;
use softsense::fem::solve::PointLoad;
use softsense::markers::{
    bind_markers, CandidateLocation, Directions, MarkerSensor, MarkersParams,
};
use softsense::math::rand::normal;
use std::path::Path;

pub const SIGMA: f64 = 1e-4;

pub fn model(name: &str) -> Model {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    Model::load(&root.join("meshes/models").join(name), None).unwrap()
}

/// A sensor with markers at `markers_mm` and candidates at `candidates_mm` (rest, mm).
pub fn sensor(
    model: &Model,
    markers_mm: &[[f64; 3]],
    candidates_mm: &[[f64; 3]],
    dirs: Directions,
) -> MarkerSensor {
    let mesh = &model.problem.mesh;
    let surface = mesh.surface();
    let names: Vec<String> = (0..markers_mm.len()).map(|i| format!("m{i}")).collect();
    let at: Vec<[f64; 3]> = markers_mm.iter().map(|p| p.map(|c| c * 1e-3)).collect();
    let markers = bind_markers(&mesh.nodes_in_rest, &surface, &names, &at, 0.005).unwrap();
    let candidates = (candidates_mm.iter().enumerate())
        .map(|(i, p)| {
            CandidateLocation::snapped(&format!("c{i}"), mesh, &surface, p.map(|c| c * 1e-3), dirs)
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
pub fn measure(s: &MarkerSensor, forces: &[[f64; 3]], seed: u64) -> Vec<Option<[f64; 3]>> {
    let loads = (s.locations.iter().zip(forces))
        .map(|(c, f)| PointLoad {
            at: c.at(),
            force: *f,
        })
        .collect();
    measure_loads(s, loads, seed)
}

/// Marker positions under `loads` with noise from `seed`.
pub fn measure_loads(s: &MarkerSensor, loads: Vec<PointLoad>, seed: u64) -> Vec<Option<[f64; 3]>> {
    let mut p = s.problem.clone();
    p.loads = loads;
    let sol = p.solve_static(&s.newton).unwrap();
    (s.markers.iter().enumerate())
        .map(|(m, mk)| {
            let q = mk.at.position(&sol.positions);
            Some([0, 1, 2].map(|k| q[k] + SIGMA * normal(seed, 0, m as u64, k as u64)))
        })
        .collect()
}

pub fn grid(xs: &[f64], ys: &[f64], z: f64) -> Vec<[f64; 3]> {
    xs.iter()
        .flat_map(|x| ys.iter().map(move |y| [*x, *y, z]))
        .collect()
}

/// The sheet with 25 markers and normal candidates 80 mm apart on its x axis.
pub fn sheet_with_two_candidates() -> MarkerSensor {
    let m = model("sheet.toml");
    let c = [[-40.0, 0.0, 4.0], [40.0, 0.0, 4.0]];
    sensor(&m, &sheet_markers(), &c, Directions::Normal)
}

/// 25 markers on the sheet's top face, 40 mm apart.
pub fn sheet_markers() -> Vec<[f64; 3]> {
    let xs = [-80.0, -40.0, 0.0, 40.0, 80.0];
    grid(&xs, &xs, 4.0)
}

/// The robot with the tip hook as the candidate and 16 markers: the surface nodes nearest
/// `around` (m) that are over 8 mm from the tip (not on the hook itself).
pub fn robot_tip_sensor(around: [f64; 3]) -> MarkerSensor {
    let m = model("robot.toml");
    let mesh = &m.problem.mesh;
    let surface = mesh.surface();
    let dist = |v: usize, q: [f64; 3]| {
        let p = mesh.nodes_in_rest[v];
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    let tip = [0.0, 0.0, 0.125];
    let mut near: Vec<usize> = (surface.nodes.iter().copied())
        .filter(|&v| dist(v, tip) > 0.008)
        .collect();
    near.sort_by(|a, b| dist(*a, around).total_cmp(&dist(*b, around)));
    let at: Vec<[f64; 3]> = near[..16].iter().map(|&v| mesh.nodes_in_rest[v]).collect();
    let names: Vec<String> = (0..16).map(|i| format!("m{i}")).collect();
    let markers = bind_markers(&mesh.nodes_in_rest, &surface, &names, &at, 1e-6).unwrap();
    let hook = m.force_points.iter().find(|e| e.name == "hook").unwrap();
    let candidates = vec![CandidateLocation::from_force_point(hook, mesh)];
    let params = MarkersParams::default();
    MarkerSensor::new(&m.problem, m.newton.clone(), markers, candidates, params).unwrap()
}

/// A small seeded generator for the trials (splitmix-style hashing of the scene's).
pub fn uniform(seed: u64, k: u64) -> f64 {
    softsense::math::rand::uniform(seed, 7, k, 0)
}

/// The bundled candidates of a body (thesis 4.7.4): `meshes/models/<body>_candidates.csv`,
/// the sheet's 12 (a 4 x 3 grid, 40 mm apart, normal) or the robot's 8.
pub fn bundled_candidates(m: &Model, body: &str) -> Vec<CandidateLocation> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = root.join(format!("meshes/models/{body}_candidates.csv"));
    softsense::markers::bind::read_candidates(&file, &m.problem.mesh).unwrap()
}

/// The sheet with 25 markers and its 12 bundled normal candidates (a 40 mm grid, 4 x 3).
pub fn sheet_with_twelve_candidates() -> MarkerSensor {
    let m = model("sheet.toml");
    let s = sensor(&m, &sheet_markers(), &[], Directions::Normal);
    s.with_locations(bundled_candidates(&m, "sheet")).unwrap()
}

/// Trial `t` of location among candidates: one or two distinct candidates (0.3-0.6 N each,
/// hanging along -z); returns the chosen candidates and the found ones, both sorted.
pub fn location_trial(s: &MarkerSensor, t: u64) -> (Vec<usize>, Vec<usize>) {
    let n = s.locations.len();
    let count = 1 + (uniform(t, 0) < 0.5) as usize;
    let mut truth = vec![[0.0; 3]; n];
    let mut chosen = Vec::new();
    let mut k = 1;
    while chosen.len() < count {
        let c = (uniform(t, k) * n as f64) as usize;
        k += 1;
        if !chosen.contains(&c) {
            chosen.push(c);
            truth[c] = [0.0, 0.0, -(0.3 + 0.3 * uniform(t, 100 + k))];
        }
    }
    chosen.sort_unstable();
    let est = s.solve_frame(t, &measure(s, &truth, 70 + t), None).unwrap();
    let mut found: Vec<usize> = softsense::markers::locate_forces(&est, &s.locations, &s.params)
        .iter()
        .flat_map(|l| l.candidates.clone())
        .collect();
    found.sort_unstable();
    (chosen, found)
}

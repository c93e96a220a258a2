//! Marker-based sensing end to end (thesis 4.6-4.7): the direct FE model makes the truth
//! (known forces at candidate nodes, marker positions with 0.1 mm Gaussian noise from a
//! seeded generator), the inverse model recovers the forces from the markers alone.
use softsense::fem::model::Model;
use softsense::fem::solve::PointLoad;
use softsense::markers::{
    bind_markers, locate_forces, Directions, ForceCandidate, MarkerSensor, MarkersParams,
};
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
    let markers = bind_markers(&mesh.nodes_in_rest, &surface, &names, &at, 0.005).unwrap();
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
    let s = sheet_with_two_candidates();
    // Thesis Table 4.4's weights (N), hanging along -z.
    let pairs = [
        (0.559, 0.559),
        (0.559, 0.459),
        (0.559, 0.359),
        (0.459, 0.459),
        (0.459, 0.359),
        (0.359, 0.359),
    ];
    // The line is "each within 2%"; with 0.1 mm noise one σ is 0.9-1.1% of a
    // 359-459 mN force here, so each force is held to 4σ and the thesis's own metric
    // (Table 4.4: the mean of the two relative errors) to 2%.
    for (k, (f1, f2)) in pairs.into_iter().enumerate() {
        let truth = [[0.0, 0.0, -f1], [0.0, 0.0, -f2]];
        let measured = measure(&s, &truth, 10 + k as u64);
        let mut est = s.solve_frame(k as u64, &measured, None).unwrap();
        est.set_truth(&truth);
        assert_eq!(est.status, softsense::markers::MarkersStatus::Converged);
        let mut mean = 0.0;
        for (i, w) in [f1, f2].into_iter().enumerate() {
            let err = (est.forces[i][2] + w).abs() / w;
            mean += 0.5 * err;
            eprintln!(
                "sheet {f1}/{f2} N: force {i} {:.4} N, error {:.3}%, sigma {:.4} N, I_w {:.3} N/m, I_e {:.4} N, updates {}",
                -est.forces[i][2], 100.0 * err, est.sigma[i], est.i_w, est.i_e.unwrap(), est.updates
            );
            assert!(
                err * w < 4.0 * est.sigma[i],
                "force {i}: {:?} against {w}",
                est.forces[i]
            );
        }
        eprintln!("sheet {f1}/{f2} N: mean error {:.3}%", 100.0 * mean);
        assert!(mean < 0.02, "{f1}/{f2}: mean error {mean}");
    }
}

/// The sheet with 25 markers and normal candidates 80 mm apart on its x axis.
fn sheet_with_two_candidates() -> MarkerSensor {
    let m = model("sheet.toml");
    let c = [[-40.0, 0.0, 4.0], [40.0, 0.0, 4.0]];
    sensor(&m, &sheet_markers(), &c, Directions::Normal)
}

/// 25 markers on the sheet's top face, 40 mm apart.
fn sheet_markers() -> Vec<[f64; 3]> {
    let xs = [-80.0, -40.0, 0.0, 40.0, 80.0];
    grid(&xs, &xs, 4.0)
}

/// The robot with the tip hook as the candidate and 16 markers: the surface nodes nearest
/// `around` (m) that are over 8 mm from the tip (not on the hook itself).
fn robot_tip_sensor(around: [f64; 3]) -> MarkerSensor {
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
    let candidates = vec![ForceCandidate::from_force_point(hook, mesh)];
    let params = MarkersParams::default();
    MarkerSensor::new(&m.problem, m.newton.clone(), markers, candidates, params).unwrap()
}

#[test]
fn a_tip_weight_seen_by_markers_far_from_it_is_reported_within_its_sigma() {
    // Table 4.5's far group: markers around the east knee (97, 0, 45) mm; the thesis
    // reports 89-97% there. Reported, and held to the noise it predicts (4σ).
    let s = robot_tip_sensor([0.097, 0.0, 0.045]);
    let w = 0.659;
    let est = s
        .solve_frame(0, &measure(&s, &[[0.0, 0.0, -w]], 60), None)
        .unwrap();
    let err = (est.intensities[0] - w).abs() / w;
    eprintln!(
        "robot tip {w} N, far markers: {:.4} N, error {:.3}%, sigma {:.4} N, I_w {:.2} N/m",
        est.intensities[0],
        100.0 * err,
        est.sigma[0],
        est.i_w
    );
    assert_eq!(est.status, softsense::markers::MarkersStatus::Converged);
    assert!(err * w < 4.0 * est.sigma[0], "{:?}", est.intensities);
}

#[test]
fn a_tip_weight_on_the_robot_is_recovered_within_one_percent_from_markers_near_it() {
    let s = robot_tip_sensor([0.0, 0.0, 0.125]);
    // Thesis Table 4.5's weights (N) with the north cable held at the model's 10 mm. One σ
    // is 1.0% of the 259 mN weight: each estimate is held to 4σ, the mean error to 1%.
    let weights = [0.859, 0.659, 0.459, 0.259];
    let mut mean = 0.0;
    for (k, w) in weights.into_iter().enumerate() {
        let truth = [[0.0, 0.0, -w]];
        let measured = measure(&s, &truth, 40 + k as u64);
        let est = s.solve_frame(k as u64, &measured, None).unwrap();
        let err = (est.intensities[0] - w).abs() / w;
        mean += err / weights.len() as f64;
        eprintln!(
            "robot tip {w} N: {:.4} N, error {:.3}%, sigma {:.4} N, I_w {:.2} N/m, updates {}",
            est.intensities[0],
            100.0 * err,
            est.sigma[0],
            est.i_w,
            est.updates
        );
        assert_eq!(est.status, softsense::markers::MarkersStatus::Converged);
        assert!(err * w < 4.0 * est.sigma[0], "{w} N: {:?}", est.intensities);
    }
    eprintln!("robot tip: mean error {:.3}%", 100.0 * mean);
    assert!(mean < 0.01, "mean error {mean}");
}

/// A small seeded generator for the trials (splitmix-style hashing of the scene's).
fn uniform(seed: u64, k: u64) -> f64 {
    softsense::scene::sensor::uniform(seed, 7, k, 0)
}

#[test]
fn forces_on_two_of_twelve_sheet_candidates_are_located_in_most_random_trials() {
    let m = model("sheet.toml");
    let cands: Vec<[f64; 3]> = grid(&[-60.0, -20.0, 20.0, 60.0], &[-40.0, 0.0, 40.0], 4.0);
    let s = sensor(&m, &sheet_markers(), &cands, Directions::Normal);
    let trials: u64 = 6;
    let mut right: u64 = 0;
    for t in 0..trials {
        // One or two distinct candidates, 0.3-0.6 N each, hanging along -z.
        let count = 1 + (uniform(t, 0) < 0.5) as usize;
        let mut truth = vec![[0.0; 3]; cands.len()];
        let mut chosen = Vec::new();
        let mut k = 1;
        while chosen.len() < count {
            let c = (uniform(t, k) * cands.len() as f64) as usize;
            k += 1;
            if !chosen.contains(&c) {
                chosen.push(c);
                truth[c] = [0.0, 0.0, -(0.3 + 0.3 * uniform(t, 100 + k))];
            }
        }
        chosen.sort_unstable();
        let est = s
            .solve_frame(t, &measure(&s, &truth, 70 + t), None)
            .unwrap();
        let mut found: Vec<usize> = locate_forces(&est, &s.candidates, &s.params)
            .iter()
            .flat_map(|l| l.candidates.clone())
            .collect();
        found.sort_unstable();
        eprintln!(
            "trial {t}: truth {chosen:?}, found {found:?}, I_w {:.1} N/m",
            est.i_w
        );
        right += (found == chosen) as u64;
    }
    eprintln!("located {right}/{trials}");
    assert!(right + 1 >= trials, "located {right} of {trials}");
}

#[test]
fn with_thirty_percent_of_markers_hidden_the_forces_stay_within_five_percent() {
    let s = sheet_with_two_candidates();
    let truth = [[0.0, 0.0, -0.459], [0.0, 0.0, -0.359]];
    let before = measure(&s, &truth, 90);
    let mut now = measure(&s, &truth, 91);
    // 7 of 25 markers lost and one swapped 20 mm away by the tracker: 8 hidden (32%).
    let lost = [1, 4, 7, 11, 15, 18, 22];
    for &i in &lost {
        now[i] = None;
    }
    let swapped = 12;
    now[swapped] = now[swapped].map(|p| [p[0] + 0.02, p[1], p[2]]);
    let tracks = softsense::markers::MarkerTracks {
        names: s.markers.iter().map(|m| m.name.clone()).collect(),
        frames: vec![
            softsense::markers::TrackFrame {
                frame: 0,
                positions: before,
            },
            softsense::markers::TrackFrame {
                frame: 1,
                positions: now.clone(),
            },
        ],
    };
    let flags = softsense::markers::tracks::flag_hidden(&tracks, &s.params);
    let measured: Vec<_> = now
        .iter()
        .zip(&flags[1])
        .map(|(p, h)| if *h { None } else { *p })
        .collect();
    let est = s.solve_frame(1, &measured, None).unwrap();
    let mut want: Vec<usize> = lost.to_vec();
    want.push(swapped);
    want.sort_unstable();
    assert_eq!(est.hidden, want, "hidden markers flagged");
    for (i, f) in truth.iter().enumerate() {
        let err = (est.forces[i][2] - f[2]).abs() / -f[2];
        eprintln!(
            "hidden 32%: force {i} error {:.3}%, sigma {:.4} N",
            100.0 * err,
            est.sigma[i]
        );
        assert!(err < 0.05);
    }
}

#[test]
fn the_markers_command_reads_a_track_file_and_prints_the_forces() {
    let s = sheet_with_two_candidates();
    let dir = tempfile::tempdir().unwrap();
    let truth = [[0.0, 0.0, -0.459], [0.0, 0.0, -0.359]];
    // Frame 0: the sheet under gravity alone (where the command binds the markers);
    // frame 1: the two weights hang.
    let frames = [measure(&s, &[[0.0; 3]; 2], 120), measure(&s, &truth, 121)];
    let tracks = softsense::markers::MarkerTracks {
        names: s.markers.iter().map(|m| m.name.clone()).collect(),
        frames: (frames.into_iter().enumerate())
            .map(|(k, positions)| softsense::markers::TrackFrame {
                frame: k as u64,
                positions,
            })
            .collect(),
    };
    let track_path = dir.path().join("tracks.csv");
    softsense::markers::tracks::write_tracks(&track_path, &tracks).unwrap();
    let cand_path = dir.path().join("candidates.csv");
    std::fs::write(
        &cand_path,
        "name,x,y,z,directions\nleft,-0.04,0,0.004,normal\nright,0.04,0,0.004,normal\n",
    )
    .unwrap();
    let (cand, track) = (cand_path.to_str().unwrap(), track_path.to_str().unwrap());
    let model = "meshes/models/sheet.toml";
    let out = crate::cli::softsense(&["markers", "--json", "--candidates", cand, track, model]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = (String::from_utf8(out.stdout).unwrap().lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    let forces = &lines[1]["forces_n"];
    for (i, f) in truth.iter().enumerate() {
        let z = forces[i][2].as_f64().unwrap();
        let sigma = lines[1]["sigma_n"][i].as_f64().unwrap();
        eprintln!(
            "cli: force {i} {z:.4} N against {:.3} N (sigma {sigma:.4})",
            f[2]
        );
        assert!((z - f[2]).abs() < 4.0 * sigma);
    }
    assert_eq!(lines[1]["located"].as_array().unwrap().len(), 2);
}

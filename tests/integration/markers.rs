//! Marker-based sensing end to end (thesis 4.6-4.7): the direct FE model makes the truth
//! (known forces at candidate nodes, marker positions with 0.1 mm Gaussian noise from a
//! seeded generator), the inverse model recovers the forces from the markers alone.
use crate::common::markers::*;

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

#[test]
fn forces_on_two_of_twelve_sheet_candidates_are_located_in_most_random_trials() {
    let s = sheet_with_twelve_candidates();
    let trials: u64 = 6;
    let mut right: u64 = 0;
    for t in 0..trials {
        let (chosen, found) = location_trial(&s, t);
        eprintln!("trial {t}: truth {chosen:?}, found {found:?}");
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
    // frames 1 and 2: the two weights hang (independent noise).
    let frames = [
        measure(&s, &[[0.0; 3]; 2], 120),
        measure(&s, &truth, 121),
        measure(&s, &truth, 122),
    ];
    let (track_path, cand_path) = write_inputs(
        &dir,
        &s,
        frames.to_vec(),
        "left,-0.04,0,0.004,normal\nright,0.04,0,0.004,normal\n",
    );
    let (cand, track) = (cand_path.to_str().unwrap(), track_path.to_str().unwrap());
    let model = "meshes/models/sheet.toml";
    let out = crate::cli::softsense(&["markers", "--json", "--candidates", cand, track, model]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = json_lines(&out.stdout);
    assert_eq!(lines.len(), 3);
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
    // Each force found at one candidate alone: nothing to refine.
    assert_eq!(lines[1]["refined"], serde_json::json!([null, null]));
    // Frame 2 with frame 1's rows stacked: twice the rows. The frames' own noise share of σ
    // is divided by about √2; the reference's (frame 0, where the markers are bound) is
    // common to both frames and stays. `--reference` on the track file itself binds at the
    // same frame 0 taken as exact: σ is then the frames' share alone.
    let run = |extra: &[&str]| {
        let mut args = vec!["markers", "--json", "--candidates", cand, track, model];
        args.extend_from_slice(extra);
        let out = crate::cli::softsense(&args);
        assert!(out.status.success(), "{}", crate::cli::stderr(&out));
        json_lines(&out.stdout)
    };
    let acc = run(&["--accumulate", "2"]);
    let own = run(&["--reference", track]);
    let own_acc = run(&["--reference", track, "--accumulate", "2"]);
    assert_eq!(acc[2]["rows"], 2 * lines[2]["rows"].as_u64().unwrap());
    let sigma = |v: &[serde_json::Value], i: usize| v[2]["sigma_n"][i].as_f64().unwrap();
    for (i, f) in truth.iter().enumerate() {
        let ratio = sigma(&own, i) / sigma(&own_acc, i);
        let reference = sigma(&lines, i).powi(2) - sigma(&own, i).powi(2);
        let reference_acc = sigma(&acc, i).powi(2) - sigma(&own_acc, i).powi(2);
        let z = acc[2]["forces_n"][i][2].as_f64().unwrap();
        eprintln!(
            "cli --accumulate 2: force {i} {z:.4} N, sigma {:.4} N (own noise 1 frame / 2: {ratio:.3}; reference share {:.4} / {:.4} N)",
            sigma(&acc, i),
            reference.sqrt(),
            reference_acc.sqrt()
        );
        assert!((ratio - 2f64.sqrt()).abs() < 0.02, "σ ratio {ratio}");
        assert!(reference > 0.0 && (reference_acc / reference - 1.0).abs() < 0.05);
        assert!((z - f[2]).abs() < 4.0 * sigma(&acc, i));
    }
    let zero = crate::cli::softsense(&["markers", "--accumulate", "0", track, model]);
    assert!(!zero.status.success());
    assert!(String::from_utf8_lossy(&zero.stderr).contains("--accumulate"));
}

/// A track file of `frames` (frame numbers 0, 1, ...) of the markers of `s` and a candidate
/// file of `candidate_lines` (CSV rows) in `dir`.
fn write_inputs(
    dir: &tempfile::TempDir,
    s: &softsense::markers::MarkerSensor,
    frames: Vec<Vec<Option<[f64; 3]>>>,
    candidate_lines: &str,
) -> (std::path::PathBuf, std::path::PathBuf) {
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
    let text = format!("name,x,y,z,directions\n{candidate_lines}");
    std::fs::write(&cand_path, text).unwrap();
    (track_path, cand_path)
}

fn json_lines(stdout: &[u8]) -> Vec<serde_json::Value> {
    (String::from_utf8_lossy(stdout).lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn the_markers_command_refines_a_force_found_at_two_neighbouring_candidates() {
    // Candidates 20 mm apart on the sheet's x axis, one 0.45 N weight at the node halfway
    // between them: both carry part of it, one located force, refined near the truth.
    let s = sheet_with_two_candidates();
    let mesh = &s.problem.mesh;
    let top = mesh.surface().nodes.into_iter().min_by(|&a, &b| {
        let d = |v: usize| {
            let p = mesh.nodes_in_rest[v];
            p[0].powi(2) + p[1].powi(2) + (p[2] - 0.004).powi(2)
        };
        d(a).total_cmp(&d(b))
    });
    let node = top.unwrap();
    let at = softsense::fem::solve::MappedPoint::node(node);
    let loads = |w: f64| {
        vec![softsense::fem::solve::PointLoad {
            at,
            force: [0.0, 0.0, -w],
        }]
    };
    let dir = tempfile::tempdir().unwrap();
    let frames = vec![
        measure_loads(&s, loads(0.0), 130),
        measure_loads(&s, loads(0.45), 131),
    ];
    let (track_path, cand_path) = write_inputs(
        &dir,
        &s,
        frames,
        "left,-0.01,0,0.004,normal\nright,0.01,0,0.004,normal\n",
    );
    let (cand, track) = (cand_path.to_str().unwrap(), track_path.to_str().unwrap());
    let out = crate::cli::softsense(&[
        "markers",
        "--json",
        "--candidates",
        cand,
        track,
        "meshes/models/sheet.toml",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = json_lines(&out.stdout);
    let located = lines[1]["located"].as_array().unwrap();
    assert_eq!(located.len(), 1, "{located:?}");
    assert_eq!(located[0]["candidates"].as_array().unwrap().len(), 2);
    let refined = &lines[1]["refined"][0];
    let c: Vec<f64> = (0..3)
        .map(|a| refined["centre"][a].as_f64().unwrap())
        .collect();
    let p = mesh.nodes_in_rest[node];
    let off = ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2)).sqrt();
    let fz = refined["force"][2].as_f64().unwrap();
    eprintln!(
        "cli refined: {:.1} mm off the truth, force {fz:.4} N against -0.45 N",
        1e3 * off
    );
    assert!(off <= 0.005, "refined {:.1} mm off", 1e3 * off);
    assert!((fz + 0.45).abs() < 0.05 * 0.45, "force {fz}");
}

#[test]
fn markers_layout_proposes_eight_robot_markers_and_writes_a_track_file() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("layout.csv");
    let out = crate::cli::softsense(&[
        "markers",
        "layout",
        "meshes/models/robot.toml",
        "--markers",
        "8",
        "--candidates",
        "meshes/models/robot_candidates.csv",
        "--json",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (greedy, last) = (
        v["i_w_greedy_n_per_m"].as_f64().unwrap(),
        v["i_w_n_per_m"].as_f64().unwrap(),
    );
    eprintln!("cli layout: I_w greedy {greedy:.2}, exchange {last:.2} N/m");
    assert!(last.is_finite() && last <= greedy);
    assert_eq!(v["nodes"].as_array().unwrap().len(), 8);
    let tracks = softsense::markers::tracks::read_tracks(&csv).unwrap();
    assert_eq!(tracks.names.len(), 8);
    let refused = crate::cli::softsense(&[
        "markers",
        "layout",
        "meshes/models/robot.toml",
        "--markers",
        "2",
        "--candidates",
        "meshes/models/robot_candidates.csv",
    ]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("Corollary 1"));
}

/// A force between two of the sheet's 12 candidates spreads over both; `refine_located`
/// moves it to the surface node that explains the markers best: within one 10 mm node
/// spacing of the truth, and never further off than the weighted centre it starts from.
#[test]
fn a_force_between_candidates_is_refined_to_within_one_node_of_the_truth() {
    use softsense::fem::solve::{MappedPoint, PointLoad};
    use softsense::markers::{locate_forces, refine_located, MarkersParams};
    let mut s = sheet_with_twelve_candidates();
    s.params = MarkersParams {
        group_radius: 0.06,
        ..Default::default()
    };
    let (a, b) = (s.locations[0].position, s.locations[1].position);
    let mesh = &s.problem.mesh;
    let top: Vec<usize> = (mesh.surface().nodes.iter().copied())
        .filter(|&v| mesh.nodes_in_rest[v][2] > 0.0039)
        .collect();
    let dist = |p: [f64; 3], q: [f64; 3]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
    // Halfway between the two candidates, and a quarter of the way.
    for (case, t) in [0.5, 0.25].into_iter().enumerate() {
        let goal = [0, 1, 2].map(|k| a[k] + t * (b[k] - a[k]));
        let node = (top.iter().copied())
            .min_by(|&u, &v| {
                let d = |w: usize| dist(mesh.nodes_in_rest[w], goal);
                d(u).total_cmp(&d(v))
            })
            .unwrap();
        let loads = vec![PointLoad {
            at: MappedPoint::node(node),
            force: [0.0, 0.0, -0.45],
        }];
        let measured = measure_loads(&s, loads, 900 + case as u64);
        let est = s.solve_frame(0, &measured, None).unwrap();
        let grid = locate_forces(&est, &s.locations, &s.params);
        let refined = refine_located(&s, &est, &measured, &grid).unwrap();
        let truth = mesh.nodes_in_rest[node];
        assert_eq!(
            (grid.len(), refined.len()),
            (1, 1),
            "case {case}: one force"
        );
        let (before, after) = (dist(grid[0].centre, truth), dist(refined[0].centre, truth));
        eprintln!(
            "case {case}: weighted centre {:.1} mm off, refined {:.1} mm",
            1e3 * before,
            1e3 * after
        );
        assert!(
            after <= 0.0101,
            "case {case}: refined {:.1} mm off",
            1e3 * after
        );
        assert!(
            after <= before + 1e-9,
            "case {case}: refined {after} > centre {before}"
        );
    }
}

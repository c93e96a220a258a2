//! The bundled marker recordings (`clouds/markers/`, made by `cargo run --example
//! make_marker_recordings`) through `softsense markers`: every loaded frame's forces are
//! located at the candidates that carried them, with the magnitudes of `truth.json`.
use serde_json::Value;

/// Runs `softsense markers --json` with `extra` arguments on `clouds/markers/<body>` and
/// returns, per loaded frame, the largest relative error of a loaded candidate's force, after
/// checking the located candidates against the truth and each force against its 4σ.
fn run_bundled(body: &str, model: &str, extra: &[&str], names: &[&str]) -> Vec<f64> {
    let tracks = format!("clouds/markers/{body}/tracks.csv");
    let mut args = vec!["markers", "--json", tracks.as_str(), model];
    args.extend_from_slice(extra);
    let out = crate::cli::softsense(&args);
    assert!(out.status.success(), "{}", crate::cli::stderr(&out));
    let frames: Vec<Value> = (String::from_utf8_lossy(&out.stdout).lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let truth_text =
        std::fs::read_to_string(root.join(format!("clouds/markers/{body}/truth.json")));
    let truth: Value = serde_json::from_str(&truth_text.unwrap()).unwrap();
    let truth = truth["frames"].as_array().unwrap();
    assert_eq!(frames.len(), truth.len(), "one output per recorded frame");
    let vec3 = |v: &Value| [0, 1, 2].map(|a| v[a].as_f64().unwrap());
    let norm = |v: [f64; 3]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
    let mut errors = Vec::new();
    for (got, want) in frames.iter().zip(truth) {
        let k = got["frame"].as_u64().unwrap();
        assert_eq!(got["status"], "Converged", "frame {k}");
        let mut loaded: Vec<(usize, [f64; 3])> = (want["forces"].as_array().unwrap().iter())
            .map(|f| {
                let name = f["candidate"].as_str().unwrap();
                let i = names.iter().position(|n| *n == name).unwrap();
                (i, vec3(&f["force_n"]))
            })
            .collect();
        loaded.sort_by_key(|l| l.0);
        let mut located: Vec<(usize, [f64; 3])> = (got["located"].as_array().unwrap().iter())
            .map(|l| {
                let c = l["candidates"].as_array().unwrap();
                assert_eq!(c.len(), 1, "frame {k}: a force at one candidate: {l}");
                (c[0].as_u64().unwrap() as usize, vec3(&l["force"]))
            })
            .collect();
        located.sort_by_key(|l| l.0);
        let found: Vec<usize> = located.iter().map(|l| l.0).collect();
        let truth_at: Vec<usize> = loaded.iter().map(|l| l.0).collect();
        assert_eq!(found, truth_at, "frame {k}: located candidates");
        if loaded.is_empty() {
            continue;
        }
        let mut worst = 0.0f64;
        for ((i, f), (_, l)) in loaded.iter().zip(&located) {
            let est = vec3(&got["forces_n"][*i]);
            let sigma = got["sigma_n"][*i].as_f64().unwrap();
            let err = norm([0, 1, 2].map(|a| est[a] - f[a])) / norm(*f);
            let err_located = norm([0, 1, 2].map(|a| l[a] - f[a])) / norm(*f);
            eprintln!(
                "{body} frame {k}: {} {:.4} N against {:.3} N, error {:.3}% (located {:.3}%), sigma {:.4} N ({:.2}%), I_w {:.1} N/m",
                names[*i],
                norm(est),
                norm(*f),
                100.0 * err,
                100.0 * err_located,
                sigma,
                100.0 * sigma / norm(*f),
                got["i_w_n_per_m"].as_f64().unwrap()
            );
            // The noise the solve itself predicts, whatever the line.
            assert!(
                err * norm(*f) < 4.0 * sigma,
                "frame {k}: {est:?} against {f:?}"
            );
            worst = worst.max(err);
        }
        errors.push(worst);
    }
    errors
}

/// The sheet's loaded candidates as `clouds/markers/sheet/candidates.csv` names them.
const SHEET_LOADED: [&str; 2] = ["c1", "c10"];

#[test]
fn the_bundled_sheet_recording_gives_table_4_4_weights_within_two_percent_at_known_locations() {
    let extra = ["--candidates", "clouds/markers/sheet/candidates.csv"];
    let errors = run_bundled("sheet", "meshes/models/sheet.toml", &extra, &SHEET_LOADED);
    assert_eq!(errors.len(), 6, "six loaded frames");
    // The line (each force within 2%) is for Table 4.4's 359-559 mN weights, frames
    // 2-6; frame 1 (180 mN, one σ about 2%) is held to 4σ only.
    for (k, err) in errors.iter().enumerate().skip(1) {
        assert!(*err < 0.02, "frame {}: error {err}", k + 1);
    }
}

#[test]
fn the_bundled_sheet_recording_locates_both_weights_among_the_twelve_bundled_candidates() {
    let names: Vec<String> = (0..12).map(|i| format!("c{i}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let extra = ["--candidates", "meshes/models/sheet_candidates.csv"];
    // Twelve unknowns from the same 75 rows: I_w is about ten times the two-candidate one,
    // so the magnitudes are held to their 4σ (checked in `run_bundled`), not to 2%.
    let errors = run_bundled("sheet", "meshes/models/sheet.toml", &extra, &names);
    assert_eq!(errors.len(), 6, "six loaded frames");
}

#[test]
fn the_bundled_robot_recording_gives_its_tip_weight_at_the_hook_in_every_frame() {
    // The model's force points (top-east and the tip hook) are the candidates. The issue's
    // 1% line is not asserted: one σ here is 1.7% of the 259 mN weight (see docs/markers.md).
    let names = ["top-east", "hook"];
    let errors = run_bundled("robot", "meshes/models/robot.toml", &[], &names);
    assert_eq!(errors.len(), 4, "four loaded frames");
}

#[test]
fn force_points_by_name_solve_the_robot_tip_weight_at_the_hook_alone() {
    // One unknown instead of two: σ falls from about 4.3 to 3.2-3.4 mN (2.6-2.8 mN of it the
    // frame's own noise, the rest the reference frame's). The 1% line is not asserted: one
    // σ of a frame's own noise is already 1.06% of 259 mN (docs/markers.md).
    let errors = run_bundled(
        "robot",
        "meshes/models/robot.toml",
        &["--force-points", "hook"],
        &["hook"],
    );
    assert_eq!(errors.len(), 4, "four loaded frames");
    let out = crate::cli::softsense(&[
        "markers",
        "clouds/markers/robot/tracks.csv",
        "meshes/models/robot.toml",
        "--force-points",
        "hock",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", crate::cli::stderr(&out));
    let err = crate::cli::stderr(&out);
    assert!(err.contains("\"hock\"") && err.contains("hook"), "{err}");
}

/// The hook's force along z and its σ per frame (N) from `softsense markers --json
/// --force-points hook` on the robot with `tracks` and `extra` arguments.
fn hook_forces(tracks: &str, extra: &[&str]) -> Vec<(f64, f64)> {
    let mut args = vec![
        "markers",
        "--json",
        tracks,
        "meshes/models/robot.toml",
        "--force-points",
        "hook",
    ];
    args.extend_from_slice(extra);
    let out = crate::cli::softsense(&args);
    assert!(out.status.success(), "{}", crate::cli::stderr(&out));
    (String::from_utf8_lossy(&out.stdout).lines())
        .map(|l| {
            let v: Value = serde_json::from_str(l).unwrap();
            let f = v["forces_n"][0][2].as_f64().unwrap();
            (f, v["sigma_n"][0].as_f64().unwrap())
        })
        .collect()
}

/// The robot's tip weights (N, along −z) in the loaded frames of its bundled recording.
const ROBOT_WEIGHTS: [f64; 4] = [0.259, 0.459, 0.659, 0.859];

#[test]
fn a_noisy_reference_frame_shifts_every_robot_estimate_alike_and_its_noise_is_in_sigma() {
    let noisy = hook_forces("clouds/markers/robot/tracks.csv", &[]);
    let exact = hook_forces(
        "clouds/markers/robot/tracks.csv",
        &["--reference", "clouds/markers/robot/markers_truth.csv"],
    );
    // Frame 0's tangential noise moves the markers' bound points: the same offset in every
    // later frame, so the loaded frames' estimates differ from the exact reference's by one
    // common bias (W_ef changes little with the load).
    let shifts: Vec<f64> = (noisy.iter().zip(&exact).skip(1))
        .map(|(n, e)| n.0 - e.0)
        .collect();
    let mean = shifts.iter().sum::<f64>() / shifts.len() as f64;
    for s in &shifts {
        assert!((s - mean).abs() < 0.1 * noisy[1].1, "{shifts:?}");
    }
    for (k, ((n, e), w)) in noisy
        .iter()
        .zip(&exact)
        .skip(1)
        .zip(ROBOT_WEIGHTS)
        .enumerate()
    {
        // The reference's share is in σ: larger than the exact reference's, by less than
        // √2 (one more frame's noise, of which binding keeps the tangential 2 of 3 axes).
        assert!(
            n.1 > 1.1 * e.1 && n.1 < 2f64.sqrt() * e.1,
            "frame {}: {n:?} {e:?}",
            k + 1
        );
        assert!(
            (e.0 + w).abs() < 4.0 * e.1,
            "frame {}: {e:?} against {w}",
            k + 1
        );
    }
}

/// The bundled robot recording rebuilt from its exact positions (`markers_truth.csv`)
/// with `unloaded` noisy copies of the unloaded frame ahead of the loaded ones, 0.1 mm
/// noise from `seed`; returns the track file's path.
fn robot_with_unloaded_frames(dir: &std::path::Path, unloaded: usize, seed: u64) -> String {
    use softsense::markers::tracks::{read_tracks, write_tracks};
    use softsense::markers::TrackFrame;
    use softsense::math::rand::normal;
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let exact = read_tracks(&root.join("clouds/markers/robot/markers_truth.csv")).unwrap();
    let mut out = exact.clone();
    let sources = std::iter::repeat_n(&exact.frames[0], unloaded).chain(&exact.frames[1..]);
    out.frames = (sources.enumerate())
        .map(|(k, f)| TrackFrame {
            frame: k as u64,
            positions: (f.positions.iter().enumerate())
                .map(|(m, p)| {
                    let p = p.unwrap();
                    Some(
                        [0, 1, 2].map(|a| p[a] + 1e-4 * normal(seed, k as u64, m as u64, a as u64)),
                    )
                })
                .collect(),
        })
        .collect();
    let path = dir.join("tracks.csv");
    write_tracks(&path, &out).unwrap();
    path.display().to_string()
}

#[test]
fn the_mean_of_ten_unloaded_frames_is_the_reference_with_a_tenth_of_its_noise_in_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = robot_with_unloaded_frames(dir.path(), 10, 3601);
    let one = hook_forces(&tracks, &[]);
    let ten = hook_forces(&tracks, &["--reference-frames", "10"]);
    let exact = hook_forces(
        &tracks,
        &["--reference", "clouds/markers/robot/markers_truth.csv"],
    );
    assert_eq!(ten.len(), 14);
    for (k, w) in ROBOT_WEIGHTS.iter().enumerate() {
        let i = 10 + k;
        // σ² = σ_exact² + v σ_ref²: v is 1 for one reference frame, 1/10 for ten.
        let (s1, s10, s0) = (one[i].1.powi(2), ten[i].1.powi(2), exact[i].1.powi(2));
        let tenth = (s10 - s0) / (s1 - s0);
        assert!((tenth - 0.1).abs() < 0.01, "frame {i}: {tenth}");
        assert!(
            (ten[i].0 + w).abs() < 4.0 * ten[i].1,
            "frame {i}: {:?}",
            ten[i]
        );
    }
}

#[test]
fn tracks_in_a_tracker_frame_give_the_robot_frame_forces_through_markers_calibrate() {
    use softsense::markers::tracks::{read_tracks, write_tracks};
    use softsense::math::{Iso3, Point3, Vec3};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let robot = read_tracks(&root.join("clouds/markers/robot/tracks.csv")).unwrap();
    let tracker_from_robot = Iso3::new(Vec3::new(0.3, -1.2, 0.8), Vec3::new(0.4, -1.1, 2.0));
    let mut tracker = robot.clone();
    for p in tracker
        .frames
        .iter_mut()
        .flat_map(|f| f.positions.iter_mut().flatten())
    {
        *p = (tracker_from_robot * Point3::from(*p)).coords.into();
    }
    let dir = tempfile::tempdir().unwrap();
    let tracks = dir.path().join("tracker.csv");
    write_tracks(&tracks, &tracker).unwrap();
    let calibration = dir.path().join("tracker.json");
    let (tracks, calibration) = (tracks.to_str().unwrap(), calibration.to_str().unwrap());
    let out = crate::cli::softsense(&[
        "markers",
        "calibrate",
        tracks,
        "meshes/models/robot.toml",
        "--positions",
        "clouds/markers/robot/markers_truth.csv",
        "--out",
        calibration,
    ]);
    assert!(out.status.success(), "{}", crate::cli::stderr(&out));
    let text = std::fs::read_to_string(calibration).unwrap();
    let c: Value = serde_json::from_str(&text).unwrap();
    // 16 markers with 0.1 mm noise per coordinate: the residual is the noise's,
    // 0.1 mm * sqrt(3 * 42 / 48) = 0.16 mm RMS (6 of the 48 coordinates absorbed by the fit).
    let rms = c["residual_rms_m"].as_f64().unwrap();
    assert!(rms > 0.6 * 1.62e-4 && rms < 1.4 * 1.62e-4, "{rms}");
    // The fitted transform puts the exact rest positions back within the fit's noise: its
    // 6 parameters from 48 coordinates leave σ sqrt(6/16) = 0.06 mm RMS over the markers
    // (the tracker's origin is 1.5 m away, so its own translation carries the rotation's
    // error and is not compared alone).
    let m: Vec<Vec<f64>> = (0..4)
        .map(|r| {
            (0..4)
                .map(|k| c["robot_from_tracker"][r][k].as_f64().unwrap())
                .collect()
        })
        .collect();
    let exact = read_tracks(&root.join("clouds/markers/robot/markers_truth.csv")).unwrap();
    let rest: Vec<[f64; 3]> = exact.frames[0]
        .positions
        .iter()
        .flatten()
        .copied()
        .collect();
    let sq: f64 = (rest.iter())
        .map(|p| {
            let t = tracker_from_robot * Point3::from(*p);
            (0..3)
                .map(|r| (m[r][0] * t.x + m[r][1] * t.y + m[r][2] * t.z + m[r][3] - p[r]).powi(2))
                .sum::<f64>()
        })
        .sum();
    let rms_back = (sq / rest.len() as f64).sqrt();
    assert!(rms_back < 2.0 * 1e-4 * (6.0f64 / 16.0).sqrt(), "{rms_back}");
    eprintln!("residual RMS {rms:.6} m, rest positions mapped back within {rms_back:.6} m RMS");
    let direct = hook_forces("clouds/markers/robot/tracks.csv", &[]);
    let mapped = hook_forces(tracks, &["--calibration", calibration]);
    for (k, (d, m)) in direct.iter().zip(&mapped).enumerate() {
        // The calibration absorbs the rigid part of frame 0's noise: its error is one rigid
        // offset in every frame, a common shift (3.5 mN here), and its share is in σ.
        let share = (m.1 * m.1 - d.1 * d.1).sqrt();
        assert!(share > 0.3 * d.1, "frame {k}: {d:?} against {m:?}");
        assert!(
            (d.0 - m.0).abs() < 3.0 * share,
            "frame {k}: {d:?} against {m:?}"
        );
    }
    // Without the calibration the tracker-frame markers are nowhere near the model.
    let out = crate::cli::softsense(&["markers", tracks, "meshes/models/robot.toml"]);
    assert!(!out.status.success());
}

#[test]
fn markers_render_writes_one_picture_per_frame_of_two_panels() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("pictures");
    let out = crate::cli::softsense(&[
        "markers",
        "clouds/markers/robot/tracks.csv",
        "meshes/models/robot.toml",
        "--force-points",
        "hook",
        "--render",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", crate::cli::stderr(&out));
    let mut files: Vec<String> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let want: Vec<String> = (0..5).map(|k| format!("frame_{k:04}.png")).collect();
    assert_eq!(files, want);
    for f in &files {
        let c = softsense::render::Canvas::from_png(out_dir.join(f)).unwrap();
        // Two 480 x 400 panels 8 pixels apart under a 28-pixel title band.
        assert_eq!((c.width(), c.height()), (968, 428), "{f}");
        // Something is drawn: the force arrow's red in every loaded frame.
        let red = (c.pixels().iter())
            .filter(|p| **p == softsense::render::FORCE)
            .count();
        assert!(f == "frame_0000.png" || red > 50, "{f}: {red} force pixels");
    }
}

/// On the SOFA finger (three candidates along a cantilever, 5σ of 1-7 N against 0.14-0.5 N
/// loads) every loaded frame located nothing and said nothing. A frame that locates no
/// force now says, per candidate, the smallest force it would have found; a frame that
/// locates one does not.
#[test]
fn a_frame_that_locates_no_force_says_how_large_a_force_could_go_unseen() {
    let args = [
        "markers",
        "--json",
        "clouds/markers/robot/tracks.csv",
        "meshes/models/robot.toml",
    ];
    let out = crate::cli::softsense(&args);
    assert!(out.status.success(), "{}", crate::cli::stderr(&out));
    let frames: Vec<Value> = (String::from_utf8_lossy(&out.stdout).lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let unseen = |f: &Value| {
        (f["warnings"].as_array().unwrap().iter())
            .filter_map(Value::as_str)
            .find(|w| w.starts_with("no force located"))
            .map(str::to_string)
    };
    // Frame 0 is the unloaded reference: nothing located, both candidates' limits named.
    assert!(frames[0]["located"].as_array().unwrap().is_empty());
    let w = unseen(&frames[0]).expect("frame 0 says what it could not see");
    assert!(w.contains("hook ") && w.contains("top-east "), "{w}");
    for f in &frames[1..] {
        assert!(!f["located"].as_array().unwrap().is_empty(), "{f}");
        assert_eq!(unseen(f), None, "{f}");
    }
}

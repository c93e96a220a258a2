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
    // One unknown instead of two: σ falls from about 4.3 to 2.6-2.8 mN. The 1% line is still
    // not asserted (measured 3.7, 1.6, 0.6, 0.5% at 259-859 mN; docs/markers.md).
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

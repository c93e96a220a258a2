//! `softsense catheter`: a short run of a bundled scenario writes its files and pictures;
//! bad files are refused with their name and field.

use crate::cli::{assert_fails, softsense};
use crate::common::project_root;

#[test]
fn a_short_catheter_run_writes_steps_run_and_both_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(project_root().join("scenarios/catheter/tracking_2.4.toml"))
        .unwrap()
        .replace("end_mm = 150", "end_mm = 3");
    let scenario = dir.path().join("short.toml");
    std::fs::write(&scenario, text).unwrap();
    let out = dir.path().join("out");
    let o = softsense(&[
        "catheter",
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("tracking error"), "{stdout}");
    for f in ["steps.csv", "run.json", "path.png", "errors.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    // 3 mm at 2.4 mm/s and 20 Hz: 25 steps and the first.
    assert_eq!(csv.lines().count(), 1 + 26, "{csv}");
}

#[test]
fn a_catheter_scenario_with_a_bad_field_or_no_file_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(project_root().join("scenarios/catheter/tracking_2.4.toml"))
        .unwrap()
        .replace("diameter_mm = 28", "diameter_mm = 6");
    std::fs::write(&bad, text).unwrap();
    let o = softsense(&["catheter", bad.to_str().unwrap()]);
    assert_fails(&o, 1, &["bad.toml", "tube.diameter_mm"]);
    let o = softsense(&["catheter", "scenarios/catheter/nothing.toml"]);
    assert_fails(&o, 1, &["nothing.toml"]);
}

#[test]
fn statics_prints_one_row_per_insertion_and_refuses_zero_positions() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(project_root().join("scenarios/catheter/insertions_3d.toml"))
            .unwrap()
            .replace("end_mm = 160", "end_mm = 30");
    let scenario = dir.path().join("short.toml");
    std::fs::write(&scenario, text).unwrap();
    let o = softsense(&["catheter", scenario.to_str().unwrap(), "--statics", "3"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}");
    // Straight in the tube's first straight: model and robot are both straight.
    for d in ["10.0", "20.0", "30.0"] {
        assert!(
            stdout.lines().any(|l| l.trim_start().starts_with(d)
                && l.contains("0.000")
                && l.ends_with("yes")),
            "no row for {d} mm: {stdout}"
        );
    }
    assert!(
        stdout.contains("model tip error: mean 0.000 mm"),
        "{stdout}"
    );
    let o = softsense(&["catheter", scenario.to_str().unwrap(), "--statics", "0"]);
    assert_fails(&o, 1, &["count must be > 0"]);
}

#[test]
fn a_short_coupled_run_in_a_straight_tube_tracks_with_an_unrotated_jacobian() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("straight.toml");
    let text = r#"
[tube]
pieces = [{ kind = "straight", length_mm = 100 }]
[insertion]
speed_mm_per_s = 2.4
end_mm = 5
[controller]
rotation_check_every = 10
"#;
    std::fs::write(&scenario, text).unwrap();
    let path = scenario.to_str().unwrap();
    let o = softsense(&["catheter", path, "--scheme", "coupled"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}");
    // Free of the wall, the free model's J is the robot's: the margin is near 1.
    let margin: f64 = (stdout.lines())
        .find_map(|l| l.split("sym(J_true J^+) ").nth(1))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("no margin: {stdout}"));
    assert!(margin > 0.5, "{stdout}");
    // A ramp under a P law lags by v / (K_P rate) = 0.6 mm; the tracker adds 0.1 mm noise.
    let max: f64 = (stdout.lines())
        .find_map(|l| l.split("max ").nth(1))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("no max: {stdout}"));
    assert!(max < 1.0, "{stdout}");
    // Antagonistic pairs need an even number of cables.
    std::fs::write(&scenario, format!("{text}\n[catheter]\ncables = 3\n")).unwrap();
    let o = softsense(&["catheter", path, "--scheme", "coupled"]);
    assert_fails(&o, 1, &["straight.toml", "catheter.cables"]);
}

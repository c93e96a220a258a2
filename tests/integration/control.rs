//! Control on the bundled robot against a simulated plant: short runs of the bundled
//! scenarios (the full ones are in the acceptance tier), and `softsense control`'s files
//! and errors.

use crate::cli::{assert_fails, softsense};
use crate::common::project_root;
use softsense::control::run::{run, RunStatus};
use softsense::control::scenario::Scenario;

fn scenario(name: &str, steps: usize) -> Scenario {
    let path = project_root().join("scenarios/control").join(name);
    let mut s = Scenario::load(&path).unwrap();
    s.steps = steps;
    s
}

#[test]
fn closed_loop_positioning_settles_within_half_a_millimetre_where_open_loop_does_not() {
    let closed = run(&scenario("positioning.toml", 60), &mut |_, _| {}).unwrap();
    assert_eq!(closed.status, RunStatus::Completed);
    let open = run(&scenario("positioning_open.toml", 60), &mut |_, _| {}).unwrap();
    assert!(
        closed.summary.settled_error_mm < 0.5,
        "{:?}",
        closed.summary
    );
    assert!(
        open.summary.settled_error_mm > 2.0 * closed.summary.settled_error_mm,
        "open {:?} closed {:?}",
        open.summary,
        closed.summary
    );
}

#[test]
fn theorem_two_inside_the_bound_converges_and_outside_runs_away() {
    let inside = run(&scenario("theorem2_inside.toml", 40), &mut |_, _| {}).unwrap();
    let bound = inside.summary.gain_bound.expect("gamma below 1");
    assert!(inside.scenario.controller.gain < bound);
    assert_eq!(inside.status, RunStatus::Completed);
    assert!(
        inside.summary.settled_error_mm < 0.5,
        "{:?}",
        inside.summary
    );
    let outside = run(&scenario("theorem2_outside.toml", 40), &mut |_, _| {}).unwrap();
    assert!(outside.scenario.controller.gain > bound);
    let ran_away = outside.status != RunStatus::Completed || outside.summary.settled_error_mm > 5.0;
    assert!(ran_away, "{:?} {:?}", outside.status, outside.summary);
}

#[test]
fn control_writes_the_trajectory_the_run_and_three_pictures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = softsense(&[
        "control",
        "scenarios/control/switched.toml",
        "--steps",
        "12",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count(), 13, "a header and one row per step");
    assert!(csv.lines().next().unwrap().contains("model_input_3,switch"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(json["steps"].as_array().unwrap().len(), 12);
    for png in ["error.png", "path.png", "inputs.png"] {
        assert!(image::open(out.join(png)).is_ok(), "{png}");
    }
}

#[test]
fn a_bad_scenario_is_refused_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(project_root().join("scenarios/control/switched.toml"))
        .unwrap()
        .replace("switch_rate = 0.5", "switch_rate = 1.5")
        .replace(
            "../../meshes",
            project_root().join("meshes").to_str().unwrap(),
        );
    std::fs::write(&bad, text).unwrap();
    let o = softsense(&["control", bad.to_str().unwrap()]);
    assert_fails(&o, 1, &["bad.toml", "switch_rate"]);
    let o = softsense(&["control", "scenarios/control/nothing.toml"]);
    assert_fails(&o, 1, &["nothing.toml"]);
}

/// The positioning scenario with `from` replaced by `to`, written into `dir` with its model
/// path made absolute.
fn edited_positioning(dir: &std::path::Path, from: &str, to: &str) -> std::path::PathBuf {
    let text =
        std::fs::read_to_string(project_root().join("scenarios/control/positioning.toml")).unwrap();
    assert!(text.contains(from), "{from:?}");
    let path = dir.join("edited.toml");
    let meshes = project_root().join("meshes");
    let text = text
        .replace(from, to)
        .replace("../../meshes", meshes.to_str().unwrap());
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn each_out_of_range_field_is_named_with_its_file_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let task = "kind = \"position\"\noffset_mm = [8.0, -6.0, -8.0]";
    let circle = |w: &str| format!("kind = \"circle\"\nradius_mm = 5.0\n{w}");
    let cases: Vec<(&str, String, &[&str])> = vec![
        (
            "young_factor = 1.15",
            "young_factor = -1.0".into(),
            &["plant.young_factor", "positive", "-1"],
        ),
        (
            "young_factor = 1.15",
            "young_factor = nan".into(),
            &["plant.young_factor", "NaN"],
        ),
        (
            "gain = 0.3",
            "gain = inf".into(),
            &["controller.gain", "inf"],
        ),
        (
            "latency = 1",
            "latency = 1000".into(),
            &["sensor.latency", "0..=100", "1000"],
        ),
        (
            "initial = 10.0 ",
            "initial = 1e9 ".into(),
            &["controller.initial", "outside the limits"],
        ),
        (
            "steps = 150",
            "steps = 0".into(),
            &["steps", "1..=100000", "got 0"],
        ),
        (
            task,
            "kind = \"position\"\noffset_mm = [inf, 0.0, 0.0]".into(),
            &["task.offset_mm", "finite", "inf"],
        ),
        (
            task,
            circle("rad_per_step = 1e300"),
            &["task.rad_per_step", "π rad a step", "1e300"],
        ),
        (
            task,
            circle("rad_per_s = 1000.0"),
            &["task.rad_per_s", "π rad a step"],
        ),
        (task, circle(""), &["task", "rad_per_s", "rad_per_step"]),
    ];
    for (from, to, needles) in cases {
        let path = edited_positioning(dir.path(), from, &to);
        let err = Scenario::load(&path).expect_err(&to).to_string();
        assert!(err.contains("edited.toml"), "{to}: {err}");
        for n in needles {
            assert!(err.contains(n), "{to}: {err} lacks {n:?}");
        }
    }
}

#[test]
fn a_plant_too_soft_to_solve_names_its_young_factor() {
    let dir = tempfile::tempdir().unwrap();
    let path = edited_positioning(dir.path(), "young_factor = 1.15", "young_factor = 1e-6");
    let o = softsense(&["control", path.to_str().unwrap(), "--steps", "3"]);
    assert_fails(&o, 1, &["edited.toml", "plant.young_factor = 0.000001"]);
}

//! Shared helpers for the test binaries: real-data location and skip policy.
#![allow(dead_code)]

pub mod bags;
pub mod batch;
pub mod catheter_tet;
pub mod corpus;
pub mod docs;
pub mod fem;
pub mod markers;
pub mod markers_painted;
pub mod markers_sensitivity;
pub mod markers_sofa;
pub mod membrane;
pub mod oracle;

use std::path::PathBuf;

/// Reports a skipped test on the process's stderr handle. libtest captures `eprintln!`
/// of passing tests, which would hide the reason; writing to the handle does not, so every
/// skip shows in a plain `cargo test` run.
///
/// The line is `SKIPPED <test>: <why> [<libtest name>]`: libtest names each test's thread
/// after the test, and `.ci/run` re-runs exactly the tests so named with the data and the
/// oracles, rather than every test twice.
pub fn skipped(test: &str, why: &str) {
    use std::io::Write;
    let thread = std::thread::current();
    let name = thread.name().unwrap_or("unnamed thread");
    let _ = writeln!(std::io::stderr().lock(), "SKIPPED {test}: {why} [{name}]");
}

/// Runs a project Python tool on the real data: `python3 TOOL ARGS...` with `SOFTSENSE_DATA`
/// set, after checking that `file` (relative to the data folder) exists and that python3
/// imports `modules` (e.g. "cv2, numpy"). `None` (with the skip said) when the data folder
/// is unset or python3 lacks a module; panics when the data is set but `file` is missing, or
/// the tool fails.
pub fn run_data_tool(
    test: &str,
    file: &str,
    modules: &str,
    tool: &str,
    args: &[&std::ffi::OsStr],
) -> Option<std::process::Output> {
    use std::process::Command;
    let data = data_dir(test)?;
    assert!(
        data.join(file).exists(),
        "SOFTSENSE_DATA is set but {file} is missing"
    );
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        skipped(test, &format!("python3 with {modules} is not available"));
        return None;
    }
    let out = Command::new("python3")
        .arg(project_root().join(tool))
        .args(args)
        .env("SOFTSENSE_DATA", &data)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{tool}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(out)
}

/// The real third-party data folder from `SOFTSENSE_DATA`.
///
/// - unset: prints why the calling test is skipped and returns `None`;
/// - set but missing (or not a directory): panics, because CI asked for the data.
pub fn data_dir(test: &str) -> Option<PathBuf> {
    match std::env::var_os("SOFTSENSE_DATA") {
        None => {
            skipped(
                test,
                "SOFTSENSE_DATA is not set (the real-data folder: see docs/testing.md)",
            );
            None
        }
        Some(dir) => {
            let dir = PathBuf::from(dir);
            assert!(
                dir.is_dir(),
                "SOFTSENSE_DATA={} is set but is not a directory",
                dir.display()
            );
            Some(dir)
        }
    }
}

/// A file under `SOFTSENSE_DATA`; `None` (with a skip message) when the variable is
/// unset, a panic when it is set and the file is missing.
pub fn data_file(test: &str, rel: &str) -> Option<PathBuf> {
    let path = data_dir(test)?.join(rel);
    assert!(
        path.exists(),
        "SOFTSENSE_DATA is set but {} is missing",
        path.display()
    );
    Some(path)
}

/// Every `.pcd` file below `dir` (recursively), sorted.
pub fn pcd_files_under(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("readable data dir") {
            let p = entry.expect("dir entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "pcd") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The project root (for fixtures under `tests/`, `clouds/`, `meshes/`).
pub fn project_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The bundled two-camera scene (`clouds/scenes/two_cameras.toml`) with its cameras at
/// 640x480 divided by `shrink` (the same field of view).
#[allow(dead_code)]
pub fn two_camera_scene(shrink: u32) -> softsense::scene::Scene {
    let path = project_root().join("clouds/scenes/two_cameras.toml");
    let mut scene = softsense::scene::Scene::load(&path).unwrap();
    let k = f64::from(shrink);
    for c in &mut scene.spec.cameras {
        let s = &mut c.camera;
        (s.width, s.height) = (640 / shrink, 480 / shrink);
        (s.fx, s.fy) = (s.fx / k, s.fy / k);
        (s.cx, s.cy) = (
            f64::from(s.width) / 2.0 - 0.5,
            f64::from(s.height) / 2.0 - 0.5,
        );
    }
    scene
}

/// Copies files of the bundled scene `clouds/scenes/<scene>` into `dir`, each pair
/// `(name there, name in dir)`: a recording made of chosen frames, or of frames mixed
/// from two scenes.
pub fn copy_scene_files(scene: &str, files: &[(&str, &str)], dir: &std::path::Path) {
    let src = project_root().join("clouds/scenes").join(scene);
    for (from, to) in files {
        std::fs::copy(src.join(from), dir.join(to)).unwrap();
    }
}

/// A temporary folder holding copies of `names` from the bundled scene `scene`.
pub fn scene_copy(scene: &str, names: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let pairs: Vec<(&str, &str)> = names.iter().map(|n| (*n, *n)).collect();
    copy_scene_files(scene, &pairs, dir.path());
    dir
}

/// A bundled scene (`clouds/scenes/<scene>`) and a sensor for it with `params`.
pub fn bundled(
    scene: &str,
    params: softsense::sense::SenseParams,
) -> (softsense::sense::Recording, softsense::sense::Sensor) {
    let rec = softsense::sense::Recording::open(&project_root().join("clouds/scenes").join(scene))
        .unwrap();
    let sensor = sensor_for(&rec, params);
    (rec, sensor)
}

/// A sensor for `rec` with its own model file and pose, and `params`.
pub fn sensor_for(
    rec: &softsense::sense::Recording,
    params: softsense::sense::SenseParams,
) -> softsense::sense::Sensor {
    let model = softsense::fem::model::Model::load(&rec.model_path().unwrap(), None).unwrap();
    softsense::sense::Sensor::new(model, rec.robot_from_camera.unwrap(), params)
}

/// Generates the scene whose TOML body follows `model = "<the bundled robot>"` into a
/// temporary folder and opens it as a recording; the folder lives as long as the guard.
pub fn generated_recording(body: &str) -> (tempfile::TempDir, softsense::sense::Recording) {
    let dir = tempfile::tempdir().unwrap();
    let model = project_root().join("meshes/models/robot.toml");
    let toml = format!("model = {:?}\n{body}", model.display().to_string());
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, toml).unwrap();
    let scene = softsense::scene::Scene::load(&scene_path).unwrap();
    let out = dir.path().join("frames");
    softsense::scene::generate(&scene, &out, |_, _| {}).unwrap();
    let rec = softsense::sense::Recording::open(&out).unwrap();
    (dir, rec)
}

/// The largest difference between two forces' components (N).
pub fn largest_component_gap(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).fold(0.0f64, |m, k| m.max((a[k] - b[k]).abs()))
}

/// Sends SIGTERM to `child` as soon as `ready()` holds (polled for up to a minute) and
/// waits for it: whether the signal was sent, and how the child ended. A run that ends
/// before `ready()` holds gets no signal.
#[cfg(unix)]
pub fn terminate_when(
    mut child: std::process::Child,
    ready: impl Fn() -> bool,
) -> (bool, std::process::ExitStatus) {
    let started = std::time::Instant::now();
    let mut signalled = false;
    while started.elapsed() < std::time::Duration::from_secs(60) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if ready() {
            let kill = std::process::Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status()
                .unwrap();
            signalled = kill.success();
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    (signalled, child.wait().unwrap())
}

/// Runs the `softsense` binary with `args` and returns its output.
pub fn run_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .output()
        .expect("the softsense binary runs")
}

/// Generates a one-frame probe scene (sensor noise on, scene `seed`) with the probe at `at`
/// pushing with `force`, and senses it with `params`.
pub fn sense_generated(
    seed: u64,
    at: [f64; 3],
    force: [f64; 3],
    params: softsense::sense::SenseParams,
) -> (
    softsense::sense::FrameReport,
    Vec<softsense::sense::LoadError>,
) {
    let (_dir, rec) = generated_recording(&format!(
        "seed = {seed}\n\n[sensor]\nenabled = true\ndepth_k = 0.002\ncolor_sigma = 3.0\n\n\
         [[frames]]\n[[frames.loads]]\nkind = \"probe\"\nat = {at:?}\nforce = {force:?}\n"
    ));
    let sensor = sensor_for(&rec, params);
    let obs = sensor.observe(&rec, 0).unwrap();
    let report = sensor.sense(0, &obs, rec.inputs_of(0).as_ref());
    let errors = softsense::sense::compare(&report, rec.truth_of(0).unwrap());
    (report, errors)
}

//! `softsense markers` and `sense` on a rig given bad input (issue 52 items 4, 5 and their
//! messages of item 6): each case the fuzzing found, and the key words of each message.

use crate::common::{project_root, run_cli};
use softsense::recording::Rig;
use softsense::sense::{CameraFrames, CameraState, FrameStatus, SenseParams, Sensor};
use std::path::{Path, PathBuf};

/// Each new message: (name, exit code, key words it must hold). The file names are the
/// cases' own (`tracks.csv`, `cand.csv`, ...); exit code 0 is a warning.
pub const MESSAGES: &[(&str, i32, &[&str])] = &[
    (
        "reference frames beyond the file",
        2,
        &[
            "tracks.csv",
            "--reference-frames 100",
            "3 frames",
            "unloaded",
        ],
    ),
    (
        "a loaded reference frame",
        2,
        &[
            "tracks.csv",
            "--reference-frames 3",
            "frame 1 is loaded",
            "--reference-frames 1",
            "--sigma-mm",
        ],
    ),
    (
        "a candidate off the surface",
        1,
        &[
            "cand.csv",
            "far (line 4",
            "off the model's surface",
            "metres in the model frame",
        ],
    ),
    (
        "a header-only tracks file",
        1,
        &["tracks.csv", "no frames", "markers detect"],
    ),
    (
        "a header-only candidates file",
        1,
        &["cand.csv", "no candidates", "name,x,y,z,directions"],
    ),
    (
        "an unknown Motive length unit",
        1,
        &[
            "take.csv",
            "Length Units \"Furlongs\"",
            "Millimeters",
            "Inches",
        ],
    ),
    (
        "calibrate with mismatched names",
        1,
        &[
            "tracks.csv",
            "layout.csv",
            "0 markers are in both",
            "m0, m1",
            "n0, n1",
            "name the markers alike",
        ],
    ),
    (
        "a model without force points",
        2,
        &[
            "model.toml",
            "no force points",
            "--candidates",
            "[[force_points]]",
        ],
    ),
    (
        "a symlinked camera folder",
        0,
        &[
            "cameras front and front_link are the same folder",
            "read once",
        ],
    ),
    (
        "a rig camera that sees no robot",
        0,
        &[
            "camera side",
            "no point in the box around the robot",
            "check the camera pose",
            "other cameras alone",
        ],
    ),
];

/// The key words of the message `name` in [`MESSAGES`], with its exit code.
fn message(name: &str) -> (i32, &'static [&'static str]) {
    let (_, code, words) = MESSAGES.iter().find(|(n, ..)| *n == name).unwrap();
    (*code, words)
}

/// Asserts that `text` holds every key word of the message `name`.
fn assert_words(name: &str, text: &str) {
    for w in message(name).1 {
        assert!(text.contains(w), "{name}: {w:?} not in {text}");
    }
}

/// Runs the CLI with `args` and checks the exit code and key words of the message `name`.
fn assert_cli(name: &str, args: &[&str]) {
    let out = run_cli(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(message(name).0), "{name}: {err}");
    assert_words(name, &err);
    assert!(out.stdout.is_empty() || message(name).0 == 0, "{name}");
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The bundled sheet recording's tracks cut to frames `0..frames` (frame 0 unloaded, the
/// others loaded), written to `dir/tracks.csv`.
fn sheet_tracks(dir: &Path, frames: usize) -> PathBuf {
    let text =
        std::fs::read_to_string(project_root().join("clouds/markers/sheet/tracks.csv")).unwrap();
    let kept: Vec<&str> = (text.lines())
        .filter(|l| match l.split(',').next().unwrap().parse::<usize>() {
            Ok(f) => f < frames,
            Err(_) => true,
        })
        .collect();
    let out = dir.join("tracks.csv");
    std::fs::write(&out, kept.join("\n") + "\n").unwrap();
    out
}

fn sheet_model() -> PathBuf {
    project_root().join("meshes/models/sheet.toml")
}

fn sheet_candidates() -> PathBuf {
    project_root().join("clouds/markers/sheet/candidates.csv")
}

/// `softsense markers TRACKS sheet.toml EXTRA...` gives the message `name`.
fn assert_on_sheet(name: &str, tracks: &Path, extra: &[&str]) {
    let model = sheet_model();
    let mut args = vec!["markers", path(tracks), path(&model)];
    args.extend(extra);
    assert_cli(name, &args);
}

/// [`assert_on_sheet`] with `--candidates cand.csv` holding `text`, next to `tracks`.
fn assert_with_candidates(name: &str, tracks: &Path, text: &str) {
    let cand = tracks.with_file_name("cand.csv");
    std::fs::write(&cand, text).unwrap();
    assert_on_sheet(name, tracks, &["--candidates", path(&cand)]);
}

/// `--reference-frames 100` on a 3-frame file averaged the loaded frames 1 and 2 into the
/// reference without a word, and frame 0's force flipped sign.
#[test]
fn reference_frames_100_on_a_3_frame_file_averaged_its_loaded_frames_into_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = sheet_tracks(dir.path(), 3);
    let candidates = sheet_candidates();
    let run = |n: &str, name: &str| {
        let extra = ["--candidates", path(&candidates), "--reference-frames", n];
        assert_on_sheet(name, &tracks, &extra)
    };
    run("100", "reference frames beyond the file");
    // As many frames as there are is no better when some are loaded.
    run("3", "a loaded reference frame");
}

/// A candidate 3 m off the body was snapped to a surface node and reported found there.
#[test]
fn a_candidate_3_m_off_the_body_was_snapped_to_a_node_and_reported_found_there() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = sheet_tracks(dir.path(), 2);
    let text = std::fs::read_to_string(sheet_candidates()).unwrap();
    let text = text + "far,3.0,0.0,0.004,normal\n";
    assert_with_candidates("a candidate off the surface", &tracks, &text);
}

/// A header-only tracks file (`markers detect` writes one when it finds nothing) exited 0
/// and printed nothing; a header-only candidates file said "no candidates: give
/// --candidates", though it had been given.
#[test]
fn a_header_only_tracks_file_exited_0_and_printed_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = dir.path().join("tracks.csv");
    std::fs::write(&tracks, "frame,marker,x,y,z\n").unwrap();
    assert_on_sheet("a header-only tracks file", &tracks, &[]);
    let tracks = sheet_tracks(dir.path(), 1);
    let text = "name,x,y,z,directions\n";
    assert_with_candidates("a header-only candidates file", &tracks, text);
}

/// Motive's `Length Units,Inches` gave "unknown length unit Some(\"inches\")".
#[test]
fn motive_inches_were_an_unknown_length_unit() {
    use softsense::markers::tracks::read_motive;
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("take.csv");
    let motive = |unit: &str| {
        format!(
            "Format Version,1.23,Length Units,{unit}\n,Name,m1,m1,m1\n,,Position,Position,Position\n\
             Frame,Time (Seconds),X,Y,Z\n0,0.0,1.0,2.0,0.5\n"
        )
    };
    std::fs::write(&take, motive("Inches")).unwrap();
    let t = read_motive(&take).unwrap();
    assert_eq!(t.frames[0].positions[0], Some([0.0254, 0.0508, 0.0127]));
    std::fs::write(&take, motive("Furlongs")).unwrap();
    let err = read_motive(&take).unwrap_err().to_string();
    assert_words("an unknown Motive length unit", &err);
}

/// `markers calibrate` with marker names that match nothing in --positions said "0
/// markers: a rigid fit needs at least 3", naming neither file nor any marker.
#[test]
fn calibrate_with_mismatched_names_said_0_markers_naming_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = sheet_tracks(dir.path(), 1);
    let layout = dir.path().join("layout.csv");
    let text = std::fs::read_to_string(&tracks).unwrap();
    let renamed = text.replace(",m", ",n").replace(",narker", ",marker");
    std::fs::write(&layout, renamed).unwrap();
    assert_cli(
        "calibrate with mismatched names",
        &[
            "markers",
            "calibrate",
            path(&tracks),
            path(&sheet_model()),
            "--positions",
            path(&layout),
        ],
    );
}

/// `--force-points` on a model without force points said "(its force points: )".
#[test]
fn a_model_without_force_points_listed_its_force_points_as_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let meshes = project_root().join("meshes");
    let text = std::fs::read_to_string(meshes.join("models/robot.toml")).unwrap();
    let text = text.replace("../robot.vtu", path(&meshes.join("robot.vtu")));
    let cut = text.find("[[force_points]]").unwrap();
    let model = dir.path().join("model.toml");
    std::fs::write(&model, &text[..cut]).unwrap();
    let tracks = project_root().join("clouds/markers/robot/tracks.csv");
    let name = "a model without force points";
    assert_cli(name, &["markers", path(&tracks), path(&model)]);
    let args = [
        "markers",
        path(&tracks),
        path(&model),
        "--force-points",
        "hook",
    ];
    assert_cli(name, &args);
}

/// The bundled two-camera scene, one frame at a quarter resolution, generated into
/// `dir/rig`.
fn small_rig(dir: &Path) -> PathBuf {
    let mut scene = crate::common::two_camera_scene(4);
    scene.spec.frames.truncate(1);
    let out = dir.join("rig");
    softsense::scene::generate(&scene, &out, |_, _| {}).unwrap();
    out
}

fn rig_sensor(rig: &Rig) -> Sensor {
    let model =
        softsense::fem::model::Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
    Sensor::for_rig(model, rig, SenseParams::default()).unwrap()
}

/// A camera folder symlinked to another was fused as an independent camera, so the same
/// pixels counted twice.
#[cfg(unix)]
#[test]
fn a_symlinked_camera_folder_was_fused_as_an_independent_third_camera() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_rig(dir.path());
    std::os::unix::fs::symlink(out.join("front"), out.join("front_link")).unwrap();
    let rig = Rig::open(&out).unwrap();
    assert_eq!(rig.camera_names(), ["front", "side"]);
    assert_words("a symlinked camera folder", &rig.warnings.join("\n"));
}

/// A camera whose pose put the robot out of view reported `seen` with 0 robot points and
/// no warning; it now has its own status, the single-camera hint, and is left out.
#[test]
fn a_rig_camera_with_a_wrong_pose_reported_seen_with_0_robot_points_and_no_warning() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_rig(dir.path());
    let rig = Rig::open(&out).unwrap();
    let sensor = rig_sensor(&rig);
    let obs = sensor.observe(&rig, 0).unwrap();
    assert!(obs.cameras.iter().all(|c| c.is_seen()), "{:?}", obs.cameras);
    let both = obs.robot.len();
    let away = r#"{"robot_from_camera": [[1,0,0,10],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#;
    std::fs::write(out.join("side/camera_pose.json"), away).unwrap();
    let rig = Rig::open(&out).unwrap();
    let sensor = rig_sensor(&rig);
    let obs = sensor.observe(&rig, 0).unwrap();
    assert_eq!(
        obs.cameras[1].state,
        CameraState::NoRobot { object_points: 0 }
    );
    assert_eq!(obs.views.len(), 1);
    assert!(obs.robot.len() < both);
    let report = sensor.sense(0, &obs, rig.inputs_of(0).as_ref());
    assert_eq!(report.status, FrameStatus::Sensed, "{:?}", report.warnings);
    assert_words(
        "a rig camera that sees no robot",
        &report.warnings.join("\n"),
    );
    // With no camera on the robot the frame is the one-camera no_robot, not an error.
    std::fs::write(out.join("front/camera_pose.json"), away).unwrap();
    let rig = Rig::open(&out).unwrap();
    let sensor = rig_sensor(&rig);
    let obs = sensor.observe(&rig, 0).unwrap();
    assert!(obs.views.is_empty() && obs.robot.is_empty());
    let report = sensor.sense(0, &obs, rig.inputs_of(0).as_ref());
    assert_eq!(report.status, FrameStatus::NoRobot);
}

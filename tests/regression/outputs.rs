//! One rule for outputs (issue 52 item 1): no command writes over a file it reads, or into
//! a folder that already holds a recording unless `--force`; a failed run leaves nothing
//! behind; batch never deletes a file it did not write.

use crate::common::bags::{image_msg, info_msg, mcap, pixels_u16};
use crate::common::{project_root, run_cli, scene_copy};
use softsense::recording::import::msg::Wire;
use std::path::Path;

/// Each refusal's message: (name, exit code, key words it must hold). The key words say
/// what is wrong and the fix.
pub const MESSAGES: &[(&str, i32, &[&str])] = &[
    (
        "output is an input",
        2,
        &[
            "is the input",
            "give another output path",
            "never writes over",
        ],
    ),
    (
        "output folder holds a recording",
        2,
        &[
            "already holds a recording",
            "new or empty folder",
            "--force",
        ],
    ),
    (
        "output folder holds other files",
        2,
        &["is not empty", "it holds", "new or empty folder"],
    ),
    (
        "output folder holds an input",
        2,
        &["holds the input", "another output folder"],
    ),
    (
        "output folder is a file",
        2,
        &["is a file", "folder's path"],
    ),
    (
        "output file is a folder",
        2,
        &["is a folder", "give a file path"],
    ),
    (
        "regenerated file not written by softsense",
        1,
        &["which softsense did not write", "move it away"],
    ),
];

/// Asserts that `run` ended with the message `name` of [`MESSAGES`]: its exit code and
/// key words, and no bare OS error.
fn assert_message(name: &str, run: &std::process::Output) {
    let (_, code, words) = MESSAGES
        .iter()
        .find(|m| m.0 == name)
        .unwrap_or_else(|| panic!("no message {name:?}"));
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(*code), "{name}: {err}");
    for w in *words {
        assert!(err.contains(w), "{name}: {w:?} in {err}");
    }
    assert!(!err.contains("os error"), "{name}: {err}");
}

/// The names in `dir`, sorted (hidden ones too: a temporary left would show).
fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

/// Every file of `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    names(dir)
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap();
            (n, bytes)
        })
        .collect()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const TIP_WEIGHT: [&str; 12] = [
    "actuators.json",
    "camera_pose.json",
    "intrinsics.json",
    "truth.json",
    "depth_0000.png",
    "color_0000.png",
    "depth_0001.png",
    "color_0001.png",
    "depth_0002.png",
    "color_0002.png",
    "depth_0003.png",
    "color_0003.png",
];

/// Until 2026-11-29 `scene generate SCENE.toml EXISTING_RECORDING` wrote frame 0,
/// `truth.json`, `actuators.json`, `intrinsics.json` and `camera_pose.json` over the old
/// ones, left frames 1-3 stale and exited 0; `sense` then reported those frames unreadable.
#[test]
fn scene_generate_into_an_existing_recording_overwrote_frame_0_and_left_frames_1_to_3_stale() {
    let parent = tempfile::tempdir().unwrap();
    let rec = parent.path().join("rec");
    std::fs::rename(scene_copy("tip_weight", &TIP_WEIGHT).keep(), &rec).unwrap();
    let before = snapshot(&rec);
    let scene = project_root().join("clouds/scenes/two_probes.toml");
    let run = run_cli(&["scene", "generate", s(&scene), s(&rec)]);
    assert_message("output folder holds a recording", &run);
    assert!(snapshot(&rec) == before, "the recording is untouched");
    // With --force the new recording replaces the old one whole: no stale frame.
    let run = run_cli(&["scene", "generate", s(&scene), s(&rec), "--force"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let depth: Vec<String> = (names(&rec).into_iter())
        .filter(|n| n.starts_with("depth_"))
        .collect();
    assert_eq!(
        depth,
        ["depth_0000.png", "depth_0001.png", "depth_0002.png"]
    );
    assert_eq!(
        names(parent.path()),
        ["rec"],
        "no temporary or old folder left"
    );
}

/// `--force` replaces a recording, never a folder that holds what the command reads.
#[test]
fn scene_generate_force_into_the_folder_of_its_own_scene_file_would_have_deleted_it() {
    let dir = scene_copy("calib", &["intrinsics.json", "camera_pose.json"]);
    let scene = dir.path().join("scene.toml");
    let text = std::fs::read_to_string(project_root().join("clouds/scenes/calib.toml")).unwrap();
    let model = project_root().join("meshes/models/robot.toml");
    let text = text.replace("../../meshes/models/robot.toml", s(&model));
    std::fs::write(&scene, &text).unwrap();
    let run = run_cli(&["scene", "generate", s(&scene), s(dir.path()), "--force"]);
    assert_message("output folder holds an input", &run);
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), text);
}

/// Until 2026-11-29 `markers detect REC --out REC/depth_0000.png` replaced a depth frame
/// with a CSV.
#[test]
fn markers_detect_out_a_depth_frame_of_its_recording_replaced_it_with_a_csv() {
    let dir = scene_copy("tip_weight", &TIP_WEIGHT);
    let before = snapshot(dir.path());
    let frame = dir.path().join("depth_0000.png");
    let by_another_name = dir.path().join("./depth_0000.png");
    for out in [&frame, &by_another_name] {
        let run = run_cli(&["markers", "detect", s(dir.path()), "--out", s(out)]);
        assert_message("output is an input", &run);
    }
    assert!(snapshot(dir.path()) == before, "the recording is untouched");
}

/// A track or candidates file with made-up content: the refusal comes before any read.
fn csv(dir: &Path, name: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, "name,x,y,z\nm0,0.0,0.0,0.1\n").unwrap();
    p
}

/// Until 2026-11-29 `markers calibrate T.csv ... --out T.csv` wrote the calibration over
/// its input track file. A link to it is the same file.
#[test]
fn markers_calibrate_out_its_own_track_file_overwrote_it() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = csv(dir.path(), "T.csv");
    let positions = csv(dir.path(), "P.csv");
    let model = project_root().join("meshes/models/robot.toml");
    let mut outs = vec![tracks.clone(), positions.clone()];
    #[cfg(unix)]
    {
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&tracks, &link).unwrap();
        outs.push(link);
    }
    for out in &outs {
        let run = run_cli(&[
            "markers",
            "calibrate",
            s(&tracks),
            s(&model),
            "--positions",
            s(&positions),
            "--out",
            s(out),
        ]);
        assert_message("output is an input", &run);
    }
    let text = "name,x,y,z\nm0,0.0,0.0,0.1\n";
    assert_eq!(std::fs::read_to_string(&tracks).unwrap(), text);
    assert_eq!(std::fs::read_to_string(&positions).unwrap(), text);
}

/// Until 2026-11-29 `markers layout ... --candidates C.csv --csv C.csv` wrote the layout
/// over its input candidates.
#[test]
fn markers_layout_csv_its_own_candidates_file_overwrote_it() {
    let dir = tempfile::tempdir().unwrap();
    let candidates = csv(dir.path(), "C.csv");
    let model = project_root().join("meshes/models/robot.toml");
    let run = run_cli(&[
        "markers",
        "layout",
        s(&model),
        "--markers",
        "3",
        "--candidates",
        s(&candidates),
        "--csv",
        s(&candidates),
    ]);
    assert_message("output is an input", &run);
    let text = std::fs::read_to_string(&candidates).unwrap();
    assert_eq!(text, "name,x,y,z\nm0,0.0,0.0,0.1\n");
}

/// Until 2026-11-29 a `scene generate` that failed at a frame left `intrinsics.json`,
/// `camera_pose.json` and the frames before it.
#[test]
fn a_failed_scene_generate_left_intrinsics_json_and_camera_pose_json() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(project_root().join("clouds/scenes/two_probes.toml"))
        .unwrap()
        .replace(
            "../../meshes/models/robot.toml",
            s(&project_root().join("meshes/models/robot.toml")),
        );
    // The last frame's probe pushes hard enough to invert an element: frames 0 and 1
    // are written first.
    let at = text.rfind("force = [").unwrap();
    let end = at + text[at..].find('\n').unwrap();
    let text = format!("{}force = [0.0, 900.0, 0.0]{}", &text[..at], &text[end..]);
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("rec");
    let run = run_cli(&["scene", "generate", s(&scene), s(&out)]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert_eq!(names(dir.path()), ["bad.toml"], "nothing left: {err}");
}

/// An MCAP of two depth frames (the second of another size than its CameraInfo: refused
/// after the first is written) and their colour frames.
fn bag_failing_at_frame_1(dir: &Path) -> std::path::PathBuf {
    let w = Wire::Cdr;
    let k = [100.0, 0.0, 40.0, 0.0, 100.0, 30.0, 0.0, 0.0, 1.0];
    let depth = |stamp, size: [u32; 2]| {
        let n = (size[0] * size[1]) as usize;
        image_msg(w, stamp, size, "16UC1", &pixels_u16(&vec![1000; n]))
    };
    let colour = |stamp| image_msg(w, stamp, [80, 60], "rgb8", &[9; 80 * 60 * 3]);
    let messages = vec![
        (
            "/cam/depth/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [80, 60], k),
        ),
        (
            "/cam/color/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [80, 60], k),
        ),
        (
            "/cam/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            depth(0, [80, 60]),
        ),
        ("/cam/color/image_raw", "sensor_msgs/msg/Image", colour(0)),
        (
            "/cam/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            depth(100_000_000, [40, 30]),
        ),
        (
            "/cam/color/image_raw",
            "sensor_msgs/msg/Image",
            colour(100_000_000),
        ),
    ];
    let bag = dir.join("run.mcap");
    std::fs::write(&bag, mcap(&messages, "")).unwrap();
    bag
}

/// Until 2026-11-29 an `import` that failed part way left `intrinsics.json` (and the
/// frames before the failure) in OUT_DIR.
#[test]
fn a_failed_import_left_intrinsics_json() {
    let dir = tempfile::tempdir().unwrap();
    let bag = bag_failing_at_frame_1(dir.path());
    let out = dir.path().join("rec");
    let run = run_cli(&["import", s(&bag), s(&out)]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert_eq!(names(dir.path()), ["run.mcap"], "nothing left: {err}");
}

/// Until 2026-11-29 an OUT path that is a file gave "File exists (os error 17)", and an
/// output file that is a folder "Is a directory".
#[test]
fn an_out_path_that_is_a_file_gave_file_exists_os_error_17() {
    let dir = scene_copy("tip_weight", &TIP_WEIGHT);
    let file = dir.path().join("notes.txt");
    std::fs::write(&file, "mine").unwrap();
    let scene = project_root().join("clouds/scenes/tip_weight.toml");
    let rec = s(dir.path());
    for args in [
        vec!["scene", "generate", s(&scene), s(&file)],
        vec!["sense", rec, "--render", s(&file)],
    ] {
        assert_message("output folder is a file", &run_cli(&args));
    }
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    let run = run_cli(&["markers", "detect", rec, "--out", s(&sub)]);
    assert_message("output file is a folder", &run);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    // A folder of other files is never replaced, even with --force.
    let other = tempfile::tempdir().unwrap();
    std::fs::write(other.path().join("notes.txt"), "mine").unwrap();
    let run = run_cli(&["scene", "generate", s(&scene), s(other.path()), "--force"]);
    assert_message("output folder holds other files", &run);
    assert_eq!(names(other.path()), ["notes.txt"]);
}

/// Until 2026-11-29 generating a batch item again (its result missing: an interrupted run)
/// removed its folder OUT/recordings/ID with everything in it, a user's files too.
#[test]
fn regenerating_a_batch_item_deleted_a_users_file_in_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let scene = project_root().join("clouds/scenes/calib.toml");
    let manifest = dir.path().join("m.toml");
    let body = format!("[[scene]]\nspec = {:?}\nid = \"calib\"\n", s(&scene));
    std::fs::write(&manifest, body).unwrap();
    let out = dir.path().join("out");
    let batch = || run_cli(&["batch", s(&manifest), "--out", s(&out)]);
    let run = batch();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rec = out.join("recordings/calib");
    std::fs::write(rec.join("notes.txt"), "mine").unwrap();
    std::fs::remove_file(out.join("results/calib.json")).unwrap();
    let run = batch();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(rec.join("notes.txt")).unwrap(),
        "mine"
    );
    assert!(rec.join("depth_0000.png").exists());
    assert_eq!(
        names(&out.join("recordings")),
        ["calib"],
        "no temporary left"
    );
    // A file of the user's where the new recording puts one: the item fails, naming it,
    // and the file stays.
    std::fs::remove_file(rec.join("depth_0000.png")).unwrap();
    std::fs::write(rec.join("depth_0000.png"), "mine").unwrap();
    let written = std::fs::read_to_string(rec.join(".softsense-written")).unwrap();
    let list: String = (written.lines())
        .filter(|l| *l != "depth_0000.png")
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(rec.join(".softsense-written"), list).unwrap();
    std::fs::remove_file(out.join("results/calib.json")).unwrap();
    let run = batch();
    assert_eq!(run.status.code(), Some(1));
    let result = std::fs::read_to_string(out.join("results/calib.json")).unwrap();
    for w in MESSAGES[6].2 {
        assert!(result.contains(w), "{w}: {result}");
    }
    assert!(result.contains("depth_0000.png"), "{result}");
    assert_eq!(
        std::fs::read_to_string(rec.join("depth_0000.png")).unwrap(),
        "mine"
    );
}

/// A `scene generate` stopped by SIGTERM (or Ctrl-C) mid-run must leave neither the new
/// folder nor its staged `.NAME.tmpPID`: the signal handler removes staged folders as it
/// does temporary files.
#[cfg(unix)]
#[test]
fn a_terminated_scene_generate_left_its_half_written_folder() {
    let dir = tempfile::tempdir().unwrap();
    let scene = project_root().join("clouds/scenes/probe_press.toml");
    let out = dir.path().join("rec");
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(["scene", "generate", s(&scene), s(&out)])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Signal once the staged folder holds a frame; if the run ends first, what is
    // checked below still holds, only without a signal.
    let (signalled, status) = crate::common::terminate_when(child, || {
        let staged = names(dir.path())
            .into_iter()
            .find(|n| n.starts_with(".rec.tmp"));
        staged.is_some_and(|n| dir.path().join(n).join("depth_0000.png").exists())
    });
    match signalled && status.code() == Some(143) {
        true => assert_eq!(names(dir.path()), Vec::<String>::new()),
        false => assert_eq!(names(dir.path()), ["rec"], "{status:?}"),
    }
}

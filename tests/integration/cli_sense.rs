//! `softsense sense` as a user runs it: JSON lines per frame, errors against truth, and
//! clear failures on bad input.
use std::path::Path;
use std::process::{Command, Stdio};

fn sense(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_softsense"))
        .arg("sense")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run softsense")
}

/// The stream rate from the summary line "S/N frames sensed…, M ms per frame; stream F
/// frames/s (…)". Scripts read this line (issue 56): its format is kept stable.
fn stream_frames_per_second(stderr: &str) -> Option<f64> {
    let line = stderr.lines().find(|l| l.contains(" frames sensed"))?;
    let (head, tail) = line.split_once(" ms per frame; stream ")?;
    head.rsplit(", ").next()?.parse::<f64>().ok()?;
    let (fps, rest) = tail.split_once(" frames/s (")?;
    rest.ends_with(", wall clock)").then_some(())?;
    fps.parse().ok()
}

#[test]
fn sense_prints_one_json_object_per_frame_with_errors_against_truth() {
    let out = sense(&["clouds/scenes/tip_weight", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let frames: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    assert_eq!(frames.len(), 4);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f["frame"], i);
        assert_eq!(f["status"], "sensed", "{f}");
        assert!(f["features_visible"].as_u64().unwrap() > 30);
        let forces = f["forces"].as_array().unwrap();
        assert_eq!(forces.len(), 1);
        let errors = f["errors"].as_array().unwrap();
        // Frame 0 carries no load; frames 1-3 one weight each.
        assert_eq!(errors.len(), usize::from(i > 0));
        for e in errors {
            assert!(e["magnitude_error"].as_f64().unwrap() < 0.02, "{e}");
        }
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("4/4 frames sensed"), "{stderr}");
    let fps = stream_frames_per_second(&stderr);
    assert!(fps.is_some_and(|f| f > 0.0 && f.is_finite()), "{stderr}");
    // The model is named as it would be typed from here, not via the recording's folder
    // ("clouds/scenes/tip_weight/../../../meshes/...").
    assert!(
        stderr.contains(
            "model meshes/models/robot.toml, pose from clouds/scenes/tip_weight/camera_pose.json"
        ),
        "{stderr}"
    );
}

#[test]
fn sense_finds_a_bundled_scenes_model_from_any_working_directory() {
    // truth.json names the model relative to the recording's folder.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("clouds/scenes/tip_weight");
    let elsewhere = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_softsense"))
        .arg("sense")
        .arg(&scene)
        .arg("--json")
        .current_dir(elsewhere.path())
        .output()
        .expect("run softsense");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 4);
}

#[test]
fn sense_stops_quietly_when_the_reader_of_its_output_goes_away() {
    // `softsense sense DIR | head -1`: the pipe closes while frames remain. Writing to it
    // must not panic; the command stops (nothing else is being written) and exits 0.
    for json in [true, false] {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_softsense"));
        cmd.args(["sense", "clouds/scenes/tip_weight", "--window", "1"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        if json {
            cmd.arg("--json");
        }
        let mut child = cmd.spawn().expect("run softsense");
        // Close the read end before the first frame is written.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("wait for softsense");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(out.status.code(), Some(0), "{err}");
        assert!(
            err.contains("stdout was closed: stopped after 1 of 4 frames"),
            "{err}"
        );
    }
}

#[test]
fn sense_refuses_zero_feature_points_as_a_usage_error() {
    let out = sense(&["clouds/scenes/tip_weight", "--features", "0"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--features"), "{err}");
}

#[cfg(not(feature = "rerun"))]
#[test]
fn sense_rerun_without_the_rerun_feature_is_a_usage_error_that_says_how_to_get_it() {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("out.rrd");
    let out = sense(&["clouds/scenes/tip_weight", "--rerun", rrd.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--features rerun"), "{err}");
    assert!(!rrd.exists());
}

#[test]
fn sense_on_a_missing_or_empty_folder_fails_with_a_message() {
    // A path that is not there is a usage error (exit 2), as clap's own are.
    let out = sense(&["no/such/folder"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no/such/folder: no such folder"), "{err}");
    let empty = tempfile::tempdir().unwrap();
    let out = sense(&[empty.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no frames (depth_NNNN.png"));
}

#[test]
fn sense_without_a_model_asks_for_one() {
    // A recording without truth.json names no model: the user must give --model.
    let dir = tip_weight_frame_0();
    let out = sense(&[dir.path().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--model"));
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/models/robot.toml");
    let out = sense(&[
        dir.path().to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("no recorded actuator inputs"));
}

#[test]
fn sense_render_writes_one_picture_per_frame_over_the_colour_frame() {
    let out_dir = tempfile::tempdir().unwrap();
    let pictures = out_dir.path().join("pictures");
    let out = sense(&[
        "clouds/scenes/tip_weight",
        "--render",
        pictures.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("clouds/scenes/tip_weight");
    for i in 0..4 {
        let pic = image::open(pictures.join(format!("frame_{i:04}.png")))
            .unwrap()
            .into_rgb8();
        let frame = image::open(root.join(format!("color_{i:04}.png")))
            .unwrap()
            .into_rgb8();
        assert_eq!(pic.dimensions(), frame.dimensions());
        // Drawn over: the robot tint, features and arrow change many pixels.
        let changed = pic
            .pixels()
            .zip(frame.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert!(changed > 10_000, "frame {i}: only {changed} pixels drawn");
    }
}

#[test]
fn bad_frames_get_their_own_status_and_the_stream_goes_on() {
    // tip_weight with frame 1's depth all zero (every point NaN), frame 2's colour grey
    // (no robot colour anywhere) and frame 3's depth not a PNG. Frame 0 has no load and no
    // contact: it is sensed with the model's force points, and says so.
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("clouds/scenes/tip_weight");
    let dir = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(&src).unwrap() {
        let p = entry.unwrap().path();
        std::fs::copy(&p, dir.path().join(p.file_name().unwrap())).unwrap();
    }
    let (w, h) = image::image_dimensions(src.join("depth_0000.png")).unwrap();
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(w, h)
        .save(dir.path().join("depth_0001.png"))
        .unwrap();
    image::RgbImage::from_pixel(w, h, image::Rgb([128, 128, 128]))
        .save(dir.path().join("color_0002.png"))
        .unwrap();
    std::fs::write(dir.path().join("depth_0003.png"), b"not a png").unwrap();
    // The copy is away from the model its truth.json names: a clear error, then --model.
    let out = sense(&[dir.path().to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("give --model"), "{err}");
    let out = sense(&[
        dir.path().to_str().unwrap(),
        "--json",
        "--model",
        "meshes/models/robot.toml",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "one frame is still sensed: {stderr}");
    let frames: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    assert_eq!(frames.len(), 4, "every frame gets a report");
    let status: Vec<&str> = frames
        .iter()
        .map(|f| f["status"].as_str().unwrap())
        .collect();
    assert_eq!(status, ["sensed", "no_robot", "no_robot", "unreadable"]);
    let warnings = frames[0]["warnings"].to_string();
    assert!(warnings.contains("no contact seen"), "{warnings}");
    assert!(
        frames[3]["detail"]
            .as_str()
            .unwrap()
            .contains("depth_0003.png"),
        "{}",
        frames[3]
    );
    assert!(stderr.contains("1/4 frames sensed"), "{stderr}");
    // The human-readable stream says the same in words.
    let out = sense(&[
        dir.path().to_str().unwrap(),
        "--model",
        "meshes/models/robot.toml",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("frame    1: no robot"), "{text}");
    assert!(text.contains("frame    3: unreadable: "), "{text}");
    // Frames 1-3 hang 0.26, 0.66 and 1.06 N and none is sensed: each load says it has no
    // estimate, and the summary counts them without an infinite location error.
    assert_eq!(
        text.matches("-> no estimate (counted as 100% off)").count(),
        3,
        "{text}"
    );
    let summary = String::from_utf8_lossy(&out.stderr);
    assert!(
        summary.contains("against truth.json (3 loads, 3 with no estimate, counted as 100% off)"),
        "{summary}"
    );
    assert!(!summary.contains("inf"), "{summary}");
    // Tracked, the same statuses; a bad frame leaves nothing to start from.
    let tracked = answers_of(&[
        dir.path().to_str().unwrap(),
        "--json",
        "--track",
        "--model",
        "meshes/models/robot.toml",
    ]);
    let status: Vec<&str> = tracked
        .iter()
        .map(|f| f["status"].as_str().unwrap())
        .collect();
    assert_eq!(status, ["sensed", "no_robot", "no_robot", "unreadable"]);
    assert!(tracked.iter().all(|f| f["tracked"] == false), "{tracked:?}");
}

#[test]
fn a_frame_with_more_contacts_than_the_limit_gets_its_own_status_and_the_stream_goes_on() {
    // probe_side's frames 0 and 1, frame 1's depth taken from another scene (two_probes):
    // the robot's colour then sits at other depths, and the robot is "touched" in about
    // twenty places. Estimated, that frame took 6 s and failed; over the limit it is not
    // estimated, says why, and frame 0 is sensed as before.
    // Frames 2-4 left out: two frames say it all.
    let dir = tempfile::tempdir().unwrap();
    let same = |name| (name, name);
    crate::common::copy_scene_files(
        "probe_side",
        &[
            same("intrinsics.json"),
            same("camera_pose.json"),
            same("actuators.json"),
            same("truth.json"),
            same("depth_0000.png"),
            same("color_0000.png"),
            same("color_0001.png"),
        ],
        dir.path(),
    );
    crate::common::copy_scene_files(
        "two_probes",
        &[("depth_0000.png", "depth_0001.png")],
        dir.path(),
    );
    let frames = answers_of(&[
        dir.path().to_str().unwrap(),
        "--json",
        "--model",
        "meshes/models/robot.toml",
    ]);
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert_eq!(frames[0]["status"], "sensed", "{}", frames[0]);
    assert_eq!(frames[1]["status"], "too_many_contacts", "{}", frames[1]);
    let seen = frames[1]["detail"]["seen"].as_u64().unwrap();
    assert!(seen > 6, "{}", frames[1]);
    assert_eq!(frames[1]["detail"]["max"], 6, "{}", frames[1]);
    assert!(frames[1]["forces"].as_array().unwrap().is_empty());
    // The table says it in words, with the limit given (frame 0's one contact is within
    // it); a limit of 0 is refused.
    let out = sense(&[
        dir.path().to_str().unwrap(),
        "--model",
        "meshes/models/robot.toml",
        "--max-contacts",
        "1",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!(
            "frame    1: too many contacts: {seen} seen, the limit is 1"
        )),
        "{text}"
    );
    assert!(text.contains("frame    0: sensed"), "{text}");
    let out = sense(&[dir.path().to_str().unwrap(), "--max-contacts", "0"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn sense_refuses_a_pose_that_is_not_rigid_and_says_what_to_check_when_no_frame_has_the_robot() {
    // tip_weight's frame 0 alone, with its camera pose scaled, inverted, then right but
    // with a robot colour nothing in the frame has.
    let dir = tip_weight_frame_0();
    let pose_path = dir.path().join("camera_pose.json");
    let pose: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&pose_path).unwrap()).unwrap();
    let m: Vec<Vec<f64>> = serde_json::from_value(pose["robot_from_camera"].clone()).unwrap();
    let write_pose = |m: &[Vec<f64>]| {
        std::fs::write(
            &pose_path,
            serde_json::json!({ "robot_from_camera": m }).to_string(),
        )
        .unwrap();
    };
    let run = |extra: &[&str]| {
        let mut args = vec![
            dir.path().to_str().unwrap(),
            "--model",
            "meshes/models/robot.toml",
        ];
        args.extend_from_slice(extra);
        let out = sense(&args);
        assert!(!out.status.success(), "{out:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // Scaled: refused before any frame.
    let mut scaled = m.clone();
    for row in scaled.iter_mut().take(3) {
        for v in row.iter_mut().take(3) {
            *v *= 1.01;
        }
    }
    write_pose(&scaled);
    let err = run(&[]);
    assert!(
        err.contains("camera_pose.json: robot_from_camera is not a rigid transform"),
        "{err}"
    );
    // Inverted (camera_from_robot, a common mix-up): rigid, but nothing is near the robot.
    // [Rᵀ, -Rᵀ t; 0 0 0 1].
    let inverse: Vec<Vec<f64>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| match (i, j) {
                    (3, 3) => 1.0,
                    (3, _) => 0.0,
                    (_, 3) => -(0..3).map(|k| m[k][i] * m[k][3]).sum::<f64>(),
                    _ => m[j][i],
                })
                .collect()
        })
        .collect();
    write_pose(&inverse);
    let err = run(&[]);
    assert!(err.contains("no frame could be sensed"), "{err}");
    assert!(err.contains("check the camera pose"), "{err}");
    // The right pose and a colour nothing has: the colour is what to check.
    write_pose(&m);
    let err = run(&["--robot-color", "20,20,230"]);
    assert!(err.contains("check --robot-color"), "{err}");
}

/// A folder with tip_weight's frame 0 and its intrinsics and camera pose (no truth.json,
/// so no model named).
fn tip_weight_frame_0() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let same = |name| (name, name);
    crate::common::copy_scene_files(
        "tip_weight",
        &[
            same("depth_0000.png"),
            same("color_0000.png"),
            same("intrinsics.json"),
            same("camera_pose.json"),
        ],
        dir.path(),
    );
    dir
}

/// Runs `sense` with `args` (`--json` among them), which must succeed, and returns
/// [`answers`].
fn answers_of(args: &[&str]) -> Vec<serde_json::Value> {
    let out = sense(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    answers(&out)
}

/// The JSON lines of a run without the wall-clock fields.
fn answers(out: &std::process::Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).expect("each line is JSON");
            let o = v.as_object_mut().unwrap();
            o.remove("ms");
            o.remove("timings");
            v
        })
        .collect()
}

#[test]
fn sensing_frames_one_at_a_time_or_three_at_a_time_gives_the_same_answers_in_order() {
    let one = sense(&["clouds/scenes/probe_side", "--json", "--window", "1"]);
    let three = sense(&["clouds/scenes/probe_side", "--json", "--window", "3"]);
    assert!(one.status.success() && three.status.success());
    let (a, b) = (answers(&one), answers(&three));
    assert_eq!(a.len(), 5);
    for (i, f) in a.iter().enumerate() {
        assert_eq!(f["frame"], i);
    }
    assert_eq!(a, b);
    assert!(String::from_utf8_lossy(&three.stderr).contains("3 at a time"));
}

#[test]
fn sense_track_says_which_frames_started_from_the_one_before() {
    let out = sense(&["clouds/scenes/probe_press", "--json", "--track"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames = answers(&out);
    assert_eq!(frames.len(), 10);
    let tracked: Vec<bool> = frames
        .iter()
        .map(|f| f["tracked"].as_bool().expect("a 'tracked' flag"))
        .collect();
    assert_eq!(tracked, [&[false][..], &[true; 9][..]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("tracked, 9 of 10 from the frame before"),
        "{err}"
    );
    // The human form says it too.
    let human = sense(&["clouds/scenes/probe_press", "--track"]);
    assert!(String::from_utf8_lossy(&human.stdout).contains("sensed (tracked)"));
}

#[test]
fn sense_track_and_a_window_are_refused_together() {
    let out = sense(&["clouds/scenes/probe_press", "--track", "--window", "2"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--window") && err.contains("--track"), "{err}");
}

#[test]
fn sense_reads_a_pcl_grabber_folder_with_a_given_pose_and_reports_each_frames_status() {
    let Some(dir) = crate::common::data_file(
        "sense_reads_a_pcl_grabber_folder_with_a_given_pose_and_reports_each_frames_status",
        "pcl/grabber_sequence",
    ) else {
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pose = root.join("clouds/scenes/tip_weight/camera_pose.json");
    let model = root.join("meshes/models/robot.toml");
    let run = |extra: &[&str]| {
        let mut args = vec![dir.to_str().unwrap(), "--model", model.to_str().unwrap()];
        args.extend_from_slice(extra);
        sense(&args)
    };
    // Without a pose: refused up front, saying how to give one.
    let out = run(&["--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--pose"), "{err}");
    // With one: every frame is read and says there is no robot in it (PCL's office scene).
    let out = run(&["--json", "--pose", pose.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let statuses: Vec<String> = stdout
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["status"].to_string()
        })
        .collect();
    assert_eq!(statuses.len(), 3, "{stdout}");
    assert!(statuses.iter().all(|s| s == "\"no_robot\""), "{statuses:?}");
}

#[test]
fn a_reference_frame_in_which_a_contact_is_seen_is_refused() {
    let out = sense(&["clouds/scenes/probe_press", "--reference-frames", "1"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("reference frame 0") && err.contains("unloaded"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn a_reference_of_every_frame_or_a_known_load_without_a_reference_is_a_usage_error() {
    for args in [
        &["clouds/scenes/tip_weight", "--reference-frames", "4"][..],
        &["clouds/scenes/tip_weight", "--known-load", "1=0.26"][..],
        &[
            "clouds/scenes/tip_weight",
            "--reference-frames",
            "1",
            "--known-load",
            "1=-2",
        ][..],
        &[
            "clouds/scenes/tip_weight",
            "--reference-frames",
            "1",
            "--known-load",
            "0=0.26",
        ][..],
    ] {
        let out = sense(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--reference-frames") || err.contains("--known-load"),
            "{err}"
        );
    }
}

#[test]
fn sense_with_a_reference_and_a_known_load_marks_those_frames_and_keeps_the_model_modulus_on_its_own_body(
) {
    let out = sense(&[
        "clouds/scenes/tip_weight",
        "--json",
        "--reference-frames",
        "1",
        "--known-load",
        "1=0.26",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    // The bundled scene is rendered from the model: the modulus stays.
    assert!(err.contains("modulus: 1.00"), "{err}");
    assert!(err.contains("reference: frames [0]"), "{err}");
    let reports = answers(&out);
    let marked: Vec<bool> = (reports.iter())
        .map(|r| r["reference"].as_bool().unwrap_or(false))
        .collect();
    assert_eq!(marked, [true, true, false, false]);
    for r in &reports[2..] {
        for e in r["errors"].as_array().unwrap() {
            let error = e["force_error"].as_f64().unwrap();
            assert!(error < 0.02, "frame {}: {error}", r["frame"]);
        }
    }
}

#[test]
fn sense_finds_the_models_own_modulus_from_the_sag_of_its_own_body() {
    let out = sense(&[
        "clouds/scenes/tip_weight",
        "--reference-frames",
        "1",
        "--modulus-from-sag",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let factor: f64 = err
        .split("modulus from the sag: ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    // The bundled scene is rendered from the model: its sag is the model's.
    assert!((factor - 1.0).abs() < 0.01, "{factor}");
}

/// `--dense-points` reaches the dense rows: a probe frame registered from fewer robot
/// points gets other forces and σ, still near the truth; 0 is a usage error.
#[test]
fn fewer_dense_points_change_a_probe_frames_answer_and_zero_is_refused() {
    let all = answers_of(&["clouds/scenes/probe_side", "--json", "--window", "1"]);
    let few = answers_of(&[
        "clouds/scenes/probe_side",
        "--json",
        "--window",
        "1",
        "--dense-points",
        "1000",
    ]);
    assert_eq!(all.len(), few.len());
    for (a, f) in all.iter().zip(&few) {
        assert_eq!(f["status"], "sensed", "{f}");
        assert_ne!(a["forces"][0]["sigma"], f["forces"][0]["sigma"], "{f}");
        for e in f["errors"].as_array().unwrap() {
            assert!(e["force_error"].as_f64().unwrap() < 0.2, "{e}");
        }
    }
    let out = sense(&["clouds/scenes/probe_side", "--dense-points", "0"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--dense-points"), "{err}");
}

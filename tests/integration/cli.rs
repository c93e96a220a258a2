//! The `softsense` binary on the committed fixtures and on bad input: exit codes, where
//! output goes (JSON on stdout, messages on stderr), and that messages name the file.

use crate::common::project_root;
use softsense::io::{read_cloud, rgbd};
use softsense::PointCloud;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub(crate) fn softsense(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(args)
        .current_dir(project_root())
        .output()
        .expect("run softsense")
}

/// `softsense convert --depth DEPTH --intrinsics INTRINSICS REST...`.
fn convert_rgbd(depth: &str, intrinsics: &str, rest: &[&str]) -> Output {
    let mut args = vec!["convert", "--depth", depth, "--intrinsics", intrinsics];
    args.extend_from_slice(rest);
    softsense(&args)
}

pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit code `code`, no panic, and a stderr message containing every `needle`.
pub(crate) fn assert_fails(o: &Output, code: i32, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}: {err}");
    }
}

fn fixture(rel: &str) -> String {
    format!("tests/fixtures/rgbd/{rel}")
}

pub(crate) fn json_of(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "stderr: {}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("stdout is one JSON document")
}

/// A position's bit pattern, with every NaN mapped to one value.
fn bits(p: &[f32; 3]) -> [u32; 3] {
    p.map(|c| if c.is_nan() { u32::MAX } else { c.to_bits() })
}

/// Positions equal bit for bit (NaN == NaN), colours equal, same organization.
pub(crate) fn assert_same_cloud(a: &PointCloud, b: &PointCloud) {
    assert_eq!((a.width, a.height, a.len()), (b.width, b.height, b.len()));
    for (i, (p, q)) in a.positions.iter().zip(&b.positions).enumerate() {
        assert_eq!(bits(p), bits(q), "point {i}: {p:?} vs {q:?}");
    }
    assert_eq!(a.colors, b.colors);
}

#[test]
fn help_teaches_with_examples() {
    let o = softsense(&["--help"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("info") && out.contains("convert") && out.contains("Examples"));
    let o = softsense(&["convert", "--help"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("--depth-trunc") && out.contains("intrinsic_matrix"),
        "{out}"
    );
}

#[test]
fn every_subcommands_help_shows_its_long_description_beyond_the_one_line_summary() {
    // A line from each command's long text (its Args doc or long_about); a doc comment on
    // the subcommand enum's variant would replace it with the one-line summary.
    let cases = [
        ("sense", "truth.json is never used for the estimate"),
        ("filter", "Stages run in the order crop, voxel"),
        (
            "segment",
            "softsense segment scene.pcd labelled.pcd --mode geometric",
        ),
        ("cluster", "OUT holds every input point in input order"),
        ("contacts", "Prints one line (or JSON object) per contact"),
        ("calibrate", "rough_pose.json"),
        ("hidden", "truth_hidden.json"),
        ("markers", "OptiTrack Motive CSV export"),
    ];
    for (command, line) in cases {
        let o = softsense(&[command, "--help"]);
        assert!(o.status.success(), "{command}");
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            out.contains(line),
            "{command} --help lacks {line:?}:\n{out}"
        );
    }
}

#[test]
fn the_scene_file_in_scene_generate_help_loads_and_shows_the_real_defaults() {
    let o = softsense(&["scene", "generate", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout).to_string();
    // The indented block between the format's introduction and the examples.
    let start = help.find("  model = ").expect("an example scene file");
    let end = help.find("Examples:").unwrap();
    let text: String = help[start..end]
        .lines()
        .map(|l| l.strip_prefix("  ").unwrap_or(l))
        .collect::<Vec<_>>()
        .join("\n");
    let model = project_root().join("meshes/models/robot.toml");
    let text = text.replace(
        "\"../../meshes/models/robot.toml\"",
        &format!("{:?}", model.display().to_string()),
    );
    let dir = tempfile::tempdir().unwrap();
    let shown = dir.path().join("shown.toml");
    std::fs::write(&shown, &text).unwrap();
    let shown = softsense::scene::Scene::load(&shown).unwrap().spec;
    assert_eq!(shown.frames.len(), 1);
    assert_eq!(shown.frames[0].loads.len(), 2);
    // The keys the help gives as defaults are the defaults.
    let minimal = dir.path().join("minimal.toml");
    std::fs::write(
        &minimal,
        format!("model = {:?}\n[[frames]]\n", model.display().to_string()),
    )
    .unwrap();
    let minimal = softsense::scene::Scene::load(&minimal).unwrap().spec;
    let (shown_json, minimal_json) = (
        serde_json::to_value(&shown).unwrap(),
        serde_json::to_value(&minimal).unwrap(),
    );
    for key in ["camera", "sensor", "colors", "seed", "table_half"] {
        assert_eq!(shown_json[key], minimal_json[key], "{key}");
    }
}

#[test]
fn info_json_describes_the_demo_scene() {
    let v = json_of(&softsense(&["info", "clouds/demo_scene.pcd", "--json"]));
    let depth = rgbd::read_depth_image(project_root().join(fixture("depth.png"))).unwrap();
    let nonzero = depth.data.iter().filter(|&&d| d != 0).count();
    assert_eq!(v["points"], 320 * 240);
    assert_eq!(v["finite_points"], nonzero);
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(320), Some(240))
    );
    assert_eq!(v["organized"], true);
    assert_eq!(v["fields"], serde_json::json!(["x", "y", "z", "rgb"]));
    assert_eq!(v["encoding"], "binary_compressed");
    let (lo, hi) = (&v["bounds"]["min"], &v["bounds"]["max"]);
    assert!(
        lo[2].as_f64().unwrap() > 0.3 && hi[2].as_f64().unwrap() < 2.0,
        "{v}"
    );
    assert_eq!(
        v["viewpoint"]["orientation_wxyz"],
        serde_json::json!([1.0, 0.0, 0.0, 0.0])
    );
}

#[test]
fn info_without_json_writes_only_to_stderr() {
    let o = softsense(&["info", "clouds/demo_scene.pcd"]);
    assert!(o.status.success());
    assert!(o.stdout.is_empty());
    let err = stderr(&o);
    assert!(
        err.contains("320 x 240") && err.contains("binary_compressed"),
        "{err}"
    );
}

#[test]
fn convert_round_trips_through_every_format_and_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let original = read_cloud(project_root().join("clouds/demo_scene.pcd")).unwrap();
    for (name, enc) in [
        ("a.pcd", "ascii"),
        ("b.pcd", "binary"),
        ("c.pcd", "binary_compressed"),
        ("d.ply", "ascii"),
        ("e.ply", "binary"),
    ] {
        let out = dir.path().join(name);
        let o = softsense(&[
            "convert",
            "clouds/demo_scene.pcd",
            out.to_str().unwrap(),
            "--encoding",
            enc,
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let back = read_cloud(&out).unwrap();
        let v = json_of(&softsense(&["info", out.to_str().unwrap(), "--json"]));
        let want = match (name.ends_with(".ply"), enc) {
            (true, "binary") => "binary_little_endian",
            (_, e) => e,
        };
        assert_eq!(v["encoding"], want, "{name}");
        if name.ends_with(".pcd") {
            assert_same_cloud(&original, &back);
        } else {
            // PLY has no organized shape (and says so); compare the points.
            assert!(stderr(&o).contains("organized shape"), "{name}");
            assert_eq!(back.len(), original.len(), "{name}");
            assert!(back
                .positions
                .iter()
                .map(bits)
                .eq(original.positions.iter().map(bits)));
            assert_eq!(back.colors, original.colors, "{name}");
        }
    }
    let xyz = dir.path().join("f.xyz");
    let o = softsense(&["convert", "clouds/demo_scene.pcd", xyz.to_str().unwrap()]);
    assert!(stderr(&o).contains("positions only"), "{}", stderr(&o));
}

#[test]
fn rgbd_convert_reproduces_the_committed_demo_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.pcd");
    let o = convert_rgbd(
        &fixture("depth.png"),
        &fixture("intrinsics.json"),
        &[
            "--color",
            &fixture("color.png"),
            out.to_str().unwrap(),
            "--json",
        ],
    );
    let v = json_of(&o);
    assert_eq!(v["points"], 320 * 240);
    let ours = read_cloud(&out).unwrap();
    let committed = read_cloud(project_root().join("clouds/demo_scene.pcd")).unwrap();
    assert_same_cloud(&ours, &committed);
}

#[test]
fn rgbd_convert_truncates_depth() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("near.pcd");
    let o = convert_rgbd(
        &fixture("depth.png"),
        &fixture("intrinsics.json"),
        &["--depth-trunc", "0.7", out.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let cloud = read_cloud(&out).unwrap();
    let depth = rgbd::read_depth_image(project_root().join(fixture("depth.png"))).unwrap();
    let kept = depth.data.iter().filter(|&&d| d != 0 && d < 700).count();
    assert!(kept > 0 && kept < depth.data.len());
    assert_eq!(cloud.count_finite(), kept);
    assert!(cloud.positions.iter().all(|p| p[2].is_nan() || p[2] < 0.7));
}

#[test]
fn missing_input_names_the_file() {
    let o = softsense(&["info", "no/such/cloud.pcd"]);
    assert_fails(&o, 1, &["no/such/cloud.pcd"]);
}

#[test]
fn unknown_extension_is_refused_before_reading() {
    let o = softsense(&["info", "README.md"]);
    assert_fails(&o, 1, &["README.md", "unknown cloud format"]);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.obj");
    let o = softsense(&["convert", "clouds/demo_scene.pcd", out.to_str().unwrap()]);
    assert_fails(&o, 1, &["out.obj", "unknown cloud format"]);
    assert!(!out.exists());
}

#[test]
fn malformed_files_give_a_message_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[u8]); 4] = [
        ("garbage.pcd", b"this is not a PCD file\n"),
        ("truncated.pcd", b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 10\nDATA binary\n\x00\x00"),
        ("garbage.ply", b"ply\nformat nonsense 1.0\n"),
        ("garbage.xyz", b"1 2 three\n"),
    ];
    for (name, bytes) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = softsense(&["info", p.to_str().unwrap()]);
        assert_fails(&o, 1, &[name]);
    }
}

#[test]
fn bad_rgbd_inputs_are_typed_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.pcd");
    let out = out.to_str().unwrap();
    // Colour image given as depth: wrong bit depth.
    let o = convert_rgbd(&fixture("color.png"), &fixture("intrinsics.json"), &[out]);
    assert_fails(&o, 1, &["color.png", "16-bit single-channel", "8-bit RGB"]);
    // Intrinsics missing a field.
    let bad: PathBuf = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"width": 320, "intrinsic_matrix": [1,0,0,0,1,0,0,0,1]}"#,
    )
    .unwrap();
    let o = convert_rgbd(&fixture("depth.png"), bad.to_str().unwrap(), &[out]);
    assert_fails(&o, 1, &["bad.json", "`height`"]);
    // Intrinsics of another size.
    let vga = dir.path().join("vga.json");
    std::fs::write(
        &vga,
        r#"{"width": 640, "height": 480, "intrinsic_matrix": [525,0,0,0,525,0,319.5,239.5,1]}"#,
    )
    .unwrap();
    let o = convert_rgbd(&fixture("depth.png"), vga.to_str().unwrap(), &[out]);
    assert_fails(&o, 1, &["depth.png", "(640, 480)", "(320, 240)"]);
    // Truncation so tight that nothing is left: an error, not an all-NaN file.
    let o = convert_rgbd(
        &fixture("depth.png"),
        &fixture("intrinsics.json"),
        &["--depth-trunc", "0.01", out],
    );
    assert_fails(&o, 1, &["depth.png", "no pixel gives a valid point"]);
    assert!(!Path::new(out).exists());
}

#[test]
fn argument_misuse_exits_with_code_2() {
    assert_fails(
        &softsense(&["convert", "clouds/demo_scene.pcd"]),
        2,
        &["IN OUT"],
    );
    let o = convert_rgbd(
        &fixture("depth.png"),
        &fixture("intrinsics.json"),
        &["a.pcd", "b.pcd"],
    );
    assert_fails(&o, 2, &["only the output"]);
    assert_fails(
        &softsense(&["convert", "--color", "c.png", "a.pcd", "b.pcd"]),
        2,
        &["--depth"],
    );
    let o = convert_rgbd(
        &fixture("depth.png"),
        &fixture("intrinsics.json"),
        &["--depth-scale", "0", "o.pcd"],
    );
    assert_fails(&o, 2, &["depth_scale"]);
    assert_fails(&softsense(&["frobnicate"]), 2, &[]);
}

/// The CLI on a real Kinect frame (TIFF depth + TIFF colour + PCL XML) writes the same
/// cloud PCL's grabber wrote for it.
#[test]
fn rgbd_convert_of_a_real_frame_equals_pcls_pcd() {
    let Some(dir) = crate::common::data_dir("rgbd_convert_of_a_real_frame_equals_pcls_pcd") else {
        return;
    };
    let stem = dir.join("pcl/grabber_sequence/frame_20121214T142256.068683");
    let s = stem.to_str().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("frame.pcd");
    let o = convert_rgbd(
        &format!("{s}_depth.tiff"),
        &format!("{s}.xml"),
        &["--color", &format!("{s}_rgb.tiff"), out.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let pcl = read_cloud(format!("{s}.pcd")).unwrap();
    assert_same_cloud(&read_cloud(&out).unwrap(), &pcl);
}

#[test]
fn hidden_truth_is_refused_naming_the_bad_key_and_its_help_lists_the_keys() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ds");
    let out = out.to_str().unwrap();
    for (truth, says) in [
        ("young_factor = -1", "truth.young_factor"),
        ("stiffer", "is not a preset (modulus, neo-hookean)"),
    ] {
        let o = softsense(&[
            "hidden",
            out,
            "--model",
            "meshes/models/robot.toml",
            "--truth",
            truth,
        ]);
        assert!(!o.status.success(), "{truth}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(says), "{truth}: {err}");
        assert!(!dir.path().join("ds").exists(), "{truth}: nothing written");
    }
    let o = softsense(&["hidden", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    for key in [
        "young_factor",
        "formulation",
        "mesh",
        "base_stiffness",
        "neo-hookean",
        "modulus",
    ] {
        assert!(help.contains(key), "hidden --help lacks {key}");
    }
}

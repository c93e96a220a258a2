//! Messages a new user meets (issue 52): each row is what they did, the exit code, and the
//! key words the message must hold (the file, field, topic or frame, and the fix). Usage
//! errors exit 2, results that cannot be made exit 1, warned results exit 0.

use crate::common::bags::{image_msg, info_msg, mcap, pixels_u16};
use crate::common::project_root;
use softsense::recording::import::msg::Wire;
use std::path::Path;

/// One message: what a user did, and what softsense must say.
struct Case {
    /// What the user did, as a sentence.
    did: &'static str,
    /// Writes the case's files into its folder.
    setup: fn(&Path),
    /// Arguments after `softsense`; `{tmp}` is the case's folder, `{root}` the project's.
    args: &'static [&'static str],
    /// The exit code.
    code: i32,
    /// Words stderr must hold.
    words: &'static [&'static str],
}

fn nothing(_: &Path) {}

/// A probe_side frame with its depth and camera files but no colour image.
fn depth_without_colour(dir: &Path) {
    let src = project_root().join("clouds/scenes/probe_side");
    for f in ["depth_0000.png", "intrinsics.json", "camera_pose.json"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
}

/// A scene file with one probe, `load` replacing its load's lines.
fn scene_with_load(dir: &Path, load: &str) {
    let model = project_root().join("meshes/models/robot.toml");
    let text = format!(
        "model = {:?}\nseed = 1\n[[frames]]\n[[frames.loads]]\nkind = \"probe\"\n{load}\n",
        model.display().to_string()
    );
    std::fs::write(dir.join("scene.toml"), text).unwrap();
}

/// The positioning scenario with `from` replaced by `to`.
fn scenario(dir: &Path, file: &str, from: &str, to: &str) {
    let src = project_root().join("scenarios/control").join(file);
    let text = std::fs::read_to_string(src).unwrap();
    let model = project_root().join("meshes/models/robot.toml");
    let text = text
        .replace(
            "\"../../meshes/models/robot.toml\"",
            &format!("{:?}", model.display().to_string()),
        )
        .lines()
        .map(|l| match l.trim_start().starts_with(from) {
            true => to.to_string(),
            false => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.join("scenario.toml"), text).unwrap();
}

/// A ROS 2 bag of one 80x60 depth and colour frame, as `run.mcap`, with the depth image
/// `width` pixels wide and its camera info `info_width`.
fn bag(dir: &Path, width: u32, info_width: u32) {
    let w = Wire::Cdr;
    let k = [100.0, 0.0, 40.0, 0.0, 100.0, 30.0, 0.0, 0.0, 1.0];
    let n = (width * 60) as usize;
    let messages = vec![
        (
            "/cam/depth/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [info_width, 60], k),
        ),
        (
            "/cam/color/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [80, 60], k),
        ),
        (
            "/cam/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [width, 60], "16UC1", &pixels_u16(&vec![1000; n])),
        ),
        (
            "/cam/color/image_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [80, 60], "rgb8", &[9; 80 * 60 * 3]),
        ),
    ];
    std::fs::write(dir.join("run.mcap"), mcap(&messages, "")).unwrap();
}

/// The bag of [`bag`] cut in the middle.
fn cut_bag(dir: &Path) {
    bag(dir, 80, 80);
    let b = std::fs::read(dir.join("run.mcap")).unwrap();
    std::fs::write(dir.join("run.mcap"), &b[..b.len() / 2]).unwrap();
}

const CASES: &[Case] = &[
    Case {
        did: "sense was given a scene file instead of a recording folder",
        setup: nothing,
        args: &[
            "sense",
            "{root}/clouds/scenes/probe_side.toml",
            "--model",
            "{root}/meshes/models/robot.toml",
        ],
        code: 2,
        words: &[
            "probe_side.toml",
            "not a recording folder",
            "scene generate",
        ],
    },
    Case {
        did: "sense was given a recording folder that is not there",
        setup: nothing,
        args: &[
            "sense",
            "{tmp}/nothere",
            "--model",
            "{root}/meshes/models/robot.toml",
        ],
        code: 2,
        words: &["nothere", "no such folder"],
    },
    Case {
        did: "sense was given a cloud as its model",
        setup: nothing,
        args: &[
            "sense",
            "{root}/clouds/scenes/probe_side",
            "--model",
            "{root}/clouds/demo_scene.pcd",
        ],
        code: 2,
        words: &["demo_scene.pcd", "not a model file", "TOML"],
    },
    Case {
        did: "calibrate was given its model and recording swapped",
        setup: nothing,
        args: &[
            "calibrate",
            "{root}/meshes/models/robot.toml",
            "{root}/clouds/scenes/calib",
        ],
        code: 2,
        words: &["calib", "is a folder", "wrong order"],
    },
    Case {
        did: "explain was given its model and recording swapped",
        setup: nothing,
        args: &[
            "explain",
            "{root}/clouds/scenes/probe_side",
            "{root}/meshes/models/robot.toml",
        ],
        code: 2,
        words: &["probe_side", "is a folder", "wrong order"],
    },
    Case {
        did: "sense was given a recording with depth but no colour",
        setup: depth_without_colour,
        args: &[
            "sense",
            "{tmp}",
            "--model",
            "{root}/meshes/models/robot.toml",
        ],
        code: 1,
        words: &["no colour images", "--colour-topic"],
    },
    Case {
        did: "filter was given a negative voxel leaf",
        setup: nothing,
        args: &[
            "filter",
            "{root}/clouds/demo_scene.pcd",
            "{tmp}/out.pcd",
            "--voxel",
            "-0.01",
        ],
        code: 2,
        words: &["--voxel", "positive length in metres", "-0.01"],
    },
    Case {
        did: "filter was given a voxel leaf of 1000 m",
        setup: nothing,
        args: &[
            "filter",
            "{root}/clouds/demo_scene.pcd",
            "{tmp}/out.pcd",
            "--voxel",
            "1000",
        ],
        code: 0,
        words: &["warning", "--voxel 1000", "of 76800 points", "in metres"],
    },
    Case {
        did: "scene generate was given a load of radius 0",
        setup: |d| {
            scene_with_load(
                d,
                "at = [0.0572, -0.0132, 0.1]\nforce = [0, 0.5, 0]\nradius = 0.0",
            )
        },
        args: &["scene", "generate", "{tmp}/scene.toml", "{tmp}/rec"],
        code: 1,
        words: &["scene.toml", "[[frames.loads]] 0", "radius = 0", "positive"],
    },
    Case {
        did: "scene generate was given an infinite force",
        setup: |d| scene_with_load(d, "at = [0.0572, -0.0132, 0.1]\nforce = [0, inf, 0]"),
        args: &["scene", "generate", "{tmp}/scene.toml", "{tmp}/rec"],
        code: 1,
        words: &["scene.toml", "force = [0.0, inf, 0.0]", "finite"],
    },
    Case {
        did: "control was given a plant a million times softer",
        setup: |d| {
            scenario(
                d,
                "positioning_open.toml",
                "young_factor",
                "young_factor = 1e-6",
            )
        },
        args: &["control", "{tmp}/scenario.toml", "--out", "{tmp}/out"],
        code: 1,
        words: &["scenario.toml", "plant.young_factor", "inverted"],
    },
    Case {
        did: "control was given an infinite position offset",
        setup: |d| {
            scenario(
                d,
                "positioning_open.toml",
                "offset_mm",
                "offset_mm = [inf, 0, 0]",
            )
        },
        args: &["control", "{tmp}/scenario.toml", "--out", "{tmp}/out"],
        code: 1,
        words: &["scenario.toml", "task.offset_mm", "finite"],
    },
    Case {
        did: "control was given 1e300 rad a step",
        setup: |d| scenario(d, "follow.toml", "rad_per_step", "rad_per_step = 1e300"),
        args: &["control", "{tmp}/scenario.toml", "--out", "{tmp}/out"],
        code: 1,
        words: &["scenario.toml", "task.rad_per_step", "at most"],
    },
    Case {
        did: "import was given a bag cut in the middle",
        setup: cut_bag,
        args: &["import", "{tmp}/run.mcap", "{tmp}/rec"],
        code: 1,
        words: &["run.mcap", "truncated"],
    },
    Case {
        did: "import was given the depth topic as --colour-topic",
        setup: |d| bag(d, 80, 80),
        args: &[
            "import",
            "{tmp}/run.mcap",
            "{tmp}/rec",
            "--colour-topic",
            "/cam/depth/image_rect_raw",
        ],
        code: 1,
        words: &["run.mcap", "--colour-topic", "16UC1", "colour image topic"],
    },
    Case {
        did: "import was given a depth image zero pixels wide",
        setup: |d| bag(d, 0, 80),
        args: &["import", "{tmp}/run.mcap", "{tmp}/rec"],
        code: 1,
        words: &["run.mcap", "/cam/depth/image_rect_raw", "0x60"],
    },
    Case {
        did: "import was given a depth camera and image zero pixels wide",
        setup: |d| bag(d, 0, 0),
        args: &["import", "{tmp}/run.mcap", "{tmp}/rec"],
        code: 1,
        words: &[
            "run.mcap",
            "/cam/depth/image_rect_raw",
            "0x60",
            "nothing to import",
        ],
    },
];

#[test]
fn every_message_names_what_is_wrong_and_the_fix_with_its_exit_code() {
    let root = project_root().display().to_string();
    let mut wrong = Vec::new();
    for case in CASES {
        let dir = tempfile::tempdir().unwrap();
        (case.setup)(dir.path());
        let tmp = dir.path().display().to_string();
        let args: Vec<String> = (case.args.iter())
            .map(|a| a.replace("{tmp}", &tmp).replace("{root}", &root))
            .collect();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let missing: Vec<&&str> = case.words.iter().filter(|w| !err.contains(**w)).collect();
        if out.status.code() != Some(case.code) || !missing.is_empty() {
            wrong.push(format!(
                "{}: exit {:?} (want {}), missing {missing:?}\n{err}",
                case.did,
                out.status.code(),
                case.code
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n---\n"));
}

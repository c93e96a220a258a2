//! Mutation fuzzing of the inputs added in wave 2 (issue 52): bags (rosbag v1 plain and
//! lz4, MCAP, sqlite3), the messages inside them (CameraInfo, RealSense tf, Image) wrapped
//! in a valid container so the message decoders see the damage, marker track and
//! candidate CSVs, control scenarios, and rig folders whose structure is damaged (files
//! gone, cameras symlinked or empty, JSON mutated). Each gets `CASES` seeded cases; errors
//! are fine, a panic is not.

use crate::common::bags::{db3, image_msg, info_msg, mcap, pixels_u16, rosbag1, transform_msg};
use crate::common::project_root;
use crate::mutation_fuzz::{fuzz_with, mutate, Rng, CASES};
use softsense::recording::import::msg::Wire;
use softsense::recording::import::{import, ImportParams};
use std::path::Path;

type Messages = Vec<(&'static str, &'static str, Vec<u8>)>;

const K: [f64; 9] = [100.0, 0.0, 1.5, 0.0, 100.0, 1.0, 0.0, 0.0, 1.0];

/// A RealSense-style 4x3 camera: camera infos, depth-to-colour transforms and two frames,
/// on `wire` (ROS 1 topic names and types either way; CDR for MCAP and sqlite3).
fn camera(wire: Wire) -> Messages {
    let (info, image, tf) = match wire {
        Wire::Ros1 => (
            "sensor_msgs/CameraInfo",
            "sensor_msgs/Image",
            "geometry_msgs/Transform",
        ),
        Wire::Cdr => (
            "sensor_msgs/msg/CameraInfo",
            "sensor_msgs/msg/Image",
            "geometry_msgs/msg/Transform",
        ),
    };
    let mut m: Messages = vec![
        (
            "/device_0/sensor_0/Depth_0/info/camera_info",
            info,
            info_msg(wire, [4, 3], K),
        ),
        (
            "/device_0/sensor_1/Color_0/info/camera_info",
            info,
            info_msg(wire, [4, 3], K),
        ),
        (
            "/device_0/sensor_0/Depth_0/tf/0",
            tf,
            transform_msg([0.0; 3], [0.0, 0.0, 0.0, 1.0]),
        ),
        (
            "/device_0/sensor_1/Color_0/tf/0",
            tf,
            transform_msg([0.01, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
        ),
    ];
    for i in 0..2u16 {
        let t = i64::from(i) * 33_000_000;
        m.push((
            "/device_0/sensor_0/Depth_0/image/data",
            image,
            image_msg(wire, t, [4, 3], "16UC1", &pixels_u16(&[1000 + i; 12])),
        ));
        m.push((
            "/device_0/sensor_1/Color_0/image/data",
            image,
            image_msg(wire, t, [4, 3], "rgb8", &[5; 36]),
        ));
    }
    m
}

/// Imports `bag` into a fresh folder beside it; the folder is removed first.
fn import_bag(bag: &Path) -> Result<(), String> {
    let out = bag.with_extension("out");
    let _ = std::fs::remove_dir_all(&out);
    let r = import(bag, &out, &ImportParams::default(), &mut |_, _| {});
    r.map(drop).map_err(|e| e.to_string())
}

/// Cases of `label`, with the number run and the panics, pushed onto the tallies.
struct Tally {
    counts: Vec<String>,
    panics: Vec<String>,
}

impl Tally {
    fn add(&mut self, label: &str, (n, p): (usize, Vec<String>)) {
        self.counts.push(format!("{label} {n}"));
        self.panics.extend(p);
    }
}

#[test]
fn no_bag_reader_panics_on_a_thousand_mutations_of_each_container_and_message() {
    let tmp = tempfile::tempdir().unwrap();
    let mut t = Tally {
        counts: vec![],
        panics: vec![],
    };
    let started = std::time::Instant::now();
    // Whole containers.
    let ros1 = camera(Wire::Ros1);
    let cdr = camera(Wire::Cdr);
    let rosbags = [rosbag1(&ros1, "none"), rosbag1(&ros1, "lz4")];
    let work = tmp.path().join("case.bag");
    let make = |case: usize, rng: &mut Rng| mutate(&rosbags[case % 2], rng);
    t.add(
        "rosbag1",
        fuzz_with("rosbag1", &make, &work, 9100, &import_bag),
    );
    let valid = mcap(&cdr, "");
    let work = tmp.path().join("case.mcap");
    let make = |_: usize, rng: &mut Rng| mutate(&valid, rng);
    t.add("mcap", fuzz_with("mcap", &make, &work, 9101, &import_bag));
    let seed_db3 = tmp.path().join("seed.db3");
    db3(&seed_db3, &cdr);
    let valid = std::fs::read(&seed_db3).unwrap();
    let work = tmp.path().join("case.db3");
    let make = |_: usize, rng: &mut Rng| mutate(&valid, rng);
    t.add("db3", fuzz_with("db3", &make, &work, 9102, &import_bag));
    // One kind of message mutated inside a valid container, ROS 1 and CDR in turn.
    for (k, kind) in ["CameraInfo", "Transform", "Image"].iter().enumerate() {
        let work = tmp.path().join(format!("{kind}.bag"));
        let make = |case: usize, rng: &mut Rng| {
            let base = if case % 2 == 0 { &ros1 } else { &cdr };
            let hit = (base.iter()).filter(|m| m.1.ends_with(kind)).count().max(1);
            let pick = rng.below(hit);
            let mut messages = base.clone();
            if let Some(m) = messages
                .iter_mut()
                .filter(|m| m.1.ends_with(kind))
                .nth(pick)
            {
                m.2 = mutate(&m.2, rng);
            }
            match case % 2 {
                0 => rosbag1(&messages, "none"),
                _ => mcap(&messages, ""),
            }
        };
        // Both containers are written to one path: the reader tells them by their magic.
        t.add(
            kind,
            fuzz_with(kind, &make, &work, 9110 + k as u64, &import_bag),
        );
    }
    report("bag", &t, started);
}

/// A Motive export of two markers over two frames, in millimetres.
const MOTIVE: &str =
    "Format Version,1.23,Take Name,Take 1,Length Units,Millimeters,Coordinate Space,Global\n\
\n\
,,Marker,Marker,Marker,Marker,Marker,Marker\n\
,Name,sheet:m1,sheet:m1,sheet:m1,sheet:m2,sheet:m2,sheet:m2\n\
,,Position,Position,Position,Position,Position,Position\n\
Frame,Time (Seconds),X,Y,Z,X,Y,Z\n\
0,0.000,10.0,20.0,30.0,1,2,3\n\
1,0.010,11.0,21.0,31.0,,,\n";

#[test]
fn no_marker_csv_scenario_or_rig_reader_panics_on_a_thousand_mutations() {
    use softsense::recording::tracks::{read_motive, read_tracks};
    let tmp = tempfile::tempdir().unwrap();
    let root = project_root();
    let mut t = Tally {
        counts: vec![],
        panics: vec![],
    };
    let started = std::time::Instant::now();
    let text = |p: &str| std::fs::read(root.join(p)).unwrap();
    let tracks = [
        text("clouds/markers/robot/tracks.csv"),
        text("clouds/markers/sheet/tracks.csv"),
    ];
    let work = tmp.path().join("tracks.csv");
    let make = |case: usize, rng: &mut Rng| mutate(&tracks[case % 2], rng);
    let read = |p: &Path| read_tracks(p).map(drop).map_err(|e| e.to_string());
    t.add("tracks", fuzz_with("tracks", &make, &work, 9200, &read));
    let motive = MOTIVE.as_bytes().to_vec();
    let make = |_: usize, rng: &mut Rng| mutate(&motive, rng);
    let read = |p: &Path| read_motive(p).map(drop).map_err(|e| e.to_string());
    t.add("motive", fuzz_with("motive", &make, &work, 9201, &read));
    let model =
        softsense::fem::model::Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let mesh = model.problem.mesh.clone();
    let candidates = [
        text("meshes/models/robot_candidates.csv"),
        text("clouds/markers/sheet/candidates.csv"),
    ];
    let work = tmp.path().join("candidates.csv");
    let make = |case: usize, rng: &mut Rng| mutate(&candidates[case % 2], rng);
    let read = |p: &Path| {
        let r = softsense::markers::bind::read_candidates(p, &mesh);
        r.map(drop).map_err(|e| e.to_string())
    };
    t.add(
        "candidates",
        fuzz_with("candidates", &make, &work, 9202, &read),
    );
    // Scenarios in a folder beside a copy of the model path they name.
    let scenarios: Vec<Vec<u8>> = ["positioning.toml", "follow.toml", "switched.toml"]
        .iter()
        .map(|f| text(&format!("scenarios/control/{f}")))
        .collect();
    let work = tmp.path().join("scenario.toml");
    let make = |case: usize, rng: &mut Rng| mutate(&scenarios[case % 3], rng);
    let read = |p: &Path| {
        let s = softsense::control::scenario::Scenario::load(p).map_err(|e| e.to_string())?;
        let _ = s.controller_model();
        Ok(())
    };
    t.add("scenario", fuzz_with("scenario", &make, &work, 9203, &read));
    t.add("rig", fuzz_rigs(tmp.path()));
    report("csv, scenario and rig", &t, started);
}

/// `CASES` rig folders of two probe_side cameras, each damaged by one to three random
/// structural edits, opened and read frame by frame.
fn fuzz_rigs(tmp: &Path) -> (usize, Vec<String>) {
    let scene = project_root().join("clouds/scenes/probe_side");
    let files = [
        "intrinsics.json",
        "camera_pose.json",
        "depth_0000.png",
        "color_0000.png",
    ];
    let mut rng = Rng(9300);
    let mut panics = Vec::new();
    for case in 0..CASES {
        let dir = tmp.join(format!("rig{}", case % 4));
        let _ = std::fs::remove_dir_all(&dir);
        for cam in ["a", "b"] {
            std::fs::create_dir_all(dir.join(cam)).unwrap();
            for f in files {
                std::fs::copy(scene.join(f), dir.join(cam).join(f)).unwrap();
            }
        }
        for f in ["actuators.json", "truth.json"] {
            std::fs::copy(scene.join(f), dir.join(f)).unwrap();
        }
        let edits: Vec<String> = (0..1 + rng.below(3))
            .map(|_| damage(&dir, &mut rng))
            .collect();
        let read = || -> Result<(), String> {
            let rig = softsense::recording::Rig::open(&dir).map_err(|e| e.to_string())?;
            for c in &rig.cameras {
                for &f in &rig.frames {
                    let _ = c.recording.read_frame(f);
                    let _ = c.recording.inputs_of(f);
                    let _ = c.recording.truth_of(f);
                }
            }
            Ok(())
        };
        if std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)).is_err() {
            panics.push(format!("rig case {case} (seed 9300): {}", edits.join("; ")));
        }
    }
    (CASES, panics)
}

/// One random structural edit of the rig `dir`, described.
fn damage(dir: &Path, rng: &mut Rng) -> String {
    let cam = ["a", "b"][rng.below(2)];
    let json = ["intrinsics.json", "camera_pose.json"][rng.below(2)];
    let png = ["depth_0000.png", "color_0000.png"][rng.below(2)];
    match rng.below(8) {
        0 => {
            let _ = std::fs::remove_file(dir.join(cam).join(json));
            format!("{cam}/{json} removed")
        }
        1 => {
            let _ = std::fs::remove_file(dir.join(cam).join(png));
            format!("{cam}/{png} removed")
        }
        2 => {
            let _ = std::os::unix::fs::symlink(dir.join(cam), dir.join("c"));
            format!("c -> {cam}")
        }
        3 => {
            let _ = std::fs::create_dir_all(dir.join("empty"));
            "empty camera folder".into()
        }
        4 => {
            let p = dir.join(cam).join(json);
            if let Ok(b) = std::fs::read(&p) {
                let _ = std::fs::write(&p, mutate(&b, rng));
            }
            format!("{cam}/{json} mutated")
        }
        5 => {
            let _ = std::fs::rename(
                dir.join(cam).join(png),
                dir.join(cam).join(png.replace("0000", "0001")),
            );
            format!("{cam}/{png} renamed to frame 1")
        }
        6 => {
            // A camera pose at the top, where it names no camera.
            let _ = std::fs::copy(
                dir.join(cam).join("camera_pose.json"),
                dir.join("camera_pose.json"),
            );
            "camera_pose.json at the top".into()
        }
        _ => {
            let p = dir.join(cam).join("loop.json");
            let _ = std::os::unix::fs::symlink(&p, &p);
            format!("{cam}/loop.json links to itself")
        }
    }
}

/// Prints the tally and fails on any panic.
fn report(what: &str, t: &Tally, started: std::time::Instant) {
    println!(
        "{what} mutation cases: {} in {:.1} s",
        t.counts.join(", "),
        started.elapsed().as_secs_f64()
    );
    assert!(
        t.panics.is_empty(),
        "{} panics:\n{}",
        t.panics.len(),
        t.panics.join("\n")
    );
}

//! `softsense import`: ROS 2 sqlite3 bags built with rusqlite, and the RealSense
//! depth-to-colour extrinsic, from the hand-made messages of the parent module.

use super::*;

// ---- ROS 2 sqlite3 (.db3) ----

/// The `CameraInfo` messages of two 4x3 cameras with the same `k`.
fn infos(
    w: Wire,
    topics: [&'static str; 2],
    k: [f64; 9],
) -> Vec<(&'static str, &'static str, Vec<u8>)> {
    let ty = match w {
        Wire::Ros1 => "sensor_msgs/CameraInfo",
        Wire::Cdr => "sensor_msgs/msg/CameraInfo",
    };
    topics.map(|t| (t, ty, info_msg(w, [4, 3], k))).to_vec()
}

/// Depth and colour of a 4x3 camera, three frames, the second colour frame dropped.
fn ros2_camera_messages() -> Vec<(&'static str, &'static str, Vec<u8>)> {
    let w = Wire::Cdr;
    let ms = 1_000_000;
    let mut messages = infos(
        w,
        ["/camera/depth/camera_info", "/camera/color/camera_info"],
        K,
    );
    for i in 0..3u16 {
        let t = 2_000 * ms + i64::from(i) * 33 * ms;
        let depth: Vec<u16> = (0..12).map(|p| 600 + 10 * p + i).collect();
        messages.push((
            "/camera/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, t, [4, 3], "16UC1", &pixels_u16(&depth)),
        ));
        if i != 1 {
            let rgb: Vec<u8> = (0..36).map(|p| p as u8 * 7 + i as u8).collect();
            messages.push((
                "/camera/color/image_raw",
                "sensor_msgs/msg/Image",
                image_msg(w, t + ms, [4, 3], "rgb8", &rgb),
            ));
        }
    }
    messages
}

/// Every file of a recording folder, by name.
fn folder_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

#[test]
fn a_ros2_sqlite3_bag_imports_to_the_same_folder_as_the_same_messages_in_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let messages = ros2_camera_messages();
    let mcap_path = dir.path().join("run.mcap");
    std::fs::write(&mcap_path, mcap(&messages, "")).unwrap();
    let bag = dir.path().join("run");
    std::fs::create_dir(&bag).unwrap();
    std::fs::write(bag.join("metadata.yaml"), "rosbag2_bagfile_information: {}").unwrap();
    db3(&bag.join("run_0.db3"), &messages);
    let mut outs = vec![];
    for (name, path) in [
        ("mcap", mcap_path),
        ("folder", bag.clone()),
        ("file", bag.join("run_0.db3")),
    ] {
        let out = dir.path().join(name);
        let summary = import(&path, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
        assert_eq!((summary.frames_written, summary.paired), (2, 2), "{name}");
        assert_eq!(summary.dropped_depth, [1], "{name}");
        outs.push(folder_files(&out));
    }
    assert_eq!(outs[0].len(), 5, "intrinsics and two depth-colour pairs");
    assert!(outs[0] == outs[1] && outs[0] == outs[2]);
    let png = image::open(dir.path().join("file/depth_0002.png"))
        .unwrap()
        .into_luma16();
    assert_eq!(png.get_pixel(1, 0).0[0], 612);
}

#[test]
fn a_corrupt_truncated_or_tableless_db3_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.db3");
    db3(&good, &ros2_camera_messages());
    let bytes = std::fs::read(&good).unwrap();
    let path = dir.path().join("bad.db3");
    let named = |r: Result<_, ImportError>, what: &str| {
        let e = r.expect_err(what);
        assert!(matches!(e, ImportError::Sqlite { .. }), "{what}: {e:?}");
        assert!(e.to_string().contains("bad.db3"), "{what}: {e}");
        e.to_string()
    };
    // Cut inside the messages' pages (the first page, the schema, stays whole).
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    named(read_topics(&path), "truncated");
    // The schema page overwritten past the header.
    let mut broken = bytes.clone();
    broken[100..1000].fill(0xA5);
    std::fs::write(&path, &broken).unwrap();
    named(read_topics(&path), "corrupt");
    // Only the header survives.
    std::fs::write(&path, &bytes[..16]).unwrap();
    named(read_topics(&path), "header only");
    std::fs::remove_file(&path).unwrap();
    rusqlite::Connection::open(&path)
        .unwrap()
        .execute_batch(
            "CREATE TABLE topics(id INTEGER, name TEXT, type TEXT, serialization_format TEXT)",
        )
        .unwrap();
    let text = named(read_topics(&path), "no messages table");
    assert!(text.contains("no `messages` table"), "{text}");
    // A bag without images: the topic error names the bag too.
    std::fs::remove_file(&path).unwrap();
    db3(
        &path,
        &[("/u", "std_msgs/msg/Float32", float32_msg(Wire::Cdr, 0.001))],
    );
    let e = import(
        &path,
        &dir.path().join("o"),
        &ImportParams::default(),
        &mut |_, _| {},
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("bad.db3") && e.contains("no depth image topic") && e.contains("/u ("),
        "{e}"
    );
}

// ---- RealSense depth-to-colour extrinsic ----

#[test]
fn a_realsense_extrinsic_shifts_the_reprojected_depth_by_its_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let w = Wire::Ros1;
    // Both cameras alike (fx 100 px), every depth pixel 1 m away: a 1 cm baseline along x
    // moves the depth image fx * 0.01 / 1 = 1 pixel right in the colour camera.
    let k = [100.0, 0.0, 1.5, 0.0, 100.0, 1.0, 0.0, 0.0, 1.0];
    // Each stream's transform from the reference (depth) holds the same 90° turn about z:
    // it cancels in colour_from_depth, but only when the two are composed in that order
    // (the other order turns the baseline into a vertical shift).
    let turn = [
        0.0,
        0.0,
        std::f64::consts::FRAC_1_SQRT_2,
        std::f64::consts::FRAC_1_SQRT_2,
    ];
    let tf = [
        (
            "/device_0/sensor_0/Depth_0/tf/0",
            "geometry_msgs/Transform",
            transform_msg([0.0; 3], turn),
        ),
        (
            "/device_0/sensor_1/Color_0/tf/0",
            "geometry_msgs/Transform",
            transform_msg([0.01, 0.0, 0.0], turn),
        ),
    ];
    let mut messages = infos(
        w,
        [
            "/device_0/sensor_0/Depth_0/info/camera_info",
            "/device_0/sensor_1/Color_0/info/camera_info",
        ],
        k,
    );
    messages.extend(realsense_4x3_frame());
    messages.extend(tf);
    let bag = dir.path().join("tf.bag");
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    let out = dir.path().join("rec");
    let summary = import(&bag, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
    assert!(
        summary.aligned && summary.warnings.is_empty(),
        "{summary:?}"
    );
    let png = image::open(out.join("depth_0000.png"))
        .unwrap()
        .into_luma16();
    for v in 0..3 {
        let row: Vec<u16> = (0..4).map(|u| png.get_pixel(u, v).0[0]).collect();
        assert_eq!(row, [0, 1000, 1000, 1000], "row {v}");
    }
    // Without the transforms the same cameras need no reprojection at all.
    messages.retain(|m| !m.0.contains("/tf/"));
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    let out = dir.path().join("no_tf");
    let summary = import(&bag, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
    assert!(!summary.aligned);
    let png = image::open(out.join("depth_0000.png"))
        .unwrap()
        .into_luma16();
    assert!(png.pixels().all(|p| p.0[0] == 1000));
}

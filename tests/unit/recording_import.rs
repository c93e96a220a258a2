//! `softsense import`'s readers: ROS 1 and CDR messages, rosbag v1 and MCAP files built by
//! hand byte by byte, the pairing rule, and a whole import.

use softsense::recording::import::msg::{self, Wire};
use softsense::recording::import::{import, pair, Bag, ImportError, ImportParams};
use softsense::recording::Recording;
use std::path::Path;

use crate::common::bags::*;

// ---- message serialisation (the layouts the readers must undo) ----

fn float32_msg(wire: Wire, v: f32) -> Vec<u8> {
    let mut s = Ser::new(wire);
    s.f32(v);
    s.buf
}

const K: [f64; 9] = [500.0, 0.0, 1.5, 0.0, 510.0, 1.0, 0.0, 0.0, 1.0];

#[test]
fn a_ros1_image_decodes_with_its_stamp_size_and_pixels() {
    let data: Vec<u8> = (0..12).collect();
    let buf = image_msg(Wire::Ros1, 5_000_000_123, [3, 2], "16UC1", &data);
    let im = msg::image(&buf, Wire::Ros1).unwrap();
    assert_eq!(im.stamp_ns, 5_000_000_123);
    assert_eq!([im.width, im.height, im.step], [3, 2, 6]);
    assert_eq!(im.encoding, "16UC1");
    assert_eq!(im.data, &data[..]);
}

#[test]
fn a_cdr_camera_info_decodes_across_its_alignment_padding() {
    let buf = info_msg(Wire::Cdr, [4, 3], K);
    let info = msg::camera_info(&buf, Wire::Cdr).unwrap();
    assert_eq!((info.width, info.height, info.k), (4, 3, K));
    let ros1 = info_msg(Wire::Ros1, [4, 3], K);
    assert_eq!(msg::camera_info(&ros1, Wire::Ros1).unwrap().k, K);
    assert_eq!(
        msg::float32(&float32_msg(Wire::Cdr, 0.25), Wire::Cdr).unwrap(),
        0.25
    );
}

#[test]
fn a_truncated_message_is_an_error_at_every_cut() {
    let buf = image_msg(Wire::Cdr, 1, [2, 2], "16UC1", &[1; 8]);
    for cut in 0..buf.len() {
        let r = msg::image(&buf[..cut], Wire::Cdr);
        assert!(
            matches!(r, Err(ImportError::Message { .. })),
            "cut at {cut}: {r:?}"
        );
    }
}

// ---- rosbag v1 ----

fn read_topics(path: &Path) -> Result<Vec<(String, String, usize)>, ImportError> {
    let mut seen = vec![];
    Bag::open(path)?.for_each(&mut |m| {
        seen.push((m.topic.to_string(), m.msg_type.to_string(), m.data.len()));
        Ok(())
    })?;
    Ok(seen)
}

fn some_messages(wire: Wire) -> Vec<(&'static str, &'static str, Vec<u8>)> {
    vec![
        (
            "/d",
            "sensor_msgs/Image",
            image_msg(wire, 1, [1, 1], "16UC1", &[1, 0]),
        ),
        ("/u", "std_msgs/Float32", float32_msg(wire, 0.001)),
        (
            "/d",
            "sensor_msgs/Image",
            image_msg(wire, 2, [1, 1], "16UC1", &[2, 0]),
        ),
    ]
}

#[test]
fn a_rosbag1_gives_its_messages_in_order_uncompressed_and_lz4() {
    let dir = tempfile::tempdir().unwrap();
    for compression in ["none", "lz4"] {
        let path = dir.path().join(format!("{compression}.bag"));
        std::fs::write(&path, rosbag1(&some_messages(Wire::Ros1), compression)).unwrap();
        let seen = read_topics(&path).unwrap();
        let topics: Vec<&str> = seen.iter().map(|s| s.0.as_str()).collect();
        assert_eq!(topics, ["/d", "/u", "/d"], "{compression}");
        assert_eq!(seen[1].1, "std_msgs/Float32");
    }
}

#[test]
fn a_truncated_rosbag1_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let bag = rosbag1(&some_messages(Wire::Ros1), "none");
    let path = dir.path().join("cut.bag");
    for cut in [14, 20, bag.len() / 2, bag.len() - 1] {
        std::fs::write(&path, &bag[..cut]).unwrap();
        let r = read_topics(&path);
        assert!(
            matches!(r, Err(ImportError::Truncated { .. })),
            "cut at {cut}: {r:?}"
        );
    }
}

#[test]
fn a_bz2_chunk_and_a_file_that_is_no_bag_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bz2.bag");
    std::fs::write(&path, rosbag1(&some_messages(Wire::Ros1), "bz2")).unwrap();
    let e = read_topics(&path).unwrap_err();
    assert!(e.to_string().contains("`bz2` are not read"), "{e}");
    let path = dir.path().join("notes.txt");
    std::fs::write(&path, "hello").unwrap();
    assert!(matches!(
        read_topics(&path),
        Err(ImportError::NotABag { .. })
    ));
}

// ---- MCAP ----

#[test]
fn an_mcap_bag_folder_gives_its_cdr_messages_from_plain_lz4_and_zstd_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("bag");
    std::fs::create_dir(&bag).unwrap();
    std::fs::write(bag.join("metadata.yaml"), "rosbag2_bagfile_information: {}").unwrap();
    for compression in ["", "lz4", "zstd"] {
        let file = mcap(&some_messages(Wire::Cdr), compression);
        std::fs::write(bag.join("bag_0.mcap"), file).unwrap();
        let seen = read_topics(&bag).unwrap();
        assert_eq!(seen.len(), 3, "{compression}");
        assert_eq!(seen[0].1, "sensor_msgs/Image", "{compression}");
    }
}

#[test]
fn an_mcap_chunk_of_an_unknown_compression_and_a_cut_file_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bag_0.mcap");
    std::fs::write(&path, mcap(&some_messages(Wire::Cdr), "brotli")).unwrap();
    let e = read_topics(&path).unwrap_err();
    assert!(e.to_string().contains("`brotli` are not read"), "{e}");
    for compression in ["", "zstd"] {
        let full = mcap(&some_messages(Wire::Cdr), compression);
        std::fs::write(&path, &full[..full.len() / 2]).unwrap();
        let r = read_topics(&path);
        assert!(
            matches!(r, Err(ImportError::Truncated { .. })),
            "{compression}: {r:?}"
        );
    }
}

// ---- pairing and a whole import ----

#[test]
fn each_depth_frame_takes_the_nearest_colour_frame_once_within_the_tolerance() {
    let ms = 1_000_000;
    // Colour 1 is missing (dropped); colour 3 is nearer depth 3 than depth 2.
    let depth = [0, 33 * ms, 66 * ms, 100 * ms];
    let colour = [2 * ms, 90 * ms, 98 * ms];
    assert_eq!(
        pair(&depth, &colour, 16 * ms),
        [Some(0), None, None, Some(2)]
    );
    // Depth 2 (66 ms) claims colour at 90 ms only with a wide tolerance, and loses it then
    // to depth 3, which is nearer 98 ms and takes it.
    let colour = [2 * ms, 90 * ms];
    assert_eq!(
        pair(&depth, &colour, 30 * ms),
        [Some(0), None, None, Some(1)]
    );
}

#[test]
fn a_realsense_layout_bag_imports_exactly_with_a_dropped_colour_frame_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let ms = 1_000_000;
    let w = Wire::Ros1;
    let depth = |i: u16| {
        pixels_u16(&[
            500 + i,
            0,
            700,
            800,
            900,
            1000,
            1100,
            1200,
            1300,
            1400,
            1500,
            1600,
        ])
    };
    let rgb: Vec<u8> = (0..36).collect();
    let info = info_msg(w, [4, 3], K);
    let mut messages = vec![
        (
            "/device_0/sensor_0/option/Depth Units/value",
            "std_msgs/Float32",
            float32_msg(w, 0.001),
        ),
        (
            "/device_0/sensor_0/Depth_0/info/camera_info",
            "sensor_msgs/CameraInfo",
            info.clone(),
        ),
        (
            "/device_0/sensor_1/Color_0/info/camera_info",
            "sensor_msgs/CameraInfo",
            info,
        ),
    ];
    for i in 0..3 {
        let t = 1_000 * ms + i64::from(i) * 33 * ms;
        messages.push((
            "/device_0/sensor_0/Depth_0/image/data",
            "sensor_msgs/Image",
            image_msg(w, t, [4, 3], "16UC1", &depth(i)),
        ));
        if i != 1 {
            messages.push((
                "/device_0/sensor_1/Color_0/image/data",
                "sensor_msgs/Image",
                image_msg(w, t + ms, [4, 3], "rgb8", &rgb),
            ));
        }
    }
    // Infrared streams beside them do not make the choice ambiguous.
    let ir8 = image_msg(w, 0, [4, 3], "mono8", &[9; 12]);
    let ir16 = image_msg(w, 0, [4, 3], "mono16", &[9; 24]);
    messages.push((
        "/device_0/sensor_0/Infrared_1/image/data",
        "sensor_msgs/Image",
        ir8,
    ));
    messages.push((
        "/device_0/sensor_0/Infrared_2/image/data",
        "sensor_msgs/Image",
        ir16,
    ));
    let bag = dir.path().join("walk.bag");
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    let out = dir.path().join("rec");
    let summary = import(&bag, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
    assert_eq!((summary.frames_written, summary.paired), (2, 2));
    assert_eq!(summary.dropped_depth, [1]);
    assert!(!summary.aligned);
    assert_eq!(summary.depth_topic, "/device_0/sensor_0/Depth_0/image/data");
    let rec = Recording::open(&out).unwrap();
    assert_eq!(rec.frames, [0, 2]);
    assert_eq!(rec.camera.params.depth_scale, 1000.0);
    let png = image::open(out.join("depth_0002.png"))
        .unwrap()
        .into_luma16();
    assert_eq!(png.get_pixel(0, 0).0[0], 502);
    let c = image::open(out.join("color_0000.png")).unwrap().into_rgb8();
    assert_eq!(c.as_raw(), &rgb);
    // The same bag without colour: every depth frame, depth only, with a warning.
    messages.retain(|m| !m.0.contains("Color_0/image") && !m.0.contains("Infrared"));
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    let out = dir.path().join("depth_only");
    let summary = import(&bag, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
    assert_eq!((summary.frames_written, summary.paired), (3, 0));
    assert!(
        summary.warnings[0].contains("depth only"),
        "{:?}",
        summary.warnings
    );
    assert_eq!(Recording::open(&out).unwrap().frames, [0, 1, 2]);
}

#[test]
fn a_missing_depth_topic_is_an_error_listing_the_topics_present() {
    let dir = tempfile::tempdir().unwrap();
    let w = Wire::Ros1;
    let messages = [(
        "/cam/rgb",
        "sensor_msgs/Image",
        image_msg(w, 0, [1, 1], "rgb8", &[1, 2, 3]),
    )];
    let bag = dir.path().join("c.bag");
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    let e = import(
        &bag,
        &dir.path().join("o"),
        &ImportParams::default(),
        &mut |_, _| {},
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("no depth image topic") && text.contains("/cam/rgb (sensor_msgs/Image)"),
        "{text}"
    );
}

#[test]
fn float_depth_of_another_camera_is_rounded_and_reprojected_into_the_colour_camera() {
    let dir = tempfile::tempdir().unwrap();
    let w = Wire::Cdr;
    // Colour has twice the depth camera's focal length and size: each depth pixel covers
    // a 2x2 block of colour pixels (identity extrinsic, so independent of depth).
    let depth_k = [100.0, 0.0, 0.5, 0.0, 100.0, 0.5, 0.0, 0.0, 1.0];
    let colour_k = [200.0, 0.0, 1.5, 0.0, 200.0, 1.5, 0.0, 0.0, 1.0];
    let metres: Vec<u8> = [0.5f32, f32::NAN, 1.0, 0.25]
        .iter()
        .flat_map(|z| z.to_le_bytes())
        .collect();
    let messages = [
        (
            "/cam/depth/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [2, 2], depth_k),
        ),
        (
            "/cam/color/camera_info",
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, [0, 0], colour_k), // size unset, as some drivers leave it
        ),
        (
            "/cam/depth/image",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [2, 2], "32FC1", &metres),
        ),
        (
            "/cam/color/image",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [4, 4], "bgr8", &[7; 48]),
        ),
    ];
    let bag = dir.path().join("b.mcap");
    std::fs::write(&bag, mcap(&messages, "")).unwrap();
    let out = dir.path().join("rec");
    let summary = import(&bag, &out, &ImportParams::default(), &mut |_, _| {}).unwrap();
    assert!(summary.aligned && summary.warnings[0].contains("identity extrinsic"));
    assert_eq!(summary.depth_unit, 1e-4);
    let png = image::open(out.join("depth_0000.png"))
        .unwrap()
        .into_luma16();
    let row = |v: u32| (0..4).map(|u| png.get_pixel(u, v).0[0]).collect::<Vec<_>>();
    assert_eq!(
        [row(0), row(1)],
        [[5000, 5000, 0, 0], [5000, 5000, 0, 0]].map(Vec::from)
    );
    assert_eq!(
        [row(2), row(3)],
        [[10000, 10000, 2500, 2500], [10000, 10000, 2500, 2500]].map(Vec::from)
    );
    let rec = Recording::open(&out).unwrap();
    assert_eq!(
        (rec.camera.params.depth_scale, rec.camera.intrinsics.fx),
        (10000.0, 200.0)
    );
}

// The ROS 2 sqlite3 reader and the RealSense extrinsic, with the helpers above.
#[path = "recording_import_db3_tf.rs"]
mod db3_tf;

//! `softsense import` on bags that declare implausible cameras or transforms (issue 52).

use crate::common::bags::{
    image_msg, info_msg, mcap, pixels_u16, realsense_4x3_frame, rosbag1, transform_msg,
};
use softsense::recording::import::msg::Wire;
use softsense::recording::import::{import, ImportParams, ImportSummary};
use std::path::Path;

const K: [f64; 9] = [100.0, 0.0, 40.0, 0.0, 100.0, 30.0, 0.0, 0.0, 1.0];
const COLOUR_INFO: &str = "/cam/color/camera_info";
const DEPTH_INFO: &str = "/cam/depth/camera_info";

type Messages = Vec<(&'static str, &'static str, Vec<u8>)>;

/// A ROS 2 camera of 80x60 pixels, one depth and one colour frame at 1 m, with the
/// camera infos given (size and K).
fn ros2_camera(depth_info: ([u32; 2], [f64; 9]), colour_info: ([u32; 2], [f64; 9])) -> Messages {
    let w = Wire::Cdr;
    vec![
        (
            DEPTH_INFO,
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, depth_info.0, depth_info.1),
        ),
        (
            COLOUR_INFO,
            "sensor_msgs/msg/CameraInfo",
            info_msg(w, colour_info.0, colour_info.1),
        ),
        (
            "/cam/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [80, 60], "16UC1", &pixels_u16(&[1000; 4800])),
        ),
        (
            "/cam/color/image_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, 0, [80, 60], "rgb8", &[9; 80 * 60 * 3]),
        ),
    ]
}

/// `messages` written as `run.mcap` in `dir`, and its path.
fn write_mcap(dir: &Path, messages: &Messages) -> std::path::PathBuf {
    let bag = dir.join("run.mcap");
    std::fs::write(&bag, mcap(messages, "")).unwrap();
    bag
}

/// `softsense import` run on `bag` into `out`, with `env` set.
fn run_import(bag: &Path, out: &Path, env: &[(&str, &str)]) -> (Option<i32>, String) {
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
        .envs(env.iter().copied())
        .arg("import")
        .args([bag, out])
        .output()
        .unwrap();
    (
        run.status.code(),
        String::from_utf8_lossy(&run.stderr).into(),
    )
}

/// Until 2026-11-29 a colour CameraInfo saying 60000x60000 for an 80x60 image made the
/// reprojection allocate 7.2 GB before any check: SIGABRT, "memory allocation of
/// 7200000000 bytes failed" (the same mismatch on depth was refused, after writing
/// `intrinsics.json`).
#[test]
fn a_colour_camera_info_of_60000x60000_for_an_80x60_image_aborted_import() {
    let dir = tempfile::tempdir().unwrap();
    let bag = write_mcap(dir.path(), &ros2_camera(([80, 60], K), ([60000, 60000], K)));
    let out = dir.path().join("rec");
    let (code, err) = run_import(&bag, &out, &[]);
    assert_eq!(code, Some(1), "a clean refusal, not a signal: {err}");
    for part in [
        COLOUR_INFO,
        "60000x60000",
        "80x60",
        "--colour-info-topic",
        "run.mcap",
    ] {
        assert!(err.contains(part), "{part}: {err}");
    }
    assert!(!out.join("intrinsics.json").exists(), "nothing written");
    // The depth camera's info is checked alike, before anything is written.
    let bag = write_mcap(dir.path(), &ros2_camera(([640, 480], K), ([80, 60], K)));
    let (code, err) = run_import(&bag, &dir.path().join("rec2"), &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains(DEPTH_INFO) && err.contains("640x480"), "{err}");
    assert!(!dir.path().join("rec2/intrinsics.json").exists());
    // A size that matches its images is still held to the memory budget.
    let bag = write_mcap(dir.path(), &ros2_camera(([80, 60], K), ([80, 60], K)));
    let (code, err) = run_import(
        &bag,
        &dir.path().join("rec3"),
        &[("SOFTSENSE_MAX_MEMORY", "10K")],
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(DEPTH_INFO) && err.contains("memory limit"),
        "{err}"
    );
}

/// Until 2026-11-29 a CameraInfo K of NaN or zeros was written to `intrinsics.json` as
/// `null` or fx = 0, exit 0, and failed only later in `sense`.
#[test]
fn a_nan_or_zero_camera_info_k_was_written_to_intrinsics_json_as_null_or_fx_0() {
    let dir = tempfile::tempdir().unwrap();
    for (name, k) in [("nan", [f64::NAN; 9]), ("zero", [0.0; 9])] {
        let bag = write_mcap(dir.path(), &ros2_camera(([80, 60], k), ([80, 60], K)));
        let out = dir.path().join(name);
        let e = import(&bag, &out, &ImportParams::default(), &mut |_, _| {})
            .expect_err(name)
            .to_string();
        for part in [DEPTH_INFO, "fx", "--depth-info-topic", "run.mcap"] {
            assert!(e.contains(part), "{name}, {part}: {e}");
        }
        assert!(!out.join("intrinsics.json").exists(), "{name}");
    }
}

const DEPTH_TF: &str = "/device_0/sensor_0/Depth_0/tf/0";
const COLOUR_TF: &str = "/device_0/sensor_1/Color_0/tf/0";

/// A RealSense bag of one 4x3 frame at 1 m whose colour stream's transform to the depth
/// stream is `colour_tf` (translation, quaternion), and its import.
fn realsense_with_tf(dir: &Path, name: &str, colour_tf: ([f64; 3], [f64; 4])) -> ImportSummary {
    let w = Wire::Ros1;
    let k = [100.0, 0.0, 1.5, 0.0, 100.0, 1.0, 0.0, 0.0, 1.0];
    let mut messages: Messages = vec![
        (
            "/device_0/sensor_0/Depth_0/info/camera_info",
            "sensor_msgs/CameraInfo",
            info_msg(w, [4, 3], k),
        ),
        (
            "/device_0/sensor_1/Color_0/info/camera_info",
            "sensor_msgs/CameraInfo",
            info_msg(w, [4, 3], k),
        ),
        (
            DEPTH_TF,
            "geometry_msgs/Transform",
            transform_msg([0.0; 3], [0.0, 0.0, 0.0, 1.0]),
        ),
        (
            COLOUR_TF,
            "geometry_msgs/Transform",
            transform_msg(colour_tf.0, colour_tf.1),
        ),
    ];
    messages.extend(realsense_4x3_frame());
    let bag = dir.join(format!("{name}.bag"));
    std::fs::write(&bag, rosbag1(&messages, "none")).unwrap();
    import(
        &bag,
        &dir.join(name),
        &ImportParams::default(),
        &mut |_, _| {},
    )
    .unwrap()
}

/// Until 2026-11-29 a RealSense `tf` with a NaN or zero quaternion, or a NaN
/// translation, was taken as the identity with `"warnings": []`.
#[test]
fn a_nan_or_zero_realsense_tf_quaternion_was_taken_as_the_identity_without_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let unit = [0.0, 0.0, 0.0, 1.0];
    for (name, tf, what) in [
        ("zero_q", ([0.0; 3], [0.0; 4]), "unit quaternion"),
        (
            "nan_q",
            ([0.0; 3], [f64::NAN, 0.0, 0.0, 1.0]),
            "unit quaternion",
        ),
        ("nan_t", ([f64::NAN, 0.0, 0.0], unit), "translation"),
    ] {
        let summary = realsense_with_tf(dir.path(), name, tf);
        let w = summary.warnings.join("\n");
        for part in [COLOUR_TF, what, "identity"] {
            assert!(w.contains(part), "{name}, {part}: {w}");
        }
    }
    // A plausible transform is still read without a word.
    let summary = realsense_with_tf(dir.path(), "ok", ([0.01, 0.0, 0.0], unit));
    assert!(
        summary.aligned && summary.warnings.is_empty(),
        "{summary:?}"
    );
}

/// Until 2026-11-29 a 1e30 m `tf` translation reprojected every depth pixel out of the
/// colour image: frames with no valid depth pixel, exit 0, no warning.
#[test]
fn a_1e30_metre_tf_translation_wrote_frames_without_a_valid_depth_pixel_silently() {
    let dir = tempfile::tempdir().unwrap();
    let summary = realsense_with_tf(dir.path(), "far", ([1e30, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]));
    let w = summary.warnings.join("\n");
    assert!(w.contains(COLOUR_TF) && w.contains("10 m"), "{w}");
    let png = image::open(dir.path().join("far/depth_0000.png"))
        .unwrap()
        .into_luma16();
    assert!(
        png.pixels().all(|p| p.0[0] == 1000),
        "taken as the identity"
    );
}

/// Until 2026-11-29 a frame written without one valid depth pixel was not reported.
#[test]
fn frames_without_a_valid_depth_pixel_were_written_without_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut messages = ros2_camera(([80, 60], K), ([80, 60], K));
    let w = Wire::Cdr;
    for (t, depth) in [(33_000_000, 0), (66_000_000, 1000)] {
        messages.push((
            "/cam/depth/image_rect_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, t, [80, 60], "16UC1", &pixels_u16(&[depth; 4800])),
        ));
        messages.push((
            "/cam/color/image_raw",
            "sensor_msgs/msg/Image",
            image_msg(w, t, [80, 60], "rgb8", &[9; 14400]),
        ));
    }
    let bag = write_mcap(dir.path(), &messages);
    let summary = import(
        &bag,
        &dir.path().join("rec"),
        &ImportParams::default(),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(summary.frames_written, 3);
    let w = summary.warnings.join("\n");
    assert!(
        w.contains("without a valid depth pixel") && w.contains("frames 1 of /cam/depth"),
        "{w}"
    );
}

/// Until 2026-11-29 an lz4 chunk was decompressed whatever it declared or expanded to:
/// a few kilobytes of LZ4 can stand for gigabytes. The declared size is now held to the
/// memory budget, and a chunk expanding past its declared size is refused.
#[test]
fn an_lz4_chunk_was_decompressed_without_a_look_at_its_declared_size() {
    let dir = tempfile::tempdir().unwrap();
    let depth = (
        "/cam/depth/image_rect_raw",
        "sensor_msgs/Image",
        image_msg(Wire::Ros1, 0, [80, 60], "16UC1", &[0; 9600]),
    );
    let bag = dir.path().join("zip.bag");
    let bytes = rosbag1(&[depth], "lz4");
    std::fs::write(&bag, &bytes).unwrap();
    let (code, err) = run_import(
        &bag,
        &dir.path().join("a"),
        &[("SOFTSENSE_MAX_MEMORY", "8K")],
    );
    assert_eq!(code, Some(1), "{err}");
    for part in ["zip.bag", "lz4 chunk declares", "memory limit"] {
        assert!(err.contains(part), "{part}: {err}");
    }
    // The chunk header's uncompressed size made a lie: 100 bytes.
    let at = bytes.windows(5).position(|w| w == b"size=").unwrap() + 5;
    let mut lying = bytes.clone();
    lying[at..at + 4].copy_from_slice(&100u32.to_le_bytes());
    std::fs::write(&bag, &lying).unwrap();
    let (code, err) = run_import(&bag, &dir.path().join("b"), &[]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("more than the 100 bytes"), "{err}");
}

/// A rosbag chunk that decompressed (or, uncompressed, held) fewer bytes than its header
/// declared was taken as it was: the records it lost were dropped without a word.
#[test]
fn a_rosbag_chunk_shorter_than_its_declared_size_was_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let depth = (
        "/cam/depth/image_rect_raw",
        "sensor_msgs/Image",
        image_msg(Wire::Ros1, 0, [80, 60], "16UC1", &[0; 9600]),
    );
    for compression in ["lz4", "none"] {
        let bytes = rosbag1(std::slice::from_ref(&depth), compression);
        let at = bytes.windows(5).position(|w| w == b"size=").unwrap() + 5;
        let declared = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let mut lying = bytes.clone();
        lying[at..at + 4].copy_from_slice(&(declared + 7).to_le_bytes());
        let bag = dir.path().join(format!("{compression}.bag"));
        std::fs::write(&bag, &lying).unwrap();
        let (code, err) = run_import(&bag, &dir.path().join(compression), &[]);
        assert_eq!(code, Some(1), "{compression}: {err}");
        let says = format!(
            "chunk of {declared} bytes, its header says {}",
            declared + 7
        );
        for part in [format!("{compression}.bag"), says] {
            assert!(err.contains(&part), "{compression}: {part}: {err}");
        }
    }
}

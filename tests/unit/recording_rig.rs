//! Recordings of several cameras: camera sub-folders tied by frame number, shared files at
//! the top, and the errors that name the camera.

use image::{ImageBuffer, Luma, Rgb};
use softsense::recording::{Recording, RecordingError, Rig};
use std::path::Path;

const POSE: &str = r#"{"robot_from_camera": [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#;

fn intrinsics(depth_scale: f64) -> String {
    format!(
        r#"{{"width": 4, "height": 3, "intrinsic_matrix": [500, 0, 0, 0, 500, 0, 1.5, 1, 1], "depth_scale": {depth_scale}}}"#
    )
}

/// A softsense-layout camera folder with frames `numbers` (depth = 500 + number units).
fn camera_folder(dir: &Path, numbers: &[usize], depth_scale: f64) {
    std::fs::create_dir_all(dir).unwrap();
    for &n in numbers {
        ImageBuffer::<Luma<u16>, _>::from_fn(4, 3, |_, _| Luma([500 + n as u16]))
            .save(dir.join(format!("depth_{n:04}.png")))
            .unwrap();
        ImageBuffer::<Rgb<u8>, _>::from_fn(4, 3, |_, _| Rgb([40, 200, 60]))
            .save(dir.join(format!("color_{n:04}.png")))
            .unwrap();
    }
    std::fs::write(dir.join("intrinsics.json"), intrinsics(depth_scale)).unwrap();
}

/// A rig of cameras `left` (frames 0, 1, 3; millimetres) and `right` (frames 1, 2, 3;
/// tenths of a millimetre), each with a pose, and `actuators.json` at the top.
fn two_camera_rig(dir: &Path) {
    camera_folder(&dir.join("left"), &[0, 1, 3], 1000.0);
    camera_folder(&dir.join("right"), &[1, 2, 3], 10000.0);
    for name in ["left", "right"] {
        std::fs::write(dir.join(name).join("camera_pose.json"), POSE).unwrap();
    }
    let cable = r#"[{"name": "north", "displacement_controlled": true, "shortening": 0.01, "tension": 4.0}]"#;
    let actuators = format!("[{cable}, {cable}, {cable}, {cable}]");
    std::fs::write(dir.join("actuators.json"), actuators).unwrap();
}

#[test]
fn cameras_with_different_frames_make_a_rig_of_their_union() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    let rig = Rig::open(dir.path()).unwrap();
    assert!(!rig.is_one_folder());
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["left", "right"]);
    assert_eq!(rig.frames, [0, 1, 2, 3]);
    let left = rig.camera("left").unwrap();
    let right = rig.camera("right").unwrap();
    assert_eq!(
        [0, 1, 2, 3].map(|f| left.has_frame(f)),
        [true, true, false, true]
    );
    assert_eq!(
        [0, 1, 2, 3].map(|f| right.has_frame(f)),
        [false, true, true, true]
    );
    let with_2: Vec<&str> = rig.cameras_with(2).map(|c| c.name.as_str()).collect();
    assert_eq!(with_2, ["right"]);
    // Each camera keeps its own depth unit and pose; the inputs are the top's.
    assert!((left.recording.camera.params.depth_scale - 1000.0).abs() < 1e-9);
    assert!((right.recording.camera.params.depth_scale - 10000.0).abs() < 1e-9);
    for c in &rig.cameras {
        assert!(c.recording.robot_from_camera.is_some());
        assert_eq!(c.recording.inputs_of(2).unwrap().cables.len(), 1);
    }
    // Frame 1's depth is 501 units in both: 0.501 m and 0.0501 m.
    let z =
        |c: &softsense::recording::RigCamera| c.recording.read_frame(1).unwrap().positions[0][2];
    assert!((z(left) - 0.501).abs() < 1e-6);
    assert!((z(right) - 0.0501).abs() < 1e-6);
}

#[test]
fn selecting_frames_of_a_rig_keeps_each_camera_its_own_and_refuses_a_frame_none_has() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    let rig = Rig::open(dir.path()).unwrap().select(&[0, 2]).unwrap();
    assert_eq!(rig.frames, [0, 2]);
    assert_eq!(rig.camera("left").unwrap().recording.frames, [0]);
    assert_eq!(rig.camera("right").unwrap().recording.frames, [2]);
    let err = Rig::open(dir.path()).unwrap().select(&[7]).unwrap_err();
    assert!(
        matches!(err, RecordingError::NoSuchFrame { frame: 7, .. }),
        "{err}"
    );
}

#[test]
fn a_folder_with_frames_of_its_own_opens_as_a_rig_of_one_camera() {
    let dir = tempfile::tempdir().unwrap();
    camera_folder(dir.path(), &[0, 2], 1000.0);
    std::fs::write(dir.path().join("camera_pose.json"), POSE).unwrap();
    // A sub-folder with frames beside the top's own frames is not a camera.
    camera_folder(&dir.path().join("extra"), &[5], 1000.0);
    let rig = Rig::open(dir.path()).unwrap();
    assert!(rig.is_one_folder());
    assert_eq!(rig.cameras.len(), 1);
    assert_eq!(rig.cameras[0].name, "camera");
    assert_eq!(rig.frames, [0, 2]);
    let alone = Recording::open(dir.path()).unwrap();
    assert_eq!(rig.cameras[0].recording.frames, alone.frames);
    assert_eq!(
        rig.cameras[0].recording.robot_from_camera,
        alone.robot_from_camera
    );
}

#[test]
fn opening_a_rig_folder_as_one_camera_names_its_cameras() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    let err = Recording::open(dir.path()).unwrap_err();
    let RecordingError::SeveralCameras { cameras, .. } = &err else {
        panic!("expected SeveralCameras, got {err}");
    };
    assert_eq!(cameras, &["left", "right"]);
    let message = err.to_string();
    assert!(
        message.contains("2-camera recording") && message.contains("left, right"),
        "{message}"
    );
}

#[test]
fn a_camera_folder_that_cannot_be_read_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    std::fs::remove_file(dir.path().join("right/intrinsics.json")).unwrap();
    let err = Rig::open(dir.path()).unwrap_err();
    let RecordingError::Camera { name, source } = &err else {
        panic!("expected Camera, got {err}");
    };
    assert_eq!(name, "right");
    assert!(
        matches!(**source, RecordingError::NoCamera { .. }),
        "{source}"
    );
    assert!(err.to_string().starts_with("camera right: "), "{err}");
    // A pose that is not rigid fails when the camera is read, also naming it.
    two_camera_rig(dir.path());
    let sheared = r#"{"robot_from_camera": [[1,0.5,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#;
    std::fs::write(dir.path().join("left/camera_pose.json"), sheared).unwrap();
    let err = Rig::open(dir.path()).unwrap_err();
    assert!(err.to_string().starts_with("camera left: "), "{err}");
}

#[test]
fn a_folder_without_any_camera_is_the_no_frames_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("notes")).unwrap();
    std::fs::write(dir.path().join("notes/readme.txt"), "x").unwrap();
    let err = Rig::open(dir.path()).unwrap_err();
    assert!(matches!(err, RecordingError::NoFrames { .. }), "{err}");
    let err = Recording::open(dir.path()).unwrap_err();
    assert!(matches!(err, RecordingError::NoFrames { .. }), "{err}");
}

#[test]
fn a_pose_at_the_top_of_a_rig_is_refused_but_its_cable_calibration_is_shared() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    let top = dir.path().join("calibration.json");
    std::fs::write(&top, POSE).unwrap();
    let err = Rig::open(dir.path()).unwrap_err();
    assert!(
        matches!(err, RecordingError::RigPose { cameras: 2, .. }),
        "{err}"
    );
    let calibration = r#"{"actuators": [{"name": "north", "shortening": 0.02, "tension": 5.0}]}"#;
    std::fs::write(&top, calibration).unwrap();
    let rig = Rig::open(dir.path()).unwrap();
    for c in &rig.cameras {
        let calibrated = c.recording.calibrated.as_ref().unwrap();
        assert!((calibrated[0].shortening - 0.02).abs() < 1e-12);
    }
}

#[cfg(unix)]
#[test]
fn camera_folders_that_resolve_to_the_same_folder_are_one_camera_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    two_camera_rig(dir.path());
    // `a_copy` sorts first but is the link: the real folder keeps its name.
    std::os::unix::fs::symlink(dir.path().join("left"), dir.path().join("a_copy")).unwrap();
    std::os::unix::fs::symlink(dir.path().join("right"), dir.path().join("z_copy")).unwrap();
    let rig = Rig::open(dir.path()).unwrap();
    assert_eq!(rig.camera_names(), ["left", "right"]);
    let warned: Vec<&String> = (rig.warnings.iter())
        .filter(|w| w.contains("same folder"))
        .collect();
    assert_eq!(warned.len(), 2, "{:?}", rig.warnings);
    assert!(warned[0].contains("cameras left and a_copy"), "{warned:?}");
    assert!(warned[1].contains("cameras right and z_copy"), "{warned:?}");
    // Two links to one folder outside the rig: the first by name is kept.
    let outside = tempfile::tempdir().unwrap();
    camera_folder(&outside.path().join("cam"), &[0], 1000.0);
    std::fs::write(outside.path().join("cam/camera_pose.json"), POSE).unwrap();
    let rig_dir = tempfile::tempdir().unwrap();
    for name in ["b", "a"] {
        std::os::unix::fs::symlink(outside.path().join("cam"), rig_dir.path().join(name)).unwrap();
    }
    let rig = Rig::open(rig_dir.path()).unwrap();
    assert_eq!(rig.camera_names(), ["a"]);
    assert!(
        rig.warnings.iter().any(|w| w.contains("cameras a and b")),
        "{:?}",
        rig.warnings
    );
}

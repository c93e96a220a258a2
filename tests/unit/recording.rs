//! The recording reader: its three layouts, optional files, poses and errors.

use image::{ImageBuffer, Luma, Rgb};
use softsense::recording::{Layout, Recording, RecordingError};
use std::path::Path;

const INTRINSICS: &str = r#"{"width": 4, "height": 3, "intrinsic_matrix": [500, 0, 0, 0, 500, 0, 1.5, 1, 1], "depth_scale": 1000.0}"#;
const POSE: &str = r#"{"robot_from_camera": [[1,0,0,0.1],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#;

fn depth(path: &Path, mm: u16) {
    ImageBuffer::<Luma<u16>, _>::from_fn(4, 3, |_, _| Luma([mm]))
        .save(path)
        .unwrap();
}

fn color(path: &Path) {
    ImageBuffer::<Rgb<u8>, _>::from_fn(4, 3, |_, _| Rgb([40, 200, 60]))
        .save(path)
        .unwrap();
}

/// A softsense-layout folder with frames `numbers` (depth = 500 + number mm).
fn softsense_folder(dir: &Path, numbers: &[usize]) {
    for &n in numbers {
        depth(&dir.join(format!("depth_{n:04}.png")), 500 + n as u16);
        color(&dir.join(format!("color_{n:04}.png")));
    }
    std::fs::write(dir.join("intrinsics.json"), INTRINSICS).unwrap();
}

fn pcl_camera_xml(fx: f64) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<depth>\n<focal_length_x>{fx}</focal_length_x>\n\
         <focal_length_y>{fx}</focal_length_y>\n<principal_point_x>1.5</principal_point_x>\n\
         <principal_point_y>1</principal_point_y>\n</depth>\n"
    )
}

#[test]
fn a_softsense_folder_lists_its_frames_by_number_with_an_optional_pose() {
    let dir = tempfile::tempdir().unwrap();
    softsense_folder(dir.path(), &[10, 2, 7]);
    let rec = Recording::open(dir.path()).unwrap();
    assert_eq!(rec.layout, Layout::Softsense);
    assert_eq!(rec.frames, vec![2, 7, 10]);
    assert!(rec.robot_from_camera.is_none() && rec.pose_file.is_none());
    let cloud = rec.read_frame(7).unwrap();
    assert_eq!((cloud.width, cloud.height), (4, 3));
    assert!((cloud.positions[0][2] - 0.507).abs() < 1e-6);
    assert!(matches!(
        rec.read_frame(3),
        Err(RecordingError::NoSuchFrame {
            frame: 3,
            first: 2,
            last: 10
        })
    ));

    std::fs::write(dir.path().join("camera_pose.json"), POSE).unwrap();
    let rec = Recording::open(dir.path()).unwrap();
    let pose = rec.robot_from_camera.expect("camera_pose.json is read");
    assert_eq!(pose.apply([0.0; 3]), [0.1, 0.0, 0.0]);
}

#[test]
fn a_pose_file_given_by_the_caller_replaces_the_folders() {
    let dir = tempfile::tempdir().unwrap();
    softsense_folder(dir.path(), &[0]);
    std::fs::write(dir.path().join("camera_pose.json"), POSE).unwrap();
    let other = dir.path().join("other_pose.json");
    std::fs::write(
        &other,
        r#"{"robot_from_camera": [[1,0,0,0],[0,1,0,0.2],[0,0,1,0],[0,0,0,1]]}"#,
    )
    .unwrap();
    let rec = Recording::open(dir.path())
        .unwrap()
        .with_pose_file(&other)
        .unwrap();
    assert_eq!(
        rec.robot_from_camera.unwrap().apply([0.0; 3]),
        [0.0, 0.2, 0.0]
    );
    assert_eq!(rec.pose_file.as_deref(), Some(other.as_path()));
}

#[test]
fn a_pose_that_is_not_rigid_is_refused_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    softsense_folder(dir.path(), &[0]);
    std::fs::write(
        dir.path().join("camera_pose.json"),
        r#"{"robot_from_camera": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#,
    )
    .unwrap();
    let err = Recording::open(dir.path()).unwrap_err().to_string();
    assert!(
        err.contains("camera_pose.json") && err.contains("not a rigid"),
        "{err}"
    );
}

#[test]
fn a_pcl_grabber_folder_reads_each_frames_own_camera_file() {
    let dir = tempfile::tempdir().unwrap();
    for (stem, fx) in [("frame_b", 520.0), ("frame_a", 510.0)] {
        depth(&dir.path().join(format!("{stem}_depth.tiff")), 800);
        color(&dir.path().join(format!("{stem}_rgb.png")));
        std::fs::write(dir.path().join(format!("{stem}.xml")), pcl_camera_xml(fx)).unwrap();
    }
    let rec = Recording::open(dir.path()).unwrap();
    assert_eq!(rec.layout, Layout::PclGrabber);
    assert_eq!(rec.frames, vec![0, 1]);
    assert!(rec
        .files_of(0)
        .unwrap()
        .depth
        .ends_with("frame_a_depth.tiff"));
    assert_eq!(rec.camera_of(0).unwrap().intrinsics.fx, 510.0);
    assert_eq!(rec.camera_of(1).unwrap().intrinsics.fx, 520.0);
    assert!(rec.files_of(1).unwrap().color.is_some());
}

#[test]
fn an_open3d_folder_pairs_depth_and_colour_images_in_name_order() {
    let dir = tempfile::tempdir().unwrap();
    let (d, c) = (dir.path().join("depth"), dir.path().join("color"));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::create_dir_all(&c).unwrap();
    for i in 0..3 {
        depth(&d.join(format!("{i:06}.png")), 600 + i as u16);
        color(&c.join(format!("{i:06}.png")));
    }
    std::fs::write(dir.path().join("camera_intrinsic.json"), INTRINSICS).unwrap();
    let rec = Recording::open(dir.path()).unwrap();
    assert_eq!(rec.layout, Layout::Open3d);
    assert_eq!(rec.frames, vec![0, 1, 2]);
    let cloud = rec.read_frame(2).unwrap();
    assert!((cloud.positions[5][2] - 0.602).abs() < 1e-6);
    assert!(cloud.colors.is_some());

    std::fs::remove_file(c.join("000002.png")).unwrap();
    let err = Recording::open(dir.path()).unwrap_err();
    assert!(
        matches!(
            err,
            RecordingError::Unpaired {
                depth: 3,
                color: 2,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn a_folder_without_frames_or_cameras_says_what_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let err = Recording::open(dir.path()).unwrap_err();
    assert!(matches!(err, RecordingError::NoFrames { .. }), "{err}");
    assert!(err.to_string().contains("STEM_depth.tiff"), "{err}");

    depth(&dir.path().join("depth_0000.png"), 500);
    let err = Recording::open(dir.path()).unwrap_err();
    assert!(matches!(err, RecordingError::NoCamera { .. }), "{err}");
}

#[test]
fn frames_of_two_layouts_in_one_folder_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    softsense_folder(dir.path(), &[0]);
    depth(&dir.path().join("x_depth.png"), 500);
    let err = Recording::open(dir.path()).unwrap_err();
    assert!(matches!(err, RecordingError::MixedLayouts { .. }), "{err}");
}

#[test]
fn recorded_actuator_states_become_the_commanded_cable_inputs() {
    let dir = tempfile::tempdir().unwrap();
    softsense_folder(dir.path(), &[0]);
    std::fs::write(
        dir.path().join("actuators.json"),
        r#"[[{"name": "a", "displacement_controlled": true, "shortening": 0.002, "tension": 1.5},
             {"name": "b", "displacement_controlled": false, "shortening": 0.001, "tension": 0.7}]]"#,
    )
    .unwrap();
    let rec = Recording::open(dir.path()).unwrap();
    let input = rec.inputs_of(0).unwrap();
    assert!(input.loads.is_empty());
    let got: Vec<_> = input
        .cables
        .iter()
        .map(|c| (c.name.as_str(), c.shorten, c.force))
        .collect();
    assert_eq!(got, vec![("a", Some(0.002), None), ("b", None, Some(0.7))]);
    assert!(rec.inputs_of(1).is_none());
}

#[test]
fn a_model_named_relative_to_the_folder_resolves_from_any_working_directory() {
    let dir = tempfile::tempdir().unwrap();
    let rec_dir = dir.path().join("rec");
    std::fs::create_dir_all(&rec_dir).unwrap();
    softsense_folder(&rec_dir, &[0]);
    std::fs::write(rec_dir.join("robot.toml"), "").unwrap();
    std::fs::write(
        rec_dir.join("calibration.json"),
        r#"{"robot_from_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "model": "robot.toml"}"#,
    )
    .unwrap();
    let rec = Recording::open(&rec_dir).unwrap();
    assert_eq!(rec.model_path().unwrap(), rec_dir.join("robot.toml"));
    assert_eq!(
        rec.model_named_by().unwrap(),
        rec_dir.join("calibration.json")
    );
}

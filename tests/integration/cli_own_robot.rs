//! `softsense colour` and `softsense pose`: the small steps of bringing one's own robot
//! and camera (docs/your-robot.md).

use crate::common::{project_root, run_cli};

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn colour_sampled_on_the_green_robot_segments_well_and_on_black_poorly() {
    let frame = project_root().join("clouds/scenes/tip_weight/color_0000.png");
    let f = frame.to_str().unwrap();
    let robot = run_cli(&["colour", f, "--at", "320,240", "--json"]);
    assert!(
        robot.status.success(),
        "{}",
        String::from_utf8_lossy(&robot.stderr)
    );
    let j: serde_json::Value = serde_json::from_str(&stdout(&robot)).unwrap();
    let rgb: Vec<u64> = j["rgb"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    // The bundled robots are green (40, 200, 60 before shading).
    assert!(rgb[1] > 2 * rgb[0] && rgb[1] > 2 * rgb[2], "{rgb:?}");
    assert_eq!(j["verdict"], "segments well");
    let share = j["share_of_frame"].as_f64().unwrap();
    assert!(share > 0.01 && share < 0.5, "{share}");
    let corner = run_cli(&["colour", f, "--at", "20,20", "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&corner)).unwrap();
    assert!(
        j["verdict"]
            .as_str()
            .unwrap()
            .starts_with("segments poorly"),
        "{j}"
    );
    let outside = run_cli(&["colour", f, "--at", "5000,10"]);
    assert_eq!(outside.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&outside.stderr).contains("outside the 640x480 frame"));
}

#[test]
fn a_look_at_pose_points_the_optical_axis_at_the_target_with_up_up_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rough_pose.json");
    let (eye, target, up) = ([0.1, -0.3, 0.4], [0.0, 0.0, 0.05], [0.0, 0.0, 1.0]);
    let o = run_cli(&[
        "pose",
        "--eye",
        "0.1,-0.3,0.4",
        "--target",
        "0,0,0.05",
        "--up",
        "0,0,1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let m: Vec<Vec<f64>> = (j["robot_from_camera"].as_array().unwrap().iter())
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_f64().unwrap())
                .collect()
        })
        .collect();
    let col = |k: usize| [m[0][k], m[1][k], m[2][k]];
    assert_eq!(col(3), eye, "the camera centre");
    let sight = [0, 1, 2].map(|k| target[k] - eye[k]);
    let len = sight.iter().map(|c| c * c).sum::<f64>().sqrt();
    // Camera z (the optical axis) along the line of sight; camera y (down the image) has a
    // negative component along up; the three axes orthonormal and right-handed.
    let z = col(2);
    assert!(
        (0..3).all(|k| (z[k] - sight[k] / len).abs() < 1e-12),
        "{z:?}"
    );
    let y = col(1);
    assert!(y.iter().zip(up).map(|(a, b)| a * b).sum::<f64>() < -0.5);
    let x = col(0);
    let cross = [
        x[1] * y[2] - x[2] * y[1],
        x[2] * y[0] - x[0] * y[2],
        x[0] * y[1] - x[1] * y[0],
    ];
    assert!((0..3).all(|k| (cross[k] - z[k]).abs() < 1e-12));
    // The type calibrate reads its rough start as.
    let pose: softsense::math::pose::Pose =
        serde_json::from_value(j["robot_from_camera"].clone()).unwrap();
    assert!((pose.origin()[2] - 0.4).abs() < 1e-12);
    let same = run_cli(&[
        "pose",
        "--eye",
        "0,0,1",
        "--target",
        "0,0,0",
        "--up",
        "0,0,1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        same.status.code(),
        Some(2),
        "up along the line of sight is refused"
    );
}

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

#[test]
fn clicked_pixels_with_their_robot_points_give_the_recordings_pose_within_millimetres() {
    let rec = project_root().join("clouds/scenes/calib");
    let truth = softsense::recording::read_pose(&rec.join("camera_pose.json")).unwrap();
    let cloud = softsense::recording::Recording::open(&rec)
        .unwrap()
        .read_frame(0)
        .unwrap();
    // Four pixels spread over the robot, each the point the camera measured there carried
    // into the robot frame by the true pose: what a user reads off the robot's drawing.
    let mut clicks = Vec::new();
    for (u, v) in [(250u32, 300u32), (390, 300), (320, 200), (320, 330)] {
        let (x, y) = (u..u + 40)
            .flat_map(|x| (v..v + 40).map(move |y| (x, y)))
            .find(|&(x, y)| {
                (0..9).all(|k| {
                    let (xx, yy) = (x + k % 3 - 1, y + k / 3 - 1);
                    cloud.positions[(yy * cloud.width + xx) as usize][2].is_finite()
                })
            })
            .expect("a measured pixel near each click");
        let p = cloud.positions[(y * cloud.width + x) as usize].map(f64::from);
        let r = truth.apply(p);
        clicks.push(format!("{x},{y}={},{},{}", r[0], r[1], r[2]));
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rough_pose.json");
    let mut args = vec![
        "pose",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    for c in &clicks {
        args.extend(["--click", c.as_str()]);
    }
    let o = run_cli(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fitted = softsense::recording::read_pose(&out).unwrap();
    let dt = softsense::math::norm(softsense::math::sub(fitted.origin(), truth.origin()));
    let (r1, r2) = (fitted.to_matrix(), truth.to_matrix());
    let trace: f64 = (0..3)
        .map(|i| (0..3).map(|k| r1[k][i] * r2[k][i]).sum::<f64>())
        .sum();
    let angle = ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    // The fit reads each pixel's 3x3 window (its median depth's point), up to a pixel
    // (1 mm at this range) from the clicked one.
    assert!(dt < 0.005 && angle < 1.0, "{dt} m, {angle} deg");
    assert!(
        stdout(&o).contains("fitted to 4 clicked points"),
        "{}",
        stdout(&o)
    );
    let two = run_cli(&[
        "pose",
        "--recording",
        rec.to_str().unwrap(),
        "--click",
        &clicks[0],
        "--click",
        &clicks[1],
    ]);
    assert_eq!(two.status.code(), Some(2));
    let sky = run_cli(&[
        "pose",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--click",
        "2,2=0,0,0",
        "--click",
        &clicks[1],
        "--click",
        &clicks[2],
    ]);
    assert!(
        String::from_utf8_lossy(&sky.stderr).contains("no depth at or around pixel (2, 2)"),
        "{}",
        String::from_utf8_lossy(&sky.stderr)
    );
}

//! `scene generate` with several cameras: one FE solve per frame, one folder per camera,
//! the shared files once at the top, read back as a rig.

use crate::common::two_camera_scene;
use softsense::recording::{Recording, RecordingError, Rig};
use softsense::scene::{generate, Scene};

/// The bundled two-camera scene cut to its first two frames at a quarter of the
/// resolution (the same field of view).
fn small_two_camera_scene() -> Scene {
    let mut scene = two_camera_scene(4);
    scene.spec.frames.truncate(2);
    scene
}

#[test]
fn a_two_camera_scene_generates_a_folder_per_camera_that_opens_as_a_rig() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    let truth = generate(&small_two_camera_scene(), &out, |_, _| {}).unwrap();
    let rig = Rig::open(&out).unwrap();
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["front", "side"]);
    assert_eq!(rig.frames, [0, 1]);
    let poses: Vec<_> = (rig.cameras.iter())
        .map(|c| c.recording.robot_from_camera.expect("a pose per camera"))
        .collect();
    // The optical axes (camera z in the robot frame) are 90 degrees apart in azimuth.
    let [a, b] = [poses[0].axis(2), poses[1].axis(2)];
    let horizontal_cos = (a[0] * b[0] + a[1] * b[1]) / (a[0].hypot(a[1]) * b[0].hypot(b[1]));
    assert!(horizontal_cos.abs() < 1e-9, "{horizontal_cos}");
    for c in &rig.cameras {
        assert!(c.has_frame(0) && c.has_frame(1));
        assert_eq!(
            (
                c.recording.camera.intrinsics.width,
                c.recording.camera.intrinsics.height
            ),
            (160, 120)
        );
        // Truth and inputs are shared from the top, not copied into the camera's folder.
        assert!(!c.recording.dir.join("truth.json").exists());
        assert_eq!(c.recording.truth_of(1).unwrap().loads.len(), 1);
        assert!(c.recording.inputs_of(1).is_some());
        let cloud = c.recording.read_frame(1).unwrap();
        let seen = cloud.positions.iter().filter(|p| p[2].is_finite()).count();
        assert!(seen > 160 * 120 / 4, "{}: {seen} points", c.name);
    }
    assert!(out.join("truth.json").exists() && out.join("actuators.json").exists());
    // One solve per frame, seen by both cameras: each view counts its own pixels.
    for f in &truth.frames {
        assert_eq!(f.views.len(), 2);
        assert!(f.views.iter().all(|v| v.pixels[0] > 0), "{:?}", f.views);
        let robot: usize = f.views.iter().map(|v| v.pixels[0]).sum();
        assert_eq!(f.pixels[0], robot);
    }
    let err = Recording::open(&out).unwrap_err();
    assert!(
        matches!(err, RecordingError::SeveralCameras { .. }),
        "{err}"
    );
}

#[test]
fn two_cameras_at_one_pose_draw_different_noise_of_the_same_scene() {
    let mut scene = small_two_camera_scene();
    scene.spec.frames.truncate(1);
    let front = scene.spec.cameras[0].camera.clone();
    scene.spec.cameras[1].camera = front;
    let model = scene.model().unwrap();
    let r = softsense::scene::render_frame(&scene, &model, 0).unwrap();
    let [a, b] = [&r.views[0], &r.views[1]];
    assert_eq!(r.truth.views[0].pixels, r.truth.views[1].pixels);
    let share = |differ: usize| differ as f64 / a.depth.len() as f64;
    // Independent draws of ~0.5 mm depth noise on a 1 mm grid round apart in about half
    // the pixels, and colour noise of 3 per channel almost everywhere; one draw in none.
    let depth_differ = (a.depth.iter().zip(&b.depth))
        .filter(|(x, y)| x != y)
        .count();
    let color_differ = (a.color.iter().zip(&b.color))
        .filter(|(x, y)| x != y)
        .count();
    assert!(share(depth_differ) > 0.25, "{depth_differ} depths differ");
    assert!(share(color_differ) > 0.9, "{color_differ} colours differ");
    scene.spec.sensor.enabled = false;
    let r = softsense::scene::render_frame(&scene, &model, 0).unwrap();
    assert_eq!(r.views[0].depth, r.views[1].depth);
    assert_eq!(r.views[0].color, r.views[1].color);
}

//! A sensed frame as 3-D entities (`render::scene3d`), what `sense --rerun` and
//! `softsense.rerun` log: every frame has the same entities, a camera that did not read the
//! frame is cleared, and the shapes hold what was seen.

use crate::common::two_camera_scene;
use softsense::fem::model::Model;
use softsense::recording::Rig;
use softsense::render::scene3d::{
    self, frame_entities, static_entities, Level, SceneParams, Shape,
};
use softsense::sense::{CameraFrames, FrameReport, FrameStatus, SenseParams, Sensor};

fn shape<'a>(entities: &'a [scene3d::Entity], path: &str) -> &'a Shape {
    &entities
        .iter()
        .find(|e| e.path == path)
        .unwrap_or_else(|| panic!("no {path}"))
        .shape
}

#[test]
fn a_camera_without_the_frame_is_cleared_and_the_other_shows_what_it_saw() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    let mut scene = two_camera_scene(4);
    scene.spec.frames.truncate(2);
    softsense::scene::generate(&scene, &out, |_, _| {}).unwrap();
    for name in ["depth_0001.png", "color_0001.png"] {
        std::fs::remove_file(out.join("side").join(name)).unwrap();
    }
    let rig = Rig::open(&out).unwrap();
    let model = Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
    let sensor = Sensor::for_rig(model, &rig, SenseParams::default()).unwrap();
    let cameras: Vec<_> = rig.cameras.iter().map(|c| &c.recording).collect();
    let statics = static_entities(&sensor, &cameras);
    let paths: Vec<&str> = statics.iter().map(|e| e.path.as_str()).collect();
    assert_eq!(
        paths,
        [
            "world",
            "world/cameras/front",
            "world/cameras/front/image",
            "world/cameras/side",
            "world/cameras/side/image"
        ]
    );
    let Shape::Pinhole { resolution, .. } = shape(&statics, "world/cameras/front/image") else {
        panic!("not a pinhole")
    };
    assert_eq!(*resolution, [160, 120]);

    let obs = sensor.observe(&rig, 1).unwrap();
    let report = sensor.sense(1, &obs, rig.inputs_of(1).as_ref());
    assert!(matches!(report.status, FrameStatus::Sensed));
    let e = frame_entities(&sensor, Some(&obs), &report, &SceneParams::default());
    let Shape::Image { width, height, rgb } = shape(&e, "world/cameras/front/image/rgb") else {
        panic!("front: not an image")
    };
    assert_eq!((*width, *height, rgb.len()), (160, 120, 160 * 120 * 3));
    assert_eq!(*shape(&e, "world/cameras/side/image/rgb"), Shape::Clear);
    let Shape::Points { positions, .. } = shape(&e, scene3d::ROBOT_POINTS) else {
        panic!("robot: not points")
    };
    assert_eq!(positions.len(), obs.robot.len());
    let Shape::Mesh {
        vertices,
        triangles,
        ..
    } = shape(&e, scene3d::FE_SURFACE)
    else {
        panic!("not a mesh")
    };
    assert_eq!(vertices.len(), report.positions.len());
    assert_eq!(triangles.len(), sensor.surface.triangles.len());
    let Shape::Arrows {
        vectors, labels, ..
    } = shape(&e, scene3d::FORCES)
    else {
        panic!("not arrows")
    };
    assert_eq!(vectors.len(), report.forces.len());
    assert!(labels[0].contains(&format!("{:.3} N", report.forces[0].magnitude)));
    assert_eq!(
        *shape(&e, &scene3d::force_plot_path(0)),
        Shape::Scalar {
            value: report.forces[0].magnitude
        }
    );
}

#[test]
fn an_unreadable_frame_shows_the_rest_surface_empty_clouds_and_an_error_line() {
    let rig = Rig::open(&crate::common::project_root().join("clouds/scenes/tip_weight")).unwrap();
    let model = Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
    let sensor = Sensor::for_rig(model, &rig, SenseParams::default()).unwrap();
    let report = FrameReport::empty(
        3,
        FrameStatus::Unreadable("depth_0003.png: truncated".into()),
    );
    let e = frame_entities(&sensor, None, &report, &SceneParams::default());
    assert_eq!(*shape(&e, "world/cameras/camera/image/rgb"), Shape::Clear);
    let Shape::Points { positions, .. } = shape(&e, scene3d::ROBOT_POINTS) else {
        panic!("robot: not points")
    };
    assert!(positions.is_empty());
    let Shape::Mesh { vertices, .. } = shape(&e, scene3d::FE_SURFACE) else {
        panic!("not a mesh")
    };
    assert_eq!(
        vertices.len(),
        sensor.model.problem.mesh.nodes_in_rest.len()
    );
    let Shape::Text { level, text } = shape(&e, scene3d::STATUS) else {
        panic!("not text")
    };
    assert_eq!(*level, Level::Error);
    assert!(text.contains("truncated"), "{text}");
}

//! The tour's pictures of the bundled scenes and models: no text covers other text, and
//! all of it lies inside the picture.

use softsense::fem::model::Model;
use softsense::recording::Rig;
use softsense::render::model::{model_picture, ModelPicture};
use softsense::render::{frame_picture, Canvas};
use softsense::sense::{SenseParams, Sensor};
use std::path::Path;

/// Every pair of the canvas's text boxes is disjoint, and every box is inside it.
fn assert_text_apart(c: &Canvas, what: &str) {
    let boxes = c.text_boxes();
    assert!(!boxes.is_empty(), "{what}: no text at all");
    for (i, p) in boxes.iter().enumerate() {
        assert!(
            p.x >= 0
                && p.y >= 0
                && p.x + p.width <= i64::from(c.width())
                && p.y + p.height <= i64::from(c.height()),
            "{what}: {p:?} leaves the {}x{} picture",
            c.width(),
            c.height()
        );
        for q in &boxes[i + 1..] {
            assert!(!p.overlaps(q), "{what}: {p:?} and {q:?} overlap");
        }
    }
}

#[test]
fn the_sense_pictures_of_every_bundled_scene_have_no_overlapping_text() {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("clouds/scenes");
    let mut pictures = 0;
    for name in ["tip_weight", "probe_side", "probe_press", "two_probes"] {
        let rig = Rig::open(&scenes.join(name)).unwrap();
        let model = Model::load(&rig.shared().model_path().unwrap(), None).unwrap();
        let sensor = Sensor::for_rig(model, &rig, SenseParams::default()).unwrap();
        for &frame in &rig.shared().frames {
            let obs = sensor.observe(&rig, frame).unwrap();
            let report = sensor.sense(frame, &obs, rig.shared().inputs_of(frame).as_ref());
            for view in &obs.views {
                let k = &rig.cameras[view.camera].recording.camera.intrinsics;
                let c = frame_picture(k, &sensor, view, &report).unwrap();
                assert_text_apart(&c, &format!("{name} frame {frame}"));
                pictures += 1;
            }
        }
    }
    assert!(pictures >= 12, "{pictures} pictures");
}

#[test]
fn the_model_check_pictures_of_the_bundled_models_have_no_overlapping_text() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // The other models read their meshes from the third-party data: not bundled.
    for file in ["robot", "sheet"] {
        let file = format!("meshes/models/{file}.toml");
        let path = root.join(&file);
        let model = Model::load(&path, None).unwrap();
        let mut pic = ModelPicture::of(&model, &format!("model check: {file}"));
        pic.notes = vec!["mesh: a note long enough to wrap across the bottom band".into()];
        let c = model_picture(&pic, 960, 960).unwrap();
        assert_text_apart(&c, &file);
    }
}

#[test]
fn charts_laid_out_by_plotters_have_no_overlapping_text_and_a_legend_of_drawn_lines_only() {
    use softsense::render::{bar_chart, line_chart, Series};
    let labels = [
        "no missing effect",
        "gravity / density",
        "Young's modulus scale",
    ];
    let bars = bar_chart(
        "BIC per candidate",
        &labels,
        &[412.0, -57.2, 12.0],
        Some(1),
        700,
        320,
    )
    .unwrap();
    assert_text_apart(&bars, "bar chart");
    let series = |label, points: Vec<[f64; 2]>| Series {
        label,
        color: [200, 40, 40],
        points,
    };
    let ramp: Vec<[f64; 2]> = (0..50).map(|i| [i as f64, (i as f64).sqrt()]).collect();
    let lone = vec![[3.0, 1.0], [f64::NAN, 2.0], [5.0, f64::NAN]];
    let drawn = [series("measured", ramp.clone())];
    let with_lone = [series("measured", ramp), series("never drawn", lone)];
    let a = line_chart(
        "pressure",
        ["t (s)", "kPa"],
        &drawn,
        &[[10.0, 20.0]],
        700,
        320,
    )
    .unwrap();
    let b = line_chart(
        "pressure",
        ["t (s)", "kPa"],
        &with_lone,
        &[[10.0, 20.0]],
        700,
        320,
    )
    .unwrap();
    assert_text_apart(&a, "line chart");
    // A series without two consecutive finite points draws nothing and gets no entry.
    assert_eq!(a, b);
}

#[test]
fn a_marker_picture_with_two_forces_at_one_spot_keeps_their_magnitudes_apart() {
    use softsense::render::markers::{marker_picture, MarkerMark, MarkerPicture};
    let positions = [
        [0.0, 0.0, 0.0],
        [0.1, 0.0, 0.0],
        [0.0, 0.1, 0.0],
        [0.0, 0.0, 0.05],
    ];
    let triangles = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
    let markers = [
        MarkerMark {
            rest: [0.05, 0.02, 0.0],
            current: Some([0.052, 0.021, 0.001]),
            hidden: false,
        },
        MarkerMark {
            rest: [0.02, 0.05, 0.0],
            current: None,
            hidden: true,
        },
    ];
    let forces = [
        ([0.05, 0.05, 0.0], [0.0, 0.0, -1.0]),
        ([0.0501, 0.05, 0.0], [0.0, 0.0, -0.99]),
    ];
    let pic = MarkerPicture {
        title: "markers frame 0",
        triangles: &triangles,
        positions: &positions,
        markers: &markers,
        candidates: &[[0.03, 0.03, 0.0]],
        forces: &forces,
    };
    let c = marker_picture(&pic, 480, 400).unwrap();
    assert_text_apart(&c, "marker picture");
    // Per panel two captions and both magnitudes (1.000 N and 0.990 N), and the title.
    assert_eq!(c.text_boxes().len(), 2 * 4 + 1, "{:?}", c.text_boxes());
}

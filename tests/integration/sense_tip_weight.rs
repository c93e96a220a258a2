//! End to end on the generated tip-weight scene (sensor noise on): depth + colour frames ->
//! robot points in the robot frame (segment by colour, camera pose from the scene) ->
//! registration (features on flat, camera-facing surface patches) -> intensity QP with FE
//! updates. Candidate location: the truth's node, direction along gravity (the `sense`
//! tests cover location mapping).
use softsense::inverse::frame::{estimate, Candidate, FrameParams};
use softsense::register::{surface_features, FeatureParams};
use softsense::scene::camera::Camera;
use softsense::scene::{Scene, Truth};
use std::path::Path;

fn robot_points(dir: &Path, frame: usize, cam: &Camera, unit: f64) -> Vec<[f64; 3]> {
    let depth = image::open(dir.join(format!("depth_{frame:04}.png")))
        .unwrap()
        .into_luma16();
    let color = image::open(dir.join(format!("color_{frame:04}.png")))
        .unwrap()
        .into_rgb8();
    let mut pts = Vec::new();
    for (u, v, d) in depth.enumerate_pixels() {
        let c = color.get_pixel(u, v).0;
        let green = c[1] as i32 > c[0] as i32 + 50 && c[1] as i32 > c[2] as i32 + 50;
        if d.0[0] > 0 && green {
            pts.push(cam.backproject(u as f64, v as f64, d.0[0] as f64 * unit));
        }
    }
    pts
}

fn run(hide_fraction: f64) -> (f64, Vec<f64>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(&root.join("clouds/scenes/tip_weight.toml")).unwrap();
    let dir = root.join("clouds/scenes/tip_weight");
    let truth: Truth =
        serde_json::from_str(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
    let model = scene.model().unwrap();
    let cam = Camera::new(scene.spec.camera.clone()).unwrap();
    let surface = model.problem.mesh.surface();
    // Features on flat patches the camera sees at the rest shape.
    let mut features = surface_features(
        &model.problem.mesh.nodes_in_rest,
        &surface,
        &FeatureParams {
            eye: Some(scene.spec.camera.eye),
            ..Default::default()
        },
    );
    assert_eq!(features.len(), 51, "visible flat patches on the robot");
    // Hide a fraction of the features (every k-th dropped), as if cropped away.
    if hide_fraction > 0.0 {
        let keep = ((1.0 - hide_fraction) * features.len() as f64).round() as usize;
        let n = features.len();
        features = (0..keep).map(|i| features[i * n / keep]).collect();
    }
    let mut errors = Vec::new();
    for f in truth.frames.iter().filter(|f| !f.loads.is_empty()) {
        let load = &f.loads[0];
        let pts = robot_points(&dir, f.frame, &cam, scene.spec.sensor.depth_unit);
        let cand = [Candidate {
            node: load.node,
            direction: [0.0, 0.0, -1.0],
        }];
        let est = estimate(&model, &pts, &features, &cand, &FrameParams::default()).unwrap();
        let rel = (est.estimate.forces[0] - load.magnitude).abs() / load.magnitude;
        eprintln!(
            "frame {}: truth {:.3} N, estimate {:.4} N ± {:.4}, rel error {:.2}%, visible {}/{}, updates {}, I_w {:.3e}, residual {:.2e} m",
            f.frame,
            load.magnitude,
            est.estimate.forces[0],
            est.estimate.force_sigma[0],
            100.0 * rel,
            est.visible,
            features.len(),
            est.updates,
            est.estimate.identifiability.i_w,
            est.estimate.residual_rms
        );
        errors.push(rel);
    }
    (errors.iter().sum::<f64>() / errors.len() as f64, errors)
}

#[test]
fn tip_weight_intensity_is_within_two_percent() {
    let (mean, errors) = run(0.0);
    eprintln!("mean relative error {:.2}% over {:?}", 100.0 * mean, errors);
    assert!(mean <= 0.02, "mean relative error {:.2}%", 100.0 * mean);
}

#[test]
fn tip_weight_with_thirty_percent_features_hidden_is_within_five_percent() {
    let (mean, errors) = run(0.3);
    eprintln!(
        "30% hidden: mean relative error {:.2}% over {:?}",
        100.0 * mean,
        errors
    );
    assert!(errors.iter().all(|e| *e <= 0.05), "{errors:?}");
}

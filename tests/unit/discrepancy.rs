//! Unit tests of the discrepancy module's pieces: measurement corrections, frame split,
//! updated model file.

use softsense::camera::Camera;
use softsense::discrepancy::effects::{correct_points, rotation, Effect, EffectKind};
use softsense::discrepancy::report::updated_model;
use softsense::discrepancy::{split_frames, FittedEffect};
use softsense::fem::model::{ModelSpec, Units};
use softsense::scene::camera::CameraSpec;

fn camera() -> Camera {
    CameraSpec::default().camera().unwrap()
}

#[test]
fn correcting_a_camera_pose_error_recovers_the_true_points() {
    let w = [0.01, -0.02, 0.005];
    let t = [0.002, -0.001, 0.003];
    let r = rotation(w);
    let truth = vec![[0.01, 0.02, 0.1], [-0.05, 0.03, 0.06]];
    let measured: Vec<[f64; 3]> = truth
        .iter()
        .map(|p| [0, 1, 2].map(|i| (0..3).map(|k| r[i][k] * p[k]).sum::<f64>() + t[i]))
        .collect();
    let e = Effect {
        kind: EffectKind::CameraPose,
        params: vec![w[0], w[1], w[2], t[0], t[1], t[2]],
    };
    let back = correct_points(&measured, &[e], &camera());
    for (a, b) in back.iter().zip(&truth) {
        assert!(
            (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12),
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn correcting_a_depth_error_recovers_the_true_points() {
    let cam = camera();
    let (s, o) = (0.02, 0.0015);
    let eye = cam.eye();
    let truth = vec![[0.01, 0.02, 0.1], [-0.05, 0.03, 0.06]];
    let measured: Vec<[f64; 3]> = truth
        .iter()
        .map(|p| {
            let z = cam.depth_of(*p);
            let f = ((1.0 + s) * z + o) / z;
            [0, 1, 2].map(|k| eye[k] + (p[k] - eye[k]) * f)
        })
        .collect();
    let e = Effect {
        kind: EffectKind::Depth,
        params: vec![s, o],
    };
    let back = correct_points(&measured, &[e], &cam);
    for (a, b) in back.iter().zip(&truth) {
        assert!(
            (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12),
            "{a:?} vs {b:?}"
        );
    }
}

#[test]
fn holdout_split_is_disjoint_covering_and_keeps_training_frames() {
    for n in 2..20 {
        for f in [0.1, 0.25, 0.5, 0.9] {
            let [train, hold] = split_frames(n, f);
            assert!(!train.is_empty() && !hold.is_empty(), "n {n} f {f}");
            let mut all: Vec<usize> = train.iter().chain(&hold).copied().collect();
            all.sort_unstable();
            assert_eq!(all, (0..n).collect::<Vec<_>>());
        }
    }
}

#[test]
fn updated_model_file_holds_the_fitted_stiffness_and_load() {
    let text = "units = \"mm-kg-s\"\n[mesh]\npath = \"robot.vtu\"\n[material]\nyoung = 180.0\npoisson = 0.45\n";
    let units = Units::parse("mm-kg-s").unwrap();
    let fx = |kind, params: Vec<f64>| FittedEffect {
        name: String::new(),
        sigma: vec![0.0; params.len()],
        effect: Effect { kind, params },
    };
    let out = updated_model(
        text,
        &units,
        &[
            fx(EffectKind::Young, vec![0.2]),
            fx(EffectKind::PointLoad { node: 7 }, vec![0.1, 0.0, -0.2]),
        ],
    )
    .unwrap();
    let spec: ModelSpec = toml::from_str(&out).unwrap();
    assert!((spec.material.young - 150.0).abs() < 1e-9);
    assert_eq!(spec.loads.len(), 1);
    assert_eq!(spec.loads[0].node, Some(7));
    assert!(
        (spec.loads[0].force[2] + 200.0).abs() < 1e-9,
        "mN in the file"
    );
}

#[test]
fn an_actuator_offset_moves_the_cables_then_the_cavities() {
    use softsense::discrepancy::effects::{actuator_count, actuator_steps, apply_model};
    use softsense::fem::material::Material;
    use softsense::fem::mesh::TetMesh;
    use softsense::fem::solve::{Cavity, CavityControl, Formulation, Problem};
    let mesh = TetMesh::structured_box([0.0; 3], [0.03; 3], [3, 3, 3]).unwrap();
    let top = |name: &str, control| {
        Cavity::from_box(name, &mesh, [-1.0, -1.0, 0.0299], [1.0; 3], control).unwrap()
    };
    let mut p = Problem::new(
        mesh.clone(),
        Material::new(5e5, 0.3).unwrap(),
        Formulation::Corotational,
    );
    p.cavities = vec![
        top("p", CavityControl::Pressure(1e3)),
        top("v", CavityControl::Volume(2e-7)),
    ];
    assert_eq!(actuator_count(&p), 2);
    assert_eq!(actuator_steps(&p), vec![100.0, 1e-8]);
    let offset = Effect {
        kind: EffectKind::ActuatorOffset,
        params: vec![250.0, -5e-8],
    };
    apply_model(&mut p, &[offset], &[]).unwrap();
    assert_eq!(p.cavities[0].control, CavityControl::Pressure(1250.0));
    assert_eq!(p.cavities[1].control, CavityControl::Volume(2e-7 - 5e-8));
    assert_eq!(EffectKind::ActuatorOffset.n_params(actuator_count(&p)), 2);
}

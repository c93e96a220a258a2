//! `hidden --truth`: the option's forms (preset, inline keys, file), its refusals, and the
//! point-load move onto a body on another mesh.

use softsense::discrepancy::effects::{Effect, EffectKind};
use softsense::discrepancy::truth::{onto_body, parse_truth, TRUTH_PRESETS};
use softsense::discrepancy::DiscrepancyError;
use softsense::fem::model::Model;
use softsense::scene::truth::Ranged;
use std::path::PathBuf;

fn refused(arg: &str) -> String {
    match parse_truth(arg) {
        Err(e @ DiscrepancyError::Truth { .. }) => e.to_string(),
        other => panic!("{arg:?}: expected a --truth error, got {other:?}"),
    }
}

#[test]
fn the_presets_are_the_keys_they_stand_for() {
    let m = parse_truth("modulus").unwrap();
    assert_eq!(m.young_factor, Ranged::Range([0.85, 1.15]));
    assert_eq!(m.formulation, None);
    let nh = parse_truth(" neo-hookean ").unwrap();
    assert_eq!(nh.formulation.as_deref(), Some("neo-hookean"));
    assert_eq!(nh.young_factor, Ranged::Fixed(1.0));
    for (name, keys, _) in TRUTH_PRESETS {
        assert_eq!(
            parse_truth(name).unwrap(),
            parse_truth(keys).unwrap(),
            "{name}"
        );
    }
}

#[test]
fn a_drawn_modulus_stays_in_its_range_and_follows_the_seed() {
    let m = parse_truth("modulus").unwrap();
    let f: Vec<f64> = (0..20).map(|s| m.draw(s, 0, None).young_factor).collect();
    assert!(f.iter().all(|v| (0.85..=1.15).contains(v)), "{f:?}");
    assert!(
        f.windows(2).any(|w| w[0] != w[1]),
        "one factor for every seed"
    );
    assert_eq!(m.draw(7, 0, None), m.draw(7, 0, None));
}

#[test]
fn inline_keys_take_several_fields() {
    let t =
        parse_truth("young_factor = 1.1, formulation = \"neo-hookean\", poisson = 0.4").unwrap();
    assert_eq!(t.young_factor, Ranged::Fixed(1.1));
    assert_eq!(t.poisson, Some(Ranged::Fixed(0.4)));
    assert_eq!(t.formulation.as_deref(), Some("neo-hookean"));
}

#[test]
fn a_file_gives_its_keys_at_the_top_or_in_a_truth_table_and_its_mesh_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("fine.vtu"), "not read here").unwrap();
    let top = dir.path().join("top.toml");
    std::fs::write(&top, "young_factor = 0.9\nmesh = \"fine.vtu\"\n").unwrap();
    let t = parse_truth(top.to_str().unwrap()).unwrap();
    assert_eq!(t.young_factor, Ranged::Fixed(0.9));
    let mesh = PathBuf::from(t.mesh.unwrap());
    assert!(mesh.is_absolute() && mesh.ends_with("fine.vtu"), "{mesh:?}");
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "model = \"x.toml\"\n[truth]\nbase_stiffness = 1e5\n",
    )
    .unwrap();
    let s = parse_truth(scene.to_str().unwrap()).unwrap();
    assert_eq!(s.base_stiffness, Some(Ranged::Fixed(1e5)));
}

#[test]
fn bad_values_are_refused_naming_what_is_wrong() {
    for (arg, says) in [
        ("", "is empty"),
        ("  ", "is empty"),
        ("stiffer", "is not a preset (modulus, neo-hookean)"),
        ("young_factor = 0", "truth.young_factor"),
        ("young_factor = 11", "<= 10"),
        ("young_factor = [1.2, 1.1]", "lo <= hi"),
        ("poisson = 0.5", "truth.poisson"),
        (
            "formulation = \"small-strain\"",
            "\"corotational\" or \"neo-hookean\"",
        ),
        ("base_stiffness = -1", "truth.base_stiffness"),
        ("youngfactor = 1.1", "unknown field `youngfactor`"),
        ("young_factor = ", "not [truth] keys"),
        ("mesh = \"/no/such/robot.vtu\"", "no such file"),
        ("mesh = \"\"", "must name a file"),
    ] {
        let e = refused(arg);
        assert!(e.contains(says), "{arg:?}: {e:?} should say {says:?}");
    }
}

#[test]
fn a_file_with_bad_toml_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("t.toml");
    std::fs::write(&f, "young_factor = \n").unwrap();
    let e = refused(f.to_str().unwrap());
    assert!(e.contains("t.toml"), "{e}");
}

#[test]
fn a_point_load_keeps_its_node_on_the_model_and_moves_to_the_nearest_on_another_mesh() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let node = 700;
    let e = Effect {
        kind: EffectKind::PointLoad { node },
        params: vec![0.1, 0.0, -0.2],
    };
    let same = onto_body(&e, &model, &model);
    assert_eq!(same.kind, e.kind);
    // A body whose nodes are the model's in another order: the load follows its position.
    let mut body = model.clone();
    body.problem.mesh.nodes_in_rest.swap(node, 3);
    let moved = onto_body(&e, &model, &body);
    assert_eq!(moved.kind, EffectKind::PointLoad { node: 3 });
    assert_eq!(moved.params, e.params);
    let g = Effect {
        kind: EffectKind::Gravity,
        params: vec![0.2],
    };
    assert_eq!(onto_body(&g, &model, &body).kind, EffectKind::Gravity);
}

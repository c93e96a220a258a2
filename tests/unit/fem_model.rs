//! Model files: unit conversion (mm-kg-s scenes to SI), selections, mapped points.

use crate::common;
use softsense::fem::model::{Model, ModelSpec};
use softsense::fem::solve::{CableControl, Formulation};

#[test]
fn mm_kg_s_model_is_converted_to_si() {
    let m = Model::load(
        &common::project_root().join("meshes/models/robot.toml"),
        None,
    )
    .unwrap();
    let p = &m.problem;
    assert!((p.material.young() - 180e3).abs() < 1e-9, "180 kPa");
    assert!((p.gravity[2] + 9.81).abs() < 1e-12, "9810 mm/s^2");
    let mass: f64 = p.lumped_masses().iter().sum();
    assert!((mass - 0.5).abs() < 1e-12, "total mass {mass} kg");
    assert_eq!(p.cables.len(), 4);
    assert_eq!(p.cables[0].control, CableControl::Displacement(0.010));
    let attach = p.cables[0].attach[0].position(&p.mesh.nodes_in_rest);
    assert!(
        (attach[1] - 0.097).abs() < 1e-12 && (attach[2] - 0.045).abs() < 1e-12,
        "{attach:?}"
    );
    assert!(!p.fixed.is_empty());
    for &v in &p.fixed {
        let q = p.mesh.nodes_in_rest[v];
        assert!(
            q[0].abs() <= 0.015 + 1e-12 && q[1].abs() <= 0.015 + 1e-12 && q[2] <= 0.0125 + 1e-12
        );
    }
    assert_eq!(m.effectors[0].rows.len(), 3);
    assert_eq!(
        m.force_rows.len(),
        2,
        "a normal force point and a directed one: a row each"
    );
    assert_eq!(m.force_points.len(), 2);
    assert_eq!(m.force_points[1].name, "hook");
}

#[test]
fn bad_model_files_are_errors() {
    let base = "[mesh]\npath = \"robot.vtu\"\n[material]\nyoung = 1.0\npoisson = 0.3\n";
    assert!(
        toml::from_str::<ModelSpec>(&format!("{base}bogus = 1\n")).is_err(),
        "unknown keys are rejected"
    );
    let bad_units: ModelSpec = toml::from_str(&format!("units = \"furlong\"\n{base}")).unwrap();
    let mesh =
        softsense::fem::mesh::TetMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
    assert!(Model::from_spec(&bad_units, mesh.clone()).is_err());
    let bad_nu: ModelSpec = toml::from_str(&base.replace("0.3", "0.5")).unwrap();
    assert!(Model::from_spec(&bad_nu, mesh.clone()).is_err());
    let far: ModelSpec = toml::from_str(&format!(
        "{base}[[loads]]\nat = [9.0, 9.0, 9.0]\nforce = [1.0, 0.0, 0.0]\n"
    ))
    .unwrap();
    assert!(matches!(
        Model::from_spec(&far, mesh),
        Err(softsense::fem::FemError::PointOutside { .. })
    ));
    // TODO: Audit that the environment access only happens in single-threaded code.
    unsafe { std::env::remove_var("SOFTSENSE_SURELY_UNSET_VAR") };
    assert!(softsense::fem::model::expand_env("${SOFTSENSE_SURELY_UNSET_VAR}/x").is_err());
}

#[test]
fn model_files_name_the_formulation_and_an_unknown_one_is_an_error_listing_the_choices() {
    let base = "[mesh]\npath = \"robot.vtu\"\n[material]\nyoung = 1.0\npoisson = 0.3\n";
    let mesh =
        softsense::fem::mesh::TetMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]).unwrap();
    let with = |name: &str| {
        let spec: ModelSpec = toml::from_str(&format!("formulation = \"{name}\"\n{base}")).unwrap();
        Model::from_spec(&spec, mesh.clone())
    };
    for (name, want) in [
        ("corotational", Formulation::Corotational),
        ("small-strain", Formulation::SmallStrain),
        ("neo-hookean", Formulation::NeoHookean),
    ] {
        assert_eq!(with(name).unwrap().problem.formulation, want, "{name}");
    }
    let err = with("mooney-rivlin").unwrap_err().to_string();
    assert!(
        err.contains("mooney-rivlin") && err.contains("neo-hookean"),
        "{err}"
    );
}

#[test]
fn formulation_names_read_back_and_aliases_name_the_same_law() {
    for f in [
        Formulation::SmallStrain,
        Formulation::Corotational,
        Formulation::NeoHookean,
    ] {
        assert_eq!(Formulation::from_name(f.name()), Some(f));
    }
    assert_eq!(
        Formulation::from_name("large"),
        Some(Formulation::Corotational)
    );
    assert_eq!(
        Formulation::from_name("linear"),
        Some(Formulation::SmallStrain)
    );
    assert_eq!(Formulation::from_name("Neo-Hookean"), None);
}

#[test]
fn a_model_on_another_mesh_reads_its_own_mesh_only_for_node_indices() {
    // The model file's own mesh is missing: by position alone it is never read; a
    // `fixed.nodes` needs it, and the error names it.
    let root = common::project_root();
    let robot = std::fs::read_to_string(root.join("meshes/models/robot.toml")).unwrap();
    let text = robot.replace("path = \"../robot.vtu\"", "path = \"missing.vtu\"");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("model.toml");
    std::fs::write(&file, &text).unwrap();
    let other = root.join("meshes/robot.vtu");
    let m = Model::load_on_mesh(&file, &other).unwrap();
    assert!(!m.problem.fixed.is_empty());
    std::fs::write(&file, format!("{text}\n[[fixed]]\nnodes = [0]\n")).unwrap();
    let e = Model::load_on_mesh(&file, &other).unwrap_err().to_string();
    assert!(e.contains("missing.vtu"), "{e}");
}

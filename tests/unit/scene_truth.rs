//! `[truth]`: frames rendered from a body that is not the model. Each field changes the
//! rendered body and nothing else, a bad value is refused by name, and a scene without
//! the table renders the model exactly as before.
use softsense::fem::model::Model;
use softsense::scene::{generate, render_frame, Scene, SceneError};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn robot_model() -> PathBuf {
    root().join("meshes/models/robot.toml")
}

/// A scene file in `dir`: the robot model, a small camera, an unloaded frame and a 0.66 N
/// tip weight, and `truth` (TOML) appended.
fn scene_file(dir: &Path, truth: &str) -> PathBuf {
    let path = dir.join("scene.toml");
    let text = format!(
        "model = {:?}\n\
         [camera]\nwidth = 64\nheight = 48\nfx = 60.0\nfy = 60.0\ncx = 31.5\ncy = 23.5\n\
         [[frames]]\n\
         [[frames]]\n[[frames.loads]]\nkind = \"weight\"\nat = [0.0, 0.0, 0.125]\n\
         force = [0.0, 0.0, -0.66]\n{truth}",
        robot_model().display().to_string()
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// The solved node positions of every frame of the scene with `truth`.
fn solved(truth: &str) -> Vec<Vec<[f64; 3]>> {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&scene_file(dir.path(), truth)).unwrap();
    let body = scene.truth_body(&scene.model().unwrap()).unwrap();
    (0..2)
        .map(|i| render_frame(&scene, &body, i).unwrap().positions)
        .collect()
}

fn tip_drop(frames: &[Vec<[f64; 3]>], rest: &[[f64; 3]]) -> f64 {
    // The lowest drop of a node of the top platform (z >= 110 mm at rest).
    (0..rest.len())
        .filter(|&v| rest[v][2] >= 0.110)
        .map(|v| rest[v][2] - frames[1][v][2])
        .fold(0.0, f64::max)
}

fn largest_gap(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| softsense::math::dist(*p, *q))
        .fold(0.0, f64::max)
}

#[test]
fn a_stiffer_truth_renders_a_smaller_deformation_than_the_model() {
    let rest = Model::load(&robot_model(), None)
        .unwrap()
        .problem
        .mesh
        .nodes_in_rest;
    let model = solved("");
    let stiffer = solved("[truth]\nyoung_factor = 1.15\n");
    let (m, s) = (tip_drop(&model, &rest), tip_drop(&stiffer, &rest));
    assert!(m > 0.005, "the weight drops the model's tip {m} m");
    // Linear in 1/E for small strain; the corotational body is close to that.
    let ratio = s / m;
    assert!((0.80..0.95).contains(&ratio), "tip drop ratio {ratio}");
    assert!(
        largest_gap(&model[0], &stiffer[0]) > 1e-4,
        "gravity sag alike"
    );
}

#[test]
fn a_neo_hookean_truth_differs_from_the_corotational_model_by_a_little() {
    let model = solved("");
    let neo = solved("[truth]\nformulation = \"neo-hookean\"\n");
    let rest = Model::load(&robot_model(), None)
        .unwrap()
        .problem
        .mesh
        .nodes_in_rest;
    let largest = largest_gap(&model[1], &rest);
    let gap = largest_gap(&model[1], &neo[1]) / largest;
    assert!(
        (1e-4..0.05).contains(&gap),
        "neo-hookean off by {gap} of {largest} m"
    );
}

#[test]
fn a_truth_poisson_ratio_changes_the_rendered_body() {
    let model = solved("");
    let other = solved("[truth]\npoisson = 0.3\n");
    assert!(largest_gap(&model[1], &other[1]) > 1e-4);
}

#[test]
fn a_scene_without_truth_renders_the_model_and_writes_no_truth_model() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&scene_file(dir.path(), "")).unwrap();
    let model = scene.model().unwrap();
    let body = scene.truth_body(&model).unwrap();
    assert_eq!(body.problem.material, model.problem.material);
    assert_eq!(body.problem.formulation, model.problem.formulation);
    assert_eq!(
        body.problem.mesh.nodes_in_rest,
        model.problem.mesh.nodes_in_rest
    );
    let out = dir.path().join("out");
    generate(&scene, &out, |_, _| {}).unwrap();
    let text = std::fs::read_to_string(out.join("truth.json")).unwrap();
    assert!(!text.contains("truth_model"), "{text}");
    // An empty [truth] is the model too: the same images, byte for byte.
    let empty_dir = tempfile::tempdir().unwrap();
    let empty = Scene::load(&scene_file(empty_dir.path(), "[truth]\n")).unwrap();
    let out_empty = dir.path().join("empty");
    generate(&empty, &out_empty, |_, _| {}).unwrap();
    for f in ["depth_0001.png", "color_0001.png", "actuators.json"] {
        let same = std::fs::read(out.join(f)).unwrap() == std::fs::read(out_empty.join(f)).unwrap();
        assert!(same, "{f} differs");
    }
}

#[test]
fn the_recording_names_the_model_and_says_what_the_truth_was() {
    let dir = tempfile::tempdir().unwrap();
    let file = scene_file(
        dir.path(),
        "[truth]\nyoung_factor = 1.15\npoisson = 0.4\nformulation = \"neo-hookean\"\n",
    );
    let scene = Scene::load(&file).unwrap();
    let out = dir.path().join("out");
    let truth = generate(&scene, &out, |_, _| {}).unwrap();
    let e = 180e3; // the model file's 180 kPa
    assert_eq!(truth.material, [e, 0.45], "the model's material");
    let t = truth.truth_model.expect("a truth_model");
    assert_eq!(t.young_factor, 1.15);
    assert!((t.young - 1.15 * e).abs() < 1e-6);
    assert_eq!((t.poisson, t.formulation.as_str()), (0.4, "neo-hookean"));
    assert!(t.mesh.ends_with("robot.vtu"), "{}", t.mesh);
    let rec = softsense::recording::Recording::open(&out).unwrap();
    assert_eq!(
        std::fs::canonicalize(rec.model_path().unwrap()).unwrap(),
        std::fs::canonicalize(robot_model()).unwrap()
    );
}

/// The field a `[truth]` error names, or the error itself.
fn field_of(e: SceneError) -> String {
    match e {
        SceneError::BadTruth { field, .. } => field,
        other => panic!("not a BadTruth error: {other}"),
    }
}

#[test]
fn a_bad_truth_value_is_a_typed_error_naming_its_field() {
    let cases = [
        ("young_factor = 0.0", "truth.young_factor"),
        ("young_factor = -1.15", "truth.young_factor"),
        ("young_factor = nan", "truth.young_factor"),
        ("young_factor = 20.0", "truth.young_factor"),
        ("poisson = 0.5", "truth.poisson"),
        ("poisson = -1.0", "truth.poisson"),
        ("formulation = \"linear\"", "truth.formulation"),
        ("mesh = \"\"", "truth.mesh"),
    ];
    for (line, field) in cases {
        let dir = tempfile::tempdir().unwrap();
        let e = Scene::load(&scene_file(dir.path(), &format!("[truth]\n{line}\n"))).unwrap_err();
        assert_eq!(field_of(e), field, "{line}");
    }
    // A mesh that is not there, or not the model's shape, is refused when it is loaded.
    for mesh in ["missing.vtu", "sheet.vtu"] {
        let dir = tempfile::tempdir().unwrap();
        let path = root().join("meshes").join(mesh);
        let truth = format!("[truth]\nmesh = {:?}\n", path.display().to_string());
        let scene = Scene::load(&scene_file(dir.path(), &truth)).unwrap();
        let e = scene.truth_body(&scene.model().unwrap()).unwrap_err();
        let shown = e.to_string();
        assert_eq!(field_of(e), "truth.mesh", "{mesh}");
        assert!(shown.contains(mesh), "{shown}");
    }
}

/// The robot mesh with its nodes in reverse order, written into `dir`; and the map from
/// the mesh's node to the written one's.
fn reversed_robot_mesh(dir: &Path) -> (PathBuf, Vec<usize>) {
    let mesh = softsense::fem::meshio::read_mesh(&root().join("meshes/robot.vtu")).unwrap();
    let n = mesh.num_nodes();
    let nodes: Vec<[f64; 3]> = (0..n).map(|i| mesh.nodes_in_rest[n - 1 - i]).collect();
    let tets: Vec<[usize; 4]> = mesh.tets.iter().map(|t| t.map(|v| n - 1 - v)).collect();
    let path = dir.join("reversed.vtu");
    softsense::fem::meshio::write_vtu(&path, &nodes, &tets, &[], &[]).unwrap();
    (path, (0..n).map(|v| n - 1 - v).collect())
}

#[test]
fn a_truth_on_another_mesh_keeps_the_models_supports_cables_and_node_indices() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, to_new) = reversed_robot_mesh(dir.path());
    // The robot model with two more nodes fixed by index and a load on a node.
    let model = Model::load(&robot_model(), None).unwrap();
    let top = (0..model.problem.mesh.num_nodes())
        .filter(|&v| model.problem.mesh.nodes_in_rest[v][2] >= 0.124)
        .collect::<Vec<_>>();
    let text = std::fs::read_to_string(robot_model()).unwrap().replace(
        "path = \"../robot.vtu\"",
        &format!(
            "path = {:?}",
            root().join("meshes/robot.vtu").display().to_string()
        ),
    );
    let text = format!(
        "{text}\n[[fixed]]\nnodes = [{}]\n[[loads]]\nnode = {}\nforce = [0.0, 0.0, -100.0]\n",
        top[0], top[1]
    );
    let file = dir.path().join("model.toml");
    std::fs::write(&file, text).unwrap();
    let own = Model::load(&file, None).unwrap();
    let other = Model::load_on_mesh(&file, &mesh).unwrap();
    let moved: Vec<usize> = own.problem.fixed.iter().map(|&v| to_new[v]).collect();
    let mut moved = moved;
    moved.sort_unstable();
    assert_eq!(
        other.problem.fixed, moved,
        "fixed nodes by box and by index"
    );
    let load = other.problem.loads.last().unwrap().at;
    assert_eq!(load.nodes[0], to_new[top[1]], "the load's node");
    let (a, b) = (
        own.problem.solve_static(&own.newton).unwrap(),
        other.problem.solve_static(&other.newton).unwrap(),
    );
    let gap = (0..a.positions.len())
        .map(|v| softsense::math::dist(a.positions[v], b.positions[to_new[v]]))
        .fold(0.0, f64::max);
    assert!(
        gap < 1e-7,
        "the same body on a renumbered mesh moves {gap} m apart"
    );
}

#[test]
fn a_scene_truth_mesh_is_rendered_and_named_in_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, _) = reversed_robot_mesh(dir.path());
    let truth = format!("[truth]\nmesh = {:?}\n", mesh.display().to_string());
    let scene = Scene::load(&scene_file(dir.path(), &truth)).unwrap();
    let out = dir.path().join("out");
    let t = generate(&scene, &out, |_, _| {}).unwrap();
    assert_eq!(t.truth_model.unwrap().mesh, "../reversed.vtu");
    // The same body, renumbered: the camera sees what it sees of the model.
    let plain_dir = tempfile::tempdir().unwrap();
    let plain = Scene::load(&scene_file(plain_dir.path(), "")).unwrap();
    let p = generate(&plain, &plain_dir.path().join("out"), |_, _| {}).unwrap();
    let (a, b) = (t.frames[1].pixels[0] as i64, p.frames[1].pixels[0] as i64);
    assert!((a - b).abs() <= 2, "robot pixels {a} and {b}");
}

#[test]
fn no_estimator_reads_the_truth_model() {
    // `truth_model` documents the scene: only the scene and `hidden`'s dataset writer
    // write it (and the scene command's help names it) and the schema types it; nothing
    // that senses or explains may mention it.
    let mut offenders = Vec::new();
    let mut stack = vec![root().join("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                let rel = path.strip_prefix(root()).unwrap().to_path_buf();
                let home = rel.starts_with("src/scene")
                    || rel == Path::new("src/recording/schema.rs")
                    || rel == Path::new("src/cli/scene.rs")
                    || rel == Path::new("src/discrepancy/generate.rs");
                if text.contains("truth_model") && !home {
                    offenders.push(rel);
                }
            }
        }
    }
    assert!(offenders.is_empty(), "{offenders:?} read truth_model");
}

#[test]
fn a_sweeps_truth_mesh_is_rendered_and_written_so_its_scene_files_load_again() {
    use softsense::scene::sweep::{run, Sweep};
    let dir = tempfile::tempdir().unwrap();
    let (mesh, _) = reversed_robot_mesh(dir.path());
    let file = dir.path().join("sweep.toml");
    let model = robot_model().display().to_string();
    let truth = "[truth]\nmesh = \"reversed.vtu\"\nyoung_factor = [0.9, 1.1]\n";
    std::fs::write(&file, format!("model = {model:?}\n{truth}")).unwrap();
    let sweep = Sweep::load(&file).unwrap();
    let out = dir.path().join("out");
    let records = run(&sweep, &out, 1, 5, |_, _| {}).unwrap();
    let drawn = records[0].truth.as_ref().expect("a drawn truth");
    assert!((0.9..=1.1).contains(&drawn.young_factor), "{drawn:?}");
    // The scene file names the mesh from its own folder, and loads again.
    let scene = Scene::load(&out.join("scene_0000.toml")).unwrap();
    let canon = |p: &Path| std::fs::canonicalize(p).unwrap();
    assert_eq!(canon(scene.truth_mesh.as_deref().unwrap()), canon(&mesh));
    assert_eq!(scene.spec.truth.unwrap().young_factor, drawn.young_factor);
    let text = std::fs::read_to_string(out.join("scene_0000/truth.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["truth_model"]["mesh"], "../../reversed.vtu");
}

#[test]
fn a_compliant_base_truth_lowers_the_body_and_is_recorded() {
    // 1e5 N/m under the robot's 4.9 N and the cable: the base sinks, the tip drops more.
    let problem = Model::load(&robot_model(), None).unwrap().problem;
    let (rest, base) = (&problem.mesh.nodes_in_rest, &problem.fixed);
    let (model, soft) = (solved(""), solved("[truth]\nbase_stiffness = 1.0e5\n"));
    let (m, s) = (tip_drop(&model, rest), tip_drop(&soft, rest));
    assert!(
        (1.01..1.1).contains(&(s / m)),
        "tip drop {s} m against {m} m"
    );
    let sinks = base.iter().map(|&v| rest[v][2] - soft[0][v][2]);
    let sink = sinks.sum::<f64>() / base.len() as f64;
    assert!(sink > 1e-5, "the base sinks {sink} m");
    assert!(base.iter().all(|&v| model[0][v] == rest[v]), "clamped");
    let dir = tempfile::tempdir().unwrap();
    let file = scene_file(dir.path(), "[truth]\nbase_stiffness = 1.0e5\n");
    let scene = Scene::load(&file).unwrap();
    let truth = generate(&scene, &dir.path().join("out"), |_, _| {}).unwrap();
    let t = truth.truth_model.expect("a truth_model");
    assert_eq!((t.young_factor, t.base_stiffness), (1.0, Some(1.0e5)));
}

#[test]
fn a_bad_base_stiffness_is_refused_by_name() {
    for line in [
        "base_stiffness = 0.0",
        "base_stiffness = -1.0e5",
        "base_stiffness = inf",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let e = Scene::load(&scene_file(dir.path(), &format!("[truth]\n{line}\n"))).unwrap_err();
        assert_eq!(field_of(e), "truth.base_stiffness", "{line}");
    }
}

#[test]
fn a_sweeps_base_stiffness_is_drawn_in_its_range_on_the_truths_own_stream() {
    use softsense::scene::truth::{TruthRanges, TruthSpec};
    let with: TruthRanges =
        toml::from_str("young_factor = [0.9, 1.1]\nbase_stiffness = [1.0e5, 1.0e6]").unwrap();
    let without: TruthRanges = toml::from_str("young_factor = [0.9, 1.1]").unwrap();
    assert!(with.check().is_ok());
    let mut drawn = Vec::new();
    for index in 0..8 {
        let (a, b): (TruthSpec, TruthSpec) =
            (with.draw(3, index, None), without.draw(3, index, None));
        let k = a.base_stiffness.expect("drawn");
        assert!((1.0e5..=1.0e6).contains(&k), "{k}");
        // Adding the base leaves the other draws as they were.
        assert_eq!(a.young_factor, b.young_factor);
        drawn.push(k);
    }
    assert!(drawn.windows(2).any(|w| w[0] != w[1]), "{drawn:?}");
    let bad: TruthRanges = toml::from_str("base_stiffness = [1.0e6, 1.0e5]").unwrap();
    match bad.check() {
        Err(SceneError::BadTruth { field, .. }) => assert_eq!(field, "truth.base_stiffness"),
        other => panic!("{other:?}"),
    }
}

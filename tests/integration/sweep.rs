//! `scene sweep` and `score`: drawn scenes keep to their ranges and are physical, the
//! occluder hides what was asked, and a sweep sensed and scored end to end counts right.

use crate::common::run_cli;
use softsense::register::vertex_normals;
use softsense::scene::sweep::{draw, Prepared, Sweep};
use std::path::{Path, PathBuf};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A sweep file in a temporary folder, the robot model referred to absolutely.
fn sweep_file(dir: &Path, body: &str) -> Sweep {
    let model = root().join("meshes/models/robot.toml");
    let path = dir.join("sweep.toml");
    std::fs::write(
        &path,
        format!("model = {:?}\n{body}", model.display().to_string()),
    )
    .unwrap();
    Sweep::load(&path).unwrap()
}

#[test]
fn drawn_two_probe_scenes_keep_to_their_ranges_and_are_physical() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = sweep_file(
        dir.path(),
        "[camera]\ndistance = [0.45, 0.55]\nelevation_deg = [25.0, 40.0]\n\
         [probes]\ncount = [2, 2]\nforce = [0.3, 0.6]\ncone_deg = 10.0\nmin_separation = 0.05\n",
    );
    let prepared = Prepared::new(&sweep).unwrap();
    let mesh = &prepared.model.problem.mesh;
    // Directions are drawn about the normals of the robot as the camera sees it unloaded.
    let normals = vertex_normals(prepared.unloaded(), &mesh.surface().triangles);
    for index in 0..3 {
        let d = draw(&sweep, &prepared, 5, index).unwrap();
        let r = &d.record;
        assert!((0.45..=0.55).contains(&r.distance), "{r:?}");
        assert!((25.0..=40.0).contains(&r.elevation_deg), "{r:?}");
        let c = &d.scene.spec.camera;
        let eye_dist = norm(sub(c.eye, c.target));
        assert!((eye_dist - r.distance).abs() < 1e-9);
        let loads = &d.rendered.truth.loads;
        assert_eq!(loads.len(), 2);
        let gap = norm(sub(loads[0].at_rest, loads[1].at_rest));
        assert!(gap >= 0.05, "probes {:.1} mm apart", gap * 1e3);
        for l in loads {
            assert!((0.3..=0.6).contains(&l.magnitude), "{}", l.magnitude);
            let inward = normals[l.node].map(|v| -v);
            let cos = dot(inward, l.force) / (norm(inward) * l.magnitude);
            assert!(cos >= 10f64.to_radians().cos() - 1e-9, "cone: cos {cos}");
        }
        assert!(
            d.rendered.truth.pixels[1] >= 40,
            "probes seen: {:?}",
            d.rendered.truth.pixels
        );
        // Nearly inverted elements are redrawn.
        let x = &d.rendered.positions;
        let x0 = &mesh.nodes_in_rest;
        for t in &mesh.tets {
            let v = |p: &[[f64; 3]]| {
                softsense::fem::mesh::signed_volume(p[t[0]], p[t[1]], p[t[2]], p[t[3]])
            };
            assert!(v(x) / v(x0) >= 0.1);
        }
    }
}

#[test]
fn a_sweeps_scene_depends_only_on_the_file_the_seed_and_its_index() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = sweep_file(dir.path(), "");
    let prepared = Prepared::new(&sweep).unwrap();
    let a = draw(&sweep, &prepared, 9, 1).unwrap();
    let b = draw(&sweep, &prepared, 9, 1).unwrap();
    let c = draw(&sweep, &prepared, 10, 1).unwrap();
    let text = |d: &softsense::scene::sweep::Drawn| toml::to_string(&d.scene.spec).unwrap();
    assert_eq!(text(&a), text(&b));
    assert_ne!(text(&a), text(&c));
    assert_eq!(a.rendered.views[0].depth, b.rendered.views[0].depth);
}

#[test]
fn an_occluded_sweep_hides_the_drawn_share_of_the_robot_but_not_the_probe() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = sweep_file(dir.path(), "[occluder]\nfraction = [0.3, 0.3]\n");
    let prepared = Prepared::new(&sweep).unwrap();
    for index in 0..2 {
        let d = draw(&sweep, &prepared, 3, index).unwrap();
        // Sized on the robot at rest; the loaded robot moves a few pixels.
        assert!(
            (d.record.occluded - 0.3).abs() < 0.04,
            "hidden share {}",
            d.record.occluded
        );
        assert_eq!(d.scene.spec.occluders.len(), 1);
        assert!(d.rendered.truth.pixels[1] >= 20);
    }
}

#[test]
fn a_sweep_file_with_a_bad_range_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "model = \"x.toml\"\n[camera]\ndistance = [0.6, 0.4]\n",
    )
    .unwrap();
    let e = Sweep::load(&path).expect_err("refused").to_string();
    assert!(e.contains("camera.distance"), "{e}");
    let out = run_cli(&[
        "scene",
        "sweep",
        path.to_str().unwrap(),
        dir.path().join("out").to_str().unwrap(),
        "--count",
        "1",
        "--seed",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn a_sweep_refuses_a_folder_that_is_not_empty() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("keep.txt"), "mine").unwrap();
    let sweep = root().join("tools/sweeps/robot_one_probe.toml");
    let out = run_cli(&[
        "scene",
        "sweep",
        sweep.to_str().unwrap(),
        dir.path().to_str().unwrap(),
        "--count",
        "1",
        "--seed",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not empty"));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("keep.txt")).unwrap(),
        "mine"
    );
}

#[test]
fn a_sweep_sensed_and_scored_counts_every_load_once() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("sw");
    let sweep = root().join("tools/sweeps/robot_one_probe.toml");
    let out = run_cli(&[
        "scene",
        "sweep",
        sweep.to_str().unwrap(),
        out_dir.to_str().unwrap(),
        "--count",
        "2",
        "--seed",
        "4",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out_dir.join("sweep.toml").is_file() && out_dir.join("draws.json").is_file());
    // The written sweep file draws the same scenes again.
    let again = Sweep::load(&out_dir.join("sweep.toml")).unwrap();
    assert_eq!(again.spec.probes.count, [1, 1]);
    for k in 0..2 {
        let rec = out_dir.join(format!("scene_{k:04}"));
        let sensed = run_cli(&["sense", rec.to_str().unwrap(), "--json"]);
        assert!(sensed.status.success());
        std::fs::write(rec.join("sense.json"), &sensed.stdout).unwrap();
    }
    let scored = run_cli(&["score", out_dir.to_str().unwrap(), "--json"]);
    assert!(
        scored.status.success(),
        "{}",
        String::from_utf8_lossy(&scored.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&scored.stdout).unwrap();
    assert_eq!(v["all"]["loads"], 2);
    assert_eq!(v["all"]["frames"], 2);
    assert_eq!(v["loads"].as_array().unwrap().len(), 2);
    // Every scene falls in exactly one azimuth bin.
    let binned: u64 = v["by_azimuth"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["summary"]["frames"].as_u64().unwrap())
        .sum();
    assert_eq!(binned, 2);
    // A sense output that lost a frame is refused, not scored as fewer loads.
    std::fs::write(out_dir.join("scene_0001/sense.json"), "").unwrap();
    let scored = run_cli(&["score", out_dir.to_str().unwrap()]);
    assert_eq!(scored.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&scored.stderr).contains("truth.json has 1"));
}

/// Regression: a diamond sweep stopped at its first draw whose load inverted an element
/// during the FE solve ("inverted tetrahedron 3545"), instead of drawing again.
#[test]
fn a_load_that_inverts_an_element_is_redrawn_not_the_end_of_the_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = sweep_file(
        dir.path(),
        "[probes]\nforce = [30.0, 40.0]\n[validity]\nmax_attempts = 3\n",
    );
    let prepared = Prepared::new(&sweep).unwrap();
    let err = draw(&sweep, &prepared, 1, 0).err().unwrap().to_string();
    assert!(err.contains("no physical scene in 3 attempts"), "{err}");
    assert!(
        err.contains("the FE solve failed (inverted tetrahedron"),
        "{err}"
    );
}

#[test]
fn a_sweep_with_two_cameras_draws_a_rig_spaced_in_azimuth_and_writes_a_folder_per_camera() {
    let dir = tempfile::tempdir().unwrap();
    let body = "[camera]\ncount = 2\nazimuth_spacing_deg = 90.0\n\
                distance = [0.45, 0.55]\nelevation_deg = [25.0, 40.0]\n";
    let sweep = sweep_file(dir.path(), body);
    let prepared = Prepared::new(&sweep).unwrap();
    let out = dir.path().join("scene_0000");
    let (scene, record) =
        softsense::scene::sweep::write_drawn(&sweep, &prepared, 3, 0, &out).unwrap();
    let [more] = &record.more_cameras[..] else {
        panic!("one more camera expected: {record:?}");
    };
    assert_eq!(more.azimuth_deg, record.azimuth_deg + 90.0);
    assert!((0.45..=0.55).contains(&more.distance), "{more:?}");
    assert!((25.0..=40.0).contains(&more.elevation_deg), "{more:?}");
    let cams = &scene.spec.cameras;
    assert_eq!(cams.len(), 2);
    let eye_dist = norm(sub(cams[1].camera.eye, cams[1].camera.target));
    assert!((eye_dist - more.distance).abs() < 1e-9);
    let rig = softsense::recording::Rig::open(&out).unwrap();
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1"]);
    assert!(rig.cameras.iter().all(|c| c.has_frame(0)));
    // Adding a camera keeps the first camera and the probes of the one-camera sweep.
    let one = sweep_file(dir.path(), &body.replace("count = 2\n", ""));
    let d = draw(&one, &prepared, 3, 0).unwrap();
    assert_eq!(d.record.azimuth_deg, record.azimuth_deg);
    assert_eq!(d.record.distance, record.distance);
    assert_eq!(d.record.attempts, record.attempts);
    let at = |s: &softsense::scene::Scene| s.spec.frames[0].loads[0].at;
    assert_eq!(at(&d.scene), at(&scene));
    assert!(d.record.more_cameras.is_empty() && d.scene.spec.cameras.is_empty());
}

#[test]
fn a_sweeps_truth_is_drawn_per_scene_and_leaves_its_cameras_and_probes_alone() {
    let dir = tempfile::tempdir().unwrap();
    let plain = sweep_file(dir.path(), "");
    let truth_dir = tempfile::tempdir().unwrap();
    let body = "[truth]\nyoung_factor = [0.85, 1.15]\nformulation = \"neo-hookean\"\n";
    let with_truth = sweep_file(truth_dir.path(), body);
    let (p, q) = (
        Prepared::new(&plain).unwrap(),
        Prepared::new(&with_truth).unwrap(),
    );
    let (mut factors, mut compared) = (Vec::new(), 0);
    for index in 0..3 {
        let a = draw(&plain, &p, 4, index).unwrap();
        let b = draw(&with_truth, &q, 4, index).unwrap();
        assert!(a.record.truth.is_none() && a.scene.spec.truth.is_none());
        let t = b.record.truth.clone().expect("a drawn truth");
        assert!((0.85..=1.15).contains(&t.young_factor), "{t:?}");
        assert_eq!(t.formulation.as_deref(), Some("neo-hookean"));
        assert_eq!(b.scene.spec.truth.as_ref(), Some(&t));
        factors.push(t.young_factor);
        // Attempt k draws the same camera and probe with or without the truth (which body
        // is physical under them may differ, so the kept attempt may too); another body.
        if a.record.attempts == b.record.attempts {
            compared += 1;
            assert_eq!(a.scene.spec.camera.eye, b.scene.spec.camera.eye);
            let (la, lb) = (&a.scene.spec.frames[0].loads, &b.scene.spec.frames[0].loads);
            assert_eq!((la[0].at, la[0].force), (lb[0].at, lb[0].force));
        }
        let moved = (a.rendered.positions.iter().zip(&b.rendered.positions))
            .map(|(x, y)| norm(sub(*x, *y)))
            .fold(0.0, f64::max);
        assert!(moved > 1e-4, "the truth moved the body {moved} m");
    }
    assert_ne!(factors[0], factors[1], "one draw per scene");
    assert!(compared > 0, "no scene kept the same attempt");
    // A range the wrong way round is refused by name.
    let bad = dir.path().join("bad_truth.toml");
    std::fs::write(
        &bad,
        "model = \"x.toml\"\n[truth]\nyoung_factor = [1.15, 0.85]\n",
    )
    .unwrap();
    match Sweep::load(&bad) {
        Err(softsense::scene::SceneError::BadTruth { field, .. }) => {
            assert_eq!(field, "truth.young_factor")
        }
        other => panic!("not refused by name: {:?}", other.err()),
    }
}

#[test]
fn a_sweep_with_reference_frames_writes_that_many_unloaded_frames_before_the_loaded_one() {
    let dir = tempfile::tempdir().unwrap();
    let camera = "[camera]\ndistance = [0.45, 0.55]\n";
    let plain = sweep_file(dir.path(), camera);
    assert_eq!(plain.spec.reference_frames, 0);
    let with_ref = sweep_file(dir.path(), &format!("reference_frames = 2\n{camera}"));
    let prepared = Prepared::new(&plain).unwrap();
    let write = |sweep: &Sweep, name: &str| {
        let out = dir.path().join(name);
        let (scene, _) =
            softsense::scene::sweep::write_drawn(sweep, &prepared, 6, 0, &out).unwrap();
        let truth: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap())
                .unwrap();
        let loads: Vec<usize> = (truth["frames"].as_array().unwrap().iter())
            .map(|f| f["loads"].as_array().unwrap().len())
            .collect();
        (scene, loads, out)
    };
    // The default: one loaded frame per scene, as before.
    let (a, loads, out) = write(&plain, "plain");
    assert_eq!(loads, [1]);
    assert!(!out.join("depth_0001.png").exists());
    // Two unloaded frames first, of the same camera and cable inputs, then the same load.
    let (b, loads, out) = write(&with_ref, "reference");
    assert_eq!(loads, [0, 0, 1]);
    assert!((0..3).all(|i| out.join(format!("depth_{i:04}.png")).is_file()));
    assert_eq!(a.spec.camera.eye, b.spec.camera.eye);
    assert!(b
        .spec
        .frames
        .iter()
        .all(|f| f.cables.len() == a.spec.frames[0].cables.len()));
    let at = |s: &softsense::scene::Scene, i: usize| s.spec.frames[i].loads[0].at;
    assert_eq!(at(&a, 0), at(&b, 2));
    // Each frame is rendered at its own index: the unloaded frames differ in their noise.
    let depth = |i: usize| std::fs::read(out.join(format!("depth_{i:04}.png"))).unwrap();
    assert_ne!(depth(0), depth(1));
    // The written sweep file keeps the option, and leaves it out when 0.
    assert!(toml::to_string(&with_ref.spec)
        .unwrap()
        .contains("reference_frames = 2"));
    assert!(!toml::to_string(&plain.spec)
        .unwrap()
        .contains("reference_frames"));
}

#[test]
fn a_sweep_with_held_frames_writes_the_same_load_that_many_times_each_with_its_own_noise() {
    let dir = tempfile::tempdir().unwrap();
    let camera = "[camera]\ndistance = [0.45, 0.55]\n";
    let plain = sweep_file(dir.path(), camera);
    assert_eq!(plain.spec.held_frames, 1);
    let held = sweep_file(
        dir.path(),
        &format!("reference_frames = 1\nheld_frames = 3\n{camera}"),
    );
    let prepared = Prepared::new(&plain).unwrap();
    let out = dir.path().join("held");
    let (scene, _) = softsense::scene::sweep::write_drawn(&held, &prepared, 6, 0, &out).unwrap();
    let loads: Vec<usize> = scene.spec.frames.iter().map(|f| f.loads.len()).collect();
    assert_eq!(loads, [0, 1, 1, 1]);
    let at = |i: usize| scene.spec.frames[i].loads[0].at;
    assert_eq!(at(1), at(3));
    let depth = |i: usize| std::fs::read(out.join(format!("depth_{i:04}.png"))).unwrap();
    assert_ne!(depth(1), depth(2));
    assert!(toml::to_string(&held.spec)
        .unwrap()
        .contains("held_frames = 3"));
    assert!(!toml::to_string(&plain.spec)
        .unwrap()
        .contains("held_frames"));
    // Out of range is refused naming the key.
    let bad = dir.path().join("bad.toml");
    let model = root().join("meshes/models/robot.toml");
    std::fs::write(
        &bad,
        format!(
            "model = {:?}\nheld_frames = 0\n",
            model.display().to_string()
        ),
    )
    .unwrap();
    let err = Sweep::load(&bad).unwrap_err().to_string();
    assert!(err.contains("held_frames"), "{err}");
}

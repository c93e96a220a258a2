//! Scene files with several cameras (`[[cameras]]`): what is refused, and each camera's
//! own noise seed.

use softsense::math::rand::camera_seed;
use softsense::scene::{Scene, SceneError};

const FRAME: &str = "[[frames]]\n";

/// Loads a scene file whose body follows a model line (the model is not read by `load`).
fn load(body: &str) -> Result<Scene, SceneError> {
    load_file(&format!("model = \"robot.toml\"\nseed = 5\n{body}"))
}

fn load_file(text: &str) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path)
}

fn camera(name: &str, eye: &str) -> String {
    format!("[[cameras]]\nname = \"{name}\"\neye = {eye}\ntarget = [0.0, 0.0, 0.06]\n")
}

fn refusal(body: &str) -> String {
    match load(body) {
        Ok(_) => panic!("accepted:\n{body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_scene_with_two_named_cameras_renders_each_with_its_own_seed() {
    let body = camera("front", "[0.0, -0.433, 0.31]") + &camera("side", "[0.433, 0.0, 0.31]");
    let scene = load(&(body + FRAME)).unwrap();
    let views = scene.views();
    let names: Vec<_> = views.iter().map(|v| v.name.as_deref().unwrap()).collect();
    assert_eq!(names, ["front", "side"]);
    assert_eq!(views[1].camera.eye, [0.433, 0.0, 0.31]);
    // Unset fields take [camera]'s defaults.
    assert_eq!((views[1].camera.width, views[1].camera.fx), (640, 615.0));
    assert_eq!(views[0].seed, camera_seed(5, 0));
    assert_eq!(views[1].seed, camera_seed(5, 1));
    assert_ne!(views[0].seed, views[1].seed);
}

#[test]
fn a_scene_with_one_camera_keeps_the_scene_seed() {
    let scene = load(&format!("[camera]\nwidth = 320\nheight = 240\n{FRAME}")).unwrap();
    let views = scene.views();
    assert_eq!(views.len(), 1);
    assert_eq!(views[0].name, None);
    assert_eq!((views[0].seed, views[0].camera.width), (5, 320));
}

#[test]
fn camera_and_cameras_together_are_refused() {
    let body = format!(
        "[camera]\nwidth = 320\n{}{FRAME}",
        camera("a", "[0.0, -0.4, 0.3]")
    );
    let e = refusal(&body);
    assert!(e.contains("both [camera] and [[cameras]]"), "{e}");
}

#[test]
fn two_cameras_of_one_name_are_refused() {
    let body = camera("a", "[0.0, -0.4, 0.3]") + &camera("a", "[0.4, 0.0, 0.3]") + FRAME;
    let e = refusal(&body);
    assert!(e.contains("two cameras are named a"), "{e}");
}

#[test]
fn a_camera_name_that_is_not_a_folder_name_or_is_missing_is_refused() {
    let e = refusal(&(camera("../up", "[0.0, -0.4, 0.3]") + FRAME));
    assert!(e.contains("camera name \"../up\""), "{e}");
    let e = refusal("[[cameras]]\neye = [0.0, -0.4, 0.3]\n[[frames]]\n");
    assert!(e.contains("every camera needs a name"), "{e}");
}

#[test]
fn a_misspelt_or_faulty_camera_field_is_refused_naming_the_camera() {
    let e = refusal(&(camera("side", "[0.4, 0.0, 0.3]") + "fz = 600.0\n" + FRAME));
    assert!(e.contains("camera side") && e.contains("fz"), "{e}");
    let e = refusal(&(camera("side", "[0.4, 0.0, 0.3]") + "width = 0\n" + FRAME));
    assert!(e.contains("camera side: camera.width is 0"), "{e}");
    let e = refusal(&(camera("side", "[0.4, 0.0, 0.3]") + "width = 5000\n" + FRAME));
    assert!(e.contains("camera side: image larger than"), "{e}");
}

#[test]
fn camera_seeds_differ_by_camera_and_by_scene_seed() {
    let seeds: Vec<u64> = (0..4).map(|i| camera_seed(7, i)).collect();
    for i in 0..4 {
        for j in 0..i {
            assert_ne!(seeds[i], seeds[j]);
        }
        assert_ne!(camera_seed(8, i), seeds[i]);
        assert_ne!(seeds[i], 7);
    }
}

#[test]
fn a_scene_with_cameras_written_out_loads_again_without_a_camera_table() {
    let body = camera("front", "[0.0, -0.433, 0.31]") + &camera("side", "[0.433, 0.0, 0.31]");
    let scene = load(&(body + FRAME)).unwrap();
    let text = toml::to_string(&scene.spec).unwrap();
    let table: toml::Table = toml::from_str(&text).unwrap();
    assert!(!table.contains_key("camera"), "{text}");
    let again = load_file(&text).unwrap();
    assert_eq!(toml::to_string(&again.spec).unwrap(), text);
    // One camera is written as [camera], as before.
    let one = load(&format!("[camera]\nwidth = 320\n{FRAME}")).unwrap();
    let text = toml::to_string(&one.spec).unwrap();
    assert!(
        text.contains("[camera]") && !text.contains("cameras"),
        "{text}"
    );
}

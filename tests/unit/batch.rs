//! The batch manifest: items, defaults, sweep expansion, and errors that name the file and
//! what is wrong; result files that resume a run.
use softsense::batch::manifest::RegistrationName;
use softsense::batch::{plan, result_path, Item, Manifest, Source};
use std::path::{Path, PathBuf};

fn parse(text: &str) -> Result<Manifest, String> {
    Manifest::parse(text, Path::new("runs/m.toml")).map_err(|e| e.to_string())
}

#[test]
fn items_take_defaults_and_paths_from_the_manifests_folder() {
    let m = parse(
        r#"
        [defaults]
        features = 40
        registration = "features"
        model = "models/robot.toml"

        [[recording]]
        path = "rec/tip_weight"
        features = 60

        [[scene]]
        spec = "scenes/side.toml"
        id = "side"
        registration = "dense"

        [[sweep]]
        spec = "sweeps/one.toml"
        count = 3
        seed = 7
        "#,
    )
    .unwrap();
    let ids: Vec<&str> = m.items.iter().map(|i| i.id.as_str()).collect();
    assert_eq!(
        ids,
        ["tip_weight", "side", "one_0000", "one_0001", "one_0002"]
    );
    let tip = &m.items[0];
    assert_eq!(
        tip.source,
        Source::Recording {
            path: PathBuf::from("runs/rec/tip_weight")
        }
    );
    assert_eq!(tip.options.features, Some(60));
    assert_eq!(tip.options.registration, Some(RegistrationName::Features));
    assert_eq!(
        tip.options.model.as_deref(),
        Some(Path::new("runs/models/robot.toml"))
    );
    assert_eq!(
        m.items[1].options.registration,
        Some(RegistrationName::Dense)
    );
    assert_eq!(m.items[1].options.features, Some(40));
    assert_eq!(
        m.items[4].source,
        Source::SweepScene {
            spec: PathBuf::from("runs/sweeps/one.toml"),
            seed: 7,
            index: 2
        }
    );
}

#[test]
fn a_bad_manifest_names_the_file_and_the_fault() {
    let cases: [(&str, &str); 7] = [
        ("[[recording]]\npath = 3\n", "path"),
        ("[[recording]]\npath = \"a\"\nfeatres = 3\n", "featres"),
        ("[[sweep]]\nspec = \"s.toml\"\ncount = 2\n", "seed"),
        (
            "[[sweep]]\nspec = \"s.toml\"\ncount = 0\nseed = 1\n",
            "at least 1",
        ),
        (
            "[[recording]]\npath = \"x/a\"\n[[recording]]\npath = \"y/a\"\n",
            "two items are called \"a\"",
        ),
        (
            "[[recording]]\npath = \"a\"\nid = \"../b\"\n",
            "cannot name a file",
        ),
        ("# nothing\n", "no items"),
    ];
    for (text, want) in cases {
        let e = parse(text).unwrap_err();
        assert!(e.starts_with("runs/m.toml: "), "{e}");
        assert!(e.contains(want), "{text:?}: {e}");
    }
    let e = parse("[[recording]]\npath = \"a\"\nregistration = \"sparse\"\n").unwrap_err();
    assert!(e.contains("sparse"), "{e}");
    let e = Manifest::load(Path::new("/no/such/manifest.toml")).unwrap_err();
    assert!(
        e.to_string()
            .contains("/no/such/manifest.toml: cannot read it"),
        "{e}"
    );
}

fn write(out: &Path, item: &Item, json: serde_json::Value) {
    let p = result_path(out, &item.id);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, json.to_string()).unwrap();
}

#[test]
fn plan_skips_complete_results_and_earlier_failures_unless_retried() {
    let m = parse(
        "[[recording]]\npath = \"a\"\n[[recording]]\npath = \"b\"\n[[recording]]\npath = \"c\"\n\
         [[recording]]\npath = \"d\"\n[[recording]]\npath = \"e\"\n",
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let [a, b, c, d, _e] = &m.items[..] else {
        panic!()
    };
    write(
        out,
        a,
        serde_json::json!({"id": "a", "item": a, "status": "done", "frames": []}),
    );
    write(
        out,
        b,
        serde_json::json!({"id": "b", "item": b, "status": "failed", "error": "boom"}),
    );
    // c's result is of another item (the manifest changed); d's is cut short.
    write(
        out,
        c,
        serde_json::json!({"id": "c", "item": a, "status": "done", "frames": []}),
    );
    std::fs::write(result_path(out, "d"), "{\"id\": \"d\", \"st").unwrap();
    let _ = d;
    let p = plan(&m.items, out, false);
    let todo: Vec<&str> = p.todo.iter().map(|i| i.id.as_str()).collect();
    assert_eq!(todo, ["c", "d", "e"]);
    assert_eq!((p.done, p.replaced), (1, 2));
    assert_eq!(p.failed, [("b".to_string(), "boom".to_string())]);
    let p = plan(&m.items, out, true);
    let todo: Vec<&str> = p.todo.iter().map(|i| i.id.as_str()).collect();
    assert_eq!(todo, ["b", "c", "d", "e"]);
    assert!(p.failed.is_empty());
}

//! The house rules of `docs/architecture.md`, read from that page and checked on the code:
//! every `crate::` path (and every `super::` path that climbs to the crate root) in `src/`
//! against the layer table, and every concept of the "one type per concept" table declared,
//! aliased or given a synonym only in its home module. Comments and string literals are
//! not code: doc links are not imports.
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layer table: each top-level module's rank (0 = the bottom layer), and whether the
/// modules of a layer may import each other.
struct Layers {
    rank: BTreeMap<String, usize>,
    names: Vec<String>,
    sideways: Vec<bool>,
    /// The (from, to) pairs allowed across a "no" layer.
    across: BTreeSet<(String, String)>,
}

/// Reads the `## Layers` table: | layer | modules | sideways | holds |, top layer first.
fn parse_layers(doc: &str) -> Layers {
    let section = doc
        .split("\n## Layers")
        .nth(1)
        .expect("architecture.md has a `## Layers` section");
    let section = section.split("\n## ").next().unwrap_or_default();
    let tables = tables(section);
    let rows = &tables[0];
    assert!(
        rows.len() >= 3,
        "the layer table has too few rows: {rows:?}"
    );
    let n = rows.len();
    let (mut rank, mut names, mut sideways) =
        (BTreeMap::new(), vec![String::new(); n], vec![false; n]);
    for (i, row) in rows.iter().enumerate() {
        let r = n - 1 - i;
        names[r] = row[0].clone();
        sideways[r] = match row[2].as_str() {
            "yes" => true,
            "no" => false,
            other => panic!(
                "layer {}: the sideways column says {other:?}, not yes/no",
                row[0]
            ),
        };
        for m in backticked(&row[1]) {
            // `cli` (binary) and `python/` are not modules of the library.
            if !m.contains('/') && m != "cli" {
                assert!(rank.insert(m.clone(), r).is_none(), "{m} is in two layers");
            }
        }
    }
    // The table after it: | from | to | why |, the imports allowed between siblings.
    let across = (tables.get(1).into_iter().flatten())
        .map(|row| (backticked(&row[0]).concat(), backticked(&row[1]).concat()))
        .collect();
    Layers {
        rank,
        names,
        sideways,
        across,
    }
}

/// The body rows of the first Markdown table in `text`, cells trimmed.
fn table_rows(text: &str) -> Vec<Vec<String>> {
    tables(text).into_iter().next().unwrap_or_default()
}

/// The body rows of each Markdown table in `text`, in order, cells trimmed.
fn tables(text: &str) -> Vec<Vec<Vec<String>>> {
    let mut out: Vec<Vec<Vec<String>>> = Vec::new();
    let mut in_table = false;
    for line in text.lines().map(str::trim) {
        if !line.starts_with('|') {
            in_table = false;
            continue;
        }
        if !in_table {
            // A new table: its header row; the separator row comes next.
            in_table = true;
            out.push(Vec::new());
            continue;
        }
        if line.starts_with("| ---") {
            continue;
        }
        let cells = line.trim_start_matches('|').trim_end_matches('|');
        let row = cells.split('|').map(|c| c.trim().to_string()).collect();
        out.last_mut().expect("a table").push(row);
    }
    out
}

/// The `code` spans of a table cell.
fn backticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// `src` with every comment and the inside of every string and char literal blanked out
/// (newlines kept, so line numbers hold).
fn code_only(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                let pair = (c[i], c.get(i + 1).copied());
                if pair == ('/', Some('*')) || pair == ('*', Some('/')) {
                    depth += if pair.0 == '/' { 1 } else { -1 };
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
        } else if let Some(hashes) = raw_string_start(&c, i) {
            // r"..." and r#"..."# (b-prefixed too): no escapes; ends at a quote and the hashes.
            let open = i + usize::from(c[i] == 'b') + hashes + 2;
            out.extend(c[i..open].iter());
            i = open;
            let closes = |k: usize| c[k] == '"' && (1..=hashes).all(|h| c.get(k + h) == Some(&'#'));
            while i < c.len() && !closes(i) {
                out.push(blank(c[i]));
                i += 1;
            }
            let end = (i + 1 + hashes).min(c.len());
            out.extend(c[i.min(end)..end].iter());
            i = end;
        } else if c[i] == '"' || (c[i] == '\'' && is_char_literal(&c, i)) {
            let quote = c[i];
            out.push(quote);
            i += 1;
            while i < c.len() && c[i] != quote {
                if c[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < c.len() {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
            // The closing quote.
            if i < c.len() {
                out.push(quote);
                i += 1;
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// The number of `#` of a raw string literal starting at `i`, if one starts there.
fn raw_string_start(c: &[char], i: usize) -> Option<usize> {
    if i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_') {
        return None;
    }
    let r = i + usize::from(c[i] == 'b');
    if c.get(r) != Some(&'r') {
        return None;
    }
    let hashes = c[r + 1..].iter().take_while(|&&h| h == '#').count();
    (c.get(r + 1 + hashes) == Some(&'"')).then_some(hashes)
}

/// Whether the quote at `i` opens a char literal ('x', '\n', '\u{..}'), not a lifetime.
fn is_char_literal(c: &[char], i: usize) -> bool {
    matches!(
        (c.get(i + 1), c.get(i + 2)),
        (Some('\\'), _) | (Some(_), Some('\''))
    )
}

/// A file's module path below the crate root (`src/fem/mesh.rs` → [fem, mesh]).
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// Every top-level module a file's code names, with the line: `crate::m`, each item of
/// `crate::{a::.., b}`, and `super::` chains that climb to the crate root.
fn imports(code: &str, module: &[String]) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in code.lines().enumerate() {
        let line_no = n + 1;
        for (at, _) in line.match_indices("crate::") {
            if line[..at].ends_with(|ch: char| ch.is_alphanumeric() || ch == '_' || ch == '$') {
                continue;
            }
            out.extend(
                path_heads(&code_from(code, n, at + "crate::".len()))
                    .into_iter()
                    .map(|m| (line_no, m)),
            );
        }
        for (at, _) in line.match_indices("super::") {
            if line[..at].ends_with(|ch: char| ch.is_alphanumeric() || ch == '_' || ch == ':') {
                continue;
            }
            let supers = line[at..].split("::").take_while(|s| *s == "super").count();
            if supers >= module.len() {
                let after = code_from(code, n, at + supers * "super::".len());
                out.extend(path_heads(&after).into_iter().map(|m| (line_no, m)));
            }
        }
    }
    out
}

/// The code from byte `at` of line `n` on.
fn code_from(code: &str, n: usize, at: usize) -> String {
    let start: usize = code.lines().take(n).map(|l| l.len() + 1).sum::<usize>() + at;
    code[start.min(code.len())..].to_string()
}

/// The first segment of a path (`fem::mesh::X` → fem), or of each item of a group
/// (`{fem::mesh, io}` → fem, io).
fn path_heads(after: &str) -> Vec<String> {
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|ch| ch.is_alphanumeric() || *ch == '_')
            .collect()
    };
    let t = after.trim_start();
    if !t.starts_with('{') {
        return vec![ident(t)];
    }
    let (mut depth, mut heads, mut item_start) = (0, Vec::new(), 1);
    for (k, ch) in t.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' | ',' if depth == 1 => {
                let h = ident(&t[item_start..k]);
                if !h.is_empty() {
                    heads.push(h);
                }
                item_start = k + 1;
                if ch == '}' {
                    break;
                }
            }
            '}' => depth -= 1,
            _ => {}
        }
    }
    heads
}

/// One import that the layer table forbids.
#[derive(Debug, PartialEq)]
struct Break {
    file: String,
    line: usize,
    from: String,
    to: String,
}

/// The forbidden imports of one file (`rel` below `src/`). Files outside the layered
/// modules (the binary, the crate root and the crate-level error) are not checked.
fn check_file(layers: &Layers, rel: &Path, text: &str) -> Vec<Break> {
    let module = module_path(rel);
    let Some(from) = module.first() else {
        return vec![];
    };
    let Some(&r_from) = layers.rank.get(from) else {
        return vec![];
    };
    let mut out = Vec::new();
    for (line, to) in imports(&code_only(text), &module) {
        let Some(&r_to) = layers.rank.get(&to) else {
            continue;
        };
        let sibling = r_to == r_from && &to != from && !layers.sideways[r_from];
        let allowed = layers.across.contains(&(from.clone(), to.clone()));
        let forbidden = r_to > r_from || (sibling && !allowed);
        if forbidden {
            out.push(Break {
                file: rel.display().to_string(),
                line,
                from: from.clone(),
                to,
            });
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn architecture() -> String {
    std::fs::read_to_string(root().join("docs/architecture.md")).unwrap()
}

fn sources() -> Vec<(PathBuf, String)> {
    let src = root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p.strip_prefix(&src).unwrap().to_path_buf(), text)
        })
        .collect()
}

#[test]
fn no_module_imports_from_a_higher_layer_or_a_sibling_workflow() {
    let layers = parse_layers(&architecture());
    let files = sources();
    // Every library module is in the table, so none escapes the check.
    let tops: BTreeSet<String> = files
        .iter()
        .filter_map(|(rel, _)| module_path(rel).first().cloned())
        .collect();
    for top in &tops {
        if !matches!(top.as_str(), "cli" | "main" | "lib" | "error") {
            assert!(
                layers.rank.contains_key(top),
                "module {top} is in no layer of docs/architecture.md"
            );
        }
    }
    let breaks: Vec<String> = files
        .iter()
        .flat_map(|(rel, text)| check_file(&layers, rel, text))
        .map(|b| {
            format!(
                "src/{}:{}: {} ({}) imports {} ({})",
                b.file,
                b.line,
                b.from,
                layers.names[layers.rank[&b.from]],
                b.to,
                layers.names[layers.rank[&b.to]]
            )
        })
        .collect();
    assert!(
        breaks.is_empty(),
        "imports against the layer table:\n{}",
        breaks.join("\n")
    );
}

/// The seven breaks the house had before this check, each as it was written.
const OLD_BREAKS: [(&str, &str); 7] = [
    ("calibrate/pso.rs", "use crate::scene::sensor::uniform;\n"),
    ("control/task.rs", "fn phase(seed: u64, i: u64) -> f64 {\n    std::f64::consts::TAU * crate::scene::sensor::uniform(seed, 0, i, 0)\n}\n"),
    ("control/plant.rs", "let noise =\n    |axis: u64| s * crate::scene::sensor::normal(self.spec.seed, step as u64, axis, 7);\n"),
    ("markers/calib.rs", "let iso = crate::calibrate::rigid::kabsch(tracker, model).ok_or_else(|| {\n"),
    ("calibrate/feature.rs", "use crate::markers::bind_markers;\n"),
    ("control/output.rs", "use crate::render::{line_chart, Canvas, Rgb, Series};\n"),
    ("control/mod.rs", "    #[error(\"picture: {0}\")]\n    Render(#[from] crate::render::RenderError),\n"),
];

#[test]
fn the_scanner_catches_each_of_the_seven_breaks_it_was_written_for() {
    let layers = parse_layers(&architecture());
    for (file, text) in OLD_BREAKS {
        let found = check_file(&layers, Path::new(file), text);
        assert_eq!(found.len(), 1, "{file}: {text:?} gave {found:?}");
    }
}

#[test]
fn the_scanner_sees_groups_aliases_synonyms_and_climbing_supers_but_not_comments_or_strings() {
    let layers = parse_layers(&architecture());
    let caught = [
        ("fem/solve.rs", "use crate::{math::sub, sense::Sensor};"),
        (
            "fem/solve.rs",
            "use crate::{\n    math::sub,\n    render::{Canvas, Rgb},\n};",
        ),
        ("fem/solve.rs", "use crate::render as r;"),
        ("fem/solve.rs", "pub type Picture = crate::render::Canvas;"),
        ("fem/solve.rs", "pub use crate::control::run::Run;"),
        (
            "fem/solve.rs",
            "fn f() -> crate::sense::FrameReport { todo!() }",
        ),
        (
            "scene/sweep/spec.rs",
            "use super::super::super::sense::Sensor;",
        ),
        ("sense/mod.rs", "use super::markers::MarkerSensor;"),
        ("math/mod.rs", "let x = crate::io::atomic::write(p, b);"),
        (
            "scene/markers.rs",
            "use crate::markers::{bind_markers, BoundMarker};",
        ),
        (
            "scene/generate.rs",
            "use crate::discrepancy::DiscrepancyError;",
        ),
    ];
    for (file, text) in caught {
        assert_eq!(
            check_file(&layers, Path::new(file), text).len(),
            1,
            "{file}: {text:?}"
        );
    }
    let allowed = [
        (
            "fem/solve.rs",
            "//! See [`crate::render::Canvas`].\nuse crate::math::sub;",
        ),
        (
            "fem/solve.rs",
            "/* crate::sense */ let s = \"crate::render\";",
        ),
        (
            "fem/solve.rs",
            "let s = r#\"crate::render \"quoted\"\"#; let c = '\"'; use crate::io;",
        ),
        (
            "fem/solve.rs",
            "fn f<'a>(x: &'a str) -> &'a str { x } // crate::sense",
        ),
        (
            "scene/sweep/spec.rs",
            "use super::super::camera::CameraSpec;",
        ),
        ("sense/report.rs", "use super::params::SenseParams;"),
        ("render/control.rs", "use crate::control::run::Run;"),
        (
            "discrepancy/generate.rs",
            "use crate::scene::camera::CameraSpec;",
        ),
        ("inverse/qp.rs", "use crate::fem::solve::MappedPoint;"),
        ("main.rs", "use softsense::render;"),
    ];
    for (file, text) in allowed {
        assert_eq!(
            check_file(&layers, Path::new(file), text),
            vec![],
            "{file}: {text:?}"
        );
    }
}

/// The one-type-per-concept table: each concept's type names and the module that owns them.
fn concepts(doc: &str) -> Vec<(String, String)> {
    let section = doc
        .split("\n## One type per concept")
        .nth(1)
        .expect("architecture.md has a `## One type per concept` section");
    let mut out = Vec::new();
    for row in table_rows(section) {
        // The type column's first `code` span is the home path, with `{A, B}` for several.
        let path = backticked(&row[1]).into_iter().next().expect("a type path");
        let (home, names) = match path.split_once("::{") {
            Some((home, group)) => (
                home.to_string(),
                group
                    .trim_end_matches('}')
                    .split(',')
                    .map(|s| s.trim().to_string())
                    .collect(),
            ),
            None => {
                let (home, name) = path.rsplit_once("::").expect("a module path");
                (home.to_string(), vec![name.to_string()])
            }
        };
        out.extend(names.into_iter().map(|n| (n, home.clone())));
    }
    out
}

/// Declarations of `name` (struct, enum, trait, type alias) and aliases whose right side
/// names it, in code that is not its home module; `rel` below `src/`.
fn concept_breaks(rel: &Path, text: &str, name: &str, home: &str) -> Vec<String> {
    if module_path(rel).join("::") == home {
        return vec![];
    }
    let mut out = Vec::new();
    for (n, line) in code_only(text).lines().enumerate() {
        let words: Vec<&str> = line
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .filter(|w| !w.is_empty())
            .collect();
        let declares = words
            .windows(2)
            .any(|w| matches!(w[0], "struct" | "enum" | "trait" | "type") && w[1] == name);
        // `type Other = path::Name;`: a second name for the concept.
        let synonym = words.contains(&"type")
            && line.split_once('=').is_some_and(|(_, rhs)| {
                rhs.split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .any(|w| w == name)
            });
        if declares || synonym {
            out.push(format!("src/{}:{}: {}", rel.display(), n + 1, line.trim()));
        }
    }
    out
}

#[test]
fn each_concept_is_declared_and_named_only_in_its_home_module() {
    let doc = architecture();
    let concepts = concepts(&doc);
    assert!(concepts.iter().any(|(n, _)| n == "Camera"), "{concepts:?}");
    let mut breaks = Vec::new();
    for (rel, text) in sources() {
        for (name, home) in &concepts {
            breaks.extend(concept_breaks(&rel, &text, name, home));
        }
    }
    assert!(
        breaks.is_empty(),
        "a concept declared or aliased outside its home:\n{}",
        breaks.join("\n")
    );
}

#[test]
fn the_concept_check_sees_aliases_and_synonyms() {
    let alias =
        "/// A camera's size and `[fx, fy, cx, cy]`.\npub type Camera = ([usize; 2], [f64; 4]);\n";
    assert_eq!(
        concept_breaks(
            Path::new("recording/import/align.rs"),
            alias,
            "Camera",
            "camera"
        )
        .len(),
        1
    );
    let synonym = "pub type View = crate::camera::Camera;\n";
    assert_eq!(
        concept_breaks(Path::new("render/project.rs"), synonym, "Camera", "camera").len(),
        1
    );
    let own = "pub struct Camera {\n    intrinsics: PinholeIntrinsics,\n}\n";
    assert_eq!(
        concept_breaks(Path::new("camera.rs"), own, "Camera", "camera"),
        Vec::<String>::new()
    );
    let mention = "/// Each frame's [`Camera`].\nfn f(c: &Camera) {}\n";
    assert_eq!(
        concept_breaks(Path::new("sense/observe.rs"), mention, "Camera", "camera"),
        Vec::<String>::new()
    );
}

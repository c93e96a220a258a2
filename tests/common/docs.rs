//! Documents whose command blocks are tests: each ```sh block runs in order in one scratch
//! folder (`softsense` on the PATH; the repository's `meshes/`, `clouds/` and `scenarios/`
//! beside it; `/tmp/` in a command is the folder's own `tmp/`), and the ```text block right
//! after one lists lines its output (stdout and stderr) must show, in that order, times
//! left out and `...` standing for lines not shown. A block after `<!-- not run: WHY -->`
//! is skipped, saying why. A changed output fails until the document changes with it.
#![allow(dead_code)]

use super::project_root;
use std::path::Path;

/// A command block and the lines its output must show.
pub struct Step {
    /// The commands.
    pub script: String,
    /// Lines the output must show, in order (`...` stands for lines left out).
    pub expect: Vec<String>,
    /// Where the block starts in the document (1-based line of its first command).
    pub line: usize,
    /// Why it is not run (`<!-- not run: WHY -->` on the line before it), if it is not.
    pub not_run: Option<String>,
}

/// The ```sh blocks of a markdown text, each with the ```text block following it.
pub fn steps(markdown: &str) -> Vec<Step> {
    let lines: Vec<&str> = markdown.lines().collect();
    let mut out: Vec<Step> = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let fence = lines[i].trim_end();
        if fence == "```sh" || fence == "```text" {
            let start = i + 1;
            let mut end = start;
            while end < lines.len() && lines[end].trim_end() != "```" {
                end += 1;
            }
            let body: Vec<String> = lines[start..end].iter().map(|l| l.to_string()).collect();
            match fence {
                "```sh" => {
                    let before = if i > 0 { lines[i - 1].trim() } else { "" };
                    let not_run = (before.strip_prefix("<!-- not run:"))
                        .map(|w| w.trim_end_matches("-->").trim().to_string());
                    out.push(Step {
                        script: body.join("\n"),
                        expect: Vec::new(),
                        line: start + 1,
                        not_run,
                    });
                }
                _ => {
                    if let Some(last) = out.last_mut().filter(|s| s.expect.is_empty()) {
                        last.expect = body;
                    }
                }
            }
            i = end;
        }
        i += 1;
    }
    out
}

/// Times vary from run to run: "157 ms", "0.2 s", "5.5 frames/s" become "<time>".
pub fn redact(line: &str) -> String {
    let mut out = String::new();
    let words: Vec<&str> = line.split(' ').collect();
    let mut k = 0;
    while k < words.len() {
        let number = words[k].trim_end_matches(',').parse::<f64>().is_ok();
        let unit = words
            .get(k + 1)
            .map(|w| w.trim_end_matches([',', ';', ')']));
        if number && matches!(unit, Some("ms" | "s" | "frames/s")) {
            out.push_str("<time>");
            let tail = &words[k + 1][unit.unwrap_or("").len()..];
            out.push_str(tail);
            k += 2;
        } else {
            out.push_str(words[k]);
            k += 1;
        }
        if k < words.len() {
            out.push(' ');
        }
    }
    out
}

/// Runs every step of `doc` in a scratch folder and checks its output; a block whose first
/// line starts with one of `not_run`'s prefixes is skipped, its reason printed.
pub fn run_document(doc: &str, not_run: &[(&str, &str)]) {
    let path = project_root().join(doc);
    let text = std::fs::read_to_string(&path).unwrap();
    let scratch = tempfile::tempdir().unwrap();
    for shared in ["meshes", "clouds", "scenarios"] {
        let link = scratch.path().join(shared);
        std::os::unix::fs::symlink(project_root().join(shared), link).unwrap();
    }
    std::fs::create_dir(scratch.path().join("tmp")).unwrap();
    let tmp = format!("{}/", scratch.path().join("tmp").display());
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_softsense")).parent().unwrap();
    let path_var = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let all = steps(&text);
    assert!(!all.is_empty(), "{doc} has no ```sh block");
    for step in &all {
        let first = step.script.lines().next().unwrap_or("");
        let skip = (not_run.iter().find(|(prefix, _)| first.starts_with(prefix)))
            .map(|(_, why)| why.to_string())
            .or(step.not_run.clone());
        if let Some(why) = skip {
            println!("{doc}:{}: not run ({why}): {first}", step.line);
            continue;
        }
        // As the reader runs them: `cargo run --release --` is the installed binary, and
        // /tmp/ is the scratch folder's own.
        let script =
            (step.script.replace("cargo run --release -- ", "softsense ")).replace("/tmp/", &tmp);
        let o = std::process::Command::new("bash")
            .args(["-eo", "pipefail", "-c", &format!("exec 2>&1\n{script}")])
            .current_dir(scratch.path())
            .env("PATH", &path_var)
            .output()
            .unwrap();
        let shown = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "{doc}:{}: the block failed:\n{}\n--- output:\n{shown}",
            step.line,
            step.script
        );
        let got: Vec<String> = shown.lines().map(redact).collect();
        let mut at = 0;
        for want in step.expect.iter().filter(|w| w.trim() != "...") {
            let want = redact(&want.replace("/tmp/", &tmp));
            match got[at..].iter().position(|g| *g == want) {
                Some(k) => at += k + 1,
                None => panic!("{doc}:{}: the output no longer shows (in this order)\n  {want}\n--- output:\n{shown}", step.line),
            }
        }
    }
}

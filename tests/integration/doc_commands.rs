//! The documents' command blocks, run: each ```sh block of a walkthrough runs in order in
//! one scratch folder (with `softsense` on the PATH and the repository's `meshes/` beside
//! it), and the ```text block right after one lists lines its output (stdout and stderr)
//! must show, in that order, times left out. A changed output fails here until the document
//! is changed with it.

use crate::common::{oracle::gmsh_python, project_root};
use std::path::Path;

/// A command block and the lines its output must show.
struct Step {
    script: String,
    expect: Vec<String>,
    line: usize,
}

/// The ```sh blocks of a markdown text, each with the ```text block following it.
fn steps(markdown: &str) -> Vec<Step> {
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
                "```sh" => out.push(Step {
                    script: body.join("\n"),
                    expect: Vec::new(),
                    line: start,
                }),
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
fn redact(line: &str) -> String {
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

/// Runs every step of `doc` in a scratch folder and checks its output.
fn run_document(doc: &str) {
    let path = project_root().join(doc);
    let text = std::fs::read_to_string(&path).unwrap();
    let scratch = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(project_root().join("meshes"), scratch.path().join("meshes"))
        .unwrap();
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_softsense")).parent().unwrap();
    let path_var = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let all = steps(&text);
    assert!(!all.is_empty(), "{doc} has no ```sh block");
    for step in all {
        let o = std::process::Command::new("bash")
            .args([
                "-eo",
                "pipefail",
                "-c",
                &format!("exec 2>&1\n{}", step.script),
            ])
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
        for want in &step.expect {
            let want = redact(want);
            match got[at..].iter().position(|g| *g == want) {
                Some(k) => at += k + 1,
                None => panic!("{doc}:{}: the output no longer shows (in this order)\n  {want}\n--- output:\n{shown}", step.line),
            }
        }
    }
}

#[test]
fn the_redaction_leaves_out_times_and_keeps_everything_else() {
    assert_eq!(redact("1 FE updates, 157 ms"), "1 FE updates, <time>");
    assert_eq!(redact("gmsh 4.15.2, 0.2 s"), "gmsh 4.15.2, <time>");
    assert_eq!(
        redact("430 ms per frame; stream 2.5 frames/s (2 at a time)"),
        "<time> per frame; stream <time> (2 at a time)"
    );
    assert_eq!(redact("|F| = 0.121 ± 0.0443 N"), "|F| = 0.121 ± 0.0443 N");
}

#[test]
fn the_step_reader_pairs_each_command_block_with_the_output_after_it() {
    let md = "a\n```sh\necho 1\n```\n\n```text\n1\n```\n```toml\nx = 1\n```\n```sh\necho 2\necho 3\n```\n";
    let s = steps(md);
    assert_eq!(s.len(), 2);
    assert_eq!(
        (s[0].script.as_str(), s[0].expect.clone()),
        ("echo 1", vec!["1".to_string()])
    );
    assert_eq!(
        (s[1].script.as_str(), s[1].expect.len()),
        ("echo 2\necho 3", 0)
    );
}

#[test]
fn the_your_robot_walkthrough_runs_as_written() {
    if gmsh_python("the_your_robot_walkthrough_runs_as_written").is_none() {
        return;
    }
    run_document("docs/your-robot.md");
}

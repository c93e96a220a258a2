//! The walkthrough docs/your-robot.md, run as written (`common::docs`), and the reader
//! of command blocks itself.

use crate::common::docs::{commands, redact, run_document, softsense_args, steps};
use crate::common::oracle::gmsh_python;
use crate::common::project_root;

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
    let md = "a\n```sh\necho 1\n```\n\n```text\n1\n```\n```toml\nx = 1\n```\n<!-- not run: slow -->\n```sh\necho 2\necho 3\n```\n";
    let s = steps(md);
    assert_eq!(s.len(), 2);
    assert_eq!(
        (s[0].not_run.as_deref(), s[1].not_run.as_deref()),
        (None, Some("slow"))
    );
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
    run_document("docs/your-robot.md", &[]);
}

#[test]
fn the_command_reader_drops_redirections_assignments_and_heredoc_bodies() {
    let md = "```sh\nSOFTSENSE_DATA=../d softsense sense x --json > out.jsonl 2>&1 &\n\
cat > a.toml <<'EOF'\nsoftsense not-a-command\nEOF\n\
cargo run --release -- hidden /tmp/h --truth 'young_factor = 1.1' \\\n    --seed 3 && echo done # why\n```\n";
    let got: Vec<Vec<String>> = commands(md).into_iter().map(|c| c.words).collect();
    let w = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
    assert_eq!(
        got,
        vec![
            w("softsense sense x --json"),
            w("cat"),
            vec![
                "cargo",
                "run",
                "--release",
                "--",
                "hidden",
                "/tmp/h",
                "--truth",
                "young_factor = 1.1",
                "--seed",
                "3"
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            w("echo done"),
        ]
    );
    assert_eq!(
        softsense_args(&got[2]).map(|a| a[0].as_str()),
        Some("hidden")
    );
    assert_eq!(softsense_args(&got[1]), None);
}

/// Files a command names that must be in the repository: a script it runs, an example, a
/// test or bench target.
fn named_files(words: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    // Build outputs (`target/`) are made by an earlier command, not kept in the repository.
    let repo_path = |w: &str| {
        !w.starts_with(['/', '$', '.', '~']) && !w.starts_with("target/") && w.contains('/')
    };
    match words.first().map(String::as_str) {
        Some("python3" | "bash" | "sh") => {
            out.extend(words.get(1).filter(|w| repo_path(w)).cloned());
        }
        Some("cargo") => {
            for pair in words.windows(2) {
                let dir = match pair[0].as_str() {
                    "--example" => "examples",
                    "--test" => "tests",
                    "--bench" => "benches",
                    _ => continue,
                };
                out.push(format!("{dir}/{}", pair[1]));
            }
        }
        Some(first) if repo_path(first) => out.push(first.to_string()),
        _ => {}
    }
    out
}

#[test]
fn every_documented_softsense_command_parses_and_every_script_it_names_exists() {
    let root = project_root();
    let mut docs = vec![root.join("README.md")];
    let mut pages: Vec<_> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    pages.sort();
    docs.extend(pages);
    let (mut parsed, mut failures) = (0, Vec::new());
    for doc in &docs {
        let name = doc.strip_prefix(&root).unwrap().display().to_string();
        for cmd in commands(&std::fs::read_to_string(doc).unwrap()) {
            for file in named_files(&cmd.words) {
                let found = [
                    file.clone(),
                    format!("{file}.rs"),
                    format!("{file}/main.rs"),
                ]
                .iter()
                .any(|f| root.join(f).exists());
                if !found {
                    failures.push(format!("{name}:{}: {file} does not exist", cmd.line));
                }
            }
            let Some(args) = softsense_args(&cmd.words) else {
                continue;
            };
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
                .args(args)
                .env("SOFTSENSE_ARGS_ONLY", "1")
                .output()
                .unwrap();
            parsed += 1;
            if !o.status.success() {
                failures.push(format!(
                    "{name}:{}: softsense {}\n{}",
                    cmd.line,
                    args.join(" "),
                    String::from_utf8_lossy(&o.stderr)
                ));
            }
        }
    }
    // The documents hold 56 commands today: a reader that found none would pass vacuously.
    assert!(parsed >= 40, "only {parsed} documented commands found");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

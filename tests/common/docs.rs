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

/// A command in a document's ```sh blocks: its words, with the block's line.
pub struct DocCommand {
    /// The words, quotes removed (environment assignments and redirections left out).
    pub words: Vec<String>,
    /// The 1-based line of the block's first command.
    pub line: usize,
}

/// Every command of every ```sh block (run or not): continuation lines joined, heredoc
/// bodies left out, split at unquoted `&&`, `||`, `;`, `|`, `&` and parentheses.
pub fn commands(markdown: &str) -> Vec<DocCommand> {
    let mut out = Vec::new();
    for step in steps(markdown) {
        let mut heredoc: Option<String> = None;
        let mut joined = String::new();
        for line in step.script.lines() {
            if let Some(end) = &heredoc {
                if line.trim() == end {
                    heredoc = None;
                }
                continue;
            }
            if let Some(at) = line.find("<<") {
                let tag = line[at + 2..].trim_start_matches('-').trim();
                let tag = tag.split_whitespace().next().unwrap_or("");
                heredoc = Some(tag.trim_matches(['\'', '"']).to_string());
            }
            match line.trim_end().strip_suffix('\\') {
                Some(head) => {
                    joined.push_str(head);
                    joined.push(' ');
                }
                None => {
                    joined.push_str(line);
                    joined.push('\n');
                }
            }
        }
        for words in split_commands(&joined) {
            out.push(DocCommand {
                words,
                line: step.line,
            });
        }
    }
    out
}

/// Shell words of `text`, grouped into commands (see [`commands`]); comments dropped.
fn split_commands(text: &str) -> Vec<Vec<String>> {
    let mut all = Vec::new();
    let mut words: Vec<String> = Vec::new();
    let mut word = String::new();
    let mut in_word = false;
    let mut chars = text.chars().peekable();
    let end_word = |word: &mut String, in_word: &mut bool, words: &mut Vec<String>| {
        if *in_word {
            words.push(std::mem::take(word));
            *in_word = false;
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                in_word = true;
                for q in chars.by_ref() {
                    if q == '\'' {
                        break;
                    }
                    word.push(q);
                }
            }
            '"' => {
                in_word = true;
                while let Some(q) = chars.next() {
                    match q {
                        '"' => break,
                        '\\' => word.extend(chars.next()),
                        _ => word.push(q),
                    }
                }
            }
            '\\' => {
                in_word = true;
                word.extend(chars.next());
            }
            '#' if !in_word => {
                while chars.peek().is_some_and(|&n| n != '\n') {
                    chars.next();
                }
            }
            ' ' | '\t' => end_word(&mut word, &mut in_word, &mut words),
            // `2>&1` and `&>` are redirections, not a background `&`.
            '&' if word.ends_with('>') || chars.peek() == Some(&'>') => {
                in_word = true;
                word.push(c);
            }
            '\n' | ';' | '&' | '|' | '(' | ')' => {
                end_word(&mut word, &mut in_word, &mut words);
                if !words.is_empty() {
                    all.push(std::mem::take(&mut words));
                }
                if c != '\n' && chars.peek() == Some(&c) {
                    chars.next();
                }
            }
            _ => {
                in_word = true;
                word.push(c);
            }
        }
    }
    end_word(&mut word, &mut in_word, &mut words);
    if !words.is_empty() {
        all.push(words);
    }
    all.into_iter()
        .map(|ws| {
            let mut keep = Vec::new();
            let mut skip_next = false;
            for w in ws {
                if skip_next {
                    skip_next = false;
                } else if w.starts_with('>') || w.starts_with("2>") || w.starts_with('<') {
                    // `> FILE` takes the next word; `>FILE` and `2>&1` do not.
                    skip_next = matches!(w.as_str(), ">" | ">>" | "2>" | "<" | "<<");
                } else if keep.is_empty() && is_assignment(&w) {
                } else {
                    keep.push(w);
                }
            }
            keep
        })
        .filter(|ws| !ws.is_empty())
        .collect()
}

fn is_assignment(word: &str) -> bool {
    word.split_once('=').is_some_and(|(name, _)| {
        !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

/// The arguments a documented command gives `softsense` (after `softsense` or
/// `cargo run --release --`), or None for another program.
pub fn softsense_args(words: &[String]) -> Option<&[String]> {
    match words {
        [first, rest @ ..] if first == "softsense" => Some(rest),
        [c, r, rel, dd, rest @ ..]
            if c == "cargo" && r == "run" && rel == "--release" && dd == "--" =>
        {
            Some(rest)
        }
        _ => None,
    }
}

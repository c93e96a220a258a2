//! The walkthrough docs/your-robot.md, run as written (`common::docs`), and the reader
//! of command blocks itself.

use crate::common::docs::{redact, run_document, steps};
use crate::common::oracle::gmsh_python;

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

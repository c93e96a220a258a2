//! The README's commands, run as written (`common::docs`): the main job and the tour, with
//! the outputs it shows. In the acceptance tier: the tour's `explain` takes a minute
//! optimised.

use crate::common::docs::run_document;

/// The README's blocks that are not run, by their first line, and why.
const NOT_RUN: [(&str, &str); 4] = [
    ("cargo install", "installs the program the other blocks run"),
    ("cargo test", "the test command: this test is part of it"),
    ("SOFTSENSE_DATA=", "the test command with its switches"),
    (
        "softsense calibrate DIR",
        "a template: DIR and MODEL.toml are the reader's own",
    ),
];

#[test]
fn the_readme_runs_as_written() {
    run_document("README.md", &NOT_RUN);
}

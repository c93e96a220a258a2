//! Integration tests: whole stages and the CLI on files.
mod common;

#[path = "integration/cli.rs"]
mod cli;

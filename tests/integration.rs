//! Integration tests: whole stages and the CLI on files.
mod common;

//! Regression tests: one test per bug, named after it.
mod common;

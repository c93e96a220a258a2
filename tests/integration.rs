//! Integration tests: whole stages and the CLI on files.
mod common;

#[path = "integration/cli.rs"]
mod cli;
#[path = "integration/explain_hidden.rs"]
mod explain_hidden;
#[path = "integration/fem_cantilever.rs"]
mod fem_cantilever;
#[path = "integration/fem_diamond.rs"]
mod fem_diamond;
#[path = "integration/fem_skfem.rs"]
mod fem_skfem;
#[path = "integration/sense_tip_weight.rs"]
mod sense_tip_weight;

//! Subcommand implementations: each parses nothing itself (clap did) and calls the library.

pub mod fem;
pub mod scene;

//! Subcommand implementations: each parses nothing itself (clap did) and calls the library.

pub mod calibrate;
pub mod cluster;
pub mod contacts;
pub mod convert;
pub mod explain;
pub mod fem;
pub mod filter;
pub mod info;
pub mod scene;
pub mod segment;
pub mod sense;

use std::fmt;

/// Why a subcommand failed; decides the exit code.
#[derive(Debug)]
pub enum CliError {
    /// The arguments do not make sense together (exit code 2, like clap's own errors).
    Usage(String),
    /// The library refused (bad file, bad intrinsics, ...); the message names the file.
    Lib(softsense::Error),
    /// The command ran but its result is unusable (e.g. no valid point); exit code 1.
    Result(String),
    /// Any other error from a subcommand that returns `Box<dyn Error>`; exit code 1.
    Other(Box<dyn std::error::Error>),
}

impl CliError {
    /// The process exit code for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Usage(_) => 2,
            CliError::Lib(_) | CliError::Result(_) | CliError::Other(_) => 1,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Usage(m) | CliError::Result(m) => write!(f, "{m}"),
            CliError::Lib(e) => write!(f, "{e}"),
            CliError::Other(e) => write!(f, "{e}"),
        }
    }
}

impl From<softsense::Error> for CliError {
    fn from(e: softsense::Error) -> Self {
        CliError::Lib(e)
    }
}

impl From<softsense::pipeline::PipelineError> for CliError {
    fn from(e: softsense::pipeline::PipelineError) -> Self {
        CliError::Lib(e.into())
    }
}

impl From<Box<dyn std::error::Error>> for CliError {
    fn from(e: Box<dyn std::error::Error>) -> Self {
        CliError::Other(e)
    }
}

impl From<softsense::io::IoError> for CliError {
    fn from(e: softsense::io::IoError) -> Self {
        CliError::Lib(e.into())
    }
}

/// The result every subcommand returns.
pub type CliResult = Result<(), CliError>;

/// Prints a JSON value on stdout, one document per line. A closed pipe (`| head`) is not
/// an error; any other write failure is.
pub fn print_json(value: &serde_json::Value) -> CliResult {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{value}") {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(CliError::Result(format!("cannot write to stdout: {e}")))
        }
        _ => Ok(()),
    }
}

/// Parses `R,G,B` (0-255 each), e.g. `40,200,60`.
pub fn parse_rgb(s: &str) -> Result<[u8; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [r, g, b] = parts[..] else {
        return Err(format!("expected R,G,B, e.g. 40,200,60 (got {s:?})"));
    };
    let c = |v: &str| {
        v.trim()
            .parse::<u8>()
            .map_err(|e| format!("colour {v:?}: {e}"))
    };
    Ok([c(r)?, c(g)?, c(b)?])
}

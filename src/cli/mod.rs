//! Subcommand implementations: each parses nothing itself (clap did) and calls the library.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};

/// `println!` through [`out`]: a closed pipe or a full disk is not a panic.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub mod batch;
pub mod calibrate;
pub mod catheter;
pub mod cluster;
pub mod colour;
pub mod contacts;
pub mod control;
pub mod convert;
pub mod explain;
pub mod fem;
pub mod filter;
pub mod import;
pub mod info;
pub mod markers;
pub mod markers_calib;
pub mod markers_detect;
pub mod markers_layout;
pub mod model;
pub mod model_check;
pub mod model_new;
pub mod pose;
pub mod rerun_out;
pub mod scene;
pub mod score;
pub mod segment;
pub mod sense;
pub mod sense_membrane;
mod sense_membrane_plot;
pub mod sense_print;

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
        use softsense::{fem::FemError, recording::RecordingError, Error};
        match self {
            CliError::Usage(_) => 2,
            // A path of the wrong kind (a file for a folder, arguments swapped) is a usage
            // error, wherever the library found it.
            CliError::Lib(Error::Recording(RecordingError::NotAFolder { .. }))
            | CliError::Lib(Error::Fem(FemError::NotAModel { .. })) => 2,
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

impl std::error::Error for CliError {}

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

impl From<softsense::fem::FemError> for CliError {
    fn from(e: softsense::fem::FemError) -> Self {
        CliError::Lib(e.into())
    }
}

impl From<softsense::io::IoError> for CliError {
    fn from(e: softsense::io::IoError) -> Self {
        CliError::Lib(e.into())
    }
}

/// The result every subcommand returns.
pub type CliResult = Result<(), CliError>;

/// Set once stdout's reader has gone (`| head`): later output is dropped, not an error.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes to stdout without panicking. A closed pipe (`| head`) is not an error: the rest of
/// the output is dropped (see [`stdout_closed`]) and the command's other work (files it
/// writes) goes on. Any other write failure (a full disk) is an error, exit code 1.
pub fn out(args: fmt::Arguments<'_>) -> CliResult {
    use std::io::Write;
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return Ok(());
    }
    let mut stdout = std::io::stdout().lock();
    match stdout.write_fmt(args).and_then(|()| stdout.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            STDOUT_CLOSED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Err(e) => Err(CliError::Result(format!("cannot write to stdout: {e}"))),
        Ok(()) => Ok(()),
    }
}

/// Whether stdout's reader has gone: a command whose only product is stdout may stop.
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

/// A bar of `len` control steps named `name` on a terminal's stderr, hidden otherwise (so
/// piped output stays clean).
pub fn steps_bar(len: usize, name: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(len as u64);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} steps ({eta})")
    {
        b.set_style(style);
    }
    b.set_message(name.to_string());
    b
}

/// Prints a JSON value on stdout, one document per line (see [`out`]).
pub fn print_json(value: &serde_json::Value) -> CliResult {
    out(format_args!("{value}\n"))
}

/// `path` as a person would write it for a message: the file itself (links and `..`
/// resolved), relative to the working directory when it is inside it, else absolute.
/// `path` as given when it cannot be resolved (e.g. it does not exist).
pub fn shown_path(path: &std::path::Path) -> std::path::PathBuf {
    let Ok(real) = std::fs::canonicalize(path) else {
        return path.to_path_buf();
    };
    std::env::current_dir()
        .and_then(std::fs::canonicalize)
        .ok()
        .and_then(|cwd| real.strip_prefix(cwd).ok().map(|p| p.to_path_buf()))
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(real)
}

/// Parses a count of at least 1.
pub fn parse_positive(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(format!("{s:?}: {e}")),
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

/// A segmentation error, naming the input cloud.
pub fn segment_error(input: &std::path::Path, e: softsense::segment::SegmentError) -> CliError {
    CliError::Result(format!("{}: {e}", input.display()))
}

/// Refuses an output path that is the input file (or, for a sequence, the input folder):
/// the command would write over what it reads.
pub fn refuse_output_over_input(input: &std::path::Path, output: &std::path::Path) -> CliResult {
    softsense::io::outputs::check_not_input(output, &[input]).map_err(output_error)
}

/// The files commands read from the recording folder `dir` (those that exist): its
/// frames' images and camera files, and its pose, calibration, inputs and truth files.
pub fn recording_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    const SIDECARS: [&str; 7] = [
        "camera_pose.json",
        "calibration.json",
        "inputs.json",
        "actuators.json",
        "truth.json",
        "sensor.json",
        softsense::scene::MARKERS_TRUTH,
    ];
    let frames = softsense::recording::list_frames(dir)
        .map(|(_, frames)| frames)
        .unwrap_or_default();
    let mut files: Vec<std::path::PathBuf> = (frames.into_iter())
        .flat_map(|f| [Some(f.depth), f.color, Some(f.camera)])
        .flatten()
        .collect();
    files.extend(SIDECARS.iter().map(|n| dir.join(n)));
    files.retain(|f| f.exists());
    files
}

/// An output path refused (a usage error, exit code 2) or a folder the system would not
/// create or rename (exit code 1).
pub fn output_error(e: softsense::io::outputs::OutputsError) -> CliError {
    match e.is_refusal() {
        true => CliError::Usage(e.to_string()),
        false => CliError::Result(e.to_string()),
    }
}

/// Refuses an output file that resolves to one of `inputs`, or is a folder
/// ([`softsense::io::outputs::check_file`]).
pub fn check_output_file(output: &std::path::Path, inputs: &[&std::path::Path]) -> CliResult {
    softsense::io::outputs::check_file(output, inputs).map_err(output_error)
}

/// Refuses a folder the command writes the files `written` into (beside pictures or what
/// else it holds) when it is a file or one of `written` is an input
/// ([`softsense::io::outputs::check_files_dir`]).
pub fn check_files_dir(
    dir: &std::path::Path,
    written: &[&str],
    inputs: &[&std::path::Path],
) -> CliResult {
    softsense::io::outputs::check_files_dir(dir, written, inputs).map_err(output_error)
}

/// Refuses an output folder that is a file, holds an input, holds a recording (unless
/// `force`) or holds other files ([`softsense::io::outputs::check_dir`]), then stages it:
/// the command writes into the returned folder's `path()` and commits it at the end.
pub fn staged_output_dir(
    dir: &std::path::Path,
    inputs: &[&std::path::Path],
    force: bool,
) -> Result<softsense::io::outputs::StagedDir, CliError> {
    softsense::io::outputs::check_dir(dir, inputs, force).map_err(output_error)?;
    softsense::io::outputs::StagedDir::new(dir).map_err(output_error)
}

/// `--force`'s help, shared by the commands that write a recording folder.
pub const FORCE_HELP: &str = "Replace an OUT_DIR that already holds a recording: the new \
folder takes its place whole, and the old one's files (all of them) are deleted. Without it such a \
folder is refused; a folder holding other files is refused always, and an input is never \
written over";

//! The one way softsense writes an output file: all of it or none of it.
//!
//! [`write()`] puts the bytes in `.NAME.tmpPID` beside the target, fsyncs it, renames it
//! over the target and fsyncs the directory, so a reader (or the next run after a crash
//! or a full disk) sees the old file or the new one, never half of one. The temporary
//! file is removed on every error path. While it exists it is listed in a process-wide
//! registry, so an interrupted run removes it too ([`remove_live_temps`], called from
//! the SIGINT/SIGTERM handler that [`install_signal_cleanup`] starts). A run killed
//! outright (SIGKILL, power loss) cannot clean up; the next write of the same NAME
//! removes temporaries whose process is gone. A folder staged by
//! [`super::outputs::StagedDir`] is listed in the same registry and removed the same ways.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};
use thiserror::Error;

/// Errors of writing an output file. Every variant names the file.
#[derive(Debug, Error)]
pub enum AtomicError {
    /// The operating system refused to create, write or rename the file.
    #[error("{path}: cannot write: {source}")]
    Os {
        /// The output file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be encoded as PNG.
    #[error("{path}: cannot encode the PNG: {message}")]
    Encode {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl AtomicError {
    /// The output file.
    pub fn path(&self) -> &Path {
        match self {
            AtomicError::Os { path, .. } | AtomicError::Encode { path, .. } => path,
        }
    }
}

/// Temporary files this process has created and not yet renamed or removed.
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_temps() -> MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while holding the lock leaves a usable list.
    LIVE_TEMPS.lock().unwrap_or_else(|p| p.into_inner())
}

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), AtomicError> {
    let os = |source| AtomicError::Os {
        path: path.to_path_buf(),
        source,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| os(std::io::Error::other("the path names no file")))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    remove_stale_temps(&dir, &name);
    let tmp = dir.join(temp_name(&name, std::process::id()));
    let file = create_registered(&tmp).map_err(os)?;
    let result = fill_and_rename(file, bytes, &tmp, path);
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    live_temps().retain(|p| p != &tmp);
    result.map_err(os)?;
    sync_dir(&dir);
    Ok(())
}

/// Encodes `image` as PNG in memory and writes it with [`write()`].
pub fn write_png(path: &Path, image: &image::DynamicImage) -> Result<(), AtomicError> {
    let bytes = png_bytes(image).map_err(|e| AtomicError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write(path, &bytes)
}

/// `image` encoded as a PNG file's bytes.
pub fn png_bytes(image: &image::DynamicImage) -> Result<Vec<u8>, image::ImageError> {
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png)?;
    Ok(out.into_inner())
}

/// Lists `tmp` (a staged output folder) as this process's temporary, under the
/// registry's lock, and creates it: removed on SIGINT/SIGTERM as a temporary file is.
pub(crate) fn create_registered_dir(tmp: &Path) -> std::io::Result<()> {
    let mut live = live_temps();
    std::fs::create_dir(tmp)?;
    live.push(tmp.to_path_buf());
    Ok(())
}

/// Takes `tmp` off the registry (it was renamed into place or removed).
pub(crate) fn unregister(tmp: &Path) {
    live_temps().retain(|p| p != tmp);
}

/// Removes a temporary, file or staged folder.
fn remove_temp(p: &Path) {
    let is_dir = std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir());
    if !is_dir {
        let _ = std::fs::remove_file(p);
        return;
    }
    // A writer thread may rename a finished file into the folder after remove_dir_all
    // listed it (its last rmdir then fails: not empty). No new temporary can start while
    // the registry is locked, so a few more tries empty it.
    for _ in 0..20 {
        if std::fs::remove_dir_all(p).is_ok() || !p.exists() {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// The temporary name for output `name` written by process `pid`.
pub(crate) fn temp_name(name: &str, pid: u32) -> String {
    format!(".{name}.tmp{pid}")
}

/// Creates `tmp` and lists it, under the registry's lock: a signal handler that takes
/// the lock then sees either no file or a listed one, never an unlisted file.
fn create_registered(tmp: &Path) -> std::io::Result<File> {
    let mut live = live_temps();
    let file = File::create(tmp)?;
    live.push(tmp.to_path_buf());
    Ok(file)
}

fn fill_and_rename(mut file: File, bytes: &[u8], tmp: &Path, path: &Path) -> std::io::Result<()> {
    file.write_all(bytes)?;
    file.sync_all()?;
    drop(file);
    std::fs::rename(tmp, path)
}

/// Makes the rename itself durable. Best effort: some systems cannot open a directory.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// Removes `.NAME.tmpPID` files (and staged folders) in `dir` left by processes that no
/// longer run.
pub(crate) fn remove_stale_temps(dir: &Path, name: &str) {
    let prefix = format!(".{name}.tmp");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(pid) = file_name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && process_is_gone(pid) {
            remove_temp(&entry.path());
        }
    }
}

/// Whether process `pid` has certainly exited. Where the system cannot tell (no
/// `/proc`), a temporary is never taken for stale.
fn process_is_gone(pid: u32) -> bool {
    let proc_root = Path::new("/proc");
    proc_root.join("self").exists() && !proc_root.join(pid.to_string()).exists()
}

/// Removes every temporary file this process is writing. Holds the registry's lock
/// until the process exits when `then_exit` is given, so no writer creates another.
pub fn remove_live_temps(then_exit: Option<i32>) {
    let mut live = live_temps();
    for p in live.drain(..) {
        remove_temp(&p);
    }
    if let Some(code) = then_exit {
        std::process::exit(code);
    }
}

/// Starts a thread that, on SIGINT or SIGTERM, removes this process's temporary files
/// and exits with 128 + the signal (130, 143), as the shell reports a killed command.
/// Where signals cannot be caught this does nothing.
pub fn install_signal_cleanup() -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
        std::thread::Builder::new()
            .name("signal-cleanup".into())
            .spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    remove_live_temps(Some(128 + sig));
                }
            })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        write(&p, b"old").unwrap();
        write(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        assert!(live_temps().iter().all(|t| !t.starts_with(dir.path())));
    }

    #[test]
    fn a_failed_rename_removes_the_temporary() {
        let dir = tempfile::tempdir().unwrap();
        // A directory in the way: the rename fails after the temporary is written.
        let p = dir.path().join("taken");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("x"), b"keep").unwrap();
        let e = write(&p, b"data").unwrap_err();
        assert!(e.to_string().contains("taken"), "{e}");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn only_temporaries_of_gone_processes_are_stale() {
        let dir = tempfile::tempdir().unwrap();
        let own = dir.path().join(temp_name("a.pcd", std::process::id()));
        let other_name = dir.path().join(temp_name("b.pcd", u32::MAX - 1));
        let gone = dir.path().join(temp_name("a.pcd", u32::MAX - 1));
        for p in [&own, &other_name, &gone] {
            std::fs::write(p, b"x").unwrap();
        }
        remove_stale_temps(dir.path(), "a.pcd");
        assert!(own.exists() && other_name.exists());
        assert_eq!(gone.exists(), !Path::new("/proc/self").exists());
    }
}

//! The one rule for outputs: no command writes over a file it reads, or into a folder that
//! already holds a recording unless told to replace it (`--force`), and a failed run leaves
//! nothing behind.
//!
//! - Files: [`check_file`] refuses an output that is one of the inputs, paths resolved
//!   (links, `.` and `..` followed), or that is a folder; [`super::atomic::write`] then
//!   writes it all or nothing.
//! - Folders: [`check_dir`] refuses a file, a folder holding an input, a folder that holds
//!   a recording (unless it is to be replaced) and any other non-empty folder (always: a
//!   folder is replaced wholly, and softsense deletes no file it was not asked to).
//!   [`StagedDir`] is the folder written beside the target as `.NAME.tmpPID` and renamed
//!   into place at the end ([`StagedDir::commit`]); dropped uncommitted, it is removed,
//!   and an interrupted run removes it as it does a temporary file.
//! - A folder a tool regenerates in place (a batch item's recording) is merged by
//!   [`StagedDir::commit_keeping`]: only the files listed as written by the last run are
//!   replaced, and every other file in it is kept.

use super::atomic;
use std::path::{Component, Path, PathBuf};
use thiserror::Error;

/// Why an output path is refused, or could not be written. Every variant names the path.
#[derive(Debug, Error)]
pub enum OutputsError {
    /// The output is one of the files the command reads.
    #[error(
        "the output {} is {}: give another output path (softsense never writes over what it \
         reads)",
        output.display(),
        an_input(output, input)
    )]
    OverInput {
        /// The output path, as given.
        output: PathBuf,
        /// The input it resolves to.
        input: PathBuf,
    },
    /// The output folder holds a file the command reads, which replacing it would delete.
    #[error(
        "the output folder {dir} holds the input {input}: give another output folder \
         (softsense never writes over what it reads)"
    )]
    HoldsInput {
        /// The output folder.
        dir: PathBuf,
        /// The input inside it.
        input: PathBuf,
    },
    /// The output folder already holds a recording.
    #[error(
        "{dir} already holds a recording: give a new or empty folder, or --force to replace \
         it wholly (its old files are deleted)"
    )]
    HoldsRecording {
        /// The output folder.
        dir: PathBuf,
    },
    /// The output folder holds other files.
    #[error(
        "{dir} is not empty (it holds {example}): give a new or empty folder (the output \
         folder is replaced wholly, so softsense writes only into a new one, an empty one, or \
         with --force one holding a recording)"
    )]
    NotEmpty {
        /// The output folder.
        dir: PathBuf,
        /// One of the entries in it.
        example: String,
    },
    /// The output folder is a file.
    #[error("the output folder {path} is a file: give a folder's path")]
    NotAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// The output file is a folder.
    #[error("the output file {path} is a folder: give a file path, e.g. {path}/NAME")]
    IsAFolder {
        /// The path given.
        path: PathBuf,
    },
    /// Regenerating a folder would replace a file that an earlier run did not write.
    #[error(
        "{dir} holds {file}, which softsense did not write: move it away (softsense never \
         deletes a file it did not write)"
    )]
    NotWritten {
        /// The folder regenerated.
        dir: PathBuf,
        /// The file in the way, relative to `dir`.
        file: PathBuf,
    },
    /// The operating system refused to create, rename or remove.
    #[error("{path}: {source}")]
    Os {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl OutputsError {
    /// Whether the output path was refused (the user's to fix: a usage error), not a
    /// failure of the system.
    pub fn is_refusal(&self) -> bool {
        !matches!(self, OutputsError::Os { .. })
    }
}

/// The list, in a regenerated folder, of the files the last run wrote there (one relative
/// path a line): what [`StagedDir::commit_keeping`] may replace.
pub const WRITTEN_LIST: &str = ".softsense-written";

/// "the input", naming it when it goes by another name than the output.
fn an_input(output: &Path, input: &Path) -> String {
    match output == input {
        true => "the input".into(),
        false => format!("the input {}", input.display()),
    }
}

fn os(path: &Path) -> impl FnOnce(std::io::Error) -> OutputsError + '_ {
    move |source| OutputsError::Os {
        path: path.to_path_buf(),
        source,
    }
}

/// `path` resolved: links, `.` and `..` followed. A path that does not exist yet is its
/// nearest existing ancestor resolved plus the rest, so two names of one new file match.
pub fn resolved(path: &Path) -> PathBuf {
    let absolute = match path.is_absolute() {
        true => path.to_path_buf(),
        false => std::env::current_dir().unwrap_or_default().join(path),
    };
    let mut rest = Vec::new();
    let mut at = absolute.as_path();
    loop {
        if let Ok(real) = std::fs::canonicalize(at) {
            return rest.iter().rev().fold(real, |p, c| p.join(c));
        }
        match (at.parent(), at.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                at = parent;
            }
            _ => return absolute,
        }
    }
}

/// Refuses `output` when it resolves to one of `inputs`, or is a folder.
pub fn check_file(output: &Path, inputs: &[&Path]) -> Result<(), OutputsError> {
    if output.is_dir() {
        return Err(OutputsError::IsAFolder {
            path: output.to_path_buf(),
        });
    }
    check_not_input(output, inputs)
}

/// Refuses `output` (a file, or a folder of a sequence) when it resolves to one of
/// `inputs`.
pub fn check_not_input(output: &Path, inputs: &[&Path]) -> Result<(), OutputsError> {
    let out = resolved(output);
    match inputs.iter().find(|i| resolved(i) == out) {
        Some(input) => Err(OutputsError::OverInput {
            output: output.to_path_buf(),
            input: input.to_path_buf(),
        }),
        None => Ok(()),
    }
}

/// Refuses `dir` as a folder the command writes the files `written` into, beside what it
/// holds (pictures, a report): a file, or a folder where one of `written` is an input.
pub fn check_files_dir(dir: &Path, written: &[&str], inputs: &[&Path]) -> Result<(), OutputsError> {
    if dir.exists() && !dir.is_dir() {
        return Err(OutputsError::NotAFolder {
            path: dir.to_path_buf(),
        });
    }
    written
        .iter()
        .try_for_each(|name| check_file(&dir.join(name), inputs))
}

/// Refuses `dir` as an output folder when it is a file, holds (or is) one of `inputs`,
/// holds a recording (unless `replace`), or holds anything else.
pub fn check_dir(dir: &Path, inputs: &[&Path], replace: bool) -> Result<(), OutputsError> {
    let Ok(meta) = std::fs::metadata(dir) else {
        return Ok(());
    };
    if !meta.is_dir() {
        return Err(OutputsError::NotAFolder {
            path: dir.to_path_buf(),
        });
    }
    let real = resolved(dir);
    if let Some(input) = inputs.iter().find(|i| resolved(i).starts_with(&real)) {
        return Err(OutputsError::HoldsInput {
            dir: dir.to_path_buf(),
            input: input.to_path_buf(),
        });
    }
    let entries = names(dir).map_err(os(dir))?;
    if entries.is_empty() {
        return Ok(());
    }
    if holds_recording(dir, &entries) {
        return match replace {
            true => Ok(()),
            false => Err(OutputsError::HoldsRecording {
                dir: dir.to_path_buf(),
            }),
        };
    }
    Err(OutputsError::NotEmpty {
        dir: dir.to_path_buf(),
        example: entries[0].clone(),
    })
}

/// The sorted names in `dir`.
fn names(dir: &Path) -> std::io::Result<Vec<String>> {
    let mut names: Vec<String> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    Ok(names)
}

/// Whether a folder with these entries holds a recording: depth frames (`depth_*`,
/// `*_depth.*`, an Open3D `depth/` folder), or (a rig, a sweep) only sub-folders that hold
/// them and the small files written beside them. Camera and truth files alone do not
/// count: a project folder with an `inputs.json` in it is not a recording to replace.
fn holds_recording(dir: &Path, entries: &[String]) -> bool {
    let own = |names: &[String]| {
        names.iter().any(|n| {
            let l = n.to_ascii_lowercase();
            l.starts_with("depth_") || l.contains("_depth.") || l == "depth"
        })
    };
    if own(entries) {
        return true;
    }
    // A rig or a sweep: every entry is a recording sub-folder or one of the small files
    // written beside them. Anything else (a home folder with one recording in it) is not
    // a recording, so --force never deletes it.
    let small_file = |n: &str| {
        n == WRITTEN_LIST
            || [".json", ".jsonl", ".toml", ".csv", ".txt", ".png"]
                .iter()
                .any(|e| n.to_ascii_lowercase().ends_with(e))
    };
    let mut has_sub = false;
    let all = entries.iter().all(|n| {
        let sub = dir.join(n);
        match sub.is_dir() {
            true => {
                has_sub = true;
                names(&sub).is_ok_and(|s| own(&s))
            }
            false => small_file(n),
        }
    });
    all && has_sub
}

/// An output folder being written: the files go into a temporary folder beside the
/// target, renamed into place by [`StagedDir::commit`]. Dropped before that, it is removed.
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    tmp: PathBuf,
    done: bool,
}

impl StagedDir {
    /// Creates the temporary folder for `target` (and `target`'s parents). `target` is
    /// checked by [`check_dir`] first; a link to a folder stands for the folder.
    pub fn new(target: &Path) -> Result<Self, OutputsError> {
        let target = match std::fs::canonicalize(target) {
            Ok(real) => real,
            Err(_) => target.to_path_buf(),
        };
        let name = (target.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .ok_or_else(|| os(&target)(std::io::Error::other("the path names no folder")))?;
        let parent = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(os(&parent))?;
        atomic::remove_stale_temps(&parent, &name);
        let tmp = parent.join(atomic::temp_name(&name, std::process::id()));
        // Left by this process (a reused pid): nothing else writes this name.
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).map_err(os(&tmp))?;
        }
        atomic::create_registered_dir(&tmp).map_err(os(&tmp))?;
        Ok(Self {
            target,
            tmp,
            done: false,
        })
    }

    /// The folder to write into now.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Puts the written folder in place of the target: into an empty target its files are
    /// moved (the folder stays, a shell's working directory with it); a recording to
    /// replace (which [`check_dir`] allowed) is removed once the new one is in place.
    pub fn commit(mut self) -> Result<(), OutputsError> {
        let target = self.target.clone();
        match std::fs::symlink_metadata(&target) {
            Err(_) => std::fs::rename(&self.tmp, &target).map_err(os(&target))?,
            Ok(_) if names(&target).is_ok_and(|n| n.is_empty()) => {
                for name in names(&self.tmp).map_err(os(&self.tmp))? {
                    let to = target.join(&name);
                    std::fs::rename(self.tmp.join(&name), &to).map_err(os(&to))?;
                }
                std::fs::remove_dir(&self.tmp).map_err(os(&self.tmp))?;
            }
            Ok(_) => {
                let old = self.tmp.with_file_name(old_name(&self.tmp));
                std::fs::rename(&target, &old).map_err(os(&target))?;
                if let Err(e) = std::fs::rename(&self.tmp, &target) {
                    let _ = std::fs::rename(&old, &target);
                    return Err(os(&target)(e));
                }
                std::fs::remove_dir_all(&old).map_err(os(&old))?;
            }
        }
        self.finish();
        Ok(())
    }

    /// Moves the written files into the target, keeping every file there that the last
    /// run did not write (not in its [`WRITTEN_LIST`]); the files it did write are
    /// replaced or removed. Refuses, before changing anything, when a new file would
    /// replace one the last run did not write.
    pub fn commit_keeping(mut self) -> Result<(), OutputsError> {
        let target = self.target.clone();
        let new = files_under(&self.tmp).map_err(os(&self.tmp))?;
        atomic::write(&self.tmp.join(WRITTEN_LIST), list_text(&new).as_bytes())
            .map_err(|e| os(e.path())(std::io::Error::other(e.to_string())))?;
        if std::fs::symlink_metadata(&target).is_err() {
            return self.commit();
        }
        let old = read_list(&target);
        if let Some(file) = new
            .iter()
            .find(|f| !old.contains(f) && std::fs::symlink_metadata(target.join(f)).is_ok())
        {
            return Err(OutputsError::NotWritten {
                dir: target,
                file: file.clone(),
            });
        }
        remove_listed(&target, &old);
        for f in new.iter().chain([&PathBuf::from(WRITTEN_LIST)]) {
            let to = target.join(f);
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent).map_err(os(parent))?;
            }
            std::fs::rename(self.tmp.join(f), &to).map_err(os(&to))?;
        }
        std::fs::remove_dir_all(&self.tmp).map_err(os(&self.tmp))?;
        self.finish();
        Ok(())
    }

    fn finish(&mut self) {
        self.done = true;
        atomic::unregister(&self.tmp);
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.done {
            let _ = std::fs::remove_dir_all(&self.tmp);
            atomic::unregister(&self.tmp);
        }
    }
}

/// `.NAME.oldPID` for the temporary `.NAME.tmpPID`: where the replaced target waits.
fn old_name(tmp: &Path) -> String {
    let t = tmp.file_name().unwrap_or_default().to_string_lossy();
    match t.rfind(".tmp") {
        Some(i) => format!("{}.old{}", &t[..i], &t[i + 4..]),
        None => format!("{t}.old"),
    }
}

/// The files under `dir`, relative to it, sorted.
fn files_under(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let mut todo = vec![PathBuf::new()];
    while let Some(rel) = todo.pop() {
        for e in std::fs::read_dir(dir.join(&rel))? {
            let e = e?;
            let r = rel.join(e.file_name());
            match e.file_type()?.is_dir() {
                true => todo.push(r),
                false => out.push(r),
            }
        }
    }
    out.sort();
    Ok(out)
}

fn list_text(files: &[PathBuf]) -> String {
    files
        .iter()
        .map(|f| format!("{}\n", f.to_string_lossy()))
        .collect()
}

/// The files `dir`'s [`WRITTEN_LIST`] names; only plain relative paths, so an edited list
/// cannot reach outside the folder.
fn read_list(dir: &Path) -> Vec<PathBuf> {
    let text = std::fs::read_to_string(dir.join(WRITTEN_LIST)).unwrap_or_default();
    text.lines()
        .map(PathBuf::from)
        .filter(|p| {
            p.components().next().is_some()
                && p.components().all(|c| matches!(c, Component::Normal(_)))
        })
        .collect()
}

/// Removes the `listed` files of `dir`, and the folders they leave empty.
fn remove_listed(dir: &Path, listed: &[PathBuf]) {
    for f in listed {
        let _ = std::fs::remove_file(dir.join(f));
    }
    let _ = std::fs::remove_file(dir.join(WRITTEN_LIST));
    let mut parents: Vec<&Path> = listed.iter().filter_map(|f| f.parent()).collect();
    // Deepest first; removing a folder that still holds a file fails, and is meant to.
    parents.sort_by_key(|p| std::cmp::Reverse(p.components().count()));
    for p in parents.into_iter().filter(|p| !p.as_os_str().is_empty()) {
        let _ = std::fs::remove_dir(dir.join(p));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, b"x").unwrap();
    }

    #[test]
    fn a_dropped_staged_folder_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let staged = StagedDir::new(&dir.path().join("rec")).unwrap();
        touch(&staged.path().join("intrinsics.json"));
        drop(staged);
        assert_eq!(names(dir.path()).unwrap(), Vec::<String>::new());
    }

    #[test]
    fn a_commit_replaces_the_old_folder_wholly() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        touch(&target.join("depth_0003.png"));
        let staged = StagedDir::new(&target).unwrap();
        touch(&staged.path().join("depth_0000.png"));
        staged.commit().unwrap();
        assert_eq!(names(&target).unwrap(), ["depth_0000.png"]);
        assert_eq!(names(dir.path()).unwrap(), ["rec"]);
    }

    #[test]
    fn a_commit_into_an_empty_folder_keeps_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        std::fs::create_dir(&target).unwrap();
        #[cfg(unix)]
        let inode = || std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(&target).unwrap());
        #[cfg(unix)]
        let before = inode();
        let staged = StagedDir::new(&target).unwrap();
        touch(&staged.path().join("depth_0000.png"));
        staged.commit().unwrap();
        assert_eq!(names(&target).unwrap(), ["depth_0000.png"]);
        assert_eq!(names(dir.path()).unwrap(), ["rec"]);
        #[cfg(unix)]
        assert_eq!(inode(), before);
    }

    #[test]
    fn a_regenerated_folder_keeps_the_files_it_did_not_write() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        let first = StagedDir::new(&target).unwrap();
        touch(&first.path().join("cam/depth_0000.png"));
        touch(&first.path().join("depth_0001.png"));
        first.commit_keeping().unwrap();
        touch(&target.join("notes.txt"));
        let second = StagedDir::new(&target).unwrap();
        touch(&second.path().join("depth_0000.png"));
        second.commit_keeping().unwrap();
        assert_eq!(
            names(&target).unwrap(),
            [WRITTEN_LIST, "depth_0000.png", "notes.txt"]
        );
        // A user's file where a new one would go is refused, and nothing changes.
        touch(&target.join("depth_0009.png"));
        let third = StagedDir::new(&target).unwrap();
        touch(&third.path().join("depth_0009.png"));
        let e = third.commit_keeping().unwrap_err();
        assert!(e.to_string().contains("depth_0009.png"), "{e}");
        assert!(target.join("depth_0000.png").exists());
        assert_eq!(names(dir.path()).unwrap(), ["rec"]);
    }

    #[test]
    fn force_replaces_a_sweep_of_recordings_but_never_a_folder_that_also_holds_other_things() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("sweep");
        touch(&sweep.join("scene_0000/depth_0000.png"));
        touch(&sweep.join("scene_0001/depth_0000.png"));
        touch(&sweep.join("draws.json"));
        assert!(check_dir(&sweep, &[], true).is_ok());
        assert!(check_dir(&sweep, &[], false).is_err());
        // A home folder with one recording among other things.
        let home = dir.path().join("home");
        touch(&home.join("rec/depth_0000.png"));
        touch(&home.join(".bashrc"));
        touch(&home.join("thesis/chapter1.tex"));
        let e = check_dir(&home, &[], true).unwrap_err();
        assert!(matches!(e, OutputsError::NotEmpty { .. }), "{e}");
    }

    #[test]
    fn a_folder_is_checked_by_what_it_holds() {
        let dir = tempfile::tempdir().unwrap();
        let rec = dir.path().join("rec");
        assert!(check_dir(&rec, &[], false).is_ok());
        touch(&rec.join("cam0/intrinsics.json"));
        // Camera files alone are not a recording to replace.
        assert!(matches!(
            check_dir(&rec, &[], true),
            Err(OutputsError::NotEmpty { .. })
        ));
        touch(&rec.join("cam0/depth_0000.png"));
        assert!(matches!(
            check_dir(&rec, &[], false),
            Err(OutputsError::HoldsRecording { .. })
        ));
        assert!(check_dir(&rec, &[], true).is_ok());
        let input = rec.join("cam0/intrinsics.json");
        assert!(matches!(
            check_dir(&rec, &[&input], true),
            Err(OutputsError::HoldsInput { .. })
        ));
        let other = dir.path().join("other");
        touch(&other.join("notes.txt"));
        assert!(matches!(
            check_dir(&other, &[], true),
            Err(OutputsError::NotEmpty { .. })
        ));
        assert!(matches!(
            check_dir(&other.join("notes.txt"), &[], true),
            Err(OutputsError::NotAFolder { .. })
        ));
    }

    #[test]
    fn a_file_is_the_input_by_any_of_its_names() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("t.csv");
        touch(&input);
        let other_name = dir.path().join("sub/../t.csv");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        assert!(check_file(&other_name, &[&input]).is_err());
        #[cfg(unix)]
        {
            let link = dir.path().join("link.csv");
            std::os::unix::fs::symlink(&input, &link).unwrap();
            assert!(check_file(&link, &[&input]).is_err());
        }
        assert!(check_file(&dir.path().join("new.csv"), &[&input]).is_ok());
        assert!(check_file(dir.path(), &[]).is_err());
        assert!(check_files_dir(&input, &[], &[]).is_err());
        assert!(check_files_dir(dir.path(), &["t.csv"], &[&input]).is_err());
        assert!(check_files_dir(dir.path(), &["run.json"], &[&input]).is_ok());
    }
}

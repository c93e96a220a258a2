//! The recorded inputs of a recording (`inputs.json` or `actuators.json`), read entry by
//! entry so that one bad frame costs that frame, not the run.

use super::schema::{ActuatorTruth, FrameInput};
use super::{file_err, RecordingResult};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which file the recorded inputs came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputsFile {
    /// `inputs.json`: one [`FrameInput`] per frame.
    Inputs,
    /// `actuators.json`: per frame, each cable's [`ActuatorTruth`] (its commanded input).
    Actuators,
}

/// Recorded inputs, one entry per frame number (entry `i` is frame `i`).
#[derive(Clone, Debug)]
pub struct RecordedInputs {
    /// The file.
    pub path: PathBuf,
    /// Its kind.
    pub kind: InputsFile,
    /// Each frame's inputs, or why its entry cannot be used.
    pub entries: Vec<Result<FrameInput, EntryProblem>>,
}

/// Why one frame's entry of the recorded inputs cannot be used (the other frames' can).
#[derive(Clone, Debug, thiserror::Error)]
pub enum EntryProblem {
    /// The entry is not a frame's inputs (a missing field, a string for a number).
    #[error("{0}")]
    Parse(#[source] Arc<serde_json::Error>),
    /// A cable's shortening or force is NaN or infinite.
    #[error("cable '{cable}': {field} is not finite")]
    CableNotFinite {
        /// The cable.
        cable: String,
        /// `shorten` or `force`.
        field: &'static str,
    },
    /// A cavity's pressure or volume is NaN or infinite.
    #[error("cavity '{cavity}': {field} is not finite")]
    CavityNotFinite {
        /// The cavity.
        cavity: String,
        /// `pressure` or `volume`.
        field: &'static str,
    },
    /// A known load's position, force or radius is NaN or infinite.
    #[error("load {load}: a position, force or radius is not finite")]
    LoadNotFinite {
        /// The load's index in the entry.
        load: usize,
    },
}

impl RecordedInputs {
    /// Reads `path` as `kind`. A file that is not a JSON array is an error; an entry that
    /// does not parse, or holds a number that is NaN or infinite, is kept as that frame's
    /// problem.
    pub fn read(path: &Path, kind: InputsFile) -> RecordingResult<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| file_err(path, e))?;
        // Python's json module writes NaN and Infinity; serde_json refuses the whole file.
        let text = quote_non_finite(&text);
        let list: Vec<Value> = serde_json::from_str(&text).map_err(|e| {
            file_err(
                path,
                format!("{e} (expected a JSON list with one entry per frame)"),
            )
        })?;
        let entries = list.into_iter().map(|v| parse_entry(v, kind)).collect();
        Ok(Self {
            path: path.to_path_buf(),
            kind,
            entries,
        })
    }

    /// The usable inputs of `frame`, if its entry exists and parsed.
    pub fn get(&self, frame: usize) -> Option<&FrameInput> {
        self.entries.get(frame)?.as_ref().ok()
    }

    /// Why `frame`'s entry cannot be used, naming the file, if it exists and is bad.
    pub fn problem(&self, frame: usize) -> Option<String> {
        let why = self.entries.get(frame)?.as_ref().err()?;
        Some(format!("{}: frame {frame}: {why}", self.path.display()))
    }

    /// A warning when some of `frames` have no entry: they are sensed without recorded
    /// inputs.
    pub fn coverage_warning(&self, frames: &[usize]) -> Option<String> {
        let missing: Vec<usize> = frames
            .iter()
            .copied()
            .filter(|&f| f >= self.entries.len())
            .collect();
        if missing.is_empty() {
            return None;
        }
        let shown: Vec<String> = missing.iter().take(8).map(|f| f.to_string()).collect();
        let more = match missing.len() > 8 {
            true => format!(" and {} more", missing.len() - 8),
            false => String::new(),
        };
        Some(format!(
            "{}: {} entries, so frames {}{more} have no recorded inputs and keep the \
             model's (or the calibration's) cable inputs",
            self.path.display(),
            self.entries.len(),
            shown.join(", ")
        ))
    }
}

fn parse_entry(v: Value, kind: InputsFile) -> Result<FrameInput, EntryProblem> {
    let parse = |e| EntryProblem::Parse(Arc::new(e));
    let input = match kind {
        InputsFile::Inputs => serde_json::from_value::<FrameInput>(v).map_err(parse)?,
        InputsFile::Actuators => {
            let cables: Vec<ActuatorTruth> = serde_json::from_value(v).map_err(parse)?;
            FrameInput {
                cables: cables.iter().map(ActuatorTruth::commanded).collect(),
                cavities: Vec::new(),
                loads: Vec::new(),
            }
        }
    };
    check_finite(&input)?;
    Ok(input)
}

fn check_finite(input: &FrameInput) -> Result<(), EntryProblem> {
    for c in &input.cables {
        for (field, v) in [("shorten", c.shorten), ("force", c.force)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(EntryProblem::CableNotFinite {
                    cable: c.name.clone(),
                    field,
                });
            }
        }
    }
    for c in &input.cavities {
        for (field, v) in [("pressure", c.pressure), ("volume", c.volume)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(EntryProblem::CavityNotFinite {
                    cavity: c.name.clone(),
                    field,
                });
            }
        }
    }
    for (load, l) in input.loads.iter().enumerate() {
        let all = l.at.iter().chain(&l.force).chain([&l.radius]);
        if all.into_iter().any(|v| !v.is_finite()) {
            return Err(EntryProblem::LoadNotFinite { load });
        }
    }
    Ok(())
}

/// `NaN`, `Infinity` and `-Infinity` outside strings become the strings `"NaN"`,
/// `"Infinity"`, `"-Infinity"`, so the entry holding one fails to parse on its own
/// ("invalid type: string \"NaN\", expected f64") instead of the whole file.
fn quote_non_finite(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_string = false;
    let mut escaped = false;
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if in_string {
            match (escaped, c) {
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => escaped = false,
            }
        } else if c == '"' {
            in_string = true;
        } else if let Some(token) = ["-Infinity", "Infinity", "NaN"]
            .into_iter()
            .find(|t| rest.starts_with(t))
        {
            out.push('"');
            out.push_str(token);
            out.push('"');
            rest = &rest[token.len()..];
            continue;
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::quote_non_finite;

    #[test]
    fn non_finite_tokens_outside_strings_are_quoted_and_strings_are_untouched() {
        assert_eq!(
            quote_non_finite(r#"[{"a": NaN, "b": -Infinity, "c": "NaN \" Infinity"}]"#),
            r#"[{"a": "NaN", "b": "-Infinity", "c": "NaN \" Infinity"}]"#
        );
    }
}

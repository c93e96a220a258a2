//! Marker track files: the positions of named markers, frame by frame, as a motion-capture
//! system or `softsense markers detect` writes them. The hidden-marker rule that reads them
//! is the markers workflow's ([`crate::markers::tracks::flag_hidden`]).
//!
//! softsense's format is a CSV with the header `frame,marker,x,y,z`: one row per marker and
//! frame, positions in metres in the tracker frame, a hidden marker as a row with empty
//! x, y, z (or no row at all). Markers are named; their order is that of first appearance.
//!
//! OptiTrack Motive exports (`read_motive_str`) have a few header rows (the first holds
//! `Length Units`, a `Name` row the marker names, a `Position`/`Rotation` row which columns
//! are positions), then `Frame,Time,...` and X, Y, Z triplets per marker; empty cells are a
//! hidden marker. Lengths are millimetres unless the header says otherwise (millimetres,
//! centimetres, metres or inches).
//!
//! A file with no frame is an error ([`TracksError::NoFrames`]).

use crate::io::InFile;
use std::path::Path;
use thiserror::Error;

/// Errors of reading or writing a track file.
#[derive(Debug, Error)]
pub enum TracksError {
    /// A file could not be read.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: String,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A malformed line (1-based line number).
    #[error("line {line}: {message}")]
    Parse {
        /// The 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A malformed line of a named file.
    #[error("{path}: {source}")]
    InFile {
        /// The file.
        path: String,
        /// What is wrong in it.
        source: Box<TracksError>,
    },
    /// A file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// A track file with a header but no frame.
    #[error("no frames: the file has a header and no marker positions (`markers detect` writes this when it finds no marker; check its --colour and --max-angle-deg)")]
    NoFrames,
    /// A Motive export whose `Length Units` is not one softsense reads.
    #[error("line 1: Length Units {unit:?}: expected Millimeters, Centimeters, Meters or Inches (re-export from Motive in one of them)")]
    LengthUnit {
        /// The unit as written.
        unit: String,
    },
}

impl crate::io::InFile for TracksError {
    fn names_file(&self) -> bool {
        matches!(
            self,
            TracksError::File { .. } | TracksError::InFile { .. } | TracksError::Write(_)
        )
    }

    fn wrap_in_file(self, path: &Path) -> Self {
        TracksError::InFile {
            path: path.display().to_string(),
            source: Box::new(self),
        }
    }
}

/// `Result` with [`TracksError`].
pub type TracksResult<T> = std::result::Result<T, TracksError>;

/// The markers of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFrame {
    /// The frame number as written.
    pub frame: u64,
    /// Each marker's position (m, tracker frame), in the order of [`MarkerTracks::names`];
    /// `None`: hidden.
    pub positions: Vec<Option<[f64; 3]>>,
}

/// A recording of marker tracks.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerTracks {
    /// Marker names.
    pub names: Vec<String>,
    /// Frames in file order.
    pub frames: Vec<TrackFrame>,
}

fn parse_err(line: usize, message: impl Into<String>) -> TracksError {
    TracksError::Parse {
        line,
        message: message.into(),
    }
}

fn read_text(path: &Path) -> TracksResult<String> {
    std::fs::read_to_string(path).map_err(|source| TracksError::File {
        path: path.display().to_string(),
        source,
    })
}

/// A finite number from a cell, or a parse error naming the line and column.
fn number(cell: &str, line: usize, what: &str) -> TracksResult<f64> {
    match cell.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(parse_err(
            line,
            format!("{what} {cell:?} is not a finite number"),
        )),
    }
}

/// Reads a track file in softsense's format.
pub fn read_tracks(path: &Path) -> TracksResult<MarkerTracks> {
    read_tracks_str(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses softsense's `frame,marker,x,y,z` CSV.
pub fn read_tracks_str(text: &str) -> TracksResult<MarkerTracks> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let header: Vec<String> = match lines.next() {
        Some((_, h)) => h
            .split(',')
            .map(|c| c.trim().to_ascii_lowercase())
            .collect(),
        None => {
            return Err(parse_err(
                1,
                "empty file: expected the header frame,marker,x,y,z",
            ))
        }
    };
    if header != ["frame", "marker", "x", "y", "z"] {
        return Err(parse_err(1, "the header must be frame,marker,x,y,z"));
    }
    let mut tracks = MarkerTracks {
        names: Vec::new(),
        frames: Vec::new(),
    };
    for (i, l) in lines {
        let line = i + 1;
        let cells: Vec<&str> = l.split(',').map(str::trim).collect();
        if cells.len() != 5 {
            return Err(parse_err(
                line,
                format!("{} cells, expected 5", cells.len()),
            ));
        }
        let frame: u64 = cells[0]
            .parse()
            .map_err(|_| parse_err(line, format!("frame {:?} is not a whole number", cells[0])))?;
        if cells[1].is_empty() {
            return Err(parse_err(line, "empty marker name"));
        }
        let position = if cells[2..].iter().all(|c| c.is_empty()) {
            None
        } else {
            let mut p = [0.0; 3];
            for (k, (pk, axis)) in p.iter_mut().zip(["x", "y", "z"]).enumerate() {
                *pk = number(cells[2 + k], line, axis)?;
            }
            Some(p)
        };
        let m = match tracks.names.iter().position(|n| n == cells[1]) {
            Some(m) => m,
            None => {
                tracks.names.push(cells[1].to_string());
                tracks.names.len() - 1
            }
        };
        if tracks.frames.last().is_none_or(|f| f.frame != frame) {
            if tracks.frames.iter().any(|f| f.frame == frame) {
                return Err(parse_err(
                    line,
                    format!("frame {frame} appears again after other frames"),
                ));
            }
            tracks.frames.push(TrackFrame {
                frame,
                positions: Vec::new(),
            });
        }
        let f = tracks.frames.last_mut().expect("a frame was just pushed");
        f.positions.resize(tracks.names.len(), None);
        if f.positions[m].is_some() {
            return Err(parse_err(
                line,
                format!("marker {} twice in frame {frame}", cells[1]),
            ));
        }
        f.positions[m] = position;
    }
    let n = tracks.names.len();
    tracks
        .frames
        .iter_mut()
        .for_each(|f| f.positions.resize(n, None));
    no_frames_is_an_error(tracks)
}

/// `tracks`, or an error when it has no frame: a header alone (what `markers detect` writes
/// when it finds no marker) would otherwise be sensed as nothing, with exit status 0.
fn no_frames_is_an_error(tracks: MarkerTracks) -> TracksResult<MarkerTracks> {
    if tracks.frames.is_empty() {
        return Err(TracksError::NoFrames);
    }
    Ok(tracks)
}

/// softsense's CSV text of `tracks` (every marker in every frame; hidden ones empty).
pub fn write_tracks_string(tracks: &MarkerTracks) -> String {
    let mut s = String::from("frame,marker,x,y,z\n");
    for f in &tracks.frames {
        for (name, p) in tracks.names.iter().zip(&f.positions) {
            match p {
                Some([x, y, z]) => s.push_str(&format!("{},{name},{x},{y},{z}\n", f.frame)),
                None => s.push_str(&format!("{},{name},,,\n", f.frame)),
            }
        }
    }
    s
}

/// Writes `tracks` to `path` in softsense's format (all or nothing).
pub fn write_tracks(path: &Path, tracks: &MarkerTracks) -> TracksResult<()> {
    Ok(crate::io::atomic::write(
        path,
        write_tracks_string(tracks).as_bytes(),
    )?)
}

/// Reads an OptiTrack Motive CSV export.
pub fn read_motive(path: &Path) -> TracksResult<MarkerTracks> {
    read_motive_str(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Metres per length unit named in a Motive header (millimetres when absent).
fn motive_scale(first_line: &str) -> TracksResult<f64> {
    let cells: Vec<&str> = first_line.split(',').map(str::trim).collect();
    let Some(i) = cells
        .iter()
        .position(|c| c.eq_ignore_ascii_case("Length Units"))
    else {
        return Ok(1e-3);
    };
    match cells.get(i + 1).map(|u| u.to_ascii_lowercase()).as_deref() {
        Some("millimeters" | "millimetres" | "mm") => Ok(1e-3),
        Some("centimeters" | "centimetres" | "cm") => Ok(1e-2),
        Some("meters" | "metres" | "m") => Ok(1.0),
        // Motive offers inches among its export units.
        Some("inches" | "inch" | "in") => Ok(0.0254),
        _ => Err(TracksError::LengthUnit {
            unit: cells.get(i + 1).unwrap_or(&"").to_string(),
        }),
    }
}

/// Parses an OptiTrack Motive CSV export (see the module docs).
pub fn read_motive_str(text: &str) -> TracksResult<MarkerTracks> {
    let lines: Vec<&str> = text.lines().collect();
    let Some(h) = lines
        .iter()
        .position(|l| l.trim_start().starts_with("Frame,"))
    else {
        return Err(parse_err(
            1,
            "no `Frame,Time,...` header line: not a Motive CSV export",
        ));
    };
    let scale = motive_scale(lines[0])?;
    let split = |l: &str| {
        l.split(',')
            .map(|c| c.trim().to_string())
            .collect::<Vec<_>>()
    };
    let header = split(lines[h]);
    let above: Vec<Vec<String>> = lines[..h].iter().map(|l| split(l)).collect();
    let labelled = |label: &str| {
        above
            .iter()
            .find(|r| r.iter().take(2).any(|c| c.eq_ignore_ascii_case(label)))
    };
    let names_row = labelled("Name");
    let kinds_row = above
        .iter()
        .find(|r| r.iter().skip(2).any(|c| c == "Position" || c == "Rotation"));
    let mut columns = Vec::new();
    let mut names = Vec::new();
    let mut c = 2;
    while c + 2 < header.len() {
        let xyz = header[c] == "X" && header[c + 1] == "Y" && header[c + 2] == "Z";
        let position = kinds_row.is_none_or(|r| r.get(c).is_none_or(|k| k == "Position"));
        if xyz && position {
            let name = names_row
                .and_then(|r| r.get(c))
                .filter(|n| !n.is_empty())
                .cloned()
                .unwrap_or_else(|| format!("marker{}", names.len() + 1));
            names.push(name);
            columns.push(c);
            c += 3;
        } else {
            c += 1;
        }
    }
    if columns.is_empty() {
        return Err(parse_err(h + 1, "no X,Y,Z position columns"));
    }
    let mut frames = Vec::new();
    for (i, l) in lines.iter().enumerate().skip(h + 1) {
        if l.trim().is_empty() {
            continue;
        }
        let cells = split(l);
        let frame: u64 = cells[0]
            .parse()
            .map_err(|_| parse_err(i + 1, format!("frame {:?} is not a whole number", cells[0])))?;
        let mut positions = Vec::with_capacity(columns.len());
        for &c in &columns {
            let get = |k: usize| cells.get(c + k).map(String::as_str).unwrap_or("");
            if (0..3).all(|k| get(k).is_empty()) {
                positions.push(None);
                continue;
            }
            let mut p = [0.0; 3];
            for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
                p[k] = scale * number(get(k), i + 1, &format!("column {} ({axis})", c + k + 1))?;
            }
            positions.push(Some(p));
        }
        frames.push(TrackFrame { frame, positions });
    }
    no_frames_is_an_error(MarkerTracks { names, frames })
}

//! Plain-text clouds: `x y z` per line, whitespace- or comma-separated.
//!
//! Extra columns (intensity, colour, normals from other tools) are ignored; blank lines
//! and lines starting with `#` are skipped. The writer emits `x y z` with the fewest
//! digits that read back to the same `f32`, and `nan` for NaN.
//!
//! ```
//! use softsense::io::xyz;
//! let cloud = xyz::parse_xyz(b"# scan\n1 2 3 0.5\n4,5,6\n")?;
//! assert_eq!(cloud.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
//! assert_eq!(xyz::to_xyz_bytes(&cloud), b"1 2 3\n4 5 6\n");
//! # Ok::<(), softsense::io::xyz::XyzError>(())
//! ```

use super::IoError;
use crate::cloud::PointCloud;
use std::path::Path;
use thiserror::Error;

/// What is wrong with an XYZ file.
#[derive(Debug, Error, PartialEq)]
pub enum XyzError {
    /// A line has fewer than three values.
    #[error("line {line}: expected at least 3 values (x y z), found {found}")]
    TooFewValues {
        /// 1-based line number.
        line: usize,
        /// Values found.
        found: usize,
    },
    /// A coordinate is not a number.
    #[error("line {line}: `{text}` is not a number")]
    NotANumber {
        /// 1-based line number.
        line: usize,
        /// The offending text (at most 40 characters).
        text: String,
    },
}

/// Parses XYZ text held in memory.
pub fn parse_xyz(bytes: &[u8]) -> Result<PointCloud, XyzError> {
    let mut positions = Vec::new();
    for (k, raw) in lines(bytes).enumerate() {
        let line = k + 1;
        let mut tokens = raw
            .split(|&b| b.is_ascii_whitespace() || b == b',')
            .filter(|t| !t.is_empty());
        let Some(first) = tokens.next() else { continue };
        if first.starts_with(b"#") {
            continue;
        }
        let mut p = [0f32; 3];
        let mut found = 0;
        for token in std::iter::once(first).chain(tokens).take(3) {
            p[found] = std::str::from_utf8(token)
                .ok()
                .and_then(|t| t.parse::<f32>().ok())
                .ok_or_else(|| XyzError::NotANumber {
                    line,
                    text: String::from_utf8_lossy(token).chars().take(40).collect(),
                })?;
            found += 1;
        }
        if found < 3 {
            return Err(XyzError::TooFewValues { line, found });
        }
        positions.push(p);
    }
    Ok(PointCloud::from_positions(positions))
}

/// The lines of `bytes`, ended by `\n`, `\r\n` or a lone `\r` (old Mac tools write
/// CR-only files; splitting on `\n` alone would read such a file as one line).
fn lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = bytes;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let end = rest
            .iter()
            .position(|&b| b == b'\n' || b == b'\r')
            .unwrap_or(rest.len());
        let line = &rest[..end];
        let skip = match rest.get(end..end + 2) {
            Some(b"\r\n") => 2,
            _ if end < rest.len() => 1,
            _ => 0,
        };
        rest = &rest[end + skip..];
        Some(line)
    })
}

/// Reads an XYZ file.
pub fn read_xyz(path: &Path) -> Result<PointCloud, IoError> {
    let bytes = super::read_bytes(path)?;
    parse_xyz(&bytes).map_err(|source| IoError::Xyz {
        path: path.to_path_buf(),
        source,
    })
}

/// Encodes a cloud's positions as XYZ text (other attributes are not written).
pub fn to_xyz_bytes(cloud: &PointCloud) -> Vec<u8> {
    let mut text = String::with_capacity(cloud.len() * 30);
    for p in &cloud.positions {
        for (a, v) in p.iter().enumerate() {
            if a > 0 {
                text.push(' ');
            }
            super::pcd::format_f32(&mut text, *v);
        }
        text.push('\n');
    }
    text.into_bytes()
}

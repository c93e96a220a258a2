//! A minimal reader of NumPy `.npy` files: version 1 or 2, little-endian `float32`
//! (`<f4`), C order. Everything else is refused with the reason, never guessed at
//! (a per-pixel ray table is the only array softsense reads).
//!
//! ```
//! use softsense::io::npy::parse_npy_f32;
//! let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }";
//! let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
//! bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
//! bytes.extend_from_slice(header.as_bytes());
//! bytes.extend_from_slice(&1.5f32.to_le_bytes());
//! bytes.extend_from_slice(&(-2.0f32).to_le_bytes());
//! let a = parse_npy_f32(&bytes)?;
//! assert_eq!((a.shape, a.data), (vec![2], vec![1.5, -2.0]));
//! # Ok::<(), softsense::io::npy::NpyError>(())
//! ```

use super::{limits, IoError};
use std::path::Path;
use thiserror::Error;

/// Why a `.npy` file is refused.
#[derive(Debug, Error)]
pub enum NpyError {
    /// The file does not start with `\x93NUMPY`.
    #[error("not a .npy file (no \\x93NUMPY magic)")]
    NotNpy,
    /// A format version other than 1.0 or 2.0.
    #[error("unsupported .npy version {0}.{1} (expected 1.0 or 2.0)")]
    Version(u8, u8),
    /// The header is cut short or is not the dictionary NumPy writes.
    #[error("bad .npy header: {0}")]
    Header(String),
    /// An element type other than little-endian float32.
    #[error("element type {0:?} is not float32 ('<f4')")]
    Dtype(String),
    /// The array is stored in Fortran (column-major) order.
    #[error("the array is in Fortran order (expected C order)")]
    FortranOrder,
    /// The data is not exactly the shape's size.
    #[error("the data is {found} bytes, the shape {shape:?} needs {expected}")]
    Length {
        /// The declared shape.
        shape: Vec<usize>,
        /// Bytes the shape needs.
        expected: u64,
        /// Bytes after the header.
        found: u64,
    },
    /// The array is over the memory budget.
    #[error(transparent)]
    TooLarge(#[from] limits::TooLarge),
}

/// A `float32` array: its shape and its elements in C (row-major) order.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyF32 {
    /// The dimensions, outermost first.
    pub shape: Vec<usize>,
    /// `shape.product()` elements, row-major.
    pub data: Vec<f32>,
}

/// Reads a `.npy` file of `<f4` in C order; errors name the file.
pub fn read_npy_f32(path: impl AsRef<Path>) -> Result<NpyF32, IoError> {
    let path = path.as_ref();
    // Refused before reading: the file is held whole, then its elements.
    let len = std::fs::metadata(path)
        .map_err(|source| IoError::Os {
            path: path.to_path_buf(),
            source,
        })?
        .len();
    limits::check("npy bytes", len, 2).map_err(|source| IoError::TooLarge {
        path: path.to_path_buf(),
        source,
    })?;
    let bytes = super::read_bytes(path)?;
    parse_npy_f32(&bytes).map_err(|source| IoError::Npy {
        path: path.to_path_buf(),
        source,
    })
}

/// Parses the bytes of a `.npy` file of `<f4` in C order.
pub fn parse_npy_f32(bytes: &[u8]) -> Result<NpyF32, NpyError> {
    if bytes.len() < 8 || &bytes[..6] != b"\x93NUMPY" {
        return Err(NpyError::NotNpy);
    }
    let (major, minor) = (bytes[6], bytes[7]);
    let (len_bytes, start) = match (major, minor) {
        (1, 0) => (2, 10),
        (2, 0) => (4, 12),
        _ => return Err(NpyError::Version(major, minor)),
    };
    let cut = || NpyError::Header("the file ends inside the header".into());
    let len_field = bytes.get(8..8 + len_bytes).ok_or_else(cut)?;
    let header_len = len_field
        .iter()
        .rev()
        .fold(0usize, |acc, &b| (acc << 8) | usize::from(b));
    let end = start + header_len;
    let header = bytes.get(start..end).ok_or_else(cut)?;
    let header = std::str::from_utf8(header)
        .map_err(|_| NpyError::Header("the header is not text".into()))?;
    let descr = quoted_value(header, "descr")?;
    if descr != "<f4" {
        return Err(NpyError::Dtype(descr.to_string()));
    }
    match raw_value(header, "fortran_order")? {
        v if v.starts_with("False") => {}
        v if v.starts_with("True") => return Err(NpyError::FortranOrder),
        v => return Err(NpyError::Header(format!("fortran_order is {v:?}"))),
    }
    let shape = shape_of(raw_value(header, "shape")?)?;
    let count = shape
        .iter()
        .try_fold(1u64, |acc, &d| acc.checked_mul(d as u64))
        .ok_or_else(|| NpyError::Header(format!("shape {shape:?} overflows")))?;
    limits::check("npy elements", count, 4)?;
    let data = &bytes[end..];
    let expected = count * 4;
    if data.len() as u64 != expected {
        return Err(NpyError::Length {
            shape,
            expected,
            found: data.len() as u64,
        });
    }
    let data = data
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok(NpyF32 { shape, data })
}

/// The text after `'key':` in the header dictionary, trimmed at the start.
fn raw_value<'a>(header: &'a str, key: &str) -> Result<&'a str, NpyError> {
    let tag = format!("'{key}':");
    let at = header
        .find(&tag)
        .ok_or_else(|| NpyError::Header(format!("no '{key}' in the header")))?;
    Ok(header[at + tag.len()..].trim_start())
}

/// The quoted string value of `key`.
fn quoted_value<'a>(header: &'a str, key: &str) -> Result<&'a str, NpyError> {
    let v = raw_value(header, key)?;
    let bad = || NpyError::Header(format!("'{key}' is not a quoted string"));
    let rest = v.strip_prefix('\'').ok_or_else(bad)?;
    rest.find('\'').map(|e| &rest[..e]).ok_or_else(bad)
}

/// The tuple `(a, b, ...)` at the start of `v`.
fn shape_of(v: &str) -> Result<Vec<usize>, NpyError> {
    let bad = || NpyError::Header(format!("shape is not a tuple of integers: {v:?}"));
    let inner = v.strip_prefix('(').ok_or_else(bad)?;
    let inner = &inner[..inner.find(')').ok_or_else(bad)?];
    inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| bad()))
        .collect()
}

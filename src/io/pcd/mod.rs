//! PCL's PCD v0.7 reader and writer: `ascii`, `binary` and `binary_compressed` bodies.
//!
//! Fields the cloud model knows are decoded into [`PointCloud`] columns: `x y z` (F4 or
//! F8), `rgb`/`rgba` (4 bytes of any TYPE, reinterpreted as `0xAARRGGBB`), `normal_x/y/z`,
//! `curvature` and `label` (any integer up to 4 bytes). Other fields (`_` padding,
//! `intensity`, descriptors with `COUNT 33`, ...) are skipped. Organized clouds keep their
//! `WIDTH x HEIGHT` and NaN points; `VIEWPOINT` is kept.
//!
//! Every size is checked against the bytes actually present before anything is
//! allocated, so a hostile header (`POINTS 4000000000` with a ten-byte body) is an error,
//! not an out-of-memory abort. A `binary_compressed` body may expand at most
//! [`lzf::MAX_RATIO`] times, LZF's own limit. Each thread keeps its last decompression
//! buffer (up to 64 MB) for the next read, so frame-after-frame reading does not fault
//! in fresh pages.
//!
//! Where PCL is lenient we report an error instead: `COUNT 0` (PCL drops the field),
//! malformed ASCII rows (PCL skips them but counts them as points) and unknown header
//! keywords. An `rgb` field gives colours without an alpha column; `rgba` keeps alpha.
//!
//! Writing ([`to_pcd_bytes`]) emits the fields of [`PointCloud::field_names`], all 4 bytes:
//! floats as `TYPE F`, colour as `TYPE U` (`rgb`, or `rgba` when the cloud has an alpha
//! column; without one the alpha byte is written as 255, PCL's `PointXYZRGB` default),
//! `label` as `U`. ASCII uses the shortest text that reads back to the same `f32`, and `nan`.
//!
//! ```
//! use softsense::cloud::PointCloud;
//! use softsense::io::{pcd, Encoding};
//! let mut cloud = PointCloud::from_positions(vec![[0.1, 0.2, 0.3], [f32::NAN; 3]]);
//! cloud.colors = Some(vec![[255, 0, 1], [0, 0, 0]]);
//! for encoding in [Encoding::Ascii, Encoding::Binary, Encoding::BinaryCompressed] {
//!     let bytes = pcd::to_pcd_bytes(&cloud, encoding);
//!     let back = pcd::parse_pcd(&bytes)?;
//!     assert_eq!(back.positions[0], [0.1, 0.2, 0.3]);
//!     assert!(back.positions[1][0].is_nan());
//!     assert_eq!(back.colors, cloud.colors);
//! }
//! # Ok::<(), softsense::io::pcd::PcdError>(())
//! ```

mod header;
pub mod lzf;

pub use header::{DataEncoding, PcdField, PcdHeader, ScalarType, MAX_RECORD_SIZE};
pub use lzf::LzfError;

use super::{Encoding, IoError};
use crate::cloud::{CloudError, PointCloud};
use std::io::Read;
use std::path::Path;
use thiserror::Error;

/// What is wrong with a PCD file.
#[derive(Debug, Error, PartialEq)]
pub enum PcdError {
    /// The file has no bytes at all.
    #[error("empty file")]
    Empty,
    /// A header line is not UTF-8 text.
    #[error("header line {line} is not UTF-8 text")]
    NotUtf8 {
        /// 1-based line number.
        line: usize,
    },
    /// A header line starts with a keyword PCD does not define.
    #[error("header line {line}: unknown keyword `{keyword}`")]
    UnknownKeyword {
        /// 1-based line number.
        line: usize,
        /// The keyword (at most 40 characters of it).
        keyword: String,
    },
    /// A header value does not parse (or has the wrong number of entries).
    #[error("header line {line}: bad {key} value `{value}`")]
    BadValue {
        /// 1-based line number.
        line: usize,
        /// The keyword.
        key: &'static str,
        /// The offending text.
        value: String,
    },
    /// A required header line is absent.
    #[error("header has no {key} line")]
    MissingKey {
        /// The keyword.
        key: &'static str,
    },
    /// `SIZE`, `TYPE` or `COUNT` lists a different number of entries than `FIELDS`.
    #[error("{key} lists {got} entries but FIELDS lists {expected}")]
    ListLength {
        /// The keyword.
        key: &'static str,
        /// Entries on that line.
        got: usize,
        /// Entries on the FIELDS line.
        expected: usize,
    },
    /// A field's `TYPE`/`SIZE` combination is not one PCD defines.
    #[error("field `{field}` has TYPE {ty} SIZE {size}, which PCD does not define")]
    BadType {
        /// Field name.
        field: String,
        /// Declared TYPE.
        ty: String,
        /// Declared SIZE.
        size: usize,
    },
    /// A field declares `COUNT 0`.
    #[error("field `{field}` has COUNT 0")]
    ZeroCount {
        /// Field name.
        field: String,
    },
    /// The same field name appears twice.
    #[error("field `{field}` is declared twice")]
    DuplicateField {
        /// Field name.
        field: String,
    },
    /// The sizes and counts add up to an absurd record size.
    #[error("point record is larger than {max} bytes")]
    RecordTooLarge {
        /// The limit.
        max: u64,
    },
    /// `WIDTH * HEIGHT != POINTS`.
    #[error("WIDTH {width} x HEIGHT {height} does not equal POINTS {points}")]
    PointsMismatch {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Declared points.
        points: u64,
    },
    /// The `DATA` line names an unknown encoding.
    #[error("unknown DATA encoding `{kind}` (expected ascii, binary or binary_compressed)")]
    UnknownData {
        /// The text after DATA.
        kind: String,
    },
    /// The file lacks one of `x`, `y`, `z`.
    #[error("the file has no `{field}` field")]
    MissingField {
        /// The missing field.
        field: &'static str,
    },
    /// A known field has a type or count that makes no sense for it.
    #[error("field `{field}` is {ty} with COUNT {count}; expected {expected}")]
    BadFieldType {
        /// Field name.
        field: String,
        /// Declared type, e.g. `U2`.
        ty: ScalarType,
        /// Declared count.
        count: usize,
        /// What would be accepted.
        expected: &'static str,
    },
    /// The point count does not fit this machine's address space.
    #[error("{points} points cannot be held in memory")]
    TooManyPoints {
        /// Declared points.
        points: u64,
    },
    /// The body is shorter than the header requires.
    #[error("body is truncated: needs {needed} bytes, has {available}")]
    Truncated {
        /// Bytes the header requires (at least).
        needed: u64,
        /// Bytes present after the header.
        available: u64,
    },
    /// The compressed size field exceeds the bytes present.
    #[error("compressed size {declared} exceeds the {available} bytes present")]
    CompressedSize {
        /// Declared compressed size.
        declared: u64,
        /// Bytes present after the two size fields.
        available: u64,
    },
    /// The uncompressed size field disagrees with `POINTS` times the record size.
    #[error("uncompressed size {declared} does not equal POINTS x record size = {expected}")]
    UncompressedSize {
        /// Declared uncompressed size.
        declared: u64,
        /// What the header implies.
        expected: u64,
    },
    /// The declared sizes imply an expansion no LZF stream can encode.
    #[error("{compressed} compressed bytes cannot expand to {uncompressed}")]
    CompressionRatio {
        /// Declared compressed size.
        compressed: u64,
        /// Declared uncompressed size.
        uncompressed: u64,
    },
    /// The LZF stream is corrupt.
    #[error("corrupt LZF data: {0}")]
    Lzf(#[from] LzfError),
    /// An ASCII row cannot be parsed.
    #[error("ascii body line {line}: {reason}")]
    AsciiRow {
        /// 1-based line number within the file.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The ASCII body has fewer rows than `POINTS`.
    #[error("ascii body has {got} rows but POINTS is {expected}")]
    AsciiRows {
        /// Declared points.
        expected: u64,
        /// Rows found.
        got: u64,
    },
}

/// Largest header we read when only the header is wanted.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Reads a PCD file.
pub fn read_pcd(path: &Path) -> Result<PointCloud, IoError> {
    let bytes = super::read_bytes(path)?;
    parse_pcd(&bytes).map_err(|source| IoError::Pcd {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads only the header of a PCD file (all declared fields, unknown ones included).
pub fn read_pcd_header(path: &Path) -> Result<PcdHeader, IoError> {
    let os = |source| IoError::Os {
        path: path.to_path_buf(),
        source,
    };
    let mut prefix = Vec::new();
    std::fs::File::open(path)
        .map_err(os)?
        .take(MAX_HEADER_BYTES)
        .read_to_end(&mut prefix)
        .map_err(os)?;
    PcdHeader::parse(&prefix).map_err(|source| IoError::Pcd {
        path: path.to_path_buf(),
        source,
    })
}

/// What a declared field becomes in the cloud.
#[derive(Clone, Copy)]
enum Role {
    Axis(usize),
    Color { alpha: bool },
    Normal(usize),
    Curvature,
    Label,
    Skip,
}

fn role_of(field: &PcdField) -> Result<Role, PcdError> {
    let bad = |expected| PcdError::BadFieldType {
        field: field.name.clone(),
        ty: field.ty,
        count: field.count,
        expected,
    };
    let float = |role| {
        if field.ty.is_float() && field.count == 1 {
            Ok(role)
        } else {
            Err(bad("F4 or F8 with COUNT 1"))
        }
    };
    match field.name.as_str() {
        "x" => float(Role::Axis(0)),
        "y" => float(Role::Axis(1)),
        "z" => float(Role::Axis(2)),
        "normal_x" => float(Role::Normal(0)),
        "normal_y" => float(Role::Normal(1)),
        "normal_z" => float(Role::Normal(2)),
        "curvature" => float(Role::Curvature),
        "rgb" | "rgba" => {
            if field.ty.size() == 4 && field.count == 1 {
                Ok(Role::Color {
                    alpha: field.name == "rgba",
                })
            } else {
                Err(bad("a 4-byte packed value (U4, I4 or F4) with COUNT 1"))
            }
        }
        "label" => {
            if !field.ty.is_float() && field.ty.size() <= 4 && field.count == 1 {
                Ok(Role::Label)
            } else {
                Err(bad("an integer of at most 4 bytes with COUNT 1"))
            }
        }
        _ => Ok(Role::Skip),
    }
}

/// The decoded body: either interleaved records or field-columnar blocks.
struct Body<'a> {
    data: &'a [u8],
    n: usize,
    columnar: bool,
    /// Per field: byte offset within the record (interleaved) or of its column (columnar).
    offsets: Vec<usize>,
    record: usize,
}

impl<'a> Body<'a> {
    fn new(header: &PcdHeader, data: &'a [u8], n: usize, columnar: bool) -> Body<'a> {
        let mut offsets = Vec::with_capacity(header.fields.len());
        let mut at = 0;
        for f in &header.fields {
            offsets.push(at);
            at += if !columnar {
                f.byte_len()
            } else if f.is_padding() {
                0 // PCL stores no column for `_` padding in compressed bodies
            } else {
                f.byte_len() * n
            };
        }
        Body {
            data,
            n,
            columnar,
            offsets,
            record: header.record_size(),
        }
    }

    /// The bytes of field `k`'s first value, point by point. The caller has checked
    /// that `data` holds `n` records.
    fn values(&self, header: &PcdHeader, k: usize) -> impl Iterator<Item = &'a [u8]> {
        let f = &header.fields[k];
        let size = f.ty.size();
        let (slice, stride, off) = if self.columnar {
            let start = self.offsets[k];
            let len = f.byte_len() * self.n;
            (&self.data[start..start + len], f.byte_len(), 0)
        } else {
            (
                &self.data[..self.record * self.n],
                self.record,
                self.offsets[k],
            )
        };
        slice.chunks_exact(stride).map(move |c| &c[off..off + size])
    }
}

fn arr4(b: &[u8]) -> [u8; 4] {
    [b[0], b[1], b[2], b[3]]
}

fn arr8(b: &[u8]) -> [u8; 8] {
    [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]
}

/// Calls `f(i, value)` for every value of a float column.
fn for_each_f32<'a>(
    values: impl Iterator<Item = &'a [u8]>,
    ty: ScalarType,
    mut f: impl FnMut(usize, f32),
) {
    if ty == ScalarType::F64 {
        for (i, b) in values.enumerate() {
            f(i, f64::from_le_bytes(arr8(b)) as f32);
        }
    } else {
        for (i, b) in values.enumerate() {
            f(i, f32::from_le_bytes(arr4(b)));
        }
    }
}

/// An integer value of at most 4 bytes as `u32` (signed values keep their bits).
fn int_u32(b: &[u8], ty: ScalarType) -> u32 {
    match ty {
        ScalarType::I8 => b[0] as i8 as u32,
        ScalarType::U8 => u32::from(b[0]),
        ScalarType::I16 => i16::from_le_bytes([b[0], b[1]]) as u32,
        ScalarType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
        _ => u32::from_le_bytes(arr4(b)),
    }
}

fn decode(header: &PcdHeader, body: &Body<'_>) -> Result<PointCloud, PcdError> {
    let roles: Vec<Role> = header
        .fields
        .iter()
        .map(role_of)
        .collect::<Result<_, _>>()?;
    let find = |want: &dyn Fn(Role) -> bool| roles.iter().position(|&r| want(r));
    let n = body.n;
    let mut positions = vec![[0f32; 3]; n];
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        let k = find(&|r| matches!(r, Role::Axis(a) if a == axis))
            .ok_or(PcdError::MissingField { field: name })?;
        for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
            positions[i][axis] = v
        });
    }
    let mut cloud = PointCloud {
        positions,
        width: header.width,
        height: header.height,
        viewpoint: header.viewpoint,
        ..Default::default()
    };
    if let Some(k) = find(&|r| matches!(r, Role::Color { .. })) {
        let mut colors = Vec::with_capacity(n);
        let mut alpha = Vec::with_capacity(n);
        for b in body.values(header, k) {
            let v = u32::from_le_bytes(arr4(b));
            colors.push([(v >> 16) as u8, (v >> 8) as u8, v as u8]);
            alpha.push((v >> 24) as u8);
        }
        cloud.colors = Some(colors);
        if matches!(roles[k], Role::Color { alpha: true }) {
            cloud.alpha = Some(alpha);
        }
    }
    let normal_fields: Vec<usize> = (0..3)
        .filter_map(|axis| find(&|r| matches!(r, Role::Normal(a) if a == axis)))
        .collect();
    if normal_fields.len() == 3 {
        let mut normals = vec![[0f32; 3]; n];
        for (axis, &k) in normal_fields.iter().enumerate() {
            for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
                normals[i][axis] = v
            });
        }
        cloud.normals = Some(normals);
    }
    if let Some(k) = find(&|r| matches!(r, Role::Curvature)) {
        let mut curvature = vec![0f32; n];
        for_each_f32(body.values(header, k), header.fields[k].ty, |i, v| {
            curvature[i] = v
        });
        cloud.curvature = Some(curvature);
    }
    if let Some(k) = find(&|r| matches!(r, Role::Label)) {
        let ty = header.fields[k].ty;
        cloud.labels = Some(body.values(header, k).map(|b| int_u32(b, ty)).collect());
    }
    Ok(cloud)
}

/// Parses a whole PCD file held in memory.
pub fn parse_pcd(bytes: &[u8]) -> Result<PointCloud, PcdError> {
    let header = PcdHeader::parse(bytes)?;
    // Reject bad field types before touching the body.
    for f in &header.fields {
        role_of(f)?;
    }
    let points = header.points;
    let n = usize::try_from(points).map_err(|_| PcdError::TooManyPoints { points })?;
    let record = header.record_size() as u64;
    let body = &bytes[header.data_offset..];
    let available = body.len() as u64;
    let total = points
        .checked_mul(record)
        .ok_or(PcdError::TooManyPoints { points })?;
    match header.encoding {
        DataEncoding::Binary => {
            if total > available {
                return Err(PcdError::Truncated {
                    needed: total,
                    available,
                });
            }
            decode(&header, &Body::new(&header, body, n, false))
        }
        DataEncoding::BinaryCompressed => SCRATCH.with(|scratch| {
            // A re-entrant call (none exists today) would find the buffer borrowed and
            // simply use a fresh one.
            let mut fresh = Vec::new();
            let mut guard = scratch.try_borrow_mut();
            let data = match guard.as_mut() {
                Ok(buf) => &mut **buf,
                Err(_) => &mut fresh,
            };
            let columns = points
                .checked_mul(header.columnar_record_size() as u64)
                .ok_or(PcdError::TooManyPoints { points })?;
            decompress_body(body, columns, data)?;
            let cloud = decode(&header, &Body::new(&header, data, n, true));
            if data.capacity() > MAX_SCRATCH_BYTES {
                *data = Vec::new();
            }
            cloud
        }),
        DataEncoding::Ascii => {
            let records = ascii_records(&header, bytes, n)?;
            decode(&header, &Body::new(&header, &records, n, false))
        }
    }
}

thread_local! {
    /// PERF: the decompressed body of the last `binary_compressed` file read on this
    /// thread, reused so that reading frame after frame does not fault in ~5 MB of
    /// fresh pages each time. Dropped when larger than [`MAX_SCRATCH_BYTES`].
    static SCRATCH: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Largest decompression buffer kept between reads (a 640x480 XYZRGBA body is 4.9 MB).
const MAX_SCRATCH_BYTES: usize = 64 << 20;

/// Checks the two size words of a `binary_compressed` body and decompresses it into `out`.
fn decompress_body(body: &[u8], expected: u64, out: &mut Vec<u8>) -> Result<(), PcdError> {
    let available = body.len() as u64;
    if body.len() < 8 {
        return Err(PcdError::Truncated {
            needed: 8,
            available,
        });
    }
    let compressed = u64::from(u32::from_le_bytes(arr4(&body[0..4])));
    let uncompressed = u64::from(u32::from_le_bytes(arr4(&body[4..8])));
    let stream = &body[8..];
    if compressed > stream.len() as u64 {
        return Err(PcdError::CompressedSize {
            declared: compressed,
            available: stream.len() as u64,
        });
    }
    if uncompressed != expected {
        return Err(PcdError::UncompressedSize {
            declared: uncompressed,
            expected,
        });
    }
    if uncompressed > compressed * lzf::MAX_RATIO {
        return Err(PcdError::CompressionRatio {
            compressed,
            uncompressed,
        });
    }
    // Both sizes fit in u32 and are bounded by the file size, so these casts hold.
    Ok(lzf::decompress_into(
        &stream[..compressed as usize],
        uncompressed as usize,
        out,
    )?)
}

/// Parses an ASCII body into little-endian records in the header's field layout.
fn ascii_records(header: &PcdHeader, bytes: &[u8], n: usize) -> Result<Vec<u8>, PcdError> {
    let body = &bytes[header.data_offset..];
    let tokens_per_row: usize = header.fields.iter().map(|f| f.count).sum();
    // Each value takes at least one character and one separator.
    let min_bytes = (n as u64)
        .checked_mul(2 * tokens_per_row as u64)
        .ok_or(PcdError::TooManyPoints { points: n as u64 })?;
    if n > 0 && min_bytes > body.len() as u64 + 1 {
        return Err(PcdError::Truncated {
            needed: min_bytes - 1,
            available: body.len() as u64,
        });
    }
    let header_lines = bytes[..header.data_offset]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    let mut out = Vec::with_capacity(n * header.record_size());
    let mut rows = 0usize;
    for (k, line) in body.split(|&b| b == b'\n').enumerate() {
        if rows == n {
            break;
        }
        let line_no = header_lines + k + 1;
        let row_err = |reason: String| PcdError::AsciiRow {
            line: line_no,
            reason,
        };
        let mut tokens = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let mut first = true;
        for f in &header.fields {
            for _ in 0..f.count {
                let Some(token) = tokens.next() else {
                    if first {
                        break;
                    }
                    return Err(row_err(format!(
                        "{tokens_per_row} values expected, fewer found"
                    )));
                };
                first = false;
                push_ascii_value(&mut out, token, f.ty)
                    .map_err(|text| row_err(format!("`{text}` is not a {} value", f.ty)))?;
            }
        }
        if first {
            continue; // blank line
        }
        if tokens.next().is_some() {
            return Err(row_err(format!(
                "more than the {tokens_per_row} declared values"
            )));
        }
        rows += 1;
    }
    if rows < n {
        return Err(PcdError::AsciiRows {
            expected: n as u64,
            got: rows as u64,
        });
    }
    Ok(out)
}

/// Appends one ASCII value as little-endian bytes of `ty`; on failure returns the text.
fn push_ascii_value(out: &mut Vec<u8>, token: &[u8], ty: ScalarType) -> Result<(), String> {
    let text = std::str::from_utf8(token).map_err(|_| {
        String::from_utf8_lossy(token)
            .chars()
            .take(40)
            .collect::<String>()
    })?;
    let fail = || text.chars().take(40).collect::<String>();
    use ScalarType::*;
    match ty {
        F32 => out.extend_from_slice(&text.parse::<f32>().map_err(|_| fail())?.to_le_bytes()),
        F64 => out.extend_from_slice(&text.parse::<f64>().map_err(|_| fail())?.to_le_bytes()),
        I8 | I16 | I32 | I64 => {
            let v: i64 = text.parse().map_err(|_| fail())?;
            let bytes = v.to_le_bytes();
            let size = ty.size();
            let fits = size == 8 || {
                let bits = 8 * size as u32;
                v >= -(1i64 << (bits - 1)) && v < (1i64 << (bits - 1))
            };
            if !fits {
                return Err(fail());
            }
            out.extend_from_slice(&bytes[..size]);
        }
        U8 | U16 | U32 | U64 => {
            let v: u64 = text.parse().map_err(|_| fail())?;
            let size = ty.size();
            if size < 8 && v >> (8 * size) != 0 {
                return Err(fail());
            }
            out.extend_from_slice(&v.to_le_bytes()[..size]);
        }
    }
    Ok(())
}

/// One output column: name, TYPE letter, and each point's 4 bytes as a `u32`.
struct OutColumn {
    name: &'static str,
    letter: char,
    bits: Vec<u32>,
}

fn out_columns(cloud: &PointCloud) -> Vec<OutColumn> {
    if let Err(e @ CloudError::LengthMismatch { .. }) = cloud.validate() {
        panic!("to_pcd_bytes: inconsistent cloud: {e}");
    }
    let float = |name, it: &mut dyn Iterator<Item = f32>| OutColumn {
        name,
        letter: 'F',
        bits: it.map(f32::to_bits).collect(),
    };
    let mut cols = Vec::new();
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        cols.push(float(name, &mut cloud.positions.iter().map(|p| p[axis])));
    }
    if let Some(colors) = &cloud.colors {
        let names = cloud.field_names();
        let name = if names.contains(&"rgba") {
            "rgba"
        } else {
            "rgb"
        };
        let bits = colors
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let a = cloud.alpha.as_ref().map_or(255, |a| a[i]);
                u32::from_be_bytes([a, c[0], c[1], c[2]])
            })
            .collect();
        cols.push(OutColumn {
            name,
            letter: 'U',
            bits,
        });
    }
    if let Some(normals) = &cloud.normals {
        for (axis, name) in ["normal_x", "normal_y", "normal_z"].into_iter().enumerate() {
            cols.push(float(name, &mut normals.iter().map(|p| p[axis])));
        }
    }
    if let Some(curvature) = &cloud.curvature {
        cols.push(float("curvature", &mut curvature.iter().copied()));
    }
    if let Some(labels) = &cloud.labels {
        cols.push(OutColumn {
            name: "label",
            letter: 'U',
            bits: labels.clone(),
        });
    }
    cols
}

/// Formats an `f32` with the fewest digits that read back to the same value; `nan` for
/// NaN as PCL writes it.
pub(crate) fn format_f32(out: &mut String, v: f32) {
    use std::fmt::Write;
    if v.is_nan() {
        out.push_str("nan");
    } else if v != 0.0 && v.is_finite() && !(1e-5..1e16).contains(&v.abs()) {
        let _ = write!(out, "{v:e}");
    } else {
        let _ = write!(out, "{v}");
    }
}

/// Encodes a cloud as PCD bytes. A cloud whose `width * height` does not match its
/// length is written unorganized (`WIDTH len`, `HEIGHT 1`).
///
/// Panics if an attribute column's length differs from the point count (a programmer
/// error; see [`PointCloud::validate`]).
pub fn to_pcd_bytes(cloud: &PointCloud, encoding: Encoding) -> Vec<u8> {
    use std::fmt::Write;
    let cols = out_columns(cloud);
    let n = cloud.len();
    let (width, height) = if u64::from(cloud.width) * u64::from(cloud.height) == n as u64 {
        (u64::from(cloud.width), u64::from(cloud.height))
    } else {
        (n as u64, 1)
    };
    let data = match encoding {
        Encoding::Ascii => DataEncoding::Ascii,
        Encoding::Binary => DataEncoding::Binary,
        Encoding::BinaryCompressed => DataEncoding::BinaryCompressed,
    };
    let list = |f: &dyn Fn(&OutColumn) -> String| cols.iter().map(f).collect::<Vec<_>>().join(" ");
    let mut text = String::from("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n");
    let _ = writeln!(text, "FIELDS {}", list(&|c| c.name.to_string()));
    let _ = writeln!(text, "SIZE {}", list(&|_| "4".to_string()));
    let _ = writeln!(text, "TYPE {}", list(&|c| c.letter.to_string()));
    let _ = writeln!(text, "COUNT {}", list(&|_| "1".to_string()));
    let _ = writeln!(text, "WIDTH {width}\nHEIGHT {height}");
    text.push_str("VIEWPOINT");
    let vp = &cloud.viewpoint;
    for v in vp.origin.iter().chain(&vp.orientation) {
        text.push(' ');
        format_f32(&mut text, *v);
    }
    let _ = writeln!(text, "\nPOINTS {n}\nDATA {}", data.keyword());
    match encoding {
        Encoding::Ascii => {
            text.reserve(n * cols.len() * 12);
            for i in 0..n {
                for (k, c) in cols.iter().enumerate() {
                    if k > 0 {
                        text.push(' ');
                    }
                    if c.letter == 'F' {
                        format_f32(&mut text, f32::from_bits(c.bits[i]));
                    } else {
                        let _ = write!(text, "{}", c.bits[i]);
                    }
                }
                text.push('\n');
            }
            text.into_bytes()
        }
        Encoding::Binary => {
            let mut out = text.into_bytes();
            out.reserve(n * cols.len() * 4);
            for i in 0..n {
                for c in &cols {
                    out.extend_from_slice(&c.bits[i].to_le_bytes());
                }
            }
            out
        }
        Encoding::BinaryCompressed => {
            let mut raw = Vec::with_capacity(n * cols.len() * 4);
            for c in &cols {
                raw.extend(c.bits.iter().flat_map(|b| b.to_le_bytes()));
            }
            let packed = lzf::compress(&raw);
            let mut out = text.into_bytes();
            // PCL's format stores both sizes as u32; clouds beyond 4 GiB cannot be PCD.
            out.extend_from_slice(&(packed.len() as u32).to_le_bytes());
            out.extend_from_slice(&(raw.len() as u32).to_le_bytes());
            out.extend_from_slice(&packed);
            out
        }
    }
}

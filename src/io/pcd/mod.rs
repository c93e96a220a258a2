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

mod ascii;
mod decode;
mod header;
pub mod lzf;
mod write;

pub use header::{DataEncoding, PcdField, PcdHeader, ScalarType, MAX_RECORD_SIZE};
pub use lzf::LzfError;
pub(crate) use write::format_f32;
pub use write::to_pcd_bytes;

use super::IoError;
use crate::cloud::PointCloud;
use ascii::ascii_records;
use decode::{arr4, decode, role_of, Body};
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
    /// `HEIGHT 0`: an unorganized cloud has height 1.
    #[error("HEIGHT is 0 (WIDTH {width}); an unorganized cloud has HEIGHT 1")]
    ZeroHeight {
        /// Declared width.
        width: u32,
    },
    /// Bytes follow the data the header declares (PCL ignores them; we refuse, as they
    /// mean the header's counts do not describe the body; zero padding after a
    /// compressed block, which PCL's writer leaves, is accepted).
    #[error("{extra} bytes follow the {expected} bytes of data the header declares")]
    TrailingBytes {
        /// Bytes beyond the declared data.
        extra: u64,
        /// Bytes of data the header declares (compressed size words included).
        expected: u64,
    },
    /// The ASCII body has more rows than `POINTS`.
    #[error("ascii body line {line}: a row beyond the POINTS {expected} declared")]
    AsciiExtraRow {
        /// 1-based line number within the file.
        line: usize,
        /// Declared points.
        expected: u64,
    },
    /// The header declares more points than the memory budget allows.
    #[error(transparent)]
    TooLarge(#[from] super::limits::TooLarge),
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
    parse_pcd(&bytes).map_err(|source| match source {
        PcdError::TooLarge(source) => IoError::TooLarge {
            path: path.to_path_buf(),
            source,
        },
        source => IoError::Pcd {
            path: path.to_path_buf(),
            source,
        },
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
    // The decoded record plus the cloud's f32 positions, per point; checked after the
    // body-size checks, which name the more telling fault for a lying header.
    let budget = || super::limits::check("points", points, record + 12);
    match header.encoding {
        DataEncoding::Binary => {
            if total > available {
                return Err(PcdError::Truncated {
                    needed: total,
                    available,
                });
            }
            if available > total {
                return Err(PcdError::TrailingBytes {
                    extra: available - total,
                    expected: total,
                });
            }
            budget()?;
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
            budget()?;
            let cloud = decode(&header, &Body::new(&header, data, n, true));
            if data.capacity() > MAX_SCRATCH_BYTES {
                *data = Vec::new();
            }
            cloud
        }),
        DataEncoding::Ascii => {
            let records = ascii_records(&header, bytes, n)?;
            budget()?;
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
    // PCL's own grabber files pad the compressed block with zeros (3,901 bytes in its
    // 2012 Kinect sequence) and PCL reads them, so zero padding is accepted; anything
    // else after the block means the header does not describe the body.
    let padding = &stream[(compressed as usize).min(stream.len())..];
    if padding.iter().any(|&b| b != 0) {
        return Err(PcdError::TrailingBytes {
            extra: stream.len() as u64 - compressed,
            expected: compressed + 8,
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

//! PLY reader and writer: `ascii`, `binary_little_endian` and `binary_big_endian`.
//!
//! The reader takes the `vertex` element's `x y z` (any numeric type), `nx ny nz`,
//! `red green blue` (integers, or floats in `0..=1` scaled by 255) and `alpha`, plus
//! `curvature` and `label`; every other property, list properties and other elements
//! (faces, edges) are read past and dropped. The writer uses Open3D's property names:
//! `float x y z`, `float nx ny nz`, `uchar red green blue`, then `uchar alpha`,
//! `float curvature` and `uint label` when present. Coordinates are written as `float`
//! (Open3D writes `double`): the cloud is `f32`, so `float` is lossless and half the size.
//!
//! ```
//! use softsense::cloud::PointCloud;
//! use softsense::io::{ply, Encoding};
//! let mut cloud = PointCloud::from_positions(vec![[0.1, 0.2, 0.3]]);
//! cloud.colors = Some(vec![[10, 20, 30]]);
//! let back = ply::parse_ply(&ply::to_ply_bytes(&cloud, Encoding::Ascii))?;
//! assert_eq!(back, cloud);
//! # Ok::<(), softsense::io::ply::PlyError>(())
//! ```

mod body;
mod header;
mod write;

use super::IoError;
use crate::cloud::PointCloud;
use body::{target_of, Column, ReadFail, Source, Target, VertexColumns};
use header::{parse_header, Element, Scalar};
use std::path::Path;
use thiserror::Error;

pub use write::{to_ply_bytes, to_ply_bytes_with};

/// What is wrong with a PLY file.
#[derive(Debug, Error, PartialEq)]
pub enum PlyError {
    /// The file does not start with the `ply` magic line.
    #[error("not a PLY file (first line is not `ply`)")]
    NotPly,
    /// A header line is not UTF-8 text.
    #[error("header line {line} is not UTF-8 text")]
    NotUtf8 {
        /// 1-based line number.
        line: usize,
    },
    /// The header ends before `end_header`.
    #[error("header has no end_header line")]
    NoEndHeader,
    /// A header line cannot be understood.
    #[error("header line {line}: {reason}")]
    BadHeaderLine {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The `format` line names an unknown format, or is missing.
    #[error("unknown PLY format `{format}`")]
    UnknownFormat {
        /// The format text.
        format: String,
    },
    /// The file has no `vertex` element.
    #[error("the file has no vertex element")]
    NoVertexElement,
    /// The vertex element lacks a required property.
    #[error("the vertex element has no `{property}` property")]
    MissingProperty {
        /// The property.
        property: &'static str,
    },
    /// A known vertex property is declared as a list.
    #[error("vertex property `{property}` is a list; expected a scalar")]
    ListProperty {
        /// The property.
        property: String,
    },
    /// An element count is larger than the body could possibly hold.
    #[error(
        "element `{element}` declares {count} entries but the body has only {available} bytes"
    )]
    TooManyElements {
        /// Element name.
        element: String,
        /// Declared count.
        count: u64,
        /// Body bytes.
        available: u64,
    },
    /// The body ends before all declared elements are read.
    #[error("body is truncated in element `{element}` entry {index}")]
    Truncated {
        /// Element name.
        element: String,
        /// 0-based entry.
        index: u64,
    },
    /// An ASCII value does not parse as its declared type.
    #[error("element `{element}` entry {index}: `{text}` is not a {ty} value")]
    BadValue {
        /// Element name.
        element: String,
        /// 0-based entry.
        index: u64,
        /// The offending text.
        text: String,
        /// Declared type.
        ty: &'static str,
    },
    /// An ASCII line holds more values than its element's properties; reading on would
    /// spill them into the next entry.
    #[error("line {line}: element `{element}` entry {index} has more values than its {properties} properties")]
    ExtraValues {
        /// 1-based line number in the file.
        line: usize,
        /// Element name.
        element: String,
        /// 0-based entry.
        index: u64,
        /// Properties the element declares.
        properties: usize,
    },
    /// An ASCII line ends before all of its element's properties are read.
    #[error("line {line}: element `{element}` entry {index} has fewer values than its {properties} properties")]
    MissingValues {
        /// 1-based line number in the file.
        line: usize,
        /// Element name.
        element: String,
        /// 0-based entry.
        index: u64,
        /// Properties the element declares.
        properties: usize,
    },
    /// The header declares more vertices than the memory budget allows.
    #[error(transparent)]
    TooLarge(#[from] super::limits::TooLarge),
    /// A face corner is not a vertex index.
    #[error("face {index}: corner {value} is not a vertex index")]
    BadFaceCorner {
        /// 0-based face.
        index: u64,
        /// The value read.
        value: f64,
    },
    /// A list length is negative or not an integer.
    #[error("element `{element}` entry {index}: bad list length {count}")]
    BadListCount {
        /// Element name.
        element: String,
        /// 0-based entry.
        index: u64,
        /// The value read.
        count: f64,
    },
}

/// PLY body formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlyFormat {
    /// Text.
    Ascii,
    /// Little-endian binary.
    BinaryLittleEndian,
    /// Big-endian binary.
    BinaryBigEndian,
}

/// Parses a whole PLY file held in memory.
pub fn parse_ply(bytes: &[u8]) -> Result<PointCloud, PlyError> {
    parse(bytes, None)
}

/// Parses a PLY file's vertices and its `face` element's corner lists (`vertex_indices`
/// or `vertex_index`): a triangle or polygon surface, as CAD tools export one.
pub fn parse_ply_faces(bytes: &[u8]) -> Result<(PointCloud, Vec<Vec<usize>>), PlyError> {
    let mut faces = Vec::new();
    let cloud = parse(bytes, Some(&mut faces))?;
    Ok((cloud, faces))
}

fn parse(bytes: &[u8], mut faces: Option<&mut Vec<Vec<usize>>>) -> Result<PointCloud, PlyError> {
    let header = parse_header(bytes)?;
    let vertex_at = header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or(PlyError::NoVertexElement)?;
    let vertex = &header.elements[vertex_at];
    let targets = vertex_targets(vertex)?;
    let body = &bytes[header.body_offset..];
    check_vertex_count(vertex, header.format, body.len() as u64)?;
    // Positions, normals, colours, curvature and label at most, per vertex.
    super::limits::check("points", vertex.count, 40)?;
    let n = vertex.count as usize; // bounded by the body length above
    let mut out = VertexColumns::new(n, &targets);
    let mut src = Source {
        data: body,
        pos: 0,
        format: header.format,
        first_line: bytes[..header.body_offset]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1,
    };
    for (e_at, element) in header.elements.iter().enumerate() {
        if element.props.is_empty() {
            continue; // nothing to read, whatever the count
        }
        let vertex_out = (e_at == vertex_at).then_some((&mut out, targets.as_slice()));
        let face_out = faces.as_deref_mut().filter(|_| element.name == "face");
        if header.format != PlyFormat::Ascii && element.props.iter().all(|p| p.list.is_none()) {
            read_records(&mut src, element, vertex_out)?;
        } else {
            read_values(&mut src, element, vertex_out, face_out)?;
        }
    }
    Ok(out.into_cloud())
}

/// Where each vertex property goes; x, y and z must exist, and no known property may
/// be a list.
fn vertex_targets(vertex: &Element) -> Result<Vec<Target>, PlyError> {
    let targets: Vec<Target> = vertex.props.iter().map(|p| target_of(&p.name)).collect();
    for (p, t) in vertex.props.iter().zip(&targets) {
        if *t != Target::Skip && p.list.is_some() {
            return Err(PlyError::ListProperty {
                property: p.name.clone(),
            });
        }
    }
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        if !targets.contains(&Target::Pos(axis)) {
            return Err(PlyError::MissingProperty { property: name });
        }
    }
    Ok(targets)
}

/// Refuses a vertex count the body could not hold, before anything is allocated: each
/// vertex needs at least a few body bytes.
fn check_vertex_count(vertex: &Element, format: PlyFormat, available: u64) -> Result<(), PlyError> {
    let min_vertex_bytes: u64 = vertex
        .props
        .iter()
        .map(|p| match (format, p.list) {
            (PlyFormat::Ascii, _) => 2,
            (_, Some(c)) => c.size() as u64,
            (_, None) => p.ty.size() as u64,
        })
        .sum();
    if vertex.count.saturating_mul(min_vertex_bytes.max(1)) > available + 1 {
        return Err(PlyError::TooManyElements {
            element: vertex.name.clone(),
            count: vertex.count,
            available,
        });
    }
    Ok(())
}

/// Reads an element of fixed-size binary records, storing the vertex attributes when
/// `vertex_out` is given. PERF: the length is checked once, then decoded column by column.
fn read_records(
    src: &mut Source<'_>,
    element: &Element,
    vertex_out: Option<(&mut VertexColumns, &[Target])>,
) -> Result<(), PlyError> {
    let record: usize = element.props.iter().map(|p| p.ty.size()).sum();
    let whole = ((src.data.len() - src.pos) / record) as u64;
    if element.count > whole {
        return Err(PlyError::Truncated {
            element: element.name.clone(),
            index: whole,
        });
    }
    let len = element.count as usize * record;
    let records = &src.data[src.pos..src.pos + len];
    src.pos += len;
    if let Some((out, targets)) = vertex_out {
        let big = src.format == PlyFormat::BinaryBigEndian;
        let mut off = 0;
        for (p, &target) in element.props.iter().zip(targets) {
            let column = Column {
                records,
                record,
                offset: off,
                ty: p.ty,
                big_endian: big,
            };
            out.fill(target, &column);
            off += p.ty.size();
        }
    }
    Ok(())
}

/// Reads an element value by value (ASCII, or binary with list properties), storing
/// the vertex attributes when `vertex_out` is given.
fn read_values(
    src: &mut Source<'_>,
    element: &Element,
    mut vertex_out: Option<(&mut VertexColumns, &[Target])>,
    mut face_out: Option<&mut Vec<Vec<usize>>>,
) -> Result<(), PlyError> {
    for index in 0..element.count {
        src.start_entry();
        let fail = |f: ReadFail, ty: Scalar| match f {
            ReadFail::Eof => PlyError::Truncated {
                element: element.name.clone(),
                index,
            },
            ReadFail::LineEnd(line) => PlyError::MissingValues {
                line,
                element: element.name.clone(),
                index,
                properties: element.props.len(),
            },
            ReadFail::Bad(text) => PlyError::BadValue {
                element: element.name.clone(),
                index,
                text,
                ty: ty.name(),
            },
        };
        for (k, p) in element.props.iter().enumerate() {
            if let Some(count_ty) = p.list {
                let count = src.read(count_ty).map_err(|f| fail(f, count_ty))?;
                if count < 0.0 || count.fract() != 0.0 {
                    return Err(PlyError::BadListCount {
                        element: element.name.clone(),
                        index,
                        count,
                    });
                }
                let corners = matches!(p.name.as_str(), "vertex_indices" | "vertex_index");
                let mut face = Vec::new();
                // Each item consumes at least one byte, so a lying count ends in Eof.
                for _ in 0..count as u64 {
                    let v = src.read(p.ty).map_err(|f| fail(f, p.ty))?;
                    if corners && face_out.is_some() {
                        face.push(v);
                    }
                }
                if let Some(out) = face_out.as_mut().filter(|_| corners) {
                    if let Some(&value) = face.iter().find(|&&v| !(v >= 0.0 && v.fract() == 0.0)) {
                        return Err(PlyError::BadFaceCorner { index, value });
                    }
                    out.push(face.into_iter().map(|v| v as usize).collect());
                }
                continue;
            }
            let v = src.read(p.ty).map_err(|f| fail(f, p.ty))?;
            if let Some((out, targets)) = vertex_out.as_mut() {
                out.set(index as usize, targets[k], v, p.ty);
            }
        }
        if let Some(line) = src.extra_on_line() {
            return Err(PlyError::ExtraValues {
                line,
                element: element.name.clone(),
                index,
                properties: element.props.len(),
            });
        }
    }
    Ok(())
}

/// Reads a PLY file.
pub fn read_ply(path: &Path) -> Result<PointCloud, IoError> {
    let bytes = super::read_bytes(path)?;
    parse_ply(&bytes).map_err(|source| match source {
        PlyError::TooLarge(source) => IoError::TooLarge {
            path: path.to_path_buf(),
            source,
        },
        source => IoError::Ply {
            path: path.to_path_buf(),
            source,
        },
    })
}

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

use super::{Encoding, IoError};
use crate::cloud::PointCloud;
use std::path::Path;
use thiserror::Error;

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

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        use Scalar::*;
        Some(match name {
            "char" | "int8" => I8,
            "uchar" | "uint8" => U8,
            "short" | "int16" => I16,
            "ushort" | "uint16" => U16,
            "int" | "int32" => I32,
            "uint" | "uint32" => U32,
            "float" | "float32" => F32,
            "double" | "float64" => F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        use Scalar::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            F64 => 8,
        }
    }

    fn name(self) -> &'static str {
        use Scalar::*;
        match self {
            I8 => "char",
            U8 => "uchar",
            I16 => "short",
            U16 => "ushort",
            I32 => "int",
            U32 => "uint",
            F32 => "float",
            F64 => "double",
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
struct Property {
    name: String,
    /// `Some(count type)` for a list property.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

struct Header {
    format: PlyFormat,
    elements: Vec<Element>,
    body_offset: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, PlyError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(if line_no == 0 {
                PlyError::NotPly
            } else {
                PlyError::NoEndHeader
            });
        }
        line_no += 1;
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |k| pos + k);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(if line_no == 1 {
                PlyError::NotPly
            } else {
                PlyError::NotUtf8 { line: line_no }
            });
        };
        let line = line.trim();
        if line_no == 1 {
            if line != "ply" {
                return Err(PlyError::NotPly);
            }
            continue;
        }
        let bad = |reason: &str| PlyError::BadHeaderLine {
            line: line_no,
            reason: reason.to_string(),
        };
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [] => {}
            ["comment" | "obj_info", ..] => {}
            ["end_header"] => break,
            ["format", f, ..] => {
                format = Some(match *f {
                    "ascii" => PlyFormat::Ascii,
                    "binary_little_endian" => PlyFormat::BinaryLittleEndian,
                    "binary_big_endian" => PlyFormat::BinaryBigEndian,
                    other => {
                        return Err(PlyError::UnknownFormat {
                            format: other.chars().take(40).collect(),
                        })
                    }
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| bad("element count is not a non-negative integer"))?,
                props: Vec::new(),
            }),
            ["property", "list", count_ty, ty, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                let list = Scalar::parse(count_ty).ok_or_else(|| bad("unknown list count type"))?;
                if list.is_float() {
                    return Err(bad("list count type must be an integer"));
                }
                element.props.push(Property {
                    name: name.to_string(),
                    list: Some(list),
                    ty: Scalar::parse(ty).ok_or_else(|| bad("unknown property type"))?,
                });
            }
            ["property", ty, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                element.props.push(Property {
                    name: name.to_string(),
                    list: None,
                    ty: Scalar::parse(ty).ok_or_else(|| bad("unknown property type"))?,
                });
            }
            _ => return Err(bad("not a PLY header line")),
        }
    }
    let format = format.ok_or(PlyError::UnknownFormat {
        format: "(no format line)".into(),
    })?;
    Ok(Header {
        format,
        elements,
        body_offset: pos,
    })
}

/// Why a value could not be read.
enum ReadFail {
    Eof,
    Bad(String),
}

/// The body, read value by value.
struct Source<'a> {
    data: &'a [u8],
    pos: usize,
    format: PlyFormat,
}

impl Source<'_> {
    fn read(&mut self, ty: Scalar) -> Result<f64, ReadFail> {
        if self.format == PlyFormat::Ascii {
            return self.read_text(ty);
        }
        let size = ty.size();
        let b = self
            .data
            .get(self.pos..self.pos + size)
            .ok_or(ReadFail::Eof)?;
        self.pos += size;
        let mut a = [0u8; 8];
        a[..size].copy_from_slice(b);
        if self.format == PlyFormat::BinaryBigEndian {
            a[..size].reverse();
        }
        use Scalar::*;
        Ok(match ty {
            I8 => f64::from(a[0] as i8),
            U8 => f64::from(a[0]),
            I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            F64 => f64::from_le_bytes(a),
        })
    }

    fn read_text(&mut self, ty: Scalar) -> Result<f64, ReadFail> {
        let rest = &self.data[self.pos..];
        let start = rest
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .ok_or(ReadFail::Eof)?;
        let len = rest[start..]
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(rest.len() - start);
        let token = &rest[start..start + len];
        self.pos += start + len;
        let fail = || ReadFail::Bad(String::from_utf8_lossy(token).chars().take(40).collect());
        let text = std::str::from_utf8(token).map_err(|_| fail())?;
        let value = match ty {
            // Parse float directly as f32 so the value is not rounded twice.
            Scalar::F32 => text.parse::<f32>().map(f64::from).map_err(|_| fail())?,
            Scalar::F64 => text.parse::<f64>().map_err(|_| fail())?,
            _ => {
                let v = text.parse::<i64>().map_err(|_| fail())?;
                let (lo, hi) = match ty {
                    Scalar::I8 => (i8::MIN.into(), i8::MAX.into()),
                    Scalar::U8 => (0, u8::MAX.into()),
                    Scalar::I16 => (i16::MIN.into(), i16::MAX.into()),
                    Scalar::U16 => (0, u16::MAX.into()),
                    Scalar::I32 => (i32::MIN.into(), i32::MAX.into()),
                    _ => (0, u32::MAX.into()),
                };
                if !(lo..=hi).contains(&v) {
                    return Err(fail());
                }
                v as f64
            }
        };
        Ok(value)
    }
}

/// Where a vertex property goes.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    Pos(usize),
    Normal(usize),
    Color(usize),
    Alpha,
    Curvature,
    Label,
    Skip,
}

fn target_of(name: &str) -> Target {
    match name {
        "x" => Target::Pos(0),
        "y" => Target::Pos(1),
        "z" => Target::Pos(2),
        "nx" => Target::Normal(0),
        "ny" => Target::Normal(1),
        "nz" => Target::Normal(2),
        "red" => Target::Color(0),
        "green" => Target::Color(1),
        "blue" => Target::Color(2),
        "alpha" => Target::Alpha,
        "curvature" => Target::Curvature,
        "label" => Target::Label,
        _ => Target::Skip,
    }
}

/// A colour channel: integers are clamped to `0..=255`, floats are taken as `0..=1`.
fn channel(v: f64, ty: Scalar) -> u8 {
    let v = if ty.is_float() { v * 255.0 } else { v };
    if v.is_nan() {
        0
    } else {
        v.round().clamp(0.0, 255.0) as u8
    }
}

/// Parses a whole PLY file held in memory.
pub fn parse_ply(bytes: &[u8]) -> Result<PointCloud, PlyError> {
    let header = parse_header(bytes)?;
    let vertex_at = header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or(PlyError::NoVertexElement)?;
    let vertex = &header.elements[vertex_at];
    let targets: Vec<Target> = vertex.props.iter().map(|p| target_of(&p.name)).collect();
    for (p, t) in vertex.props.iter().zip(&targets) {
        if *t != Target::Skip && p.list.is_some() {
            return Err(PlyError::ListProperty {
                property: p.name.clone(),
            });
        }
    }
    let has = |t: Target| targets.contains(&t);
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        if !has(Target::Pos(axis)) {
            return Err(PlyError::MissingProperty { property: name });
        }
    }
    let body = &bytes[header.body_offset..];
    let available = body.len() as u64;
    // Each vertex needs at least this many body bytes: bound the count before allocating.
    let min_vertex_bytes: u64 = vertex
        .props
        .iter()
        .map(|p| match (header.format, p.list) {
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
    let n = vertex.count as usize; // bounded by the body length above
    let mut cloud = PointCloud::from_positions(vec![[0.0; 3]; n]);
    let normals_present = (0..3).all(|a| has(Target::Normal(a)));
    let colors_present = (0..3).all(|a| has(Target::Color(a)));
    let mut normals = vec![[0f32; 3]; if normals_present { n } else { 0 }];
    let mut colors = vec![[0u8; 3]; if colors_present { n } else { 0 }];
    let mut alpha = vec![0u8; if has(Target::Alpha) { n } else { 0 }];
    let mut curvature = vec![0f32; if has(Target::Curvature) { n } else { 0 }];
    let mut labels = vec![0u32; if has(Target::Label) { n } else { 0 }];

    let mut src = Source {
        data: body,
        pos: 0,
        format: header.format,
    };
    for (e_at, element) in header.elements.iter().enumerate() {
        if element.props.is_empty() {
            continue; // nothing to read, whatever the count
        }
        for index in 0..element.count {
            let fail = |f: ReadFail, ty: Scalar| match f {
                ReadFail::Eof => PlyError::Truncated {
                    element: element.name.clone(),
                    index,
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
                    // Each item consumes at least one byte, so a lying count ends in Eof.
                    for _ in 0..count as u64 {
                        src.read(p.ty).map_err(|f| fail(f, p.ty))?;
                    }
                    continue;
                }
                let v = src.read(p.ty).map_err(|f| fail(f, p.ty))?;
                if e_at != vertex_at {
                    continue;
                }
                let i = index as usize;
                match targets[k] {
                    Target::Pos(a) => cloud.positions[i][a] = v as f32,
                    Target::Normal(a) if normals_present => normals[i][a] = v as f32,
                    Target::Color(a) if colors_present => colors[i][a] = channel(v, p.ty),
                    Target::Alpha => alpha[i] = channel(v, p.ty),
                    Target::Curvature => curvature[i] = v as f32,
                    Target::Label => labels[i] = v as u32,
                    _ => {}
                }
            }
        }
    }
    cloud.normals = normals_present.then_some(normals);
    cloud.colors = colors_present.then_some(colors);
    cloud.alpha = has(Target::Alpha).then_some(alpha);
    cloud.curvature = has(Target::Curvature).then_some(curvature);
    cloud.labels = has(Target::Label).then_some(labels);
    Ok(cloud)
}

/// Reads a PLY file.
pub fn read_ply(path: &Path) -> Result<PointCloud, IoError> {
    let bytes = super::read_bytes(path)?;
    parse_ply(&bytes).map_err(|source| IoError::Ply {
        path: path.to_path_buf(),
        source,
    })
}

/// Encodes a cloud as PLY bytes: ASCII for [`Encoding::Ascii`], otherwise
/// `binary_little_endian` (PLY has no compressed encoding).
pub fn to_ply_bytes(cloud: &PointCloud, encoding: Encoding) -> Vec<u8> {
    let format = match encoding {
        Encoding::Ascii => PlyFormat::Ascii,
        Encoding::Binary | Encoding::BinaryCompressed => PlyFormat::BinaryLittleEndian,
    };
    to_ply_bytes_with(cloud, format)
}

/// One written vertex value.
#[derive(Clone, Copy)]
enum Value {
    F(f32),
    U8(u8),
    U32(u32),
}

/// Encodes a cloud as PLY bytes in the given format.
///
/// Panics if an attribute column's length differs from the point count.
pub fn to_ply_bytes_with(cloud: &PointCloud, format: PlyFormat) -> Vec<u8> {
    use std::fmt::Write;
    if let Err(e @ crate::cloud::CloudError::LengthMismatch { .. }) = cloud.validate() {
        panic!("to_ply_bytes: inconsistent cloud: {e}");
    }
    let n = cloud.len();
    let mut props: Vec<(&str, &str)> = vec![("float", "x"), ("float", "y"), ("float", "z")];
    if cloud.normals.is_some() {
        props.extend([("float", "nx"), ("float", "ny"), ("float", "nz")]);
    }
    if cloud.colors.is_some() {
        props.extend([("uchar", "red"), ("uchar", "green"), ("uchar", "blue")]);
    }
    if cloud.alpha.is_some() {
        props.push(("uchar", "alpha"));
    }
    if cloud.curvature.is_some() {
        props.push(("float", "curvature"));
    }
    if cloud.labels.is_some() {
        props.push(("uint", "label"));
    }
    let format_name = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::BinaryLittleEndian => "binary_little_endian",
        PlyFormat::BinaryBigEndian => "binary_big_endian",
    };
    let mut text = format!(
        "ply\nformat {format_name} 1.0\ncomment Created by softsense\nelement vertex {n}\n"
    );
    for (ty, name) in &props {
        let _ = writeln!(text, "property {ty} {name}");
    }
    text.push_str("end_header\n");
    let mut values = Vec::with_capacity(props.len());
    let mut out = Vec::new();
    for i in 0..n {
        values.clear();
        values.extend(cloud.positions[i].map(Value::F));
        if let Some(nm) = &cloud.normals {
            values.extend(nm[i].map(Value::F));
        }
        if let Some(c) = &cloud.colors {
            values.extend(c[i].map(Value::U8));
        }
        if let Some(a) = &cloud.alpha {
            values.push(Value::U8(a[i]));
        }
        if let Some(c) = &cloud.curvature {
            values.push(Value::F(c[i]));
        }
        if let Some(l) = &cloud.labels {
            values.push(Value::U32(l[i]));
        }
        for (k, v) in values.iter().enumerate() {
            match format {
                PlyFormat::Ascii => {
                    if k > 0 {
                        text.push(' ');
                    }
                    match *v {
                        Value::F(f) => super::pcd::format_f32(&mut text, f),
                        Value::U8(b) => {
                            let _ = write!(text, "{b}");
                        }
                        Value::U32(b) => {
                            let _ = write!(text, "{b}");
                        }
                    }
                }
                PlyFormat::BinaryLittleEndian => match *v {
                    Value::F(f) => out.extend_from_slice(&f.to_le_bytes()),
                    Value::U8(b) => out.push(b),
                    Value::U32(b) => out.extend_from_slice(&b.to_le_bytes()),
                },
                PlyFormat::BinaryBigEndian => match *v {
                    Value::F(f) => out.extend_from_slice(&f.to_be_bytes()),
                    Value::U8(b) => out.push(b),
                    Value::U32(b) => out.extend_from_slice(&b.to_be_bytes()),
                },
            }
        }
        if format == PlyFormat::Ascii {
            text.push('\n');
        }
    }
    let mut bytes = text.into_bytes();
    bytes.extend_from_slice(&out);
    bytes
}

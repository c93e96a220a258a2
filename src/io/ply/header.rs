//! The PLY header: the format line and the elements with their properties.

use super::{PlyError, PlyFormat};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Scalar {
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
    pub(super) fn parse(name: &str) -> Option<Scalar> {
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

    pub(super) fn size(self) -> usize {
        use Scalar::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            F64 => 8,
        }
    }

    pub(super) fn name(self) -> &'static str {
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

    pub(super) fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
pub(super) struct Property {
    pub(super) name: String,
    /// `Some(count type)` for a list property.
    pub(super) list: Option<Scalar>,
    pub(super) ty: Scalar,
}

#[derive(Debug, Clone)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) props: Vec<Property>,
}

pub(super) struct Header {
    pub(super) format: PlyFormat,
    pub(super) elements: Vec<Element>,
    /// Where the body starts in the file's bytes.
    pub(super) body_offset: usize,
}

/// Parses the header at the start of `bytes`.
pub(super) fn parse_header(bytes: &[u8]) -> Result<Header, PlyError> {
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

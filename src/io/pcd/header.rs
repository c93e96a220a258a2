//! The PCD header: `FIELDS`, `SIZE`, `TYPE`, `COUNT`, `WIDTH`, `HEIGHT`, `VIEWPOINT`,
//! `POINTS`, `DATA`, one keyword a line, `#` comments.

use super::PcdError;
use crate::cloud::Viewpoint;
use std::fmt;

/// Largest accepted point record, bytes (PCL's largest point types are a few kB).
pub const MAX_RECORD_SIZE: u64 = 1 << 20;

/// The scalar type of one PCD field value (`TYPE` letter plus `SIZE` in bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarType {
    /// `TYPE I SIZE 1`.
    I8,
    /// `TYPE I SIZE 2`.
    I16,
    /// `TYPE I SIZE 4`.
    I32,
    /// `TYPE I SIZE 8`.
    I64,
    /// `TYPE U SIZE 1`.
    U8,
    /// `TYPE U SIZE 2`.
    U16,
    /// `TYPE U SIZE 4`.
    U32,
    /// `TYPE U SIZE 8`.
    U64,
    /// `TYPE F SIZE 4`.
    F32,
    /// `TYPE F SIZE 8`.
    F64,
}

impl ScalarType {
    /// The type for a `TYPE` letter and a `SIZE`, if PCD defines it.
    pub fn from_type_size(ty: &str, size: usize) -> Option<ScalarType> {
        use ScalarType::*;
        Some(match (ty, size) {
            ("I", 1) => I8,
            ("I", 2) => I16,
            ("I", 4) => I32,
            ("I", 8) => I64,
            ("U", 1) => U8,
            ("U", 2) => U16,
            ("U", 4) => U32,
            ("U", 8) => U64,
            ("F", 4) => F32,
            ("F", 8) => F64,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub fn size(self) -> usize {
        use ScalarType::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            I64 | U64 | F64 => 8,
        }
    }

    /// The `TYPE` letter: `I`, `U` or `F`.
    pub fn letter(self) -> char {
        use ScalarType::*;
        match self {
            I8 | I16 | I32 | I64 => 'I',
            U8 | U16 | U32 | U64 => 'U',
            F32 | F64 => 'F',
        }
    }

    /// True for `F`.
    pub fn is_float(self) -> bool {
        self.letter() == 'F'
    }
}

impl fmt::Display for ScalarType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.letter(), self.size())
    }
}

/// One field of a PCD file as its header declares it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PcdField {
    /// Field name (`x`, `rgb`, `normal_x`, `_`, `fpfh`, ...).
    pub name: String,
    /// Scalar type of each value.
    pub ty: ScalarType,
    /// Values per point (`COUNT`, at least 1).
    pub count: usize,
}

impl PcdField {
    /// Bytes this field takes per point.
    pub fn byte_len(&self) -> usize {
        self.ty.size() * self.count
    }

    /// True for PCL's `_` padding fields.
    pub fn is_padding(&self) -> bool {
        self.name == "_"
    }
}

/// The body encoding named by the `DATA` line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataEncoding {
    /// Text, one point a line.
    Ascii,
    /// Packed records, one per point.
    Binary,
    /// LZF-compressed, field-columnar.
    BinaryCompressed,
}

impl DataEncoding {
    /// The keyword on the `DATA` line.
    pub fn keyword(self) -> &'static str {
        match self {
            DataEncoding::Ascii => "ascii",
            DataEncoding::Binary => "binary",
            DataEncoding::BinaryCompressed => "binary_compressed",
        }
    }
}

/// A parsed PCD header.
#[derive(Debug, Clone, PartialEq)]
pub struct PcdHeader {
    /// The `VERSION` value, if the line is present (`0.7`, `.5`, ...).
    pub version: Option<String>,
    /// Every declared field in file order, unknown ones included.
    pub fields: Vec<PcdField>,
    /// Organized width (or the point count of an unorganized cloud).
    pub width: u32,
    /// Organized height (1 when unorganized or when the line is missing).
    pub height: u32,
    /// Declared number of points (`WIDTH * HEIGHT`).
    pub points: u64,
    /// Sensor pose (`VIEWPOINT tx ty tz qw qx qy qz`).
    pub viewpoint: Viewpoint,
    /// Body encoding.
    pub encoding: DataEncoding,
    /// Byte offset of the body (just past the `DATA` line).
    pub data_offset: usize,
}

impl PcdHeader {
    /// Bytes per point record (sum of the fields' sizes times counts).
    pub fn record_size(&self) -> usize {
        self.fields.iter().map(PcdField::byte_len).sum()
    }

    /// Bytes per point in a `binary_compressed` body, which (as PCL reads and writes
    /// it) has no columns for `_` padding fields.
    pub fn columnar_record_size(&self) -> usize {
        self.fields
            .iter()
            .filter(|f| !f.is_padding())
            .map(PcdField::byte_len)
            .sum()
    }

    /// Index of the field named `name`.
    pub fn field_index(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }

    /// Parses the header at the start of `bytes` (the body may follow or be absent).
    pub fn parse(bytes: &[u8]) -> Result<PcdHeader, PcdError> {
        if bytes.is_empty() {
            return Err(PcdError::Empty);
        }
        let mut raw = RawHeader::default();
        let mut pos = 0;
        let mut line_no = 0;
        loop {
            if pos >= bytes.len() {
                return Err(PcdError::MissingKey { key: "DATA" });
            }
            line_no += 1;
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |k| pos + k);
            let line = std::str::from_utf8(&bytes[pos..end])
                .map_err(|_| PcdError::NotUtf8 { line: line_no })?;
            pos = (end + 1).min(bytes.len());
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let mut words = line.split_whitespace();
            let key = words.next().unwrap_or_default();
            let values: Vec<&str> = words.collect();
            if key == "DATA" {
                let encoding = match values.first().copied() {
                    Some("ascii") => DataEncoding::Ascii,
                    Some("binary") => DataEncoding::Binary,
                    Some("binary_compressed") => DataEncoding::BinaryCompressed,
                    other => {
                        return Err(PcdError::UnknownData {
                            kind: other.unwrap_or_default().to_string(),
                        })
                    }
                };
                return raw.finish(encoding, pos);
            }
            raw.take_line(key, &values, line_no)?;
        }
    }
}

/// Header lines collected before they can be checked against each other.
#[derive(Default)]
struct RawHeader {
    version: Option<String>,
    fields: Option<Vec<String>>,
    sizes: Option<Vec<usize>>,
    types: Option<Vec<String>>,
    counts: Option<Vec<usize>>,
    width: Option<u32>,
    height: Option<u32>,
    points: Option<u64>,
    viewpoint: Option<Viewpoint>,
}

fn number<T: std::str::FromStr>(
    key: &'static str,
    value: &str,
    line: usize,
) -> Result<T, PcdError> {
    value.parse().map_err(|_| PcdError::BadValue {
        line,
        key,
        value: value.to_string(),
    })
}

fn single<'a>(key: &'static str, values: &[&'a str], line: usize) -> Result<&'a str, PcdError> {
    match values {
        [v] => Ok(v),
        _ => Err(PcdError::BadValue {
            line,
            key,
            value: values.join(" "),
        }),
    }
}

impl RawHeader {
    fn take_line(&mut self, key: &str, values: &[&str], line: usize) -> Result<(), PcdError> {
        let list = |key: &'static str| -> Result<Vec<usize>, PcdError> {
            values.iter().map(|v| number(key, v, line)).collect()
        };
        match key {
            "VERSION" => self.version = Some(values.join(" ")),
            "FIELDS" | "COLUMNS" => {
                self.fields = Some(values.iter().map(|s| s.to_string()).collect())
            }
            "SIZE" => self.sizes = Some(list("SIZE")?),
            "TYPE" => self.types = Some(values.iter().map(|s| s.to_string()).collect()),
            "COUNT" => self.counts = Some(list("COUNT")?),
            "WIDTH" => self.width = Some(number("WIDTH", single("WIDTH", values, line)?, line)?),
            "HEIGHT" => {
                self.height = Some(number("HEIGHT", single("HEIGHT", values, line)?, line)?)
            }
            "POINTS" => {
                self.points = Some(number("POINTS", single("POINTS", values, line)?, line)?)
            }
            "VIEWPOINT" => {
                let v: Vec<f32> = values
                    .iter()
                    .map(|v| number("VIEWPOINT", v, line))
                    .collect::<Result<_, _>>()?;
                let [tx, ty, tz, qw, qx, qy, qz] = v[..] else {
                    return Err(PcdError::BadValue {
                        line,
                        key: "VIEWPOINT",
                        value: values.join(" "),
                    });
                };
                self.viewpoint = Some(Viewpoint {
                    origin: [tx, ty, tz],
                    orientation: [qw, qx, qy, qz],
                });
            }
            other => {
                return Err(PcdError::UnknownKeyword {
                    line,
                    keyword: other.chars().take(40).collect(),
                })
            }
        }
        Ok(())
    }

    fn finish(self, encoding: DataEncoding, data_offset: usize) -> Result<PcdHeader, PcdError> {
        let names = self.fields.ok_or(PcdError::MissingKey { key: "FIELDS" })?;
        let sizes = self.sizes.ok_or(PcdError::MissingKey { key: "SIZE" })?;
        let types = self.types.ok_or(PcdError::MissingKey { key: "TYPE" })?;
        // Old (0.6-ish) files may omit COUNT: one value per field.
        let counts = self.counts.unwrap_or_else(|| vec![1; names.len()]);
        for (key, got) in [
            ("SIZE", sizes.len()),
            ("TYPE", types.len()),
            ("COUNT", counts.len()),
        ] {
            if got != names.len() {
                return Err(PcdError::ListLength {
                    key,
                    got,
                    expected: names.len(),
                });
            }
        }
        let mut fields = Vec::with_capacity(names.len());
        for (((name, size), ty), count) in names.into_iter().zip(sizes).zip(types).zip(counts) {
            let Some(scalar) = ScalarType::from_type_size(&ty, size) else {
                return Err(PcdError::BadType {
                    field: name,
                    ty,
                    size,
                });
            };
            if count == 0 {
                return Err(PcdError::ZeroCount { field: name });
            }
            if name != "_" && fields.iter().any(|f: &PcdField| f.name == name) {
                return Err(PcdError::DuplicateField { field: name });
            }
            fields.push(PcdField {
                name,
                ty: scalar,
                count,
            });
        }
        // Bound the record size so that later per-point arithmetic cannot overflow.
        let record = fields.iter().try_fold(0u64, |acc, f| {
            (f.count as u64)
                .checked_mul(f.ty.size() as u64)
                .and_then(|b| acc.checked_add(b))
        });
        match record {
            Some(r) if r <= MAX_RECORD_SIZE => {}
            _ => {
                return Err(PcdError::RecordTooLarge {
                    max: MAX_RECORD_SIZE,
                })
            }
        }
        let width = self.width.ok_or(PcdError::MissingKey { key: "WIDTH" })?;
        let height = self.height.unwrap_or(1);
        // HEIGHT 0 would make WIDTH x HEIGHT zero whatever the body holds, so every row
        // would be dropped without a word.
        if height == 0 {
            return Err(PcdError::ZeroHeight { width });
        }
        let organized = u64::from(width) * u64::from(height);
        let points = self.points.unwrap_or(organized);
        if points != organized {
            return Err(PcdError::PointsMismatch {
                width,
                height,
                points,
            });
        }
        Ok(PcdHeader {
            version: self.version,
            fields,
            width,
            height,
            points,
            viewpoint: self.viewpoint.unwrap_or_default(),
            encoding,
            data_offset,
        })
    }
}

//! The PLY body: values read one by one (ASCII, or binary with lists) or column by
//! column (fixed-size binary records), stored into the vertex attributes.

use super::header::Scalar;
use super::PlyFormat;
use crate::cloud::PointCloud;

/// The value of `ty` at the start of `b` (which holds at least `ty.size()` bytes).
fn binary_value(b: &[u8], ty: Scalar, big_endian: bool) -> f64 {
    let size = ty.size();
    let mut a = [0u8; 8];
    a[..size].copy_from_slice(&b[..size]);
    if big_endian {
        a[..size].reverse();
    }
    use Scalar::*;
    match ty {
        I8 => f64::from(a[0] as i8),
        U8 => f64::from(a[0]),
        I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
        U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
        I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
        U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
        F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
        F64 => f64::from_le_bytes(a),
    }
}

/// Why a value could not be read.
pub(super) enum ReadFail {
    Eof,
    /// An ASCII entry's line ended early (1-based file line).
    LineEnd(usize),
    Bad(String),
}

/// The body, read value by value.
pub(super) struct Source<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
    pub(super) format: PlyFormat,
    /// The file line the body starts on (1-based), for ASCII error messages.
    pub(super) first_line: usize,
}

/// Blanks within an ASCII line (the line end, `\n`, is not one).
fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\r' || b == 0x0c || b == 0x0b
}

impl Source<'_> {
    /// ASCII: moves to the start of the next entry, past blank lines. Each entry is one
    /// line, so that a line with too many or too few values is caught, not spilled
    /// into the next entry.
    pub(super) fn start_entry(&mut self) {
        if self.format == PlyFormat::Ascii {
            let rest = &self.data[self.pos..];
            self.pos += rest
                .iter()
                .position(|b| !b.is_ascii_whitespace())
                .unwrap_or(rest.len());
        }
    }

    /// ASCII: the line number when values remain on the current line; moves past the
    /// line end otherwise.
    pub(super) fn extra_on_line(&mut self) -> Option<usize> {
        if self.format != PlyFormat::Ascii {
            return None;
        }
        let rest = &self.data[self.pos..];
        let blanks = rest
            .iter()
            .position(|&b| !is_blank(b))
            .unwrap_or(rest.len());
        match rest.get(blanks) {
            None | Some(b'\n') => {
                self.pos += blanks;
                None
            }
            Some(_) => Some(self.line_at(self.pos)),
        }
    }

    /// The 1-based file line holding body offset `pos`.
    fn line_at(&self, pos: usize) -> usize {
        self.first_line + self.data[..pos].iter().filter(|&&b| b == b'\n').count()
    }

    pub(super) fn read(&mut self, ty: Scalar) -> Result<f64, ReadFail> {
        if self.format == PlyFormat::Ascii {
            return self.read_text(ty);
        }
        let size = ty.size();
        let b = self
            .data
            .get(self.pos..self.pos + size)
            .ok_or(ReadFail::Eof)?;
        self.pos += size;
        Ok(binary_value(
            b,
            ty,
            self.format == PlyFormat::BinaryBigEndian,
        ))
    }

    fn read_text(&mut self, ty: Scalar) -> Result<f64, ReadFail> {
        let rest = &self.data[self.pos..];
        let start = rest
            .iter()
            .position(|&b| !is_blank(b))
            .ok_or(ReadFail::Eof)?;
        if rest[start] == b'\n' {
            return Err(ReadFail::LineEnd(self.line_at(self.pos)));
        }
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
pub(super) enum Target {
    Pos(usize),
    Normal(usize),
    Color(usize),
    Alpha,
    Curvature,
    Label,
    Skip,
}

/// The attribute a vertex property named `name` fills.
pub(super) fn target_of(name: &str) -> Target {
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

/// One property of fixed-size binary records.
pub(super) struct Column<'a> {
    pub(super) records: &'a [u8],
    pub(super) record: usize,
    pub(super) offset: usize,
    pub(super) ty: Scalar,
    pub(super) big_endian: bool,
}

impl Column<'_> {
    /// Calls `store(i, value)` for every record. PERF: the type is matched once per
    /// column, with fast paths for the common little-endian `float` and `uchar`.
    fn for_each(&self, mut store: impl FnMut(usize, f64)) {
        let rows = self
            .records
            .chunks_exact(self.record)
            .map(|r| &r[self.offset..]);
        match (self.ty, self.big_endian) {
            (Scalar::F32, false) => rows.enumerate().for_each(|(i, b)| {
                store(i, f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
            }),
            (Scalar::U8, _) => rows
                .enumerate()
                .for_each(|(i, b)| store(i, f64::from(b[0]))),
            (ty, big) => rows
                .enumerate()
                .for_each(|(i, b)| store(i, binary_value(b, ty, big))),
        }
    }
}

/// The vertex attributes being filled; a column exists when its properties do.
pub(super) struct VertexColumns {
    cloud: PointCloud,
    normals: Option<Vec<[f32; 3]>>,
    colors: Option<Vec<[u8; 3]>>,
    alpha: Option<Vec<u8>>,
    curvature: Option<Vec<f32>>,
    labels: Option<Vec<u32>>,
}

impl VertexColumns {
    pub(super) fn new(n: usize, targets: &[Target]) -> VertexColumns {
        let has = |t: Target| targets.contains(&t);
        let all3 = |f: fn(usize) -> Target| (0..3).all(|a| has(f(a)));
        VertexColumns {
            cloud: PointCloud::from_positions(vec![[0.0; 3]; n]),
            normals: all3(Target::Normal).then(|| vec![[0.0; 3]; n]),
            colors: all3(Target::Color).then(|| vec![[0; 3]; n]),
            alpha: has(Target::Alpha).then(|| vec![0; n]),
            curvature: has(Target::Curvature).then(|| vec![0.0; n]),
            labels: has(Target::Label).then(|| vec![0; n]),
        }
    }

    /// Stores value `v` (of PLY type `ty`) of vertex `i` where `target` says.
    #[inline]
    pub(super) fn set(&mut self, i: usize, target: Target, v: f64, ty: Scalar) {
        match target {
            Target::Pos(a) => self.cloud.positions[i][a] = v as f32,
            Target::Normal(a) => {
                if let Some(nm) = &mut self.normals {
                    nm[i][a] = v as f32;
                }
            }
            Target::Color(a) => {
                if let Some(c) = &mut self.colors {
                    c[i][a] = channel(v, ty);
                }
            }
            Target::Alpha => {
                if let Some(al) = &mut self.alpha {
                    al[i] = channel(v, ty);
                }
            }
            Target::Curvature => {
                if let Some(c) = &mut self.curvature {
                    c[i] = v as f32;
                }
            }
            Target::Label => {
                if let Some(l) = &mut self.labels {
                    l[i] = v as u32;
                }
            }
            Target::Skip => {}
        }
    }

    /// Stores a whole column of fixed-size binary records where `target` says.
    pub(super) fn fill(&mut self, target: Target, col: &Column<'_>) {
        let ty = col.ty;
        match target {
            Target::Pos(a) => {
                let pos = &mut self.cloud.positions;
                col.for_each(|i, v| pos[i][a] = v as f32);
            }
            Target::Normal(a) => {
                if let Some(nm) = &mut self.normals {
                    col.for_each(|i, v| nm[i][a] = v as f32);
                }
            }
            Target::Color(a) => {
                if let Some(c) = &mut self.colors {
                    col.for_each(|i, v| c[i][a] = channel(v, ty));
                }
            }
            Target::Alpha => {
                if let Some(al) = &mut self.alpha {
                    col.for_each(|i, v| al[i] = channel(v, ty));
                }
            }
            Target::Curvature => {
                if let Some(c) = &mut self.curvature {
                    col.for_each(|i, v| c[i] = v as f32);
                }
            }
            Target::Label => {
                if let Some(l) = &mut self.labels {
                    col.for_each(|i, v| l[i] = v as u32);
                }
            }
            Target::Skip => {}
        }
    }

    pub(super) fn into_cloud(self) -> PointCloud {
        PointCloud {
            normals: self.normals,
            colors: self.colors,
            alpha: self.alpha,
            curvature: self.curvature,
            labels: self.labels,
            ..self.cloud
        }
    }
}

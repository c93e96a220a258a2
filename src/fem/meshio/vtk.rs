//! VTK legacy UNSTRUCTURED_GRID, ASCII or BINARY, in either cell layout: 4.x (`CELLS n
//! size`, then each cell's node count and nodes) or 5.1 (`CELLS n_offsets
//! n_connectivity`, then `OFFSETS type` and `CONNECTIVITY type` arrays).
//!
//! Keywords are text in both encodings. In BINARY, an array's bytes are big-endian (as VTK
//! writes them) and start right after the newline that ends its keyword line, so nothing
//! between a keyword line and its data is skipped as whitespace. The 4.x cell data and the
//! cell types are 32-bit integers; the 5.1 arrays and the points name their type.

use super::{classify, parse_num, perr, to_index, MeshCells};
use crate::fem::mesh::TetMesh;
use crate::fem::{FemError, FemResult};

/// Parses a VTK legacy ASCII UNSTRUCTURED_GRID as a tetrahedral mesh (other cells: see
/// [`MeshCells::into_tet_mesh`]).
pub fn parse_vtk_legacy(text: &str) -> FemResult<TetMesh> {
    parse_vtk_cells(text.as_bytes())?.into_tet_mesh()
}

/// Parses a VTK legacy UNSTRUCTURED_GRID, ASCII or BINARY, keeping every cell kind
/// softsense uses.
pub fn parse_vtk_cells(bytes: &[u8]) -> FemResult<MeshCells> {
    let mut c = Cursor {
        b: bytes,
        pos: bytes.iter().take_while(|b| b.is_ascii_whitespace()).count(),
        binary: false,
    };
    c.line()?; // version
    c.line()?; // title
    let fmt = c.line()?.trim();
    c.binary = if fmt.eq_ignore_ascii_case("BINARY") {
        true
    } else if fmt.eq_ignore_ascii_case("ASCII") {
        false
    } else {
        return Err(FemError::Unsupported(format!(
            "VTK legacy encoding {fmt:?}"
        )));
    };
    let mut nodes: Option<Vec<[f64; 3]>> = None;
    let mut cells: Option<(Vec<usize>, Vec<i64>)> = None;
    let mut types: Option<Vec<i64>> = None;
    while let Some(kw) = c.word()? {
        match kw.to_ascii_uppercase().as_str() {
            "DATASET" => {
                let ds = c.word()?.unwrap_or("");
                if !ds.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                    return Err(FemError::Unsupported(format!("VTK dataset {ds:?}")));
                }
            }
            "POINTS" => nodes = Some(points(&mut c)?),
            "CELLS" => cells = Some(cell_arrays(&mut c)?),
            "CELL_TYPES" => {
                let n: usize = parse_num(c.word()?.unwrap_or(""), "CELL_TYPES count")?;
                c.data_start();
                types = Some(c.ints(n, Scalar::I32, "cell type")?);
            }
            "POINT_DATA" | "CELL_DATA" => break,
            _ => {}
        }
    }
    let nodes = nodes.ok_or_else(|| perr("no POINTS"))?;
    let (offsets, conn) = cells.ok_or_else(|| perr("no CELLS"))?;
    let types = types.ok_or_else(|| perr("no CELL_TYPES"))?;
    if types.len() + 1 != offsets.len() {
        return Err(perr(format!(
            "{} CELLS and {} CELL_TYPES",
            offsets.len() - 1,
            types.len()
        )));
    }
    classify(nodes, &offsets, &conn, &types)
}

/// The section after a `POINTS` keyword: count, data type, coordinates.
fn points(c: &mut Cursor<'_>) -> FemResult<Vec<[f64; 3]>> {
    let n: usize = parse_num(c.word()?.unwrap_or(""), "POINTS count")?;
    let ty = Scalar::from_name(c.word()?.unwrap_or(""))?;
    c.data_start();
    let n3 = n
        .checked_mul(3)
        .ok_or_else(|| perr(format!("POINTS {n} but the file is shorter")))?;
    let v = c.floats(n3, ty, "point coordinate")?;
    Ok(v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
}

/// The section after a `CELLS` keyword, in either layout, as `cells + 1` offsets into the
/// connectivity.
fn cell_arrays(c: &mut Cursor<'_>) -> FemResult<(Vec<usize>, Vec<i64>)> {
    let a: usize = parse_num(c.word()?.unwrap_or(""), "CELLS count")?;
    let b: usize = parse_num(c.word()?.unwrap_or(""), "CELLS size")?;
    c.data_start();
    if c.at_keyword("OFFSETS") {
        let offsets = typed_array(c, "OFFSETS", a)?;
        let conn = typed_array(c, "CONNECTIVITY", b)?;
        let offsets = (offsets.iter())
            .map(|&o| to_index(o, "offset"))
            .collect::<FemResult<Vec<_>>>()?;
        let ordered = offsets.windows(2).all(|w| w[0] <= w[1]);
        if offsets.first().is_some_and(|&o| o != 0) || !ordered {
            return Err(perr("CELLS OFFSETS do not start at 0 and ascend"));
        }
        if offsets.last().copied().unwrap_or(0) != conn.len() {
            return Err(perr(
                "CELLS OFFSETS do not end at the CONNECTIVITY's length",
            ));
        }
        let offsets = if offsets.is_empty() { vec![0] } else { offsets };
        return Ok((offsets, conn));
    }
    if a > b {
        return Err(perr(format!("CELLS {a} {b} but the file is shorter")));
    }
    let data = c.ints(b, Scalar::I32, "CELLS")?;
    let mut offsets = Vec::with_capacity(a + 1);
    let mut conn = Vec::with_capacity(b - a);
    offsets.push(0);
    let mut i = 0usize;
    for _ in 0..a {
        let k = to_index(*data.get(i).unwrap_or(&0), "CELLS node count")?;
        // Checked before anything is taken: a huge size is a broken file.
        let end = i.saturating_add(1).saturating_add(k);
        if end > data.len() {
            return Err(perr("CELLS data longer than declared"));
        }
        conn.extend_from_slice(&data[i + 1..end]);
        offsets.push(conn.len());
        i = end;
    }
    Ok((offsets, conn))
}

/// A 5.1 cell array: `NAME type`, then `n` integers.
fn typed_array(c: &mut Cursor<'_>, name: &str, n: usize) -> FemResult<Vec<i64>> {
    let kw = c.word()?.unwrap_or("");
    if !kw.eq_ignore_ascii_case(name) {
        return Err(perr(format!("CELLS: {name} expected, found {kw:?}")));
    }
    let ty = Scalar::from_name(c.word()?.unwrap_or(""))?;
    c.data_start();
    c.ints(n, ty, name)
}

/// A number type of a VTK legacy array.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    F32,
    F64,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
}

impl Scalar {
    /// The type of a VTK legacy type name (`vtkIdType` is written as 32 bits).
    fn from_name(name: &str) -> FemResult<Self> {
        Ok(match name.to_ascii_lowercase().as_str() {
            "float" | "vtktypefloat32" => Self::F32,
            "double" | "vtktypefloat64" => Self::F64,
            "char" | "vtktypeint8" => Self::I8,
            "unsigned_char" | "vtktypeuint8" => Self::U8,
            "short" | "vtktypeint16" => Self::I16,
            "unsigned_short" | "vtktypeuint16" => Self::U16,
            "int" | "vtkidtype" | "vtktypeint32" => Self::I32,
            "unsigned_int" | "vtktypeuint32" => Self::U32,
            "long" | "vtktypeint64" => Self::I64,
            "unsigned_long" | "vtktypeuint64" => Self::U64,
            _ => {
                return Err(FemError::Unsupported(format!(
                    "VTK legacy data type {name:?}"
                )))
            }
        })
    }

    /// Bytes per value.
    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::F32 | Self::I32 | Self::U32 => 4,
            Self::F64 | Self::I64 | Self::U64 => 8,
        }
    }

    /// A big-endian value of `self.size()` bytes as a float.
    fn to_f64(self, b: &[u8]) -> f64 {
        match self {
            Self::F32 => f32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Self::F64 => f64::from_be_bytes(b[..8].try_into().expect("8 bytes")),
            _ => self.to_i128(b) as f64,
        }
    }

    /// A big-endian integer value; `None` for a float type or beyond `i64`.
    fn to_i64(self, b: &[u8]) -> Option<i64> {
        match self {
            Self::F32 | Self::F64 => None,
            _ => i64::try_from(self.to_i128(b)).ok(),
        }
    }

    fn to_i128(self, b: &[u8]) -> i128 {
        match self {
            Self::I8 => b[0] as i8 as i128,
            Self::U8 => b[0] as i128,
            Self::I16 => i16::from_be_bytes([b[0], b[1]]) as i128,
            Self::U16 => u16::from_be_bytes([b[0], b[1]]) as i128,
            Self::I32 => i32::from_be_bytes([b[0], b[1], b[2], b[3]]) as i128,
            Self::U32 => u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as i128,
            Self::I64 => i64::from_be_bytes(b[..8].try_into().expect("8 bytes")) as i128,
            Self::U64 => u64::from_be_bytes(b[..8].try_into().expect("8 bytes")) as i128,
            Self::F32 | Self::F64 => 0,
        }
    }
}

/// A read position in a legacy file: text keywords, then text or binary arrays.
struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    binary: bool,
}

impl<'a> Cursor<'a> {
    fn rest(&self) -> &'a [u8] {
        &self.b[self.pos.min(self.b.len())..]
    }

    /// The next header line, without its line end.
    fn line(&mut self) -> FemResult<&'a str> {
        let rest = self.rest();
        let end = (rest.iter().position(|&b| b == b'\n'))
            .ok_or_else(|| perr("the VTK header ends early (three lines expected)"))?;
        self.pos += end + 1;
        let line = std::str::from_utf8(&rest[..end]).map_err(|_| perr("VTK header not text"))?;
        Ok(line.trim_end_matches('\r'))
    }

    /// The next whitespace-separated word; `None` at the end.
    fn word(&mut self) -> FemResult<Option<&'a str>> {
        let rest = self.rest();
        let start = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
        let len = (rest[start..].iter())
            .take_while(|b| !b.is_ascii_whitespace())
            .count();
        self.pos += start + len;
        if len == 0 {
            return Ok(None);
        }
        std::str::from_utf8(&rest[start..start + len])
            .map(Some)
            .map_err(|_| {
                perr(format!(
                    "binary bytes where a word was expected (byte {})",
                    self.pos - len
                ))
            })
    }

    /// Moves to an array's first byte: in BINARY, past the newline ending the keyword line.
    fn data_start(&mut self) {
        if self.binary {
            let rest = self.rest();
            self.pos += rest
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |i| i + 1);
        }
    }

    /// Whether the next word is `kw` (in BINARY, right at the read position).
    fn at_keyword(&self, kw: &str) -> bool {
        let mut rest = self.rest();
        if !self.binary {
            rest = &rest[rest.iter().take_while(|b| b.is_ascii_whitespace()).count()..];
        }
        rest.len() > kw.len()
            && rest[..kw.len()].eq_ignore_ascii_case(kw.as_bytes())
            && rest[kw.len()].is_ascii_whitespace()
    }

    fn floats(&mut self, n: usize, ty: Scalar, what: &str) -> FemResult<Vec<f64>> {
        self.values(n, ty, what, |t| parse_num(t, what), |b| Ok(ty.to_f64(b)))
    }

    fn ints(&mut self, n: usize, ty: Scalar, what: &str) -> FemResult<Vec<i64>> {
        let bin = |b: &[u8]| {
            ty.to_i64(b)
                .ok_or_else(|| perr(format!("{what}: {ty:?} is not an integer in range")))
        };
        self.values(n, ty, what, |t| parse_num(t, what), bin)
    }

    /// `n` values of type `ty`: words parsed by `text`, or bytes decoded by `bin`. The
    /// count is checked against what is left of the file before anything is allocated.
    fn values<T>(
        &mut self,
        n: usize,
        ty: Scalar,
        what: &str,
        text: impl Fn(&str) -> FemResult<T>,
        bin: impl Fn(&[u8]) -> FemResult<T>,
    ) -> FemResult<Vec<T>> {
        let left = self.rest().len();
        let short = || perr(format!("{n} {what} values but the file is shorter"));
        if self.binary {
            let need = (n.checked_mul(ty.size()))
                .filter(|&k| k <= left)
                .ok_or_else(short)?;
            let v = (self.rest()[..need].chunks_exact(ty.size()))
                .map(bin)
                .collect::<FemResult<Vec<_>>>()?;
            self.pos += need;
            return Ok(v);
        }
        // Each value takes a character and a separator, but the last.
        if n > left / 2 + 1 {
            return Err(short());
        }
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            v.push(text(self.word()?.ok_or_else(short)?)?);
        }
        Ok(v)
    }
}

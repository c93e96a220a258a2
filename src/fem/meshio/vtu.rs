//! VTK XML UnstructuredGrid (ASCII): the reader and the writer ParaView opens.

use super::{finish, parse_num, perr, to_index, VTK_TETRA};
use crate::fem::mesh::TetMesh;
use crate::fem::{FemError, FemResult};
use std::fmt::Write as _;
use std::path::Path;

/// One XML tag: name, attributes, whether it closes (`</x>`) or is self-closing.
struct Tag<'a> {
    name: &'a str,
    attrs: &'a str,
    closing: bool,
    self_closing: bool,
    end: usize,
}

fn next_tag(text: &str, from: usize) -> Option<(usize, Tag<'_>)> {
    let start = from + text[from..].find('<')?;
    let end = start + text[start..].find('>')?;
    let inner = &text[start + 1..end];
    let closing = inner.starts_with('/');
    let inner = inner.trim_start_matches('/');
    let self_closing = inner.ends_with('/');
    let inner = inner.trim_end_matches('/');
    let (name, attrs) = match inner.find(char::is_whitespace) {
        Some(i) => (&inner[..i], &inner[i..]),
        None => (inner, ""),
    };
    Some((
        start,
        Tag {
            name,
            attrs,
            closing,
            self_closing,
            end: end + 1,
        },
    ))
}

fn attr<'a>(attrs: &'a str, key: &str) -> Option<&'a str> {
    let mut rest = attrs;
    while let Some(i) = rest.find(key) {
        let before_ok = i == 0 || rest[..i].ends_with(char::is_whitespace);
        let after = rest[i + key.len()..].trim_start();
        if before_ok && after.starts_with('=') {
            let after = after[1..].trim_start();
            let q = after.chars().next()?;
            if q == '"' || q == '\'' {
                let close = after[1..].find(q)?;
                return Some(&after[1..1 + close]);
            }
        }
        rest = &rest[i + key.len()..];
    }
    None
}

struct DataArray<'a> {
    name: Option<&'a str>,
    ty: &'a str,
    components: usize,
    body: &'a str,
}

/// Parses a VTK XML UnstructuredGrid with ASCII data arrays (one piece, tetrahedra only).
pub fn parse_vtu(text: &str) -> FemResult<TetMesh> {
    let grid = scan_vtu(text)?;
    if !grid.grid {
        return Err(perr("no VTKFile UnstructuredGrid element"));
    }
    let (np, nc) = grid.declared.ok_or_else(|| perr("no Piece element"))?;
    let points = grid.points.ok_or_else(|| perr("no Points DataArray"))?;
    let nodes = vtu_nodes(&points, np)?;
    let tets = vtu_tets(&grid.cells, nc)?;
    finish(nodes, tets)
}

/// What [`scan_vtu`] found in a VTU file.
#[derive(Default)]
struct VtuGrid<'a> {
    /// A `VTKFile` of type `UnstructuredGrid` was seen.
    grid: bool,
    /// The piece's declared point and cell counts.
    declared: Option<(usize, usize)>,
    /// The `Points` data array.
    points: Option<DataArray<'a>>,
    /// The `Cells` data arrays.
    cells: Vec<DataArray<'a>>,
}

/// Walks the tags of a VTU file and collects the point and cell arrays.
fn scan_vtu(text: &str) -> FemResult<VtuGrid<'_>> {
    let mut pos = 0;
    let mut section = "";
    let mut found = VtuGrid::default();
    while let Some((_, tag)) = next_tag(text, pos) {
        pos = tag.end;
        if tag.name.starts_with('?') || tag.name.starts_with('!') {
            continue;
        }
        match (tag.name, tag.closing) {
            ("VTKFile", false) => {
                let ty = attr(tag.attrs, "type").unwrap_or("");
                if ty != "UnstructuredGrid" {
                    return Err(FemError::Unsupported(format!("VTK XML type {ty:?}")));
                }
                found.grid = true;
                if let Some(c) = attr(tag.attrs, "compressor") {
                    return Err(FemError::Unsupported(format!("compressed VTK XML ({c})")));
                }
            }
            ("Piece", false) => {
                if found.declared.is_some() {
                    return Err(FemError::Unsupported("more than one Piece".into()));
                }
                found.declared = Some(piece_counts(&tag)?);
            }
            ("Points" | "Cells" | "PointData" | "CellData", false) if !tag.self_closing => {
                section = tag.name
            }
            ("Points" | "Cells" | "PointData" | "CellData", true) => section = "",
            ("AppendedData", false) => {
                return Err(FemError::Unsupported("VTK XML appended data".into()))
            }
            ("DataArray", false) => {
                let da = data_array(text, &tag)?;
                pos = tag.end + da.body.len();
                match section {
                    "Points" => found.points = Some(da),
                    "Cells" => found.cells.push(da),
                    _ => {}
                }
            }
            _ => {}
        }
    }
    Ok(found)
}

/// The declared point and cell counts of a `Piece` tag.
fn piece_counts(tag: &Tag<'_>) -> FemResult<(usize, usize)> {
    let np =
        attr(tag.attrs, "NumberOfPoints").ok_or_else(|| perr("Piece without NumberOfPoints"))?;
    let nc = attr(tag.attrs, "NumberOfCells").ok_or_else(|| perr("Piece without NumberOfCells"))?;
    Ok((
        parse_num(np, "NumberOfPoints")?,
        parse_num(nc, "NumberOfCells")?,
    ))
}

/// The `DataArray` opened by `tag`, its body up to `</DataArray`.
fn data_array<'a>(text: &'a str, tag: &Tag<'a>) -> FemResult<DataArray<'a>> {
    let format = attr(tag.attrs, "format").unwrap_or("ascii");
    if format != "ascii" {
        return Err(FemError::Unsupported(format!(
            "DataArray format {format:?} (only ascii)"
        )));
    }
    let body_end = if tag.self_closing {
        tag.end
    } else {
        tag.end
            + text[tag.end..]
                .find("</DataArray")
                .ok_or_else(|| perr("unterminated DataArray"))?
    };
    let components = match attr(tag.attrs, "NumberOfComponents") {
        Some(c) => parse_num(c, "NumberOfComponents")?,
        None => 1,
    };
    Ok(DataArray {
        name: attr(tag.attrs, "Name"),
        ty: attr(tag.attrs, "type").unwrap_or("Float32"),
        components,
        body: &text[tag.end..body_end],
    })
}

/// The `np` node positions of the `Points` array.
fn vtu_nodes(points: &DataArray<'_>, np: usize) -> FemResult<Vec<[f64; 3]>> {
    if points.components != 3 {
        return Err(perr(format!(
            "Points have {} components",
            points.components
        )));
    }
    check_type(points.ty, true)?;
    let coords: Vec<f64> = tokens(points.body, "point coordinate")?;
    if coords.len() != 3 * np {
        return Err(perr(format!(
            "{} coordinates for {np} points",
            coords.len()
        )));
    }
    Ok(coords.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// The `nc` tetrahedra of the `connectivity`, `offsets` and `types` cell arrays.
fn vtu_tets(cells: &[DataArray<'_>], nc: usize) -> FemResult<Vec<[usize; 4]>> {
    let find = |name: &str| -> FemResult<&DataArray> {
        cells
            .iter()
            .find(|d| d.name == Some(name))
            .ok_or_else(|| perr(format!("no {name} DataArray in Cells")))
    };
    let conn_da = find("connectivity")?;
    let off_da = find("offsets")?;
    let ty_da = find("types")?;
    for d in [conn_da, off_da, ty_da] {
        check_type(d.ty, false)?;
    }
    let conn: Vec<i64> = tokens(conn_da.body, "connectivity")?;
    let offsets: Vec<i64> = tokens(off_da.body, "offsets")?;
    let types: Vec<i64> = tokens(ty_da.body, "types")?;
    if offsets.len() != nc || types.len() != nc {
        return Err(perr(format!(
            "{} offsets and {} types for {nc} cells",
            offsets.len(),
            types.len()
        )));
    }
    let mut tets = Vec::with_capacity(nc);
    let mut start = 0usize;
    for c in 0..nc {
        let end = to_index(offsets[c], "offset")?;
        if end < start || end > conn.len() {
            return Err(perr(format!(
                "cell {c}: offset {end} out of order or range"
            )));
        }
        // A tetrahedron whose offsets do not span four nodes is a fault of the offsets,
        // not of the cell type.
        if types[c] == VTK_TETRA && end - start != 4 {
            return Err(perr(format!(
                "cell {c}: a tetrahedron (type 10) but its offsets {start}..{end} give {} \
                 nodes, not 4: the offsets array is wrong",
                end - start
            )));
        }
        if types[c] != VTK_TETRA {
            return Err(FemError::UnsupportedCell {
                cell: c,
                cell_type: types[c],
            });
        }
        let mut t = [0usize; 4];
        for k in 0..4 {
            t[k] = to_index(conn[start + k], "node index")?;
        }
        tets.push(t);
        start = end;
    }
    Ok(tets)
}

fn check_type(ty: &str, float: bool) -> FemResult<()> {
    let ok = if float {
        matches!(ty, "Float32" | "Float64")
    } else {
        matches!(
            ty,
            "Int8" | "UInt8" | "Int16" | "UInt16" | "Int32" | "UInt32" | "Int64" | "UInt64"
        )
    };
    if ok {
        Ok(())
    } else {
        Err(FemError::Unsupported(format!("DataArray type {ty:?}")))
    }
}

fn tokens<T: std::str::FromStr>(body: &str, what: &str) -> FemResult<Vec<T>> {
    body.split_ascii_whitespace()
        .map(|t| parse_num(t, what))
        .collect()
}

/// Per-node or per-cell data for [`write_vtu`].
pub struct Field<'a> {
    /// Array name shown in ParaView.
    pub name: &'a str,
    /// Components per tuple (1 or 3).
    pub components: usize,
    /// Values, `components` per tuple.
    pub values: &'a [f64],
}

/// Formats a mesh (at positions `nodes`, usually the rest nodes) as ASCII VTU text.
pub fn vtu_string(
    nodes: &[[f64; 3]],
    tets: &[[usize; 4]],
    point_data: &[Field],
    cell_data: &[Field],
) -> String {
    let mut s = String::with_capacity(64 * (nodes.len() + tets.len()));
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">"
    );
    let _ = writeln!(s, "<UnstructuredGrid>");
    let _ = writeln!(
        s,
        "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        nodes.len(),
        tets.len()
    );
    let _ = writeln!(
        s,
        "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">"
    );
    for p in nodes {
        let _ = writeln!(s, "{} {} {}", p[0], p[1], p[2]);
    }
    let _ = writeln!(s, "</DataArray>\n</Points>\n<Cells>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
    );
    for t in tets {
        let _ = writeln!(s, "{} {} {} {}", t[0], t[1], t[2], t[3]);
    }
    let _ = writeln!(
        s,
        "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
    );
    for i in 0..tets.len() {
        let _ = write!(
            s,
            "{}{}",
            4 * (i + 1),
            if i % 16 == 15 { '\n' } else { ' ' }
        );
    }
    let _ = writeln!(
        s,
        "\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
    );
    for i in 0..tets.len() {
        let _ = write!(s, "10{}", if i % 32 == 31 { '\n' } else { ' ' });
    }
    let _ = writeln!(s, "\n</DataArray>\n</Cells>");
    for (tag, fields) in [("PointData", point_data), ("CellData", cell_data)] {
        if fields.is_empty() {
            continue;
        }
        let _ = writeln!(s, "<{tag}>");
        for f in fields {
            let _ = writeln!(
                s,
                "<DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">",
                f.name, f.components
            );
            for tuple in f.values.chunks(f.components.max(1)) {
                let line: Vec<String> = tuple.iter().map(|v| v.to_string()).collect();
                let _ = writeln!(s, "{}", line.join(" "));
            }
            let _ = writeln!(s, "</DataArray>");
        }
        let _ = writeln!(s, "</{tag}>");
    }
    let _ = writeln!(s, "</Piece>\n</UnstructuredGrid>\n</VTKFile>");
    s
}

/// Writes an ASCII VTU file (see [`vtu_string`]).
pub fn write_vtu(
    path: &Path,
    nodes: &[[f64; 3]],
    tets: &[[usize; 4]],
    point_data: &[Field],
    cell_data: &[Field],
) -> FemResult<()> {
    let text = vtu_string(nodes, tets, point_data, cell_data);
    Ok(crate::io::atomic::write(path, text.as_bytes())?)
}

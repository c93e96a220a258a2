//! Mesh files: VTK XML UnstructuredGrid (ASCII), VTK legacy (ASCII), Gmsh MSH 2.2 and 4.1
//! (ASCII) readers, and an ASCII VTU writer with point and cell data for ParaView.
//!
//! Readers detect the format from the content, not the extension (SOFA ships XML files
//! named `.vtk`). Counts declared in headers are checked against the data, and never used
//! to allocate more than the data itself can hold.

use super::mesh::TetMesh;
use super::{FemError, FemResult};
use crate::io::InFile;
use std::fmt::Write as _;
use std::path::Path;

/// Largest mesh file accepted (bytes).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: i64 = 10;

fn perr(msg: impl Into<String>) -> FemError {
    FemError::Parse(msg.into())
}

/// Reads a tetrahedral mesh from a file, detecting the format from its content.
pub fn read_mesh(path: &Path) -> FemResult<TetMesh> {
    let file_err = |source| FemError::File {
        path: path.display().to_string(),
        source,
    };
    let len = std::fs::metadata(path).map_err(file_err)?.len();
    if len > MAX_FILE_BYTES {
        return Err(perr(format!("file of {len} bytes is larger than the limit")).in_file(path));
    }
    let text = std::fs::read_to_string(path).map_err(file_err)?;
    parse_mesh(&text).map_err(|e| e.in_file(path))
}

/// Parses a mesh from text, detecting the format.
pub fn parse_mesh(text: &str) -> FemResult<TetMesh> {
    let head = text.trim_start();
    if head.starts_with('<') {
        parse_vtu(text)
    } else if head.starts_with("# vtk DataFile") {
        parse_vtk_legacy(text)
    } else if head.starts_with("$MeshFormat") {
        parse_msh(text)
    } else {
        Err(FemError::Unsupported(
            "not a VTK XML, VTK legacy or Gmsh MSH file".into(),
        ))
    }
}

fn parse_num<T: std::str::FromStr>(tok: &str, what: &str) -> FemResult<T> {
    tok.parse::<T>()
        .map_err(|_| perr(format!("bad {what} value {tok:?}")))
}

fn to_index(v: i64, what: &str) -> FemResult<usize> {
    usize::try_from(v).map_err(|_| perr(format!("negative {what} {v}")))
}

fn finish(nodes: Vec<[f64; 3]>, tets: Vec<[usize; 4]>) -> FemResult<TetMesh> {
    TetMesh::new(nodes, tets)
}

// ---------------------------------------------------------------- VTK XML

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

// ---------------------------------------------------------------- VTK legacy

/// Parses a VTK legacy ASCII UNSTRUCTURED_GRID with tetrahedral cells.
pub fn parse_vtk_legacy(text: &str) -> FemResult<TetMesh> {
    let mut lines = text.lines();
    lines.next(); // version
    lines.next(); // title
    let fmt = lines.next().unwrap_or("").trim();
    if !fmt.eq_ignore_ascii_case("ASCII") {
        return Err(FemError::Unsupported(format!(
            "VTK legacy encoding {fmt:?}"
        )));
    }
    let rest: Vec<&str> = lines.flat_map(|l| l.split_ascii_whitespace()).collect();
    let mut it = rest.into_iter();
    let mut nodes: Option<Vec<[f64; 3]>> = None;
    let mut cells: Option<Vec<Vec<i64>>> = None;
    let mut types: Option<Vec<i64>> = None;
    while let Some(kw) = it.next() {
        match kw.to_ascii_uppercase().as_str() {
            "DATASET" => {
                let ds = it.next().unwrap_or("");
                if !ds.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
                    return Err(FemError::Unsupported(format!("VTK dataset {ds:?}")));
                }
            }
            "POINTS" => nodes = Some(legacy_points(&mut it)?),
            "CELLS" => cells = Some(legacy_cells(&mut it)?),
            "CELL_TYPES" => types = Some(legacy_cell_types(&mut it)?),
            "POINT_DATA" | "CELL_DATA" => break,
            _ => {}
        }
    }
    let nodes = nodes.ok_or_else(|| perr("no POINTS"))?;
    let cells = cells.ok_or_else(|| perr("no CELLS"))?;
    let types = types.ok_or_else(|| perr("no CELL_TYPES"))?;
    if types.len() != cells.len() {
        return Err(perr("CELLS and CELL_TYPES counts differ"));
    }
    let mut tets = Vec::with_capacity(cells.len());
    for (c, (cell, &ty)) in cells.iter().zip(&types).enumerate() {
        // Gmsh writes its vertex, line and triangle cells beside the tets (SOFA's PneuNet).
        if matches!((ty, cell.len()), (1, 1) | (3, 2) | (5, 3)) && types.contains(&VTK_TETRA) {
            continue;
        }
        if ty != VTK_TETRA || cell.len() != 4 {
            return Err(FemError::UnsupportedCell {
                cell: c,
                cell_type: ty,
            });
        }
        let mut t = [0usize; 4];
        for k in 0..4 {
            t[k] = to_index(cell[k], "node index")?;
        }
        tets.push(t);
    }
    finish(nodes, tets)
}

/// The tokens of a VTK legacy file after its header.
type Tokens<'a> = std::vec::IntoIter<&'a str>;

/// The section after a `POINTS` keyword: count, data type, coordinates.
fn legacy_points(it: &mut Tokens<'_>) -> FemResult<Vec<[f64; 3]>> {
    let n: usize = parse_num(it.next().unwrap_or(""), "POINTS count")?;
    it.next(); // data type
    if n.saturating_mul(3) > it.len() {
        return Err(perr(format!("POINTS {n} but the file is shorter")));
    }
    let mut v = Vec::with_capacity(n);
    for _ in 0..n {
        let mut p = [0.0; 3];
        for c in &mut p {
            *c = parse_num(it.next().unwrap_or(""), "point coordinate")?;
        }
        v.push(p);
    }
    Ok(v)
}

/// The section after a `CELLS` keyword: count, size, then each cell's size and indices.
fn legacy_cells(it: &mut Tokens<'_>) -> FemResult<Vec<Vec<i64>>> {
    let n: usize = parse_num(it.next().unwrap_or(""), "CELLS count")?;
    let size: usize = parse_num(it.next().unwrap_or(""), "CELLS size")?;
    if size > it.len() || n > size {
        return Err(perr(format!("CELLS {n} {size} but the file is shorter")));
    }
    let mut v = Vec::with_capacity(n);
    let mut used = 0usize;
    for _ in 0..n {
        let k: usize = parse_num(it.next().unwrap_or(""), "cell size")?;
        // Checked before anything is allocated for it: a huge size is a broken file.
        used = used.saturating_add(k).saturating_add(1);
        if used > size {
            return Err(perr("CELLS data longer than declared"));
        }
        let mut c = Vec::with_capacity(k);
        for _ in 0..k {
            c.push(parse_num(it.next().unwrap_or(""), "cell index")?);
        }
        v.push(c);
    }
    Ok(v)
}

/// The section after a `CELL_TYPES` keyword: count, types.
fn legacy_cell_types(it: &mut Tokens<'_>) -> FemResult<Vec<i64>> {
    let n: usize = parse_num(it.next().unwrap_or(""), "CELL_TYPES count")?;
    if n > it.len() {
        return Err(perr("CELL_TYPES longer than the file"));
    }
    let mut v = Vec::with_capacity(n);
    for _ in 0..n {
        v.push(parse_num(it.next().unwrap_or(""), "cell type")?);
    }
    Ok(v)
}

// ---------------------------------------------------------------- Gmsh

/// Nodes per Gmsh element type for the types we skip (lower-dimensional ones).
fn gmsh_dim(ty: i64) -> Option<usize> {
    match ty {
        15 => Some(0),
        1 | 8 | 26 | 27 | 28 => Some(1),
        2 | 3 | 9 | 10 | 16 | 20 | 21 | 22 | 23 | 24 | 25 => Some(2),
        4 | 5 | 6 | 7 | 11 | 12 | 13 | 14 | 17 | 18 | 19 | 29 | 30 | 31 | 92 | 93 => Some(3),
        _ => None,
    }
}

fn section<'a>(text: &'a str, name: &str) -> FemResult<&'a str> {
    let open = format!("${name}");
    let close = format!("$End{name}");
    let s = text
        .find(&open)
        .ok_or_else(|| perr(format!("no {open} section")))?
        + open.len();
    let e = text[s..]
        .find(&close)
        .ok_or_else(|| perr(format!("no {close}")))?;
    Ok(&text[s..s + e])
}

/// Parses a Gmsh MSH 2.2 or 4.1 ASCII file; tetrahedra only, lower-dimensional elements
/// are ignored, other 3-D elements are an error.
pub fn parse_msh(text: &str) -> FemResult<TetMesh> {
    let fmt = section(text, "MeshFormat")?;
    let mut f = fmt.split_ascii_whitespace();
    let version = f.next().unwrap_or("");
    let file_type = f.next().unwrap_or("");
    if file_type != "0" {
        return Err(FemError::Unsupported("binary Gmsh file".into()));
    }
    let nodes_s = section(text, "Nodes")?;
    let elems_s = section(text, "Elements")?;
    let mut nodes = MshNodes::default();
    let mut raw_tets: Vec<RawTet> = Vec::new();
    if version.starts_with("2.") {
        msh2_nodes(&rows(nodes_s), &mut nodes)?;
        msh2_elements(&rows(elems_s), &mut raw_tets)?;
    } else if version.starts_with("4.") {
        msh4_nodes(&rows(nodes_s), &mut nodes)?;
        msh4_elements(&rows(elems_s), &mut raw_tets)?;
    } else {
        return Err(FemError::Unsupported(format!("Gmsh version {version}")));
    }
    let mut ids = nodes.ids;
    ids.sort_unstable();
    let lookup = |t: usize, elem: usize| -> FemResult<usize> {
        ids.binary_search_by_key(&t, |p| p.0)
            .map(|i| ids[i].1)
            .map_err(|_| perr(format!("element {elem} references unknown node {t}")))
    };
    let mut tets = Vec::with_capacity(raw_tets.len());
    for (e, t) in &raw_tets {
        tets.push([
            lookup(t[0], *e)?,
            lookup(t[1], *e)?,
            lookup(t[2], *e)?,
            lookup(t[3], *e)?,
        ]);
    }
    finish(nodes.positions, tets)
}

/// A tetrahedron as read: (element number, Gmsh node tags).
type RawTet = (usize, [usize; 4]);

/// The nodes of a Gmsh file as read.
#[derive(Default)]
struct MshNodes {
    /// (Gmsh tag, our index) per node.
    ids: Vec<(usize, usize)>,
    /// Positions, in our order.
    positions: Vec<[f64; 3]>,
}

impl MshNodes {
    /// Adds the node of tag `t` at the coordinates `c` (at least three).
    fn push(&mut self, t: &str, c: &[&str]) -> FemResult<()> {
        self.ids.push((msh_tag(t)?, self.positions.len()));
        self.positions.push([
            parse_num(c[0], "x")?,
            parse_num(c[1], "y")?,
            parse_num(c[2], "z")?,
        ]);
        Ok(())
    }
}

fn msh_tag(t: &str) -> FemResult<usize> {
    parse_num::<usize>(t, "tag")
}

/// Element `number` of Gmsh type `ty` with node tags `tags`: a tetrahedron goes to `out`,
/// lower-dimensional elements are skipped, others are an error.
fn msh_element(number: usize, ty: i64, tags: &[&str], out: &mut Vec<RawTet>) -> FemResult<()> {
    match (ty, gmsh_dim(ty)) {
        (4, _) => {
            if tags.len() < 4 {
                return Err(perr(format!(
                    "element {number}: tetrahedron with {} nodes",
                    tags.len()
                )));
            }
            out.push((
                number,
                [
                    msh_tag(tags[0])?,
                    msh_tag(tags[1])?,
                    msh_tag(tags[2])?,
                    msh_tag(tags[3])?,
                ],
            ));
            Ok(())
        }
        (_, Some(d)) if d < 3 => Ok(()),
        _ => Err(FemError::UnsupportedCell {
            cell: number,
            cell_type: ty,
        }),
    }
}

/// The count on the first row of an MSH 2 section, checked against its rows.
fn msh2_count(r: &[Vec<&str>], what: &str) -> FemResult<usize> {
    let n: usize = parse_num(
        r.first().and_then(|r| r.first()).copied().unwrap_or(""),
        &format!("{what} count"),
    )?;
    if r.len() != n + 1 {
        return Err(perr(format!(
            "{} {what} lines for {n} {what}s",
            r.len().saturating_sub(1)
        )));
    }
    Ok(n)
}

/// MSH 2 `$Nodes`: count, then `tag x y z` per line.
fn msh2_nodes(nr: &[Vec<&str>], nodes: &mut MshNodes) -> FemResult<()> {
    msh2_count(nr, "node")?;
    for r in &nr[1..] {
        if r.len() < 4 {
            return Err(perr("short node line"));
        }
        nodes.push(r[0], &r[1..])?;
    }
    Ok(())
}

/// MSH 2 `$Elements`: count, then `number type ntags tags... nodes...` per line.
fn msh2_elements(er: &[Vec<&str>], raw_tets: &mut Vec<RawTet>) -> FemResult<()> {
    msh2_count(er, "element")?;
    for (i, r) in er[1..].iter().enumerate() {
        if r.len() < 3 {
            return Err(perr(format!("short element line {i}")));
        }
        let ty: i64 = parse_num(r[1], "element type")?;
        let ntags: usize = parse_num(r[2], "tag count")?;
        let first = 3usize.saturating_add(ntags);
        if first > r.len() {
            return Err(perr(format!("element line {i} shorter than its tags")));
        }
        msh_element(i, ty, &r[first..], raw_tets)?;
    }
    Ok(())
}

/// MSH 4 `$Nodes`: a header, then blocks of tags followed by coordinates.
fn msh4_nodes(nr: &[Vec<&str>], nodes: &mut MshNodes) -> FemResult<()> {
    let mut k = 1usize; // skip header
    while k < nr.len() {
        let h = &nr[k];
        if h.len() < 4 {
            return Err(perr("short node block header"));
        }
        let _parametric: &str = h[2];
        let count: usize = parse_num(h[3], "block node count")?;
        if count.saturating_mul(2) > nr.len() - k - 1 {
            return Err(perr("node block longer than the section"));
        }
        let tags = &nr[k + 1..k + 1 + count];
        let coords = &nr[k + 1 + count..k + 1 + 2 * count];
        for (t, c) in tags.iter().zip(coords) {
            if c.len() < 3 || t.is_empty() {
                return Err(perr("short node line"));
            }
            nodes.push(t[0], c)?;
        }
        k += 1 + 2 * count;
    }
    Ok(())
}

/// MSH 4 `$Elements`: a header, then blocks of one element type.
fn msh4_elements(er: &[Vec<&str>], raw_tets: &mut Vec<RawTet>) -> FemResult<()> {
    let mut k = 1usize;
    let mut number = 0usize;
    while k < er.len() {
        let h = &er[k];
        if h.len() < 4 {
            return Err(perr("short element block header"));
        }
        let ty: i64 = parse_num(h[2], "element type")?;
        let count: usize = parse_num(h[3], "block element count")?;
        if count > er.len() - k - 1 {
            return Err(perr("element block longer than the section"));
        }
        for r in &er[k + 1..k + 1 + count] {
            msh_element(number, ty, r.get(1..).unwrap_or(&[]), raw_tets)?;
            number += 1;
        }
        k += 1 + count;
    }
    Ok(())
}

fn rows(s: &str) -> Vec<Vec<&str>> {
    s.lines()
        .map(|l| l.split_ascii_whitespace().collect::<Vec<_>>())
        .filter(|r| !r.is_empty())
        .collect()
}

// ---------------------------------------------------------------- writer

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

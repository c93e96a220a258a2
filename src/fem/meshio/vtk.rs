//! VTK legacy UNSTRUCTURED_GRID.

use super::{finish, parse_num, perr, to_index, VTK_TETRA};
use crate::fem::mesh::TetMesh;
use crate::fem::{FemError, FemResult};

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

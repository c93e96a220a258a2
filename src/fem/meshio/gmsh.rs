//! Gmsh MSH 2.2 and 4.1 (ASCII).

use super::{finish, parse_num, perr};
use crate::fem::mesh::TetMesh;
use crate::fem::{FemError, FemResult};

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

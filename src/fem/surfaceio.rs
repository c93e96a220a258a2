//! Triangle surface files: STL (binary and ASCII), Wavefront OBJ and PLY faces, read as a
//! list of triangles (file units); binary STL written. A cavity's face set comes from one
//! ([`crate::fem::model`]), and so does a robot's CAD surface (`softsense model new`).
//!
//! Hand-written: no maintained STL crate is in this environment, and both formats are a
//! few lines (STL: an 80-byte header, a count and 50-byte records; OBJ: `v` and `f` lines,
//! polygons fanned into triangles).

use super::{FemError, FemResult};
use crate::io::InFile;
use std::path::Path;

/// A triangle's three corners (file units), in the file's order.
pub type Triangle = [[f64; 3]; 3];

/// Reads the triangles of an STL (binary or ASCII) or OBJ file; the error names the file.
pub fn read_triangles(path: &Path) -> FemResult<Vec<Triangle>> {
    let bytes = std::fs::read(path).map_err(|source| FemError::File {
        path: path.display().to_string(),
        source,
    })?;
    let ext = (path.extension().and_then(|e| e.to_str()))
        .unwrap_or("")
        .to_ascii_lowercase();
    let tris = match ext.as_str() {
        "stl" => parse_stl(&bytes),
        "obj" => parse_obj(&String::from_utf8_lossy(&bytes)),
        "ply" => parse_ply_faces(&bytes),
        other => Err(FemError::Unsupported(format!(
            "surface file extension {other:?} (STL, OBJ or PLY)"
        ))),
    }
    .map_err(|e| e.in_file(path))?;
    if tris.is_empty() {
        return Err(FemError::Parse("no triangle".into()).in_file(path));
    }
    if tris.iter().flatten().flatten().any(|c| !c.is_finite()) {
        return Err(FemError::Parse("a non-finite coordinate".into()).in_file(path));
    }
    Ok(tris)
}

/// STL: binary when the size is exactly 84 + 50 n for the count n in the header (an ASCII
/// file starts with `solid`, but so do many binary headers).
pub fn parse_stl(bytes: &[u8]) -> FemResult<Vec<Triangle>> {
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if n.checked_mul(50).and_then(|b| b.checked_add(84)) == Some(bytes.len()) {
            return Ok(parse_stl_binary(&bytes[84..], n));
        }
    }
    let text = std::str::from_utf8(bytes).map_err(|_| {
        FemError::Parse(
            "STL is neither binary (size does not match its triangle count) nor ASCII".into(),
        )
    })?;
    parse_stl_ascii(text)
}

fn parse_stl_binary(body: &[u8], n: usize) -> Vec<Triangle> {
    let f = |b: &[u8], i: usize| {
        f32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]) as f64
    };
    (0..n)
        .map(|t| {
            // 12 bytes of normal (ignored: the corners' order is what orients a face).
            let r = &body[50 * t + 12..50 * t + 48];
            [0, 1, 2].map(|v| [f(r, 3 * v), f(r, 3 * v + 1), f(r, 3 * v + 2)])
        })
        .collect()
}

fn parse_stl_ascii(text: &str) -> FemResult<Vec<Triangle>> {
    let mut out = Vec::new();
    let mut corners: Vec<[f64; 3]> = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("vertex") => corners.push(three(&mut w, ln)?),
            Some("endfacet") => {
                let [a, b, c] = corners[..] else {
                    return Err(FemError::Parse(format!(
                        "line {}: a facet with {} vertices (3 expected)",
                        ln + 1,
                        corners.len()
                    )));
                };
                out.push([a, b, c]);
                corners.clear();
            }
            _ => {}
        }
    }
    Ok(out)
}

fn three<'a>(w: &mut impl Iterator<Item = &'a str>, ln: usize) -> FemResult<[f64; 3]> {
    let mut p = [0.0; 3];
    for c in &mut p {
        *c = (w.next().and_then(|s| s.parse().ok()))
            .ok_or_else(|| FemError::Parse(format!("line {}: bad coordinate", ln + 1)))?;
    }
    Ok(p)
}

/// PLY: the `face` element's polygons over the vertices, each fanned from its first corner.
pub fn parse_ply_faces(bytes: &[u8]) -> FemResult<Vec<Triangle>> {
    let (cloud, faces) =
        crate::io::ply::parse_ply_faces(bytes).map_err(|e| FemError::Parse(e.to_string()))?;
    let p = |i: usize| {
        (cloud.positions.get(i))
            .map(|q| q.map(f64::from))
            .ok_or_else(|| {
                FemError::Parse(format!(
                    "a face names vertex {i}, but there are {}",
                    cloud.positions.len()
                ))
            })
    };
    let mut out = Vec::new();
    for f in &faces {
        for k in 2..f.len() {
            out.push([p(f[0])?, p(f[k - 1])?, p(f[k])?]);
        }
    }
    Ok(out)
}

/// Binary STL of `triangles` over `vertices` (written as f32, as every STL is).
pub fn stl_bytes(vertices: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(84 + 50 * triangles.len());
    // An all-zero header makes gmsh take the file for another format.
    let mut header = [b' '; 80];
    let text = b"binary STL written by softsense";
    header[..text.len()].copy_from_slice(text);
    out.extend_from_slice(&header);
    out.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i]);
        let n = crate::math::cross(crate::math::sub(b, a), crate::math::sub(c, a));
        let l = crate::math::norm(n).max(f64::MIN_POSITIVE);
        for v in [n.map(|x| x / l), a, b, c] {
            for x in v {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

/// OBJ: `v x y z` and `f a b c ...` (1-based or negative indices, `a/t/n` forms), each
/// polygon fanned from its first corner.
pub fn parse_obj(text: &str) -> FemResult<Vec<Triangle>> {
    let mut verts: Vec<[f64; 3]> = Vec::new();
    let mut out = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => verts.push(three(&mut w, ln)?),
            Some("f") => {
                let idx = w
                    .map(|s| {
                        let i: i64 = (s.split('/').next().and_then(|s| s.parse().ok()))
                            .ok_or_else(|| FemError::Parse(format!("line {}: bad face", ln + 1)))?;
                        let k = if i < 0 { verts.len() as i64 + i } else { i - 1 };
                        (0..verts.len() as i64)
                            .contains(&k)
                            .then_some(k as usize)
                            .ok_or_else(|| {
                                FemError::Parse(format!(
                                    "line {}: vertex {i} is not defined",
                                    ln + 1
                                ))
                            })
                    })
                    .collect::<FemResult<Vec<usize>>>()?;
                for k in 2..idx.len() {
                    out.push([verts[idx[0]], verts[idx[k - 1]], verts[idx[k]]]);
                }
            }
            _ => {}
        }
    }
    Ok(out)
}

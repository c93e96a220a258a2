//! Mesh files: VTK XML UnstructuredGrid (ASCII), VTK legacy (ASCII or BINARY, the 4.x and
//! 5.1 cell layouts), Gmsh MSH 2.2 and 4.1 (ASCII) readers, and an ASCII VTU writer with
//! point and cell data for ParaView.
//!
//! Readers detect the format from the content, not the extension (SOFA ships XML files
//! named `.vtk`). Counts declared in headers are checked against the data, and never used
//! to allocate more than the data itself can hold.
//!
//! A file is read into [`MeshCells`]: its nodes, tetrahedra, triangles and the nodes of
//! its vertex cells (`marked`: a clamped rim, say). [`read_mesh`] wants tetrahedra;
//! [`read_surface`] wants triangles, which [`crate::fem::shell`] extrudes into thin
//! tetrahedral layers.

use super::mesh::TetMesh;
use super::shell::SurfaceMesh;
use super::{FemError, FemResult};
use crate::io::InFile;
use std::path::Path;

mod gmsh;
mod vtk;
mod vtu;

pub use gmsh::parse_msh;
pub use vtk::{parse_vtk_cells, parse_vtk_legacy};
pub use vtu::{parse_vtu, vtu_string, write_vtu, Field};

/// Largest mesh file accepted (bytes).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// VTK cell type of the linear tetrahedron.
const VTK_TETRA: i64 = 10;
/// VTK cell type of the linear triangle.
const VTK_TRIANGLE: i64 = 5;

fn perr(msg: impl Into<String>) -> FemError {
    FemError::Parse(msg.into())
}

/// What a mesh file holds that softsense uses. Line cells are skipped (a rim's edges carry
/// nothing the model needs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshCells {
    /// Node positions (file units).
    pub nodes: Vec<[f64; 3]>,
    /// Linear tetrahedra (VTK type 10, Gmsh type 4), as in the file.
    pub tets: Vec<[usize; 4]>,
    /// Linear triangles (VTK type 5), as in the file.
    pub triangles: Vec<[usize; 3]>,
    /// Nodes of vertex and poly-vertex cells (VTK types 1, 2), ascending, without repeats.
    pub marked: Vec<usize>,
}

impl MeshCells {
    /// The tetrahedral mesh; a file of triangles and no tetrahedra is refused as a surface.
    pub fn into_tet_mesh(self) -> FemResult<TetMesh> {
        if self.tets.is_empty() && !self.triangles.is_empty() {
            return Err(FemError::SurfaceNotVolume {
                triangles: self.triangles.len(),
            });
        }
        TetMesh::new(self.nodes, self.tets)
    }

    /// The triangle surface with its marked nodes; a file without triangles is refused.
    pub fn into_surface(self) -> FemResult<SurfaceMesh> {
        if self.triangles.is_empty() {
            return Err(FemError::InvalidMesh(format!(
                "no triangles to extrude ({} tetrahedra): a volume mesh is given without \
                 `shell`",
                self.tets.len()
            )));
        }
        SurfaceMesh::new(self.nodes, self.triangles, self.marked)
    }
}

/// Reads every cell softsense uses from a mesh file, detecting the format from its content.
pub fn read_cells(path: &Path) -> FemResult<MeshCells> {
    let file_err = |source| FemError::File {
        path: path.display().to_string(),
        source,
    };
    let len = std::fs::metadata(path).map_err(file_err)?.len();
    if len > MAX_FILE_BYTES {
        return Err(perr(format!("file of {len} bytes is larger than the limit")).in_file(path));
    }
    let bytes = std::fs::read(path).map_err(file_err)?;
    parse_cells(&bytes).map_err(|e| e.in_file(path))
}

/// Reads a tetrahedral mesh from a file, detecting the format from its content.
pub fn read_mesh(path: &Path) -> FemResult<TetMesh> {
    read_cells(path)
        .and_then(MeshCells::into_tet_mesh)
        .map_err(|e| e.in_file(path))
}

/// Reads a triangle surface and its marked (vertex-cell) nodes from a file.
pub fn read_surface(path: &Path) -> FemResult<SurfaceMesh> {
    read_cells(path)
        .and_then(MeshCells::into_surface)
        .map_err(|e| e.in_file(path))
}

/// Parses a file's bytes, detecting the format: legacy VTK may be binary, the others are
/// text.
pub fn parse_cells(bytes: &[u8]) -> FemResult<MeshCells> {
    let head = &bytes[bytes.iter().take_while(|b| b.is_ascii_whitespace()).count()..];
    if head.starts_with(b"# vtk DataFile") {
        return parse_vtk_cells(bytes);
    }
    let text = std::str::from_utf8(bytes)
        .map_err(|e| perr(format!("not UTF-8 text (byte {})", e.valid_up_to())))?;
    let mesh = parse_mesh(text)?;
    Ok(MeshCells {
        nodes: mesh.nodes_in_rest,
        tets: mesh.tets,
        ..MeshCells::default()
    })
}

/// Parses a tetrahedral mesh from text, detecting the format.
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

/// Sorts VTK cells (`offsets`: `types.len() + 1` ascending bounds into `conn`) by kind.
fn classify(
    nodes: Vec<[f64; 3]>,
    offsets: &[usize],
    conn: &[i64],
    types: &[i64],
) -> FemResult<MeshCells> {
    let mut out = MeshCells {
        nodes,
        ..MeshCells::default()
    };
    for (c, &ty) in types.iter().enumerate() {
        let ids = &conn[offsets[c]..offsets[c + 1]];
        let node = |k: usize| to_index(ids[k], "node index");
        let want = match ty {
            VTK_TETRA => 4,
            VTK_TRIANGLE => 3,
            1..=4 => ids.len(),
            _ => {
                return Err(FemError::UnsupportedCell {
                    cell: c,
                    cell_type: ty,
                })
            }
        };
        if ids.len() != want {
            return Err(perr(format!(
                "cell {c} of type {ty} has {} nodes, not {want}",
                ids.len()
            )));
        }
        match ty {
            VTK_TETRA => out.tets.push([node(0)?, node(1)?, node(2)?, node(3)?]),
            VTK_TRIANGLE => out.triangles.push([node(0)?, node(1)?, node(2)?]),
            1 | 2 => {
                for k in 0..ids.len() {
                    out.marked.push(node(k)?);
                }
            }
            _ => {}
        }
    }
    let n = out.nodes.len();
    if let Some(&v) = out.marked.iter().find(|&&v| v >= n) {
        return Err(perr(format!("a vertex cell names node {v} of {n}")));
    }
    out.marked.sort_unstable();
    out.marked.dedup();
    Ok(out)
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

//! Mesh files: VTK XML UnstructuredGrid (ASCII), VTK legacy (ASCII), Gmsh MSH 2.2 and 4.1
//! (ASCII) readers, and an ASCII VTU writer with point and cell data for ParaView.
//!
//! Readers detect the format from the content, not the extension (SOFA ships XML files
//! named `.vtk`). Counts declared in headers are checked against the data, and never used
//! to allocate more than the data itself can hold.

use super::mesh::TetMesh;
use super::{FemError, FemResult};
use crate::io::InFile;

use std::path::Path;
mod gmsh;
mod vtk;
mod vtu;

pub use gmsh::parse_msh;
pub use vtk::parse_vtk_legacy;
pub use vtu::{parse_vtu, vtu_string, write_vtu, Field};

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

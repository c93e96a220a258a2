//! Markers bound to the FE surface and candidate force locations.
//!
//! A marker sits at the nearest point of the surface (barycentric on that triangle)
//! and measures 3 rows (its x, y, z). A candidate force location is a surface node with its
//! allowed directions: the surface normal only (1 unknown) or free in 3-D (3 unknowns).

use super::{MarkersError, MarkersResult};
pub use crate::fem::bind::{bind_markers, BoundMarker};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::mesh::{Surface, TetMesh};
use crate::fem::model::Effector;
use crate::fem::solve::MappedPoint;
use crate::io::InFile;
use crate::math::{norm, sub};
use std::path::Path;

/// The directions a candidate force may take.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Directions {
    /// Along the surface normal at the node (one unknown, positive outward).
    Normal,
    /// Any direction (three unknowns: x, y, z).
    Free,
}

/// A candidate force location.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceCandidate {
    /// Name.
    pub name: String,
    /// Where it acts.
    pub at: MappedPoint,
    /// Unit direction of each unknown (1 or 3).
    pub directions: Vec<[f64; 3]>,
    /// Rest position (m).
    pub position: [f64; 3],
}

impl ForceCandidate {
    /// A candidate on the surface node nearest to `p` (rest shape, m).
    pub fn snapped(
        name: &str,
        mesh: &TetMesh,
        surface: &Surface,
        p: [f64; 3],
        directions: Directions,
    ) -> MarkersResult<Self> {
        let x = &mesh.nodes_in_rest;
        let node = (surface.nodes.iter().copied())
            .min_by(|a, b| norm(sub(x[*a], p)).total_cmp(&norm(sub(x[*b], p))))
            .ok_or(MarkersError::NoSurface)?;
        let directions = match directions {
            Directions::Normal => vec![surface.vertex_normals[node]],
            Directions::Free => vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        };
        Ok(Self {
            name: name.to_string(),
            at: MappedPoint::node(node),
            directions,
            position: x[node],
        })
    }

    /// A candidate from a model file's force point: its point and its rows' directions.
    pub fn from_force_point(e: &Effector, mesh: &TetMesh) -> Self {
        // A row's coefficients are w_i d with Σ w_i = 1: their sum is d.
        let directions = (e.rows.iter())
            .map(|r| {
                r.entries.iter().fold([0.0; 3], |s, (_, c)| {
                    [s[0] + c[0], s[1] + c[1], s[2] + c[2]]
                })
            })
            .collect();
        Self {
            name: e.name.clone(),
            at: e.point,
            directions,
            position: e.point.position(&mesh.nodes_in_rest),
        }
    }

    /// Its rows (one per direction).
    pub fn rows(&self) -> MarkersResult<Vec<ConstraintRow>> {
        (self.directions.iter())
            .map(|d| Ok(ConstraintRow::along(RowKind::Force, &self.at, *d)?))
            .collect()
    }
}

/// Reads a candidate file: CSV `name,x,y,z,directions` (m, model frame; directions `normal`
/// or `3d`), each point snapped to its nearest surface node.
pub fn read_candidates(path: &Path, mesh: &TetMesh) -> MarkersResult<Vec<ForceCandidate>> {
    let text = std::fs::read_to_string(path).map_err(|source| MarkersError::File {
        path: path.display().to_string(),
        source,
    })?;
    parse_candidates(&text, mesh).map_err(|e| e.in_file(path))
}

/// Parses a candidate file (see [`read_candidates`]).
pub fn parse_candidates(text: &str, mesh: &TetMesh) -> MarkersResult<Vec<ForceCandidate>> {
    let surface = mesh.surface();
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let cells: Vec<&str> = l.split(',').map(str::trim).collect();
        if l.trim().is_empty() || (i == 0 && cells[0].eq_ignore_ascii_case("name")) {
            continue;
        }
        if cells.len() != 5 {
            return Err(MarkersError::CandidateCells {
                line: i + 1,
                cells: cells.len(),
            });
        }
        let mut p = [0.0; 3];
        for (k, pk) in p.iter_mut().enumerate() {
            *pk = match cells[1 + k].parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => {
                    return Err(MarkersError::CandidateNumber {
                        line: i + 1,
                        cell: cells[1 + k].to_string(),
                    })
                }
            };
        }
        let directions = match cells[4].to_ascii_lowercase().as_str() {
            "normal" => Directions::Normal,
            "3d" => Directions::Free,
            d => {
                return Err(MarkersError::CandidateDirections {
                    line: i + 1,
                    cell: d.to_string(),
                })
            }
        };
        out.push(ForceCandidate::snapped(
            cells[0], mesh, &surface, p, directions,
        )?);
    }
    Ok(out)
}

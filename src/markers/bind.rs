//! Markers bound to the FE surface and candidate force locations.
//!
//! A marker sits at the nearest point of the surface (barycentric on that triangle)
//! and measures 3 rows (its x, y, z). A candidate force location ([`CandidateLocation`]) is a
//! surface node with a candidate force ([`Candidate`]) along each allowed direction: the
//! surface normal only (1 unknown) or free in 3-D (3 unknowns).

use super::{MarkersError, MarkersResult};
pub use crate::fem::bind::{bind_markers, BoundMarker};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::mesh::{Surface, TetMesh};
use crate::fem::model::Effector;
use crate::fem::solve::MappedPoint;
use crate::geometry::triangle::point_triangle_distance2;
use crate::inverse::Candidate;
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

/// A candidate force location: a named place on the mesh and its candidate forces, one per
/// allowed direction (1 or 3), each an unknown of the least squares.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidateLocation {
    /// Name.
    pub name: String,
    /// Its candidate forces, all at the same point: directions as the location gives them
    /// (unit to rounding; the rows normalise them, the loads take them as they are).
    pub candidates: Vec<Candidate>,
    /// Rest position (m).
    pub position: [f64; 3],
}

impl CandidateLocation {
    /// A location at `at` (rest position `position`, m) with one candidate along each of
    /// `directions`, taken as they are; the least squares leaves their intensities free.
    pub fn new(name: &str, at: MappedPoint, directions: &[[f64; 3]], position: [f64; 3]) -> Self {
        let candidates = (directions.iter())
            .map(|&direction| Candidate {
                at,
                direction,
                push_only: false,
            })
            .collect();
        Self {
            name: name.to_string(),
            candidates,
            position,
        }
    }

    /// A location on the surface node nearest to `p` (rest shape, m).
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
        Ok(Self::new(
            name,
            MappedPoint::node(node),
            &directions,
            x[node],
        ))
    }

    /// A location from a model file's force point: its point and its rows' directions.
    pub fn from_force_point(e: &Effector, mesh: &TetMesh) -> Self {
        // A row's coefficients are w_i d with Σ w_i = 1: their sum is d.
        let directions: Vec<[f64; 3]> = (e.rows.iter())
            .map(|r| {
                r.entries.iter().fold([0.0; 3], |s, (_, c)| {
                    [s[0] + c[0], s[1] + c[1], s[2] + c[2]]
                })
            })
            .collect();
        Self::new(
            &e.name,
            e.point,
            &directions,
            e.point.position(&mesh.nodes_in_rest),
        )
    }

    /// Where its forces act.
    pub fn at(&self) -> MappedPoint {
        self.candidates
            .first()
            .expect("a location has a candidate")
            .at
    }

    /// Its unknowns: one per candidate.
    pub fn unknowns(&self) -> usize {
        self.candidates.len()
    }

    /// Its rows (one per candidate, along its direction normalised).
    pub fn rows(&self) -> MarkersResult<Vec<ConstraintRow>> {
        (self.candidates.iter())
            .map(|c| Ok(ConstraintRow::along(RowKind::Force, &c.at, c.direction)?))
            .collect()
    }
}

/// A candidate farther than this from the model's rest surface is refused (m): a force
/// there would be put on the nearest surface node and reported as found at it, though the
/// file meant somewhere else (a point in millimetres, or in another frame). The markers'
/// binding allows the same 5 mm ([`super::MarkersParams::max_bind_distance`]).
pub const MAX_CANDIDATE_DISTANCE: f64 = 0.005;

/// Reads a candidate file: CSV `name,x,y,z,directions` (m, model frame; directions `normal`
/// or `3d`), each point snapped to its nearest surface node. A file without candidates, or
/// with candidates farther than [`MAX_CANDIDATE_DISTANCE`] from the surface, is an error
/// naming the file (and the candidates).
pub fn read_candidates(path: &Path, mesh: &TetMesh) -> MarkersResult<Vec<CandidateLocation>> {
    let text = std::fs::read_to_string(path).map_err(|source| MarkersError::File {
        path: path.display().to_string(),
        source,
    })?;
    parse_candidates(&text, mesh).map_err(|e| e.in_file(path))
}

/// Parses a candidate file (see [`read_candidates`]).
pub fn parse_candidates(text: &str, mesh: &TetMesh) -> MarkersResult<Vec<CandidateLocation>> {
    let surface = mesh.surface();
    let mut out = Vec::new();
    let mut off = Vec::new();
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
        let distance = surface_distance(&mesh.nodes_in_rest, &surface, p);
        if distance.is_nan() || distance > MAX_CANDIDATE_DISTANCE {
            off.push(format!(
                "{} (line {}, {:.1} mm)",
                cells[0],
                i + 1,
                1e3 * distance
            ));
        }
        out.push(CandidateLocation::snapped(
            cells[0], mesh, &surface, p, directions,
        )?);
    }
    if !off.is_empty() {
        return Err(MarkersError::CandidatesOffSurface {
            candidates: off.join(", "),
            max_distance: MAX_CANDIDATE_DISTANCE,
        });
    }
    if out.is_empty() {
        return Err(MarkersError::NoCandidates);
    }
    Ok(out)
}

/// The distance from `p` to the surface with nodes at `x` (m).
fn surface_distance(x: &[[f64; 3]], surface: &Surface, p: [f64; 3]) -> f64 {
    // PERF: brute force over the triangles, as the markers' binding; a few candidates.
    (surface.triangles.iter())
        .map(|t| point_triangle_distance2(p, x[t[0]], x[t[1]], x[t[2]]))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

//! Pressure cavities: a face set loaded by a pressure that follows the deformed faces, as an
//! actuator like a cable (SOFA's `SurfacePressureConstraint`). Its actuator value is the
//! cavity's volume change ΔV(x), its row dΔV/dx, and the pressure p its multiplier: the
//! nodal pressure force is p dΔV/dx and the consistent tangent adds −p d²ΔV/dx².
//!
//! Faces are triangles over cavity vertices, each vertex a [`MappedPoint`] (a mesh node, or
//! a point inside a tetrahedron mapped barycentrically, as SOFA's `BarycentricMapping` maps
//! a cavity surface into a coarser volume mesh). A face's normal (b − a) × (c − a) points
//! from the cavity into the material: the way a positive pressure pushes.
//!
//! Volume: V(y) = 1/6 Σ_faces y_a · (y_b × y_c), the divergence theorem, exact for a
//! closed surface. An open face set (a membrane) encloses nothing; its ΔV is the volume
//! swept from rest: the enclosed volume of the closed polyhedron made of the deformed
//! faces, the rest faces reversed, and a band joining each rim edge at rest to the same
//! edge deformed (each band quad split in two triangles). For a closed surface the band is
//! empty and ΔV = V(x) − V(X). Either way ΔV does not depend on the origin.

use super::mesh::{cross, sub, Placement, TetMesh};
use super::model::{CavitySpec, Units};
use super::problem::MappedPoint;
use super::solve::Solver;
use super::surfaceio::read_triangles;
use super::{FemError, FemResult};
use crate::io::InFile;
use serde::Serialize;
use std::path::Path;

/// How a cavity is driven.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum CavityControl {
    /// Given pressure (Pa, > 0 inflates).
    Pressure(f64),
    /// Given volume change from rest (m^3); the pressure is solved for.
    Volume(f64),
}

/// An edge of an open face set's rim: its two cavity vertices, in the direction the face
/// that holds it runs, and their rest positions (m).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RimEdge {
    /// Cavity vertex indices (from, to).
    pub ends: [usize; 2],
    /// Their rest positions (m).
    pub rest: [[f64; 3]; 2],
}

/// A pressure cavity (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cavity {
    /// Name (for inputs and reports).
    pub name: String,
    /// The cavity's vertices, mapped to the mesh.
    pub vertices: Vec<MappedPoint>,
    /// Triangles over `vertices`, normals into the material.
    pub faces: Vec<[usize; 3]>,
    /// Rim edges (empty for a closed surface).
    pub rim: Vec<RimEdge>,
    /// 1/6 Σ y_a · (y_b × y_c) at rest (m^3): the rest volume of a closed cavity.
    pub rest_volume: f64,
    /// Pressure or volume control.
    pub control: CavityControl,
}

/// A 3x3 block of a second derivative, rows of one vertex, columns of another.
pub type Block = [[f64; 3]; 3];

/// s [c]×, the matrix of v ↦ s c × v.
fn skew(c: [f64; 3], s: f64) -> Block {
    [
        [0.0, -s * c[2], s * c[1]],
        [s * c[2], 0.0, -s * c[0]],
        [-s * c[1], s * c[0], 0.0],
    ]
}

fn triple(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let bc = cross(b, c);
    a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2]
}

impl Cavity {
    /// A cavity over `vertices` and `faces` with rest node positions `rest`; the rim is
    /// found from the faces. Refuses a face with an unknown or repeated vertex and an edge
    /// run twice the same way (faces not consistently oriented, or more than two faces on
    /// an edge).
    pub fn new(
        name: &str,
        vertices: Vec<MappedPoint>,
        faces: Vec<[usize; 3]>,
        rest: &[[f64; 3]],
        control: CavityControl,
    ) -> FemResult<Self> {
        let bad = |m: String| FemError::Model(format!("cavity {name:?}: {m}"));
        if faces.is_empty() {
            return Err(bad("has no face".into()));
        }
        let nv = vertices.len();
        if let Some(f) = faces
            .iter()
            .find(|f| f.iter().any(|&v| v >= nv) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
        {
            return Err(bad(format!("face {f:?} is invalid ({nv} vertices)")));
        }
        if let Some(v) = (vertices.iter().flat_map(|p| p.nodes)).find(|&n| n >= rest.len()) {
            return Err(bad(format!("refers to node {v} ({} nodes)", rest.len())));
        }
        let mut edges: Vec<[usize; 2]> = (faces.iter())
            .flat_map(|f| [[f[0], f[1]], [f[1], f[2]], [f[2], f[0]]])
            .collect();
        edges.sort_unstable();
        if let Some(e) = edges.windows(2).find(|w| w[0] == w[1]) {
            return Err(bad(format!(
                "edge {:?} is run twice the same way: faces not consistently oriented, or \
                 more than two faces on an edge",
                e[0]
            )));
        }
        let at_rest: Vec<[f64; 3]> = vertices.iter().map(|p| p.position(rest)).collect();
        let rim = (edges.iter())
            .filter(|e| edges.binary_search(&[e[1], e[0]]).is_err())
            .map(|&e| RimEdge {
                ends: e,
                rest: [at_rest[e[0]], at_rest[e[1]]],
            })
            .collect();
        let mut c = Self {
            name: name.to_string(),
            vertices,
            faces,
            rim,
            rest_volume: 0.0,
            control,
        };
        c.rest_volume = c.volume(rest);
        Ok(c)
    }

    /// Whether the faces close (no rim).
    pub fn is_closed(&self) -> bool {
        self.rim.is_empty()
    }

    /// The vertices' positions for node positions `x`.
    pub fn positions(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.vertices.iter().map(|p| p.position(x)).collect()
    }

    /// 1/6 Σ y_a · (y_b × y_c) over the faces at node positions `x` (m^3): the enclosed
    /// volume of a closed cavity (positive with normals into the material).
    pub fn volume(&self, x: &[[f64; 3]]) -> f64 {
        let y = self.positions(x);
        (self.faces.iter())
            .map(|f| triple(y[f[0]], y[f[1]], y[f[2]]))
            .sum::<f64>()
            / 6.0
    }

    /// The volume change from rest ΔV at node positions `x` (m^3): the actuator value.
    pub fn volume_change(&self, x: &[[f64; 3]]) -> f64 {
        let y = self.positions(x);
        let band: f64 = (self.rim.iter())
            .map(|e| {
                let (yi, yj) = (y[e.ends[0]], y[e.ends[1]]);
                let [ri, rj] = e.rest;
                triple(yj, yi, ri) + triple(yj, ri, rj)
            })
            .sum();
        self.volume(x) - self.rest_volume + band / 6.0
    }

    /// dΔV/dy for each cavity vertex at node positions `x` (m^2).
    pub fn vertex_gradient(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let y = self.positions(x);
        let mut g = vec![[0.0; 3]; y.len()];
        let mut add = |v: usize, d: [f64; 3]| {
            for k in 0..3 {
                g[v][k] += d[k] / 6.0;
            }
        };
        for &[a, b, c] in &self.faces {
            add(a, cross(y[b], y[c]));
            add(b, cross(y[c], y[a]));
            add(c, cross(y[a], y[b]));
        }
        for e in &self.rim {
            let [i, j] = e.ends;
            let [ri, rj] = e.rest;
            // Band triangles (y_j, y_i, X_i) and (y_j, X_i, X_j).
            add(j, cross(y[i], ri));
            add(i, cross(ri, y[j]));
            add(j, cross(ri, rj));
        }
        g
    }

    /// The actuator row dΔV/dx as (node, 3-vector) pairs, one per node, ascending (m^2).
    pub fn row(&self, x: &[[f64; 3]]) -> Vec<(usize, [f64; 3])> {
        let g = self.vertex_gradient(x);
        let mut out: Vec<(usize, [f64; 3])> = Vec::new();
        for (p, gv) in self.vertices.iter().zip(&g) {
            for (n, w) in p.nodes.iter().zip(p.weights) {
                if w != 0.0 {
                    out.push((*n, gv.map(|c| w * c)));
                }
            }
        }
        out.sort_unstable_by_key(|e| e.0);
        let mut merged: Vec<(usize, [f64; 3])> = Vec::with_capacity(out.len());
        for (n, v) in out {
            match merged.last_mut() {
                Some((m, acc)) if *m == n => (0..3).for_each(|k| acc[k] += v[k]),
                _ => merged.push((n, v)),
            }
        }
        merged
    }

    /// Calls `f(u, v, B)` for each nonzero block B = d²ΔV/dy_u dy_v (u ≠ v; the diagonal
    /// blocks are zero: ΔV is linear in each vertex of a face) at node positions `x`.
    pub fn for_each_hessian_block(&self, x: &[[f64; 3]], mut f: impl FnMut(usize, usize, Block)) {
        let y = self.positions(x);
        // d²(a · (b × c))/da db = −[c]×, and cyclically; the transposes for the swaps.
        let mut pair = |u: usize, v: usize, c: [f64; 3]| {
            f(u, v, skew(c, -1.0 / 6.0));
            f(v, u, skew(c, 1.0 / 6.0));
        };
        for &[a, b, c] in &self.faces {
            pair(a, b, y[c]);
            pair(b, c, y[a]);
            pair(c, a, y[b]);
        }
        for e in &self.rim {
            // y_j · (y_i × X_i): the only band term with a second derivative.
            pair(e.ends[1], e.ends[0], e.rest[0]);
        }
    }

    /// The mesh nodes of each face (up to 12), which the pressure's tangent couples.
    pub fn face_nodes(&self) -> Vec<Vec<usize>> {
        (self.faces.iter())
            .map(|f| {
                let mut n: Vec<usize> = (f.iter())
                    .flat_map(|&v| {
                        let p = &self.vertices[v];
                        p.nodes.into_iter().zip(p.weights).filter(|e| e.1 != 0.0)
                    })
                    .map(|e| e.0)
                    .collect();
                n.sort_unstable();
                n.dedup();
                n
            })
            .collect()
    }

    /// The net pressure force p dΔV/dx summed over the nodes, at positions `x` (N per Pa
    /// of p): zero for a closed cavity, which pushes on itself.
    pub fn net_gradient(&self, x: &[[f64; 3]]) -> [f64; 3] {
        let mut s = [0.0; 3];
        for (_, v) in self.row(x) {
            (0..3).for_each(|k| s[k] += v[k]);
        }
        s
    }

    /// The centroid of the rest vertices (m): where a cavity is drawn and named.
    pub fn rest_centroid(&self, rest: &[[f64; 3]]) -> [f64; 3] {
        let y = self.positions(rest);
        let mut c = [0.0; 3];
        for p in &y {
            (0..3).for_each(|k| c[k] += p[k] / y.len() as f64);
        }
        c
    }
}

/// Whether the faces of `cavity` point into the material, by their area-weighted normals
/// against `outward` (the mesh surface's outward normal at each node): a cavity's normal
/// points against the material's outward normal where both meet.
pub fn faces_point_inward(
    cavity: &Cavity,
    rest: &[[f64; 3]],
    outward: &[[f64; 3]],
) -> Option<bool> {
    let y = cavity.positions(rest);
    let mut score = 0.0;
    for &[a, b, c] in &cavity.faces {
        let n = cross(sub(y[b], y[a]), sub(y[c], y[a]));
        for &v in &[a, b, c] {
            let p = &cavity.vertices[v];
            for (node, w) in p.nodes.iter().zip(p.weights) {
                let o = outward[*node];
                score += w * (n[0] * o[0] + n[1] * o[1] + n[2] * o[2]);
            }
        }
    }
    (score != 0.0).then_some(score < 0.0)
}

/// Sets the control of each cavity named in `inputs` (unlisted cavities keep theirs); the
/// error names a cavity that is not there or is not given exactly one of pressure, volume.
pub fn apply_cavity_inputs(
    cavities: &mut [Cavity],
    inputs: &[crate::recording::CavityInput],
) -> FemResult<()> {
    for c in inputs {
        let cavity = (cavities.iter_mut())
            .find(|k| k.name == c.name)
            .ok_or_else(|| FemError::Model(format!("no cavity named {:?}", c.name)))?;
        cavity.control = match (c.pressure, c.volume) {
            (Some(p), None) if p.is_finite() => CavityControl::Pressure(p),
            (None, Some(v)) if v.is_finite() => CavityControl::Volume(v),
            _ => {
                return Err(FemError::Model(format!(
                    "cavity {:?}: give exactly one finite pressure or volume",
                    c.name
                )))
            }
        };
    }
    Ok(())
}

impl Solver<'_> {
    /// Adds the pressure's tangent −p d²ΔV/dx² of `cavity` under pressure `p` (Pa) at
    /// positions `x`: the residual's p dΔV/dx changes with x as the faces turn and stretch.
    pub fn add_cavity_stiffness(&mut self, cavity: &Cavity, p: f64, x: &[[f64; 3]]) {
        if p == 0.0 {
            return;
        }
        let (pattern, dofs, values) = (&self.pattern, &self.dofs, &mut self.values);
        cavity.for_each_hessian_block(x, |u, v, b| {
            let (pu, pv) = (&cavity.vertices[u], &cavity.vertices[v]);
            for (na, wa) in pu.nodes.iter().zip(pu.weights) {
                for (nb, wb) in pv.nodes.iter().zip(pv.weights) {
                    let s = -p * wa * wb;
                    if s != 0.0 {
                        pattern.add_block(dofs, *na, *nb, &b.map(|r| r.map(|c| s * c)), values);
                    }
                }
            }
        });
    }
}

/// Builds cavities from what a model file gives: a triangle list or mesh faces in a box.
impl Cavity {
    /// The cavity of the mesh's boundary faces whose three nodes lie in the box [lo, hi]
    /// (m), each face reversed so its normal points into the material.
    pub fn from_box(
        name: &str,
        mesh: &TetMesh,
        lo: [f64; 3],
        hi: [f64; 3],
        control: CavityControl,
    ) -> FemResult<Self> {
        let inside = |v: usize| {
            let p = mesh.nodes_in_rest[v];
            (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k])
        };
        let tris: Vec<[usize; 3]> = (mesh.surface().triangles.into_iter())
            .filter(|t| t.iter().all(|&v| inside(v)))
            .map(|[a, b, c]| [a, c, b])
            .collect();
        if tris.is_empty() {
            return Err(FemError::Model(format!(
                "cavity {name:?}: no boundary face of the mesh has its three nodes in the \
                 box {lo:?} - {hi:?} m"
            )));
        }
        let mut nodes: Vec<usize> = tris.iter().flatten().copied().collect();
        nodes.sort_unstable();
        nodes.dedup();
        let vertex = |v: usize| nodes.binary_search(&v).expect("a node of a face");
        let faces = tris.iter().map(|t| t.map(vertex)).collect();
        let vertices = nodes.iter().map(|&v| MappedPoint::node(v)).collect();
        Self::new(name, vertices, faces, &mesh.nodes_in_rest, control)
    }

    /// The cavity of the triangles `tris` (m, rest frame; corners shared between
    /// triangles merged when equal to the bit). Each corner within `snap` of a mesh node is
    /// that node; any other is mapped barycentrically into the tetrahedron containing it
    /// (or one within `tol` of it, as SOFA's `BarycentricMapping`). Faces are turned, all
    /// together, so their normals point into the material: a closed set by the sign of its
    /// volume, an open one against the mesh surface's outward normals. The error says how
    /// many triangles have a corner farther than `tol` from the mesh.
    pub fn from_triangles(
        name: &str,
        tris: &[[[f64; 3]; 3]],
        mesh: &TetMesh,
        snap: f64,
        tol: f64,
        control: CavityControl,
    ) -> FemResult<Self> {
        let mut index: std::collections::HashMap<[u64; 3], usize> = Default::default();
        let mut corners: Vec<[f64; 3]> = Vec::new();
        let mut faces: Vec<[usize; 3]> = Vec::new();
        for t in tris {
            let f = t.map(|p| {
                *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                    corners.push(p);
                    corners.len() - 1
                })
            });
            // A triangle collapsed by the file's rounding carries no area: left out.
            if f[0] != f[1] && f[1] != f[2] && f[0] != f[2] {
                faces.push(f);
            }
        }
        let surface = mesh.surface();
        let near_node = |p: [f64; 3]| {
            (surface.nodes.iter().copied())
                .map(|v| (v, super::mesh::norm(sub(mesh.nodes_in_rest[v], p))))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .filter(|(_, d)| *d <= snap)
                .map(|(v, _)| v)
        };
        let mapped: Vec<Option<MappedPoint>> = (corners.iter())
            .map(|&p| match near_node(p) {
                Some(v) => Some(MappedPoint::node(v)),
                None => MappedPoint::locate(mesh, p, tol).ok(),
            })
            .collect();
        let unmatched = (faces.iter())
            .filter(|f| f.iter().any(|&v| mapped[v].is_none()))
            .count();
        if unmatched > 0 {
            return Err(FemError::Model(format!(
                "cavity {name:?}: {unmatched} of {} triangles have a corner more than \
                 {tol:.3e} m from the volume mesh (is the surface in the mesh's units and \
                 placement?)",
                faces.len()
            )));
        }
        let vertices = mapped.into_iter().flatten().collect();
        let rest = &mesh.nodes_in_rest;
        let mut c = Self::new(name, vertices, faces, rest, control)?;
        let inward = match c.is_closed() {
            true => c.rest_volume > 0.0,
            false => faces_point_inward(&c, rest, &surface.vertex_normals).unwrap_or(true),
        };
        if !inward {
            let faces = c.faces.iter().map(|&[a, b, f]| [a, f, b]).collect();
            c = Self::new(name, c.vertices, faces, rest, control)?;
        }
        Ok(c)
    }
}

/// The cavity a model file's `[[cavities]]` entry gives, from its surface file or box; `tol` is how far (m) a surface corner
/// may lie outside the mesh.
pub(super) fn from_spec(
    c: &CavitySpec,
    mesh: &TetMesh,
    placement: &Placement,
    u: &Units,
    tol: f64,
) -> FemResult<Cavity> {
    let control = match (c.pressure, c.volume) {
        (Some(p), None) => CavityControl::Pressure(p * u.pressure),
        (None, Some(v)) => CavityControl::Volume(v * u.length.powi(3)),
        (None, None) => CavityControl::Pressure(0.0),
        _ => {
            return Err(FemError::Model(format!(
                "cavity {}: give pressure or volume, not both",
                c.name
            )))
        }
    };
    match (&c.surface, c.r#box) {
        (Some(s), None) => {
            let path = Path::new(s);
            let tris: Vec<_> = (read_triangles(path)?.iter())
                .map(|t| t.map(|p| placement.apply(p).map(|c| c * u.length)))
                .collect();
            // Corners this close to a node are that node (1e-3 of the 5% tolerance).
            Cavity::from_triangles(&c.name, &tris, mesh, 1e-3 * tol, tol, control)
                .map_err(|e| e.in_file(path))
        }
        (None, Some([lo, hi])) => {
            let (lo, hi) = (lo.map(|c| c * u.length), hi.map(|c| c * u.length));
            Cavity::from_box(&c.name, mesh, lo, hi, control)
        }
        _ => Err(FemError::Model(format!(
            "cavity {}: give exactly one of surface, box",
            c.name
        ))),
    }
}

//! Thin bodies as thin tetrahedral layers: a triangle surface ([`SurfaceMesh`], read by
//! [`crate::fem::meshio::read_surface`]) extruded along its vertex normals into `layers`
//! layers of prisms, each prism split into three tetrahedra.
//!
//! Why layers of linear tetrahedra, not a membrane element: the result is an ordinary
//! [`TetMesh`], so the compliance W = H K⁻¹ Hᵀ, `sense`, `markers`, `control` and
//! `explain` work on it unchanged. The cost is the bending locking of thin linear
//! tetrahedra, which stiffens bending, not stretching; a membrane carries its load by
//! stretching (docs/membrane.md measures it against Hencky's solution).
//!
//! The split is conforming: each prism's vertices are taken in ascending global index, so
//! the quad face two prisms share is cut along the same diagonal in both (from the top of
//! the lower-index node to the bottom of the higher-index one).
//!
//! ```
//! use softsense::fem::shell::{extrude, ShellParams, ShellSide, SurfaceMesh};
//! let surface = SurfaceMesh::disk(0.05, 4)?;
//! let shell = extrude(&surface, &ShellParams { thickness: 0.001, layers: 2, side: ShellSide::Outside, tension: 0.0 })?;
//! assert_eq!(shell.mesh.num_nodes(), 3 * surface.nodes.len());
//! assert_eq!(shell.marked.len(), 3 * surface.marked.len());
//! # Ok::<(), softsense::fem::FemError>(())
//! ```

use super::mesh::{signed_volume, TetMesh};
use super::{FemError, FemResult};
use crate::geometry::triangle::vertex_normals;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Most layers a shell may have.
pub const MAX_LAYERS: usize = 64;

/// A triangle surface with marked nodes (a clamped rim, say).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceMesh {
    /// Node positions (file units until a model converts them).
    pub nodes: Vec<[f64; 3]>,
    /// Triangles, consistently oriented: the outward side is the one the right-hand rule
    /// of (a, b, c) points to.
    pub triangles: Vec<[usize; 3]>,
    /// Marked nodes, ascending, without repeats.
    pub marked: Vec<usize>,
}

impl SurfaceMesh {
    /// Builds a surface, checking that nodes are finite, indices in range, no triangle
    /// repeats a node, and neighbouring triangles are oriented alike.
    pub fn new(
        nodes: Vec<[f64; 3]>,
        triangles: Vec<[usize; 3]>,
        mut marked: Vec<usize>,
    ) -> FemResult<Self> {
        let bad = |m: String| Err(FemError::InvalidMesh(m));
        if let Some(i) = nodes.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return bad(format!("node {i} is not finite"));
        }
        let n = nodes.len();
        // Each directed edge belongs to one triangle when orientations agree.
        let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v >= n) {
                return bad(format!("triangle {t} names node {v} of {n}"));
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                return bad(format!("triangle {t} repeats a node: {tri:?}"));
            }
            for k in 0..3 {
                let e = (tri[k], tri[(k + 1) % 3]);
                if let Some(other) = edges.insert(e, t) {
                    return bad(format!(
                        "triangles {other} and {t} both run edge {} -> {}: they are \
                         oriented opposite ways, or the edge has more than two triangles",
                        e.0, e.1
                    ));
                }
            }
        }
        marked.sort_unstable();
        marked.dedup();
        if let Some(&v) = marked.iter().find(|&&v| v >= n) {
            return bad(format!("marked node {v} of {n}"));
        }
        Ok(Self {
            nodes,
            triangles,
            marked,
        })
    }

    /// A flat disk of `radius` in the plane z = 0, centred at the origin, normal +z:
    /// `rings` rings of nodes, ring k holding 6k nodes at radius k/rings, triangulated
    /// ring to ring. The outer ring is marked (a clamped rim).
    pub fn disk(radius: f64, rings: usize) -> FemResult<Self> {
        if !(radius > 0.0) || rings == 0 {
            return Err(FemError::InvalidMesh(format!(
                "disk of radius {radius} with {rings} rings"
            )));
        }
        let mut nodes = vec![[0.0; 3]];
        // First node of each ring; ring 0 is the centre.
        let mut first = vec![0usize];
        for k in 1..=rings {
            first.push(nodes.len());
            let r = radius * k as f64 / rings as f64;
            for j in 0..6 * k {
                let a = std::f64::consts::TAU * j as f64 / (6 * k) as f64;
                nodes.push([r * a.cos(), r * a.sin(), 0.0]);
            }
        }
        let mut triangles = Vec::new();
        for k in 1..=rings {
            let inner: Vec<usize> = (0..6 * (k - 1)).map(|j| first[k - 1] + j).collect();
            let inner = if k == 1 { vec![0] } else { inner };
            let outer: Vec<usize> = (0..6 * k).map(|j| first[k] + j).collect();
            ring_strip(&nodes, &inner, &outer, &mut triangles);
        }
        let marked = (first[rings]..nodes.len()).collect();
        Self::new(nodes, triangles, marked)
    }
}

/// Triangulates the band between two closed rings of nodes sorted by angle (`inner` may be
/// a single centre node), advancing on the ring whose next node comes first in angle;
/// triangles are oriented counter-clockwise seen from +z.
fn ring_strip(nodes: &[[f64; 3]], inner: &[usize], outer: &[usize], out: &mut Vec<[usize; 3]>) {
    let angle = |v: usize, step: usize, len: usize| -> f64 {
        // Angle of the node, unwrapped past the start for the closing triangles.
        let a = nodes[v][1]
            .atan2(nodes[v][0])
            .rem_euclid(std::f64::consts::TAU);
        if step == len && a < 1e-9 {
            std::f64::consts::TAU
        } else {
            a
        }
    };
    let (ni, no) = (inner.len(), outer.len());
    let from = out.len();
    // A centre node never advances: the band is a fan.
    let (mut i, mut o) = (usize::from(ni == 1), 0);
    while i < ni || o < no {
        let (vi, vo) = (inner[i % ni], outer[o % no]);
        let next_i = angle(inner[(i + 1) % ni], i + 1, ni);
        let next_o = angle(outer[(o + 1) % no], o + 1, no);
        if o < no && (i >= ni || next_o <= next_i) {
            out.push([vi, vo, outer[(o + 1) % no]]);
            o += 1;
        } else {
            out.push([vi, vo, inner[(i + 1) % ni]]);
            i += 1;
        }
    }
    for t in &mut out[from..] {
        let [a, b, c] = t.map(|v| nodes[v]);
        let z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if z < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// Which side of the surface the layers grow on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ShellSide {
    /// Along the outward normal: the surface is the shell's inner face.
    #[default]
    Outside,
    /// Against the outward normal: the surface is the shell's outer face.
    Inside,
    /// Half each way: the surface is the shell's mid-surface.
    Centred,
}

/// How a surface becomes a shell (the model file's `[mesh] shell` table).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ShellParams {
    /// Total thickness (length unit of the surface's nodes; the model file's length unit
    /// after placement).
    pub thickness: f64,
    /// Layers of tetrahedra through the thickness (1 to [`MAX_LAYERS`]; default 1).
    #[serde(default = "one")]
    pub layers: usize,
    /// The side the layers grow on (default outside).
    #[serde(default)]
    pub side: ShellSide,
    /// In-plane pre-tension of an inflated membrane (force per length: N/m, which is also
    /// mN/mm under mm-kg-s; default 0): its stiffening ([`super::prestress`]), linear
    /// about the rest shape.
    #[serde(default)]
    pub tension: f64,
}

fn one() -> usize {
    1
}

/// A tetrahedral mesh with the nodes its file marks (vertex cells). Extruded from a
/// surface of `n` nodes, node `k * n + i` is surface node `i` moved to layer `k` (0
/// innermost along the normal), and every layer copy of a marked node is marked.
#[derive(Debug, Clone)]
pub struct MarkedMesh {
    /// The mesh.
    pub mesh: TetMesh,
    /// Marked nodes, ascending.
    pub marked: Vec<usize>,
}

/// The body a model file's `[mesh]` names: the file's tetrahedra, or with `shell` its
/// triangle surface extruded. `length_scale` is the placement's scale, applied after this:
/// the thickness is divided by it so that the placed shell has the thickness given.
pub fn read_body(
    path: &std::path::Path,
    shell: Option<&ShellParams>,
    length_scale: f64,
) -> FemResult<MarkedMesh> {
    let cells = super::meshio::read_cells(path)?;
    let in_file = |e: FemError| crate::io::InFile::in_file(e, path);
    match shell {
        None => {
            let marked = cells.marked.clone();
            let mesh = cells.into_tet_mesh().map_err(in_file)?;
            Ok(MarkedMesh { mesh, marked })
        }
        Some(p) => {
            let surface = cells.into_surface().map_err(in_file)?;
            let p = ShellParams {
                thickness: p.thickness / length_scale.abs(),
                ..*p
            };
            extrude(&surface, &p).map_err(in_file)
        }
    }
}

/// Extrudes `surface` into `params.layers` layers of total `params.thickness` along its
/// area-weighted vertex normals.
pub fn extrude(surface: &SurfaceMesh, params: &ShellParams) -> FemResult<MarkedMesh> {
    let (t, layers) = (params.thickness, params.layers);
    if !(t > 0.0 && t.is_finite() && (1..=MAX_LAYERS).contains(&layers)) {
        return Err(FemError::Model(format!(
            "shell thickness {t} and layers {layers}: the thickness must be positive and \
             the layers 1 to {MAX_LAYERS}"
        )));
    }
    let n = surface.nodes.len();
    let normals = vertex_normals(&surface.nodes, &surface.triangles);
    if let Some(i) = normals.iter().position(|v| *v == [0.0; 3]) {
        return Err(FemError::InvalidMesh(format!(
            "surface node {i} is on no triangle (or its triangles' normals cancel): it \
             has no direction to extrude along"
        )));
    }
    let start = match params.side {
        ShellSide::Outside => 0.0,
        ShellSide::Inside => -t,
        ShellSide::Centred => -0.5 * t,
    };
    let mut nodes = Vec::with_capacity(n * (layers + 1));
    for k in 0..=layers {
        let h = start + t * k as f64 / layers as f64;
        nodes.extend(
            (surface.nodes.iter().zip(&normals))
                .map(|(p, d)| [p[0] + h * d[0], p[1] + h * d[1], p[2] + h * d[2]]),
        );
    }
    let mut tets = Vec::with_capacity(3 * layers * surface.triangles.len());
    for k in 0..layers {
        for tri in &surface.triangles {
            tets.extend(prism_tets(*tri, k * n, (k + 1) * n));
        }
    }
    for (e, tet) in tets.iter().enumerate() {
        let v = signed_volume(nodes[tet[0]], nodes[tet[1]], nodes[tet[2]], nodes[tet[3]]);
        // Not re-oriented: a negative volume means the layers fold over (a shell thicker
        // than the surface's radius of curvature on the inside, or a bad normal).
        if !(v > 0.0) {
            return Err(FemError::InvertedElement { tet: e, volume: v });
        }
    }
    let marked = (0..=layers)
        .flat_map(|k| surface.marked.iter().map(move |&m| k * n + m))
        .collect();
    Ok(MarkedMesh {
        mesh: TetMesh::new(nodes, tets)?,
        marked,
    })
}

/// The three tetrahedra of the prism over triangle `tri` between the layers whose nodes
/// start at `bottom` and `top`, positively oriented when the top lies on the triangle's
/// outward side.
fn prism_tets(tri: [usize; 3], bottom: usize, top: usize) -> [[usize; 4]; 3] {
    let mut v = tri;
    v.sort_unstable();
    // Sorting is a rotation of (a, b, c) (orientation kept) or a rotation and a swap.
    let kept = [0, 1, 2].iter().any(|&r| {
        let rot = [tri[r], tri[(r + 1) % 3], tri[(r + 2) % 3]];
        rot == v
    });
    let [a, b, c] = v.map(|i| bottom + i);
    let [a2, b2, c2] = v.map(|i| top + i);
    let mut tets = [[a, b, c, a2], [b, c, a2, b2], [c, a2, b2, c2]];
    if !kept {
        // The sorted triangle faces inward: one swap per tetrahedron restores the sign.
        for t in &mut tets {
            t.swap(0, 1);
        }
    }
    tets
}

/// The in-plane pre-tension `tension` (N/m) of every tetrahedron of a shell `thickness`
/// (m) thick, extruded by [`extrude`] from a surface of `mesh.num_nodes() / (layers + 1)`
/// nodes: each tetrahedron's plane is that of the triangle it was extruded from (its
/// nodes' surface indices), read from `mesh` as placed.
pub fn shell_prestress(
    mesh: &TetMesh,
    layers: usize,
    tension: f64,
    thickness: f64,
) -> FemResult<Vec<super::prestress::Stress>> {
    let n = mesh.num_nodes() / (layers + 1);
    if n == 0 || n * (layers + 1) != mesh.num_nodes() {
        return Err(FemError::Model(format!(
            "a shell of {layers} layers cannot have {} nodes",
            mesh.num_nodes()
        )));
    }
    let x = &mesh.nodes_in_rest;
    mesh.tets
        .iter()
        .enumerate()
        .map(|(e, tet)| {
            let mut tri: Vec<usize> = tet.iter().map(|&v| v % n).collect();
            tri.sort_unstable();
            tri.dedup();
            if tri.len() != 3 {
                return Err(FemError::Model(format!(
                    "tetrahedron {e} is not one of a shell's prisms (surface nodes {tri:?})"
                )));
            }
            let (a, b, c) = (x[tri[0]], x[tri[1]], x[tri[2]]);
            let normal = super::mesh::cross(super::mesh::sub(b, a), super::mesh::sub(c, a));
            Ok(super::prestress::in_plane_tension(
                tension, thickness, normal,
            ))
        })
        .collect()
}

/// `problem` with its shell's surface node `i` moved by `d` for each `(i, d)` of `moves`
/// (every layer copy of the node moves with it) and its pre-tension taken again on the
/// moved planes: a measured rest shape in place of the mesh file's. Refused for a problem
/// that is not a shell, or whose cables, cavities or loads were placed on the old shape.
pub fn move_surface(
    problem: &super::problem::Problem,
    moves: &[(usize, [f64; 3])],
) -> FemResult<super::problem::Problem> {
    let Some(shell) = problem.shell else {
        return Err(FemError::Model(
            "only a shell's surface can be moved (the model has no [mesh] shell)".into(),
        ));
    };
    if !(problem.cables.is_empty() && problem.cavities.is_empty() && problem.loads.is_empty()) {
        return Err(FemError::Model(
            "a shell with cables, cavities or loads keeps its mesh file's rest shape \
             (they were placed on it)"
                .into(),
        ));
    }
    let total = problem.mesh.num_nodes();
    let n = total / (shell.layers + 1);
    let mut nodes = problem.mesh.nodes_in_rest.clone();
    for &(i, d) in moves {
        if i >= n {
            return Err(FemError::Model(format!(
                "surface node {i} is not one of the shell's {n} surface nodes"
            )));
        }
        for k in 0..=shell.layers {
            let p = &mut nodes[k * n + i];
            *p = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
        }
    }
    let mesh = TetMesh::new(nodes, problem.mesh.tets.clone())?;
    for (e, tet) in mesh.tets.iter().enumerate() {
        let x = &mesh.nodes_in_rest;
        let v = signed_volume(x[tet[0]], x[tet[1]], x[tet[2]], x[tet[3]]);
        if !(v > 0.0) {
            return Err(FemError::InvertedElement { tet: e, volume: v });
        }
    }
    let mut moved = problem.clone();
    if shell.tension != 0.0 {
        moved.prestress = shell_prestress(&mesh, shell.layers, shell.tension, shell.thickness)?;
    }
    moved.mesh = mesh;
    Ok(moved)
}

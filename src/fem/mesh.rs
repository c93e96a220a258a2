//! Tetrahedral meshes: validation, quality report, boundary surface, placement, point location.

use super::{FemError, FemResult};
use serde::{Deserialize, Serialize};

/// Relative volume below which a tetrahedron is degenerate (times the mean edge length cubed).
pub const DEGENERATE_REL_VOLUME: f64 = 1e-12;

/// A linear tetrahedral mesh in its rest configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct TetMesh {
    /// Node positions at rest.
    pub nodes_in_rest: Vec<[f64; 3]>,
    /// Tetrahedra as four node indices (positive orientation: (b-a)x(c-a).(d-a) > 0).
    pub tets: Vec<[usize; 4]>,
}

/// Quality of a mesh: signed volumes and their extremes.
#[derive(Debug, Clone, Serialize)]
pub struct QualityReport {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of tetrahedra.
    pub tets: usize,
    /// Total volume.
    pub volume: f64,
    /// Smallest signed volume.
    pub min_volume: f64,
    /// Largest signed volume.
    pub max_volume: f64,
    /// Smallest radius-ratio-like shape measure (volume / mean edge^3 scaled to 1 for a regular tet).
    pub min_shape: f64,
    /// Index of the worst-shaped tetrahedron.
    pub worst_tet: usize,
    /// Smallest dihedral angle of any tetrahedron (degrees; 70.5 for a regular one).
    pub min_dihedral_deg: f64,
    /// Largest dihedral angle of any tetrahedron (degrees).
    pub max_dihedral_deg: f64,
    /// Largest circumradius-to-shortest-edge ratio (TetGen's radius-edge ratio; 0.612 for
    /// a regular tetrahedron, unbounded for slivers' neighbours, caps and needles).
    pub max_radius_edge: f64,
    /// Axis-aligned bounding box [min, max].
    pub bbox: [[f64; 3]; 2],
}

/// The boundary surface of a tetrahedral mesh.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Boundary triangles (node indices into the volume mesh), oriented outward.
    pub triangles: Vec<[usize; 3]>,
    /// The tetrahedron each triangle belongs to.
    pub tet_of_triangle: Vec<usize>,
    /// Nodes on the surface, ascending.
    pub nodes: Vec<usize>,
    /// Area-weighted unit normals per volume node (zero for interior nodes).
    pub vertex_normals: Vec<[f64; 3]>,
}

/// A rigid placement with scale: x' = R (s x) + t, rotations applied in the listed order.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Placement {
    /// Uniform scale applied first (1 if absent), e.g. 0.001 for mm to m.
    pub scale: Option<f64>,
    /// Rotations in degrees about the x, y, z axes, applied in the order x, y, z.
    pub rotate_deg: Option<[f64; 3]>,
    /// Translation applied last.
    pub translate: Option<[f64; 3]>,
}

impl Placement {
    /// Applies the placement to a point.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let s = self.scale.unwrap_or(1.0);
        let mut q = [p[0] * s, p[1] * s, p[2] * s];
        if let Some(r) = self.rotate_deg {
            for (axis, deg) in r.iter().enumerate() {
                if *deg != 0.0 {
                    q = rotate_axis(q, axis, deg.to_radians());
                }
            }
        }
        if let Some(t) = self.translate {
            q = [q[0] + t[0], q[1] + t[1], q[2] + t[2]];
        }
        q
    }
}

fn rotate_axis(p: [f64; 3], axis: usize, a: f64) -> [f64; 3] {
    let (s, c) = a.sin_cos();
    match axis {
        0 => [p[0], c * p[1] - s * p[2], s * p[1] + c * p[2]],
        1 => [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]],
        _ => [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]],
    }
}

pub(crate) use crate::math::{cross, dot, norm, sub};

/// Signed volume of the tetrahedron (a, b, c, d).
pub fn signed_volume(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    dot(cross(sub(b, a), sub(c, a)), sub(d, a)) / 6.0
}

impl TetMesh {
    /// Builds a mesh, checking that it is non-empty, finite and that indices are in range.
    pub fn new(nodes_in_rest: Vec<[f64; 3]>, tets: Vec<[usize; 4]>) -> FemResult<Self> {
        if nodes_in_rest.is_empty() || tets.is_empty() {
            return Err(FemError::InvalidMesh(format!(
                "{} nodes and {} tetrahedra",
                nodes_in_rest.len(),
                tets.len()
            )));
        }
        if let Some(i) = nodes_in_rest
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(FemError::InvalidMesh(format!("node {i} is not finite")));
        }
        let n = nodes_in_rest.len();
        for (t, tet) in tets.iter().enumerate() {
            for &v in tet {
                if v >= n {
                    return Err(FemError::BadIndex {
                        tet: t,
                        node: v,
                        nodes: n,
                    });
                }
            }
            if (0..4).any(|i| (i + 1..4).any(|j| tet[i] == tet[j])) {
                return Err(FemError::DegenerateElement {
                    tet: t,
                    volume: 0.0,
                });
            }
        }
        Ok(Self {
            nodes_in_rest,
            tets,
        })
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes_in_rest.len()
    }

    /// Corner positions of tetrahedron `t` at rest.
    pub fn corners(&self, t: usize) -> [[f64; 3]; 4] {
        self.tets[t].map(|v| self.nodes_in_rest[v])
    }

    /// Signed rest volume of every tetrahedron.
    pub fn signed_volumes(&self) -> Vec<f64> {
        (0..self.tets.len())
            .map(|t| {
                let [a, b, c, d] = self.corners(t);
                signed_volume(a, b, c, d)
            })
            .collect()
    }

    /// The quality report; inverted or degenerate tetrahedra are errors naming the element.
    pub fn quality(&self) -> FemResult<QualityReport> {
        let mut rep = QualityReport {
            nodes: self.num_nodes(),
            tets: self.tets.len(),
            volume: 0.0,
            min_volume: f64::INFINITY,
            max_volume: f64::NEG_INFINITY,
            min_shape: f64::INFINITY,
            worst_tet: 0,
            min_dihedral_deg: f64::INFINITY,
            max_dihedral_deg: f64::NEG_INFINITY,
            max_radius_edge: 0.0,
            bbox: self.bbox(),
        };
        // A regular tetrahedron of edge l has volume l^3 / (6 sqrt 2).
        let regular = 1.0 / (6.0 * std::f64::consts::SQRT_2);
        for t in 0..self.tets.len() {
            let c = self.corners(t);
            let v = signed_volume(c[0], c[1], c[2], c[3]);
            let mut edge = 0.0;
            for i in 0..4 {
                for j in i + 1..4 {
                    edge += norm(sub(c[i], c[j]));
                }
            }
            let l = edge / 6.0;
            let shape = v / (l * l * l) / regular;
            if !(shape.abs() > DEGENERATE_REL_VOLUME) {
                return Err(FemError::DegenerateElement { tet: t, volume: v });
            }
            if v < 0.0 {
                return Err(FemError::InvertedElement { tet: t, volume: v });
            }
            rep.volume += v;
            rep.min_volume = rep.min_volume.min(v);
            rep.max_volume = rep.max_volume.max(v);
            if shape < rep.min_shape {
                rep.min_shape = shape;
                rep.worst_tet = t;
            }
            let [lo, hi] = super::tet_quality::dihedral_range_deg(&c);
            rep.min_dihedral_deg = rep.min_dihedral_deg.min(lo);
            rep.max_dihedral_deg = rep.max_dihedral_deg.max(hi);
            rep.max_radius_edge = rep.max_radius_edge.max(super::tet_quality::radius_edge(&c));
        }
        Ok(rep)
    }

    /// Swaps two nodes of every negatively oriented tetrahedron so all volumes are positive.
    pub fn orient_positive(&mut self) {
        for t in 0..self.tets.len() {
            let [a, b, c, d] = self.corners(t);
            if signed_volume(a, b, c, d) < 0.0 {
                self.tets[t].swap(2, 3);
            }
        }
    }

    /// Axis-aligned bounding box [min, max] of the rest nodes.
    pub fn bbox(&self) -> [[f64; 3]; 2] {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.nodes_in_rest {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        [lo, hi]
    }

    /// Applies a placement to all rest nodes (orientation is kept positive).
    pub fn place(&mut self, placement: &Placement) {
        for p in &mut self.nodes_in_rest {
            *p = placement.apply(*p);
        }
        if placement.scale.is_some_and(|s| s < 0.0) {
            self.orient_positive();
        }
    }

    /// The boundary surface: faces used by exactly one tetrahedron, oriented outward
    /// (assuming positively oriented tetrahedra), with area-weighted vertex normals.
    pub fn surface(&self) -> Surface {
        // Outward faces of a positive tetrahedron (a, b, c, d).
        const FACES: [[usize; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let mut faces: Vec<([usize; 3], [usize; 3], usize)> =
            Vec::with_capacity(4 * self.tets.len());
        for (t, tet) in self.tets.iter().enumerate() {
            for f in FACES {
                let tri = [tet[f[0]], tet[f[1]], tet[f[2]]];
                let mut key = tri;
                key.sort_unstable();
                faces.push((key, tri, t));
            }
        }
        faces.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.2.cmp(&b.2)));
        let mut triangles = Vec::new();
        let mut tet_of_triangle = Vec::new();
        let mut i = 0;
        while i < faces.len() {
            let mut j = i + 1;
            while j < faces.len() && faces[j].0 == faces[i].0 {
                j += 1;
            }
            if j - i == 1 {
                triangles.push(faces[i].1);
                tet_of_triangle.push(faces[i].2);
            }
            i = j;
        }
        let mut vertex_normals = vec![[0.0; 3]; self.num_nodes()];
        let mut on = vec![false; self.num_nodes()];
        for tri in &triangles {
            let [a, b, c] = tri.map(|v| self.nodes_in_rest[v]);
            let n = cross(sub(b, a), sub(c, a)); // |n| = 2 * area
            for &v in tri {
                on[v] = true;
                for k in 0..3 {
                    vertex_normals[v][k] += n[k];
                }
            }
        }
        for n in &mut vertex_normals {
            let l = norm(*n);
            if l > 0.0 {
                *n = n.map(|c| c / l);
            }
        }
        let nodes = (0..self.num_nodes()).filter(|&v| on[v]).collect();
        Surface {
            triangles,
            tet_of_triangle,
            nodes,
            vertex_normals,
        }
    }

    /// Barycentric coordinates of `p` in tetrahedron `t` (rest shape).
    pub fn barycentric(&self, t: usize, p: [f64; 3]) -> [f64; 4] {
        let [a, b, c, d] = self.corners(t);
        let v = signed_volume(a, b, c, d);
        let l0 = signed_volume(p, b, c, d) / v;
        let l1 = signed_volume(a, p, c, d) / v;
        let l2 = signed_volume(a, b, p, d) / v;
        [l0, l1, l2, 1.0 - l0 - l1 - l2]
    }

    /// Locates `p`: the tetrahedron containing it (or, for a point just outside, the one
    /// it is least outside of, with extrapolated coordinates as SOFA's barycentric mapping).
    /// Points farther than `max_distance` from the mesh are an error.
    pub fn locate(&self, p: [f64; 3], max_distance: f64) -> FemResult<(usize, [f64; 4])> {
        let mut best = (0usize, [0.0; 4], f64::NEG_INFINITY);
        for t in 0..self.tets.len() {
            let l = self.barycentric(t, p);
            let m = l.iter().copied().fold(f64::INFINITY, f64::min);
            if m > best.2 {
                best = (t, l, m);
                if m >= 0.0 {
                    break;
                }
            }
        }
        if best.2 < 0.0 {
            // Distance to the clamped barycentric point of the best tetrahedron.
            let mut l = best.1.map(|x| x.max(0.0));
            let s: f64 = l.iter().sum();
            l = l.map(|x| x / s);
            let c = self.corners(best.0);
            let mut q = [0.0; 3];
            for (i, ci) in c.iter().enumerate() {
                for k in 0..3 {
                    q[k] += l[i] * ci[k];
                }
            }
            let distance = norm(sub(p, q));
            if !(distance <= max_distance) {
                return Err(FemError::PointOutside { point: p, distance });
            }
        }
        Ok((best.0, best.1))
    }

    /// A structured mesh of the box [lo, hi] with n cells per axis, each cube split into
    /// the six Kuhn tetrahedra (conforming). Nodes are numbered x fastest, then y, then z.
    pub fn structured_box(lo: [f64; 3], hi: [f64; 3], n: [usize; 3]) -> FemResult<Self> {
        Self::structured_box_with(lo, hi, n, false)
    }

    /// As [`TetMesh::structured_box`]; with `mirrored`, every other cube along each axis is
    /// the mirror image of its neighbour (still conforming), which removes the single
    /// preferred diagonal direction of the plain Kuhn pattern.
    pub fn structured_box_with(
        lo: [f64; 3],
        hi: [f64; 3],
        n: [usize; 3],
        mirrored: bool,
    ) -> FemResult<Self> {
        if n.iter().any(|&k| k == 0 || k > 1000) || (0..3).any(|k| !(hi[k] > lo[k])) {
            return Err(FemError::InvalidMesh(format!(
                "box {lo:?}..{hi:?} with {n:?} cells"
            )));
        }
        let mut nodes = Vec::with_capacity((n[0] + 1) * (n[1] + 1) * (n[2] + 1));
        for k in 0..=n[2] {
            for j in 0..=n[1] {
                for i in 0..=n[0] {
                    let f = |a: usize, m: usize, d: usize| {
                        lo[d] + (hi[d] - lo[d]) * a as f64 / m as f64
                    };
                    nodes.push([f(i, n[0], 0), f(j, n[1], 1), f(k, n[2], 2)]);
                }
            }
        }
        let tets = kuhn_tets(n, |c| c.map(|i| i % 2 == 1 && mirrored));
        let mut mesh = Self::new(nodes, tets)?;
        mesh.orient_positive();
        Ok(mesh)
    }

    /// A solid circular cylinder along +x from the origin: `length` (m) in `along` slices,
    /// radius (m) with `across` cells over the diameter. Each slice is a square grid mapped
    /// onto the disc (x' = x √(1 − y²/2), y' = y √(1 − x²/2) on [−1, 1]²), and each cube is
    /// split into six Kuhn tetrahedra whose shared diagonal runs outward, so that no
    /// tetrahedron has its face on the three nearly collinear rim points of a corner cell.
    /// Nodes are numbered as [`TetMesh::structured_box`]'s, x (along the axis) fastest.
    pub fn cylinder(radius: f64, length: f64, across: usize, along: usize) -> FemResult<Self> {
        let ok = |k: usize| (1..=1000).contains(&k);
        let sizes = radius > 0.0 && length > 0.0 && radius.is_finite() && length.is_finite();
        if !(sizes && ok(across) && ok(along)) {
            return Err(FemError::InvalidMesh(format!(
                "cylinder of radius {radius} m, length {length} m, {across} cells across, {along} along"
            )));
        }
        let unit = |j: usize| 2.0 * j as f64 / across as f64 - 1.0;
        let mut nodes = Vec::with_capacity((along + 1) * (across + 1) * (across + 1));
        for k in 0..=across {
            for j in 0..=across {
                for i in 0..=along {
                    let (u, v) = (unit(j), unit(k));
                    let y = radius * u * (1.0 - 0.5 * v * v).sqrt();
                    let z = radius * v * (1.0 - 0.5 * u * u).sqrt();
                    nodes.push([length * i as f64 / along as f64, y, z]);
                }
            }
        }
        // Mirror the cells on the negative side of each transverse axis, so the diagonal
        // of every cell points away from the axis (mirror images stay conforming).
        let negative = |j: usize| 2 * j + 1 < across;
        let tets = kuhn_tets([along, across, across], |c| {
            [false, negative(c[1]), negative(c[2])]
        });
        let mut mesh = Self::new(nodes, tets)?;
        mesh.orient_positive();
        Ok(mesh)
    }

    /// Nodes inside the axis-aligned box [lo, hi] (inclusive).
    pub fn nodes_in_box(&self, lo: [f64; 3], hi: [f64; 3]) -> Vec<usize> {
        (0..self.num_nodes())
            .filter(|&v| {
                let p = self.nodes_in_rest[v];
                (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k])
            })
            .collect()
    }
}

/// The six Kuhn tetrahedra of every cube of an n[0] × n[1] × n[2] grid of nodes numbered
/// x fastest; `flip` says per cube which local axes are mirrored.
fn kuhn_tets(n: [usize; 3], flip: impl Fn([usize; 3]) -> [bool; 3]) -> Vec<[usize; 4]> {
    let id = |i: usize, j: usize, k: usize| i + (n[0] + 1) * (j + (n[1] + 1) * k);
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut tets = Vec::with_capacity(6 * n[0] * n[1] * n[2]);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let flip = flip([i, j, k]);
                // Local corner offsets (0/1 per axis), mirrored per axis as asked.
                let corner = |o: [usize; 3]| {
                    let o = [0, 1, 2].map(|a| if flip[a] { 1 - o[a] } else { o[a] });
                    id(i + o[0], j + o[1], k + o[2])
                };
                for perm in PERMS {
                    let mut o = [0usize; 3];
                    let mut t = [corner(o); 4];
                    for (s, ax) in perm.iter().enumerate() {
                        o[*ax] = 1;
                        t[s + 1] = corner(o);
                    }
                    tets.push(t);
                }
            }
        }
    }
    tets
}

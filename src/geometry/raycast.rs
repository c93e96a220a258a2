//! A small ray caster: a bounding-volume hierarchy over triangles (median split on the
//! longest axis), plus spheres and planes.

/// A ray hit: distance along the ray and the (unnormalised) geometric normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter t (distance for a unit direction).
    pub t: f64,
    /// Unit surface normal at the hit (facing the outside of the object).
    pub normal: [f64; 3],
}

use crate::math::{cross, dot, sub, unit};

/// Ray-triangle intersection (Möller-Trumbore), both sides; returns t > `t_min`.
pub fn ray_triangle(o: [f64; 3], d: [f64; 3], tri: [[f64; 3]; 3], t_min: f64) -> Option<f64> {
    ray_triangle_edges(o, d, &Edges::of(tri), t_min)
}

/// A triangle as its first vertex and the two edges from it: what every ray test needs,
/// computed once per triangle instead of once per test (the same values, so the same hits).
#[derive(Clone, Copy, Debug)]
struct Edges {
    v0: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

impl Edges {
    fn of(tri: [[f64; 3]; 3]) -> Self {
        Self {
            v0: tri[0],
            e1: sub(tri[1], tri[0]),
            e2: sub(tri[2], tri[0]),
        }
    }
}

#[inline]
fn ray_triangle_edges(o: [f64; 3], d: [f64; 3], tri: &Edges, t_min: f64) -> Option<f64> {
    let p = cross(d, tri.e2);
    let det = dot(tri.e1, p);
    if det.abs() < 1e-18 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri.v0);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, tri.e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot(tri.e2, q) * inv;
    (t > t_min).then_some(t)
}

/// Ray-sphere intersection: the nearest t > 0 and the outward normal.
pub fn ray_sphere(o: [f64; 3], d: [f64; 3], center: [f64; 3], radius: f64) -> Option<Hit> {
    let oc = sub(o, center);
    let a = dot(d, d);
    let b = dot(oc, d);
    let c = dot(oc, oc) - radius * radius;
    let disc = b * b - a * c;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t = [(-b - s) / a, (-b + s) / a]
        .into_iter()
        .find(|t| *t > 0.0)?;
    let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
    Some(Hit {
        t,
        normal: unit(sub(p, center)),
    })
}

/// Ray-plane intersection for the plane n·x = offset within a square of half side
/// `half` around the origin's projection; the normal faces the ray origin.
pub fn ray_plane(o: [f64; 3], d: [f64; 3], n: [f64; 3], offset: f64, half: f64) -> Option<Hit> {
    let dn = dot(d, n);
    if dn.abs() < 1e-15 {
        return None;
    }
    let t = (offset - dot(o, n)) / dn;
    if t <= 0.0 {
        return None;
    }
    let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
    let inplane = sub(p, n.map(|c| c * offset));
    if inplane.iter().any(|c| c.abs() > half) {
        return None;
    }
    let normal = if dn < 0.0 { n } else { n.map(|c| -c) };
    Some(Hit { t, normal })
}

#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Aabb {
    fn empty() -> Self {
        Self {
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        }
    }
    fn grow(&mut self, p: [f64; 3]) {
        for (k, c) in p.iter().enumerate() {
            self.lo[k] = self.lo[k].min(*c);
            self.hi[k] = self.hi[k].max(*c);
        }
    }
    /// Slab test: entry distance if the ray hits the box before `t_max`.
    fn hit(&self, o: [f64; 3], inv_d: [f64; 3], t_max: f64) -> Option<f64> {
        let mut t0 = 0.0f64;
        let mut t1 = t_max;
        for k in 0..3 {
            let a = (self.lo[k] - o[k]) * inv_d[k];
            let b = (self.hi[k] - o[k]) * inv_d[k];
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return None;
            }
        }
        Some(t0)
    }
}

#[derive(Clone, Debug)]
struct Node {
    bbox: Aabb,
    /// Leaf: start..end into the triangles; inner: children indices.
    start: u32,
    end: u32,
    children: Option<(u32, u32)>,
}

/// A BVH over triangles given by vertex positions and index triples.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// The triangles in leaf order, so a leaf's are adjacent in memory.
    tris: Vec<Edges>,
    /// Their vertex indices, for [`Bvh::refit`].
    indices: Vec<[usize; 3]>,
    /// Index of each of `tris` in the triangles given to [`Bvh::new`].
    source: Vec<usize>,
    nodes: Vec<Node>,
}

const LEAF: usize = 4;

/// The nodes still to visit by one ray, with the distance at which it enters each: on the
/// stack, since a frame casts thousands of rays. Median splits halve the triangles at each
/// level, so a walk holds at most log2(triangles) + 2 entries, below 64 for any mesh that
/// fits in memory.
struct NodeStack {
    items: [(u32, f64); 64],
    len: usize,
}

impl Default for NodeStack {
    fn default() -> Self {
        Self {
            items: [(0, 0.0); 64],
            len: 0,
        }
    }
}

impl NodeStack {
    fn push(&mut self, item: (u32, f64)) {
        self.items[self.len] = item;
        self.len += 1;
    }

    fn pop(&mut self) -> Option<(u32, f64)> {
        self.len = self.len.checked_sub(1)?;
        Some(self.items[self.len])
    }
}

/// The hierarchy under construction: `order` is permuted in place by the median splits.
struct Build<'a> {
    tris: &'a [[[f64; 3]; 3]],
    centroids: &'a [[f64; 3]],
    order: Vec<usize>,
    nodes: Vec<Node>,
}

impl Build<'_> {
    fn node(&mut self, start: usize, end: usize) -> u32 {
        let c = self.centroids;
        let mut bbox = Aabb::empty();
        let mut cbox = Aabb::empty();
        for &i in &self.order[start..end] {
            for p in self.tris[i] {
                bbox.grow(p);
            }
            cbox.grow(c[i]);
        }
        let id = self.nodes.len();
        self.nodes.push(Node {
            bbox,
            start: start as u32,
            end: end as u32,
            children: None,
        });
        if end - start > LEAF {
            let ext = [0, 1, 2].map(|k| cbox.hi[k] - cbox.lo[k]);
            let axis = (0..3).fold(0, |b, k| if ext[k] > ext[b] { k } else { b });
            if ext[axis] > 0.0 {
                let mid = (start + end) / 2;
                self.order[start..end].select_nth_unstable_by(mid - start, |a, b| {
                    c[*a][axis].total_cmp(&c[*b][axis])
                });
                let l = self.node(start, mid);
                let r = self.node(mid, end);
                self.nodes[id].children = Some((l, r));
            }
        }
        id as u32
    }
}

impl Bvh {
    /// Builds the hierarchy (indices must be valid for `vertices`; invalid ones are skipped).
    pub fn new(vertices: &[[f64; 3]], triangles: &[[usize; 3]]) -> Self {
        let (source, tris): (Vec<usize>, Vec<[[f64; 3]; 3]>) = triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| t.iter().all(|&i| i < vertices.len()))
            .map(|(k, t)| (k, t.map(|i| vertices[i])))
            .unzip();
        let centroids: Vec<[f64; 3]> = tris
            .iter()
            .map(|t| [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0))
            .collect();
        let mut build = Build {
            tris: &tris,
            centroids: &centroids,
            order: (0..tris.len()).collect(),
            nodes: Vec::new(),
        };
        if !tris.is_empty() {
            build.node(0, tris.len());
        }
        Self {
            tris: build.order.iter().map(|&i| Edges::of(tris[i])).collect(),
            indices: build.order.iter().map(|&i| triangles[source[i]]).collect(),
            source: build.order.iter().map(|&i| source[i]).collect(),
            nodes: build.nodes,
        }
    }

    /// Moves the triangles to new vertex positions, keeping the hierarchy's grouping and
    /// growing or shrinking each box to fit again: a fraction of [`Bvh::new`]'s cost (no
    /// sorting), for a mesh that deforms between casts. Casts answer exactly as a new
    /// hierarchy's would (the nearest hit, ties to the triangle given first); only their
    /// speed depends on the grouping, which loosens as the mesh moves far from where it was
    /// built. False, and nothing changed, if a triangle's vertex is not in `vertices`.
    pub fn refit(&mut self, vertices: &[[f64; 3]]) -> bool {
        if self.indices.iter().flatten().any(|&i| i >= vertices.len()) {
            return false;
        }
        for (tri, idx) in self.tris.iter_mut().zip(&self.indices) {
            *tri = Edges::of(idx.map(|i| vertices[i]));
        }
        // Children come after their parent, so a backward pass sees them refitted first.
        for n in (0..self.nodes.len()).rev() {
            let mut bbox = Aabb::empty();
            match self.nodes[n].children {
                Some((l, r)) => {
                    for c in [l, r] {
                        let child = self.nodes[c as usize].bbox;
                        bbox.grow(child.lo);
                        bbox.grow(child.hi);
                    }
                }
                None => {
                    let node = &self.nodes[n];
                    for idx in &self.indices[node.start as usize..node.end as usize] {
                        for &i in idx {
                            bbox.grow(vertices[i]);
                        }
                    }
                }
            }
            self.nodes[n].bbox = bbox;
        }
        true
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The nearest hit of the ray `o + t d` (t > 0) with its triangle's unit normal
    /// oriented by the triangle winding (outward for a surface from [`crate::fem`]).
    pub fn cast(&self, o: [f64; 3], d: [f64; 3]) -> Option<Hit> {
        self.cast_triangle(o, d).map(|(hit, _)| hit)
    }

    /// [`Bvh::cast`] with the index of the hit triangle in the triangles given to
    /// [`Bvh::new`]. Of hits at the same distance (a ray through a shared edge), the
    /// triangle given first.
    pub fn cast_triangle(&self, o: [f64; 3], d: [f64; 3]) -> Option<(Hit, usize)> {
        let root = self.nodes.first()?;
        let inv = d.map(|c| if c != 0.0 { 1.0 / c } else { f64::INFINITY });
        // (t, position in `tris`): the nearest hit so far.
        let mut best: Option<(f64, usize)> = None;
        let closer = |t: f64, i: usize, best: Option<(f64, usize)>| match best {
            None => true,
            Some((bt, bi)) => t < bt || (t == bt && self.source[i] < self.source[bi]),
        };
        // Nearer child first, so the first hits bound the rest; a box entered beyond the
        // best hit cannot hold a nearer one.
        let mut stack = NodeStack::default();
        if let Some(t0) = root.bbox.hit(o, inv, f64::INFINITY) {
            stack.push((0, t0));
        }
        while let Some((n, t_in)) = stack.pop() {
            if best.is_some_and(|b| t_in > b.0) {
                continue;
            }
            let node = &self.nodes[n as usize];
            match node.children {
                Some((l, r)) => {
                    let t_max = best.map_or(f64::INFINITY, |b| b.0);
                    let hl = self.nodes[l as usize].bbox.hit(o, inv, t_max);
                    let hr = self.nodes[r as usize].bbox.hit(o, inv, t_max);
                    match (hl, hr) {
                        (Some(a), Some(b)) if a <= b => {
                            stack.push((r, b));
                            stack.push((l, a));
                        }
                        (Some(a), Some(b)) => {
                            stack.push((l, a));
                            stack.push((r, b));
                        }
                        (Some(a), None) => stack.push((l, a)),
                        (None, Some(b)) => stack.push((r, b)),
                        (None, None) => {}
                    }
                }
                None => {
                    for i in node.start as usize..node.end as usize {
                        if let Some(t) = ray_triangle_edges(o, d, &self.tris[i], 0.0) {
                            if closer(t, i, best) {
                                best = Some((t, i));
                            }
                        }
                    }
                }
            }
        }
        best.map(|(t, i)| {
            let tri = &self.tris[i];
            let hit = Hit {
                t,
                normal: unit(cross(tri.e1, tri.e2)),
            };
            (hit, self.source[i])
        })
    }
}

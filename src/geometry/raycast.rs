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
    let e1 = sub(tri[1], tri[0]);
    let e2 = sub(tri[2], tri[0]);
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det.abs() < 1e-18 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri[0]);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot(e2, q) * inv;
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
    /// Leaf: start..end into `order`; inner: children indices.
    start: usize,
    end: usize,
    children: Option<(usize, usize)>,
}

/// A BVH over triangles given by vertex positions and index triples.
#[derive(Clone, Debug)]
pub struct Bvh {
    tris: Vec<[[f64; 3]; 3]>,
    /// Index of each of `tris` in the triangles given to [`Bvh::new`].
    source: Vec<usize>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

const LEAF: usize = 4;

/// The nodes still to visit by one ray, with the distance at which it enters each: on the
/// stack, since a frame casts thousands of rays. Median splits halve the triangles at each
/// level, so a walk holds at most log2(triangles) + 2 entries, below 64 for any mesh that
/// fits in memory.
struct NodeStack {
    items: [(usize, f64); 64],
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
    fn push(&mut self, item: (usize, f64)) {
        self.items[self.len] = item;
        self.len += 1;
    }

    fn pop(&mut self) -> Option<(usize, f64)> {
        self.len = self.len.checked_sub(1)?;
        Some(self.items[self.len])
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
        let mut bvh = Self {
            order: (0..tris.len()).collect(),
            tris,
            source,
            nodes: Vec::new(),
        };
        if !bvh.tris.is_empty() {
            bvh.build(0, bvh.tris.len(), &centroids);
        }
        bvh
    }

    fn build(&mut self, start: usize, end: usize, c: &[[f64; 3]]) -> usize {
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
            start,
            end,
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
                let l = self.build(start, mid, c);
                let r = self.build(mid, end, c);
                self.nodes[id].children = Some((l, r));
            }
        }
        id
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
            let node = &self.nodes[n];
            match node.children {
                Some((l, r)) => {
                    let t_max = best.map_or(f64::INFINITY, |b| b.0);
                    let hl = self.nodes[l].bbox.hit(o, inv, t_max);
                    let hr = self.nodes[r].bbox.hit(o, inv, t_max);
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
                    for &i in &self.order[node.start..node.end] {
                        if let Some(t) = ray_triangle(o, d, self.tris[i], 0.0) {
                            if closer(t, i, best) {
                                best = Some((t, i));
                            }
                        }
                    }
                }
            }
        }
        best.map(|(t, i)| {
            let tri = self.tris[i];
            let hit = Hit {
                t,
                normal: unit(cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))),
            };
            (hit, self.source[i])
        })
    }
}

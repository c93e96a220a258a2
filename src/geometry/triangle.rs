//! Triangles and triangle surfaces: the closest point of a triangle to a point (with its
//! barycentric weights) and the area-weighted vertex normals of a surface.

use crate::math::{dot, sub};

/// Area-weighted unit vertex normals of a triangle surface at node positions `x`
/// (zero for nodes not on the surface).
pub fn vertex_normals(x: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0; 3]; x.len()];
    for t in triangles {
        if t.iter().any(|&i| i >= x.len()) {
            continue;
        }
        let [a, b, c] = t.map(|i| x[i]);
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let f = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        for &v in t {
            for k in 0..3 {
                n[v][k] += f[k];
            }
        }
    }
    for v in &mut n {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

/// Squared distance from `p` to the triangle `abc` (closest point by Voronoi regions).
pub fn point_triangle_distance2(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let q = closest_point_on_triangle(p, a, b, c);
    let d = sub(p, q);
    dot(d, d)
}

/// The point of triangle `abc` closest to `p`.
pub fn closest_point_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    closest_point_on_triangle_weights(p, a, b, c).0
}

/// The point of triangle `abc` closest to `p` and its barycentric weights on `(a, b, c)`,
/// found region by region (vertex, edge or face Voronoi region; Ericson, Real-Time
/// Collision Detection 5.1.5). A degenerate triangle answers `a`.
pub fn closest_point_on_triangle_weights(
    p: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let lerp =
        |o: [f64; 3], e: [f64; 3], t: f64| [o[0] + t * e[0], o[1] + t * e[1], o[2] + t * e[2]];
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (lerp(a, ab, v), [1.0 - v, v, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (lerp(a, ac, w), [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (lerp(b, sub(c, b), w), [0.0, 1.0 - w, w]);
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let (v, w) = (vb / denom, vc / denom);
    (
        [
            a[0] + ab[0] * v + ac[0] * w,
            a[1] + ab[1] * v + ac[1] * w,
            a[2] + ab[2] * v + ac[2] * w,
        ],
        [1.0 - v - w, v, w],
    )
}

/// The 12 triangles of the axis-aligned box [lo, hi], counter-clockwise seen from outside:
/// the simplest closed surface (a cavity, a test solid).
pub fn box_triangles(lo: [f64; 3], hi: [f64; 3]) -> Vec<[[f64; 3]; 3]> {
    let corner = |i: usize| [0, 1, 2].map(|k| if i >> k & 1 == 0 { lo[k] } else { hi[k] });
    const QUADS: [[usize; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    (QUADS.iter())
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .map(|t| t.map(corner))
        .collect()
}

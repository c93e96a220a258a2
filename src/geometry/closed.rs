//! Whether a triangle soup (an STL from CAD) bounds a solid: corners welded, every edge
//! shared by exactly two triangles, one orientation per shell, no two triangles crossing.
//! A mesher given less fails deep inside or meshes the wrong region, so each defect is
//! named here in one line with where it is. Triangles that collapse when their corners are
//! welded and shells oriented inconsistently are repaired (and counted), not refused.

use crate::math::{cross, dot, norm, sub};
use std::collections::{HashMap, HashSet};
use thiserror::Error;

/// Why a surface does not bound a solid; each message is one line with a place to look.
#[derive(Debug, Error, PartialEq)]
pub enum SurfaceDefect {
    /// No triangle with three distinct corners.
    #[error("the surface has no triangle with three distinct corners")]
    Empty,
    /// Edges used by one triangle only: the surface has a hole.
    #[error("the surface is not closed: {edges} edges belong to one triangle only (a hole), one at ({:.3}, {:.3}, {:.3})", at[0], at[1], at[2])]
    Hole {
        /// Boundary edges.
        edges: usize,
        /// The midpoint of one of them (file units).
        at: [f64; 3],
    },
    /// Edges used by three or more triangles: shells touch along an edge, or faces repeat.
    #[error("the surface is not a manifold: {edges} edges are shared by 3 or more triangles, one at ({:.3}, {:.3}, {:.3})", at[0], at[1], at[2])]
    NonManifold {
        /// Such edges.
        edges: usize,
        /// The midpoint of one of them (file units).
        at: [f64; 3],
    },
    /// A shell that cannot be oriented (a Moebius-like surface).
    #[error("the surface cannot be oriented (inside and outside meet), near ({:.3}, {:.3}, {:.3})", at[0], at[1], at[2])]
    NotOrientable {
        /// Where the orientation conflict was found (file units).
        at: [f64; 3],
    },
    /// Two triangles that cross.
    #[error("the surface intersects itself: triangles {first} and {second} cross near ({:.3}, {:.3}, {:.3})", at[0], at[1], at[2])]
    SelfIntersection {
        /// One triangle (index in the file).
        first: usize,
        /// The other.
        second: usize,
        /// A point of the crossing (file units).
        at: [f64; 3],
    },
}

/// A closed, oriented, non-self-intersecting surface: welded corners and its shells.
#[derive(Debug, Clone)]
pub struct ClosedSurface {
    /// Welded corners (file units).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (corner indices), each shell's normals pointing out of the solid.
    pub triangles: Vec<[usize; 3]>,
    /// The connected shells, the outer one (largest enclosed volume) first.
    pub shells: Vec<Shell>,
    /// Triangles dropped because two of their corners welded into one.
    pub collapsed: usize,
    /// Triangles turned to agree with their neighbours' orientation.
    pub flipped: usize,
}

/// One connected, closed piece of a surface: the outer skin or a cavity inside it.
#[derive(Debug, Clone)]
pub struct Shell {
    /// Its triangles (indices into [`ClosedSurface::triangles`]).
    pub triangles: Vec<usize>,
    /// The volume it encloses (file units cubed).
    pub volume: f64,
}

/// Checks and repairs a triangle soup. Corners closer than `weld_tol` (file units) are one
/// corner; 0 takes 1e-7 of the bounding-box diagonal, below any CAD feature.
pub fn close_surface(
    soup: &[[[f64; 3]; 3]],
    weld_tol: f64,
) -> Result<ClosedSurface, SurfaceDefect> {
    let (vertices, mut triangles, soup_index, collapsed) = weld(soup, weld_tol);
    if triangles.is_empty() {
        return Err(SurfaceDefect::Empty);
    }
    let edges = edge_faces(&triangles);
    let mid = |e: &(usize, usize)| {
        let (a, b) = (vertices[e.0], vertices[e.1]);
        [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]))
    };
    let first = |want: &dyn Fn(usize) -> bool| {
        let mut hits: Vec<&(usize, usize)> = (edges.iter())
            .filter(|(_, f)| want(f.len()))
            .map(|(e, _)| e)
            .collect();
        hits.sort_unstable();
        hits.first().map(|e| (hits.len(), mid(e)))
    };
    if let Some((edges, at)) = first(&|n| n == 1) {
        return Err(SurfaceDefect::Hole { edges, at });
    }
    if let Some((edges, at)) = first(&|n| n > 2) {
        return Err(SurfaceDefect::NonManifold { edges, at });
    }
    let (shell_of, flipped) = orient(&mut triangles, &edges, &vertices)?;
    let mut shells = shells_by_volume(&vertices, &mut triangles, &shell_of);
    shells.sort_by(|a, b| b.volume.total_cmp(&a.volume));
    if let Some((a, b, at)) = first_crossing(&vertices, &triangles) {
        let (first, second) = (
            soup_index[a].min(soup_index[b]),
            soup_index[a].max(soup_index[b]),
        );
        return Err(SurfaceDefect::SelfIntersection { first, second, at });
    }
    Ok(ClosedSurface {
        vertices,
        triangles,
        shells,
        collapsed,
        flipped,
    })
}

/// A welded soup: corners, triangles, each triangle's index in the soup, and how many
/// triangles collapsed.
type Welded = (Vec<[f64; 3]>, Vec<[usize; 3]>, Vec<usize>, usize);

/// Welds corners on a grid of `tol`.
fn weld(soup: &[[[f64; 3]; 3]], tol: f64) -> Welded {
    let tol = if tol > 0.0 {
        tol
    } else {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in soup.iter().flatten() {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (1e-7 * norm(sub(hi, lo))).max(f64::MIN_POSITIVE)
    };
    let mut index: HashMap<[i64; 3], usize> = HashMap::new();
    let mut vertices = Vec::new();
    let mut triangles = Vec::with_capacity(soup.len());
    let mut soup_index = Vec::with_capacity(soup.len());
    let mut collapsed = 0;
    for (i, t) in soup.iter().enumerate() {
        let ids = t.map(|p| {
            let key = p.map(|c| (c / tol).round() as i64);
            *index.entry(key).or_insert_with(|| {
                vertices.push(p);
                vertices.len() - 1
            })
        });
        if ids[0] == ids[1] || ids[1] == ids[2] || ids[0] == ids[2] {
            collapsed += 1;
            continue;
        }
        triangles.push(ids);
        soup_index.push(i);
    }
    (vertices, triangles, soup_index, collapsed)
}

/// Each undirected edge (low, high) with the triangles that use it.
fn edge_faces(triangles: &[[usize; 3]]) -> HashMap<(usize, usize), Vec<usize>> {
    let mut edges: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (f, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    edges
}

/// Whether triangle `t` runs along a then b.
fn runs(t: &[usize; 3], a: usize, b: usize) -> bool {
    (0..3).any(|k| t[k] == a && t[(k + 1) % 3] == b)
}

/// Gives every shell one orientation by a flood over shared edges (a shared edge is run
/// in opposite directions by its two triangles); returns each triangle's shell and how
/// many were flipped.
fn orient(
    triangles: &mut [[usize; 3]],
    edges: &HashMap<(usize, usize), Vec<usize>>,
    vertices: &[[f64; 3]],
) -> Result<(Vec<usize>, usize), SurfaceDefect> {
    let n = triangles.len();
    let mut shell_of = vec![usize::MAX; n];
    let mut flipped = 0;
    let mut shells = 0;
    for seed in 0..n {
        if shell_of[seed] != usize::MAX {
            continue;
        }
        shell_of[seed] = shells;
        let mut stack = vec![seed];
        while let Some(f) = stack.pop() {
            let t = triangles[f];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                for &g in &edges[&(a.min(b), a.max(b))] {
                    if g == f {
                        continue;
                    }
                    let agrees = runs(&triangles[g], b, a);
                    if shell_of[g] == usize::MAX {
                        shell_of[g] = shells;
                        if !agrees {
                            triangles[g].swap(1, 2);
                            flipped += 1;
                        }
                        stack.push(g);
                    } else if !agrees {
                        let at = [0, 1, 2].map(|c| 0.5 * (vertices[a][c] + vertices[b][c]));
                        return Err(SurfaceDefect::NotOrientable { at });
                    }
                }
            }
        }
        shells += 1;
    }
    Ok((shell_of, flipped))
}

/// The shells with their enclosed volumes, each turned so its normals point out of the
/// solid: the outer shell (largest) outward, shells inside it (cavities) inward.
fn shells_by_volume(
    vertices: &[[f64; 3]],
    triangles: &mut [[usize; 3]],
    shell_of: &[usize],
) -> Vec<Shell> {
    let count = shell_of.iter().max().map_or(0, |&s| s + 1);
    let mut shells: Vec<Shell> = (0..count)
        .map(|_| Shell {
            triangles: Vec::new(),
            volume: 0.0,
        })
        .collect();
    for (f, t) in triangles.iter().enumerate() {
        let [a, b, c] = t.map(|i| vertices[i]);
        shells[shell_of[f]].triangles.push(f);
        shells[shell_of[f]].volume += dot(a, cross(b, c)) / 6.0;
    }
    let outer = (0..count)
        .max_by(|&a, &b| shells[a].volume.abs().total_cmp(&shells[b].volume.abs()))
        .unwrap_or(0);
    for (s, shell) in shells.iter_mut().enumerate() {
        // Outward normals: positive for the outer shell, negative for a cavity.
        let want_positive = s == outer;
        if (shell.volume > 0.0) != want_positive {
            for &f in &shell.triangles {
                triangles[f].swap(1, 2);
            }
        }
        shell.volume = shell.volume.abs();
    }
    shells
}

/// The first pair of triangles that cross (by grid cells of their bounding boxes), with a
/// point of the crossing. Triangles that share an edge are not tested; those that share a
/// corner are tested away from it. Coplanar overlaps are not detected.
fn first_crossing(
    vertices: &[[f64; 3]],
    triangles: &[[usize; 3]],
) -> Option<(usize, usize, [f64; 3])> {
    let boxes: Vec<[[f64; 3]; 2]> = (triangles.iter())
        .map(|t| {
            let p = t.map(|i| vertices[i]);
            let lo = [0, 1, 2].map(|k| p[0][k].min(p[1][k]).min(p[2][k]));
            let hi = [0, 1, 2].map(|k| p[0][k].max(p[1][k]).max(p[2][k]));
            [lo, hi]
        })
        .collect();
    let mean_size: f64 =
        boxes.iter().map(|b| norm(sub(b[1], b[0]))).sum::<f64>() / boxes.len().max(1) as f64;
    let cell = mean_size.max(f64::MIN_POSITIVE);
    let key = |p: [f64; 3]| p.map(|c| (c / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (f, b) in boxes.iter().enumerate() {
        let (lo, hi) = (key(b[0]), key(b[1]));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    grid.entry([x, y, z]).or_default().push(f);
                }
            }
        }
    }
    let overlap = |a: &[[f64; 3]; 2], b: &[[f64; 3]; 2]| {
        (0..3).all(|k| a[0][k] <= b[1][k] && b[0][k] <= a[1][k])
    };
    let mut seen: HashSet<(usize, usize)> = HashSet::new();
    let mut cells: Vec<&[i64; 3]> = grid.keys().collect();
    cells.sort_unstable();
    for c in cells {
        let list = &grid[c];
        for (i, &f) in list.iter().enumerate() {
            for &g in &list[i + 1..] {
                let pair = (f.min(g), f.max(g));
                if !overlap(&boxes[f], &boxes[g]) || !seen.insert(pair) {
                    continue;
                }
                if let Some(at) = crossing(vertices, &triangles[pair.0], &triangles[pair.1]) {
                    return Some((pair.0, pair.1, at));
                }
            }
        }
    }
    None
}

/// A point where triangles `s` and `t` cross, away from the corner they share.
fn crossing(vertices: &[[f64; 3]], s: &[usize; 3], t: &[usize; 3]) -> Option<[f64; 3]> {
    let shared: Vec<usize> = s.iter().copied().filter(|v| t.contains(v)).collect();
    if shared.len() >= 2 {
        return None;
    }
    let mut longest: f64 = 0.0;
    for tri in [s, t] {
        for k in 0..3 {
            longest = longest.max(norm(sub(vertices[tri[k]], vertices[tri[(k + 1) % 3]])));
        }
    }
    // Hits within this of the shared corner are the corner itself, seen through rounding
    // (a segment from the corner nearly in the other triangle's plane).
    let near = 1e-6 * longest;
    let away = |q: [f64; 3]| shared.iter().all(|&v| norm(sub(q, vertices[v])) > near);
    let edge_hits = |a: &[usize; 3], b: &[usize; 3]| {
        let tri = b.map(|i| vertices[i]);
        (0..3).find_map(|k| {
            segment_triangle(vertices[a[k]], vertices[a[(k + 1) % 3]], &tri).filter(|&q| away(q))
        })
    };
    edge_hits(s, t).or_else(|| edge_hits(t, s))
}

/// Where segment p-q meets triangle `tri` (Moeller-Trumbore), or None (parallel counts as
/// none).
fn segment_triangle(p: [f64; 3], q: [f64; 3], tri: &[[f64; 3]; 3]) -> Option<[f64; 3]> {
    let d = sub(q, p);
    let (e1, e2) = (sub(tri[1], tri[0]), sub(tri[2], tri[0]));
    let h = cross(d, e2);
    let det = dot(e1, h);
    if det.abs() <= 1e-12 * norm(d) * norm(e1) * norm(e2) {
        return None;
    }
    let s = sub(p, tri[0]);
    let u = dot(s, h) / det;
    let qv = cross(s, e1);
    let v = dot(d, qv) / det;
    let t = dot(e2, qv) / det;
    let eps = 1e-12;
    if u < -eps || v < -eps || u + v > 1.0 + eps || !(0.0..=1.0).contains(&t) {
        return None;
    }
    Some([0, 1, 2].map(|k| p[k] + t * d[k]))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::triangle::box_triangles as cube;

    #[test]
    fn a_closed_box_passes_with_its_volume_and_outward_normals() {
        let s = close_surface(&cube([0.0; 3], [2.0, 3.0, 4.0]), 0.0).unwrap();
        assert_eq!(
            (s.vertices.len(), s.triangles.len(), s.shells.len()),
            (8, 12, 1)
        );
        assert!((s.shells[0].volume - 24.0).abs() < 1e-12);
        assert_eq!(s.flipped, 0);
    }

    #[test]
    fn a_box_with_a_missing_triangle_is_refused_as_a_hole_with_its_place() {
        let mut soup = cube([0.0; 3], [1.0; 3]);
        soup.remove(3);
        let err = close_surface(&soup, 0.0).unwrap_err();
        assert!(matches!(err, SurfaceDefect::Hole { edges: 3, .. }), "{err}");
        assert!(!err.to_string().contains('\n'));
    }

    #[test]
    fn a_flipped_triangle_is_turned_back_and_counted() {
        let mut soup = cube([0.0; 3], [1.0; 3]);
        soup[5].swap(1, 2);
        let s = close_surface(&soup, 0.0).unwrap();
        assert_eq!(s.flipped, 1);
        assert!((s.shells[0].volume - 1.0).abs() < 1e-12);
    }

    #[test]
    fn two_interpenetrating_boxes_are_refused_as_self_intersecting() {
        let mut soup = cube([0.0; 3], [1.0; 3]);
        soup.extend(cube([0.5; 3], [1.5; 3]));
        let err = close_surface(&soup, 0.0).unwrap_err();
        assert!(
            matches!(err, SurfaceDefect::SelfIntersection { .. }),
            "{err}"
        );
    }

    #[test]
    fn a_box_inside_a_box_is_a_cavity_with_inward_normals() {
        let mut soup = cube([0.0; 3], [4.0; 3]);
        soup.extend(cube([1.0; 3], [2.0; 3]));
        let s = close_surface(&soup, 0.0).unwrap();
        assert_eq!(s.shells.len(), 2);
        assert!((s.shells[0].volume - 64.0).abs() < 1e-9);
        assert!((s.shells[1].volume - 1.0).abs() < 1e-9);
        // Signed volume of the whole surface: the solid between the shells.
        let signed: f64 = (s.triangles.iter())
            .map(|t| {
                let [a, b, c] = t.map(|i| s.vertices[i]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum();
        assert!((signed - 63.0).abs() < 1e-9, "{signed}");
    }

    #[test]
    fn a_triangle_collapsed_by_welding_is_dropped_and_counted() {
        let mut soup = cube([0.0; 3], [1.0; 3]);
        soup.push([[0.0; 3], [1e-12, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let s = close_surface(&soup, 0.0).unwrap();
        assert_eq!(s.collapsed, 1);
    }
}

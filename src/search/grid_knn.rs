//! Exact k-nearest-neighbour lists for every point of a cloud, on a uniform hash grid.
//!
//! Used by the region growing: for dense sensor clouds, gathering the 3x3x3 block of
//! cells around a point and selecting the k closest is several times faster than k
//! independent tree queries. A result is used only when
//! it is provably exact: the k-th squared distance must be below the squared distance
//! from the query to the block's boundary (with a relative margin for `f32` rounding);
//! otherwise the KD-tree answers. Distances are [`squared_distance`] (`f32`, FLANN's
//! order) and lists are sorted by `(distance, index)`, as [`KdTree::nearest_n`] does.

use super::{squared_distance, KdTree, Parallelism};
use std::collections::HashMap;

/// Row-major `n x k` neighbour indices and squared distances.
pub struct KnnTable {
    /// Neighbours per row.
    pub k: usize,
    /// Indices, `n * k`.
    pub idx: Vec<u32>,
    /// Squared distances, `n * k`.
    pub d2: Vec<f32>,
}

type Cell = (i32, i32, i32);

/// k nearest neighbours (self included) of every point of `pts` (all finite).
pub fn knn_all(pts: &[[f32; 3]], k: usize, par: Parallelism) -> KnnTable {
    let n = pts.len();
    let k = k.min(n);
    let tree = KdTree::build(pts);
    if n == 0 || k == 0 {
        return KnnTable {
            k,
            idx: Vec::new(),
            d2: Vec::new(),
        };
    }
    let h = cell_size(pts, &tree, k);
    let grid = h.map(|h| Grid::new(pts, h));
    let rows = super::map_indices(n, par, |i| {
        let mut row: Vec<(f32, u32)> = Vec::new();
        let exact = grid.as_ref().is_some_and(|g| g.knn(pts, i, k, &mut row));
        if !exact {
            row.clear();
            row.extend(
                tree.nearest_n(&pts[i], k)
                    .into_iter()
                    .map(|nb| (nb.squared_distance, nb.index as u32)),
            );
        }
        row
    });
    let mut idx = Vec::with_capacity(n * k);
    let mut d2 = Vec::with_capacity(n * k);
    for row in rows {
        for j in 0..k {
            let (d, i) = row.get(j).copied().unwrap_or((f32::MAX, 0));
            idx.push(i);
            d2.push(d);
        }
    }
    KnnTable { k, idx, d2 }
}

/// The grid cell size: the median k-th-neighbour distance over a sample of points, or
/// `None` when it is not usable.
fn cell_size(pts: &[[f32; 3]], tree: &KdTree, k: usize) -> Option<f64> {
    let step = (pts.len() / 256).max(1);
    let mut radii: Vec<f64> = pts
        .iter()
        .step_by(step)
        .filter_map(|p| {
            tree.nearest_n(p, k)
                .last()
                .map(|nb| (nb.squared_distance as f64).sqrt())
        })
        .collect();
    if radii.is_empty() {
        return None;
    }
    radii.sort_by(f64::total_cmp);
    let h = radii[radii.len() / 2];
    (h.is_finite() && h > 0.0).then_some(h)
}

struct Grid {
    h: f64,
    cells: HashMap<Cell, (u32, u32)>,
    order: Vec<u32>,
}

impl Grid {
    fn cell(p: &[f32; 3], h: f64) -> Option<Cell> {
        let c = |v: f32| {
            let x = (v as f64 / h).floor();
            (x.abs() < 1e9).then_some(x as i32)
        };
        Some((c(p[0])?, c(p[1])?, c(p[2])?))
    }

    fn new(pts: &[[f32; 3]], h: f64) -> Grid {
        let mut keyed: Vec<(Cell, u32)> = pts
            .iter()
            .enumerate()
            .filter_map(|(i, p)| Grid::cell(p, h).map(|c| (c, i as u32)))
            .collect();
        keyed.sort_unstable();
        let mut cells = HashMap::new();
        let mut start = 0;
        while start < keyed.len() {
            let mut end = start;
            while end < keyed.len() && keyed[end].0 == keyed[start].0 {
                end += 1;
            }
            cells.insert(keyed[start].0, (start as u32, (end - start) as u32));
            start = end;
        }
        Grid {
            h,
            cells,
            order: keyed.into_iter().map(|(_, i)| i).collect(),
        }
    }

    /// Fills `row` with the exact k nearest of point `i` sorted by (d², index) and
    /// returns true, or returns false when the 3x3x3 block cannot prove exactness.
    fn knn(&self, pts: &[[f32; 3]], i: usize, k: usize, row: &mut Vec<(f32, u32)>) -> bool {
        let q = &pts[i];
        let Some((cx, cy, cz)) = Grid::cell(q, self.h) else {
            return false;
        };
        row.clear();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(&(s, len)) = self.cells.get(&(cx + dx, cy + dy, cz + dz)) {
                        for &j in &self.order[s as usize..(s + len) as usize] {
                            row.push((squared_distance(q, &pts[j as usize]), j));
                        }
                    }
                }
            }
        }
        if row.len() < k {
            return false;
        }
        let cmp = |a: &(f32, u32), b: &(f32, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        if row.len() > k {
            row.select_nth_unstable_by(k - 1, cmp);
            row.truncate(k);
        }
        row.sort_unstable_by(cmp);
        // Distance from q to the block's boundary: every point outside is at least this far.
        let lo = [cx - 1, cy - 1, cz - 1];
        let mut cover = f64::INFINITY;
        for a in 0..3 {
            let v = q[a] as f64;
            let min_face = lo[a] as f64 * self.h;
            let max_face = (lo[a] + 3) as f64 * self.h;
            cover = cover.min(v - min_face).min(max_face - v);
        }
        let kth = row[k - 1].0 as f64;
        kth < cover * cover * (1.0 - 1e-4)
    }
}

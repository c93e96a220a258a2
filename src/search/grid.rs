//! k nearest neighbours of every point of a cloud at once, on a uniform grid.
//!
//! Dense sensor clouds put a handful of points in every cell of a grid whose edge is a
//! little more than the k-th neighbour distance. The points are sorted by cell (radix
//! sort of packed keys); for each occupied cell, the points of the 3x3x3 block around
//! it are gathered once and every point of the cell picks its k closest among them.
//! That answer is used only when it is provably exact: the k-th squared distance must
//! be below the squared distance from the query to the block's boundary, with a
//! relative margin far above `f32` rounding. Otherwise (isolated points, cells too
//! small) a KD-tree built on first need answers, with the same tie rule.
//!
//! Result: for each point, its k nearest finite points (itself included), sorted by
//! `(squared distance, index)`; a tie at the k-th place goes to the smaller index, so
//! the answer is unique, equal to a brute-force selection, and independent of threads.
//! Distances are [`squared_distance`] (`f32`, FLANN's order).

use super::sort::{bits_for, radix_sort_packed};
use super::{squared_distance, KdTree, Neighbour, Parallelism, RadiusQuery};
use crate::cloud::PointCloud;
use std::sync::OnceLock;

/// Relative margin between the k-th squared distance and the squared distance to the
/// block boundary; `f32` distance rounding is below 1e-6 relative.
const MARGIN: f64 = 1e-4;

/// Largest block radius (in cells) tried before asking the tree.
const RINGS: u64 = 4;

/// Calls `f(i, neighbours)` for every point `i` of `positions` with its `k` nearest
/// finite points sorted by `(squared distance, index)` (fewer when the cloud has fewer
/// finite points; none for a non-finite point), and returns the results in input order.
///
/// ```
/// use softsense::search::{map_knn, Parallelism};
/// let pts = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0]];
/// let nn = map_knn(&pts, 2, Parallelism::Serial, |_, nb| nb.iter().map(|n| n.index).collect::<Vec<_>>());
/// assert_eq!(nn, vec![vec![0, 1], vec![1, 0], vec![2, 1], vec![]]); // 1's tie: 0 before 2
/// ```
pub fn map_knn<T, F>(positions: &[[f32; 3]], k: usize, par: Parallelism, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &[Neighbour]) -> T + Sync + Send,
{
    let n = positions.len();
    let finite: Vec<u32> = (0..n as u32)
        .filter(|&i| PointCloud::is_finite_point(&positions[i as usize]))
        .collect();
    let k = k.min(finite.len());
    // Every point starts with the answer for "no neighbours" (what non-finite points
    // keep); finite points are overwritten below.
    let mut out: Vec<T> = (0..n).map(|i| f(i, &[])).collect();
    let tree_cell: OnceLock<KdTree> = OnceLock::new();
    let tree = || tree_cell.get_or_init(|| KdTree::build(positions));
    let grid = if k == 0 {
        None
    } else {
        Grid::build(positions, &finite, k)
    };
    let Some(grid) = grid else {
        // No usable grid: the tree answers every query.
        return super::map_indices(n, par, |i| f(i, &tree_knn(tree(), &positions[i], k)));
    };
    // Chunks of cells, processed in parallel; each yields (point, result) pairs.
    let chunk = 512;
    let n_chunks = grid.cell_keys.len().div_ceil(chunk);
    let parts: Vec<Vec<(u32, T)>> = super::map_indices(n_chunks, par, |c| {
        let cells = c * chunk..((c + 1) * chunk).min(grid.cell_keys.len());
        grid.knn_chunk(positions, cells, k, &tree, &f)
    });
    for (i, t) in parts.into_iter().flatten() {
        out[i as usize] = t;
    }
    out
}

/// For every point `i` of `positions`, whether at least `need` finite points `p`
/// (itself included) satisfy `inside(q, p)`, where `inside` must imply
/// `|p − q| ≤ radius`. Non-finite points get `false`. Used by radius outlier removal:
/// a grid with cells of edge `radius` holds every such point in the 3x3x3 block around
/// the query's cell; queries too close to a block boundary for that to be certain
/// (rounding) ask the tree.
pub(crate) fn map_has_neighbours<I>(
    positions: &[[f32; 3]],
    radius: f64,
    need: usize,
    par: Parallelism,
    inside: I,
) -> Vec<bool>
where
    I: Fn(&[f32; 3], &[f32; 3]) -> bool + Sync + Send,
{
    let n = positions.len();
    let finite: Vec<u32> = (0..n as u32)
        .filter(|&i| PointCloud::is_finite_point(&positions[i as usize]))
        .collect();
    let tree_cell: OnceLock<KdTree> = OnceLock::new();
    let tree = || tree_cell.get_or_init(|| KdTree::build(positions));
    let by_tree = |q: &[f32; 3]| {
        PointCloud::is_finite_point(q)
            && tree().count_matching(q, radius, need, |p| inside(q, p)) >= need
    };
    let h = radius * (1.0 + 1e-3);
    let grid = (need > 0 && radius.is_finite() && radius > 0.0)
        .then(|| Grid::bounds(positions, &finite))
        .flatten()
        .and_then(|(lo, hi)| Grid::with_cell(positions, &finite, lo, hi, h));
    if need == 0 {
        return positions.iter().map(PointCloud::is_finite_point).collect();
    }
    let Some(grid) = grid else {
        return super::map_indices(n, par, |i| by_tree(&positions[i]));
    };
    let r2 = radius * radius * (1.0 + MARGIN);
    let chunk = 512;
    let n_chunks = grid.cell_keys.len().div_ceil(chunk);
    let parts: Vec<Vec<(u32, bool)>> = super::map_indices(n_chunks, par, |c| {
        let cells = c * chunk..((c + 1) * chunk).min(grid.cell_keys.len());
        let mut out = Vec::new();
        let cells: Vec<usize> = cells.collect();
        grid.blocks(positions, 1, &cells, |c, cand| {
            for &i in grid.cell(c) {
                let q = &positions[i as usize];
                let m = grid.margin(q);
                let ok = if m > 0.0 && r2 < m * m {
                    let mut count = 0;
                    for (p, _) in cand {
                        count += usize::from(inside(q, p));
                        if count >= need {
                            break;
                        }
                    }
                    count >= need
                } else {
                    by_tree(q)
                };
                out.push((i, ok));
            }
        });
        out
    });
    let mut keep = vec![false; n];
    for (i, ok) in parts.into_iter().flatten() {
        keep[i as usize] = ok;
    }
    keep
}

/// The `k` nearest points by `(squared distance, index)` from the tree: kiddo's k
/// nearest give the k-th distance, then every point within it (inclusive, so tied
/// points are all seen) is ranked.
fn tree_knn(tree: &KdTree, q: &[f32; 3], k: usize) -> Vec<Neighbour> {
    let Some(last) = tree.nearest_n(q, k).last().copied() else {
        return Vec::new();
    };
    let d = last.squared_distance;
    // A radius whose f32 square is ≥ d: the widened candidate search then sees every
    // point at d² ≤ d, and the inclusive test keeps exactly those.
    let r = (d as f64).sqrt() * (1.0 + 1e-6) + f64::MIN_POSITIVE;
    let mut all: Vec<Neighbour> = tree
        .within_radius(
            q,
            r,
            RadiusQuery {
                sorted: true,
                inclusive: true,
                ..Default::default()
            },
        )
        .into_iter()
        .filter(|nb| nb.squared_distance <= d)
        .collect();
    all.truncate(k);
    all
}

/// Points sorted by cell, with the occupied cells' keys and start offsets.
struct Grid {
    /// Cell edge, metres.
    h: f64,
    /// Grid origin (the low corner of cell 0, one padding cell below the bounds).
    origin: [f64; 3],
    /// Key strides of y and z (x stride 1).
    stride: [u64; 2],
    /// Sorted occupied cell keys.
    cell_keys: Vec<u64>,
    /// `cell_start[c]..cell_start[c + 1]` are cell `c`'s points in `sorted`.
    cell_start: Vec<u32>,
    /// Point indices sorted by cell, ascending within a cell.
    sorted: Vec<u32>,
}

impl Grid {
    /// A grid whose cells hold about `k` points on average (surface-like clouds then
    /// have their k-th neighbour within a cell's edge), or `None` when the cloud is too
    /// spread out for 32-bit cell keys.
    fn build(positions: &[[f32; 3]], finite: &[u32], k: usize) -> Option<Grid> {
        let (lo, hi) = Grid::bounds(positions, finite)?;
        let ext: Vec<f64> = {
            let mut e: Vec<f64> = (0..3).map(|a| hi[a] - lo[a]).collect();
            e.sort_by(f64::total_cmp);
            e
        };
        // First guess: points spread over the two largest extents as a surface.
        let area = (ext[1] * ext[2]).max(ext[2] * ext[2] * 1e-6);
        let spacing = (area / finite.len() as f64).sqrt();
        let mut h = spacing * (k as f64).sqrt();
        if !(h.is_finite() && h > 0.0) {
            h = 1.0;
        }
        let mut best = None;
        for _ in 0..3 {
            let Some(g) = Grid::with_cell(positions, finite, lo, hi, h) else {
                h *= 2.0;
                continue;
            };
            // Points per cell as seen from a point (dense regions weigh as they cost):
            // a surface crosses about 9 cells of a 3x3x3 block, so this many times 9
            // candidates are scanned per query; about k/2 keeps most k-th neighbours
            // inside the block and the scan short.
            let occupancy = (0..g.cell_keys.len())
                .map(|c| (g.cell(c).len() as f64).powi(2))
                .sum::<f64>()
                / finite.len() as f64;
            let ratio = 0.45 * k as f64 / occupancy;
            best = Some(g);
            if (0.7..=1.4).contains(&ratio) {
                break;
            }
            h *= ratio.sqrt().clamp(0.25, 4.0);
        }
        best
    }

    /// Bounds of the finite points, `None` when there are none (or too many for
    /// 32-bit indices).
    fn bounds(positions: &[[f32; 3]], finite: &[u32]) -> Option<([f64; 3], [f64; 3])> {
        if finite.is_empty() || finite.len() > u32::MAX as usize / 2 {
            return None;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &i in finite {
            let p = positions[i as usize];
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f64);
                hi[a] = hi[a].max(p[a] as f64);
            }
        }
        Some((lo, hi))
    }

    fn with_cell(
        positions: &[[f32; 3]],
        finite: &[u32],
        lo: [f64; 3],
        hi: [f64; 3],
        h: f64,
    ) -> Option<Grid> {
        // One padding cell on each side so that x ± 1 never wraps into another row.
        let origin: [f64; 3] = std::array::from_fn(|a| lo[a] - h);
        let dims: [u64; 3] = std::array::from_fn(|a| ((hi[a] - origin[a]) / h) as u64 + 2);
        let total = (dims[0] as u128) * (dims[1] as u128) * (dims[2] as u128);
        if total > 1u128 << 32 {
            return None;
        }
        let stride = [dims[0], dims[0] * dims[1]];
        let mut words: Vec<u64> = finite
            .iter()
            .map(|&i| {
                let c = cell_of(&positions[i as usize], origin, h);
                ((c[0] + c[1] * stride[0] + c[2] * stride[1]) << 32) | i as u64
            })
            .collect();
        radix_sort_packed(&mut words, bits_for(total as u64));
        let mut cell_keys = Vec::new();
        let mut cell_start = Vec::new();
        for (j, w) in words.iter().enumerate() {
            let key = w >> 32;
            if cell_keys.last() != Some(&key) {
                cell_keys.push(key);
                cell_start.push(j as u32);
            }
        }
        cell_start.push(words.len() as u32);
        let sorted = words.into_iter().map(|w| w as u32).collect();
        Some(Grid {
            h,
            origin,
            stride,
            cell_keys,
            cell_start,
            sorted,
        })
    }

    /// Calls `visit(cell, candidates)` for every cell of `cells` (indices into
    /// `cell_keys`, ascending) with the points (position, index) of the block of cells
    /// within `r` cells of it (`(2r+1)³` cells; near the grid's edge a row may wrap
    /// into the next one, which only adds candidates).
    fn blocks(
        &self,
        positions: &[[f32; 3]],
        r: i64,
        cells: &[usize],
        mut visit: impl FnMut(usize, &[([f32; 3], u32)]),
    ) {
        let keys = &self.cell_keys;
        let Some(&first) = cells.first() else {
            return;
        };
        let (sx, sy) = (self.stride[0] as i64, self.stride[1] as i64);
        let side = 2 * r + 1;
        let offsets: Vec<i64> = (0..side * side)
            .map(|o| (o % side - r) * sx + (o / side - r) * sy - r)
            .collect();
        // Per row of the block, a cursor into `keys` that only moves forward, since the
        // cells come in ascending key order.
        let first = keys[first] as i64;
        let mut cursor: Vec<usize> = offsets
            .iter()
            .map(|off| keys.partition_point(|&c| (c as i64) < first + off))
            .collect();
        let mut cand: Vec<([f32; 3], u32)> = Vec::new();
        let mut ranges: Vec<(usize, usize)> = Vec::with_capacity(offsets.len());
        for &c in cells {
            let key = keys[c] as i64;
            ranges.clear();
            for (cur, off) in cursor.iter_mut().zip(&offsets) {
                let lower = key + off;
                let mut j = *cur;
                while j < keys.len() && (keys[j] as i64) < lower {
                    j += 1;
                }
                *cur = j;
                let start = j;
                while j < keys.len() && (keys[j] as i64) <= lower + 2 * r {
                    j += 1;
                }
                if j > start {
                    ranges.push((start, j));
                }
            }
            // Wrapped rows of a narrow grid can overlap: merge the cell ranges so no
            // point is a candidate twice.
            ranges.sort_unstable();
            cand.clear();
            let mut done = 0;
            for &(a, b) in &ranges {
                let a = a.max(done);
                if a < b {
                    let pts =
                        &self.sorted[self.cell_start[a] as usize..self.cell_start[b] as usize];
                    cand.extend(pts.iter().map(|&i| (positions[i as usize], i)));
                    done = b;
                }
            }
            visit(c, &cand);
        }
    }

    /// The point indices of cell `c`.
    fn cell(&self, c: usize) -> &[u32] {
        &self.sorted[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// The k-NN results of the points of cells `cells`, block radius 1, then the
    /// points not yet proven exact with radius 2, 3, ... [`RINGS`], then the tree.
    fn knn_chunk<'t, T, F, G>(
        &self,
        positions: &[[f32; 3]],
        cells: std::ops::Range<usize>,
        k: usize,
        tree: &G,
        f: &F,
    ) -> Vec<(u32, T)>
    where
        F: Fn(usize, &[Neighbour]) -> T,
        G: Fn() -> &'t KdTree,
    {
        let mut best: Vec<Neighbour> = Vec::with_capacity(k + 1);
        let mut packed: Vec<u64> = Vec::new();
        let mut out = Vec::new();
        let mut todo: Vec<usize> = cells.collect();
        // Points not proven exact yet (ascending cell order), and their cells.
        let mut pending: Vec<u32> = Vec::new();
        for r in 1..=RINGS {
            let mut next: Vec<u32> = Vec::new();
            let mut next_cells: Vec<usize> = Vec::new();
            let mut from = 0;
            self.blocks(positions, r as i64, &todo, |c, cand| {
                let members: &[u32] = if r == 1 {
                    self.cell(c)
                } else {
                    let n = pending[from..]
                        .iter()
                        .take_while(|&&i| self.cell(c).contains(&i))
                        .count();
                    from += n;
                    &pending[from - n..from]
                };
                for &i in members {
                    let q = &positions[i as usize];
                    k_smallest(q, cand, k, &mut packed, &mut best);
                    let margin = self.margin_r(q, r as f64);
                    let exact = best.len() == k
                        && margin > 0.0
                        && (best[k - 1].squared_distance as f64) * (1.0 + MARGIN) < margin * margin;
                    if exact {
                        out.push((i, f(i as usize, &best)));
                    } else {
                        if next_cells.last() != Some(&c) {
                            next_cells.push(c);
                        }
                        next.push(i);
                    }
                }
            });
            pending = next;
            todo = next_cells;
            if pending.is_empty() {
                break;
            }
        }
        for &i in &pending {
            out.push((
                i,
                f(i as usize, &tree_knn(tree(), &positions[i as usize], k)),
            ));
        }
        out
    }

    /// Distance from `q` to the boundary of the 3x3x3 block around its cell (shrunk by
    /// a hair for the rounding of the cell computation).
    fn margin(&self, q: &[f32; 3]) -> f64 {
        self.margin_r(q, 1.0)
    }

    /// Distance from `q` to the boundary of the block of cells within `r` of its cell.
    fn margin_r(&self, q: &[f32; 3], r: f64) -> f64 {
        let c = cell_of(q, self.origin, self.h);
        let mut m = f64::INFINITY;
        for a in 0..3 {
            let low = self.origin[a] + (c[a] as f64 - r) * self.h;
            let high = self.origin[a] + (c[a] as f64 + 1.0 + r) * self.h;
            let v = q[a] as f64;
            m = m.min(v - low).min(high - v);
        }
        m - self.h * 1e-9
    }
}

/// The `k` smallest `(squared distance, index)` from `q` among `cand`, sorted, into
/// `best`.
///
/// PERF: a squared distance is ≥ +0 and never NaN here, so its bits order like its
/// value; packed above the 32-bit index, one `u64` compares as `(d, index)`, and a
/// selection plus a sort of k words replaces ordered insertion.
fn k_smallest(
    q: &[f32; 3],
    cand: &[([f32; 3], u32)],
    k: usize,
    packed: &mut Vec<u64>,
    best: &mut Vec<Neighbour>,
) {
    packed.clear();
    packed.extend(
        cand.iter()
            .map(|(p, i)| ((squared_distance(q, p).to_bits() as u64) << 32) | *i as u64),
    );
    if packed.len() > k {
        packed.select_nth_unstable(k - 1);
        packed.truncate(k);
    }
    packed.sort_unstable();
    best.clear();
    best.extend(packed.iter().map(|&w| Neighbour {
        index: (w & 0xffff_ffff) as usize,
        squared_distance: f32::from_bits((w >> 32) as u32),
    }));
}

/// Cell coordinates of a finite point (`≥ 1` thanks to the padding).
fn cell_of(p: &[f32; 3], origin: [f64; 3], h: f64) -> [u64; 3] {
    std::array::from_fn(|a| ((p[a] as f64 - origin[a]) / h) as u64)
}

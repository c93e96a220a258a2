//! Exact k nearest neighbours of every point of a cloud at once, on a uniform grid: the
//! one grid k-NN of the crate ([`map_knn`], [`knn_all`] and the region growing use it).
//!
//! Dense sensor clouds put a handful of points in every cell of a grid whose edge is a
//! little more than the k-th neighbour distance. The points are sorted by cell (radix
//! sort of packed keys); for each occupied cell, the points of the 3x3x3 block around
//! it are gathered once into a structure-of-arrays copy and every point of the cell
//! computes its distances to all of them and picks its k closest. Only candidates
//! closer than the block boundary (with a relative margin far above `f32` rounding)
//! compete: when at least k of them exist, they are provably the k nearest of the whole
//! cloud, since every point outside the block is farther. Otherwise the point is tried
//! again on the 5x5x5 block, and so on up to [`RINGS`](cells::RINGS), and then a KD-tree built on
//! first need answers, with the same tie rule.
//!
//! Result: for each point, its k nearest finite points (itself included) by
//! `(squared distance, index)`; a tie at the k-th place goes to the smaller index, so
//! the answer is unique, equal to a brute-force selection, and independent of threads
//! and of the chunking. Distances are [`squared_distance`] (`f32`, FLANN's order).

mod cells;
mod kernel;
mod radius;

use super::{KdTree, Neighbour, Parallelism, RadiusQuery};
use crate::cloud::PointCloud;
use cells::Grid;
use kernel::{block_knn, Scratch};
use std::sync::OnceLock;

pub(crate) use cells::Block;
pub use kernel::use_portable_kernels;
pub(crate) use radius::{map_has_neighbours, radius_scan};

/// Relative margin between the k-th squared distance and the squared distance to the
/// block boundary; `f32` distance rounding is below 1e-6 relative.
pub(crate) const MARGIN: f64 = 1e-4;

/// A neighbour as one word, `(d² bits << 32) | index`. A squared distance is `≥ +0` and
/// never NaN here, so its bits order like its value and the words order like
/// `(squared distance, index)`: one `u64` comparison replaces a tuple comparison.
#[inline]
pub(crate) fn pack(d2: f32, index: u32) -> u64 {
    ((d2.to_bits() as u64) << 32) | index as u64
}

/// The index of a packed neighbour word.
#[inline]
pub(crate) fn word_index(w: u64) -> u32 {
    w as u32
}

/// The squared distance of a packed neighbour word.
#[inline]
pub(crate) fn word_d2(w: u64) -> f32 {
    f32::from_bits((w >> 32) as u32)
}

/// Row-major `n x k` neighbour indices and squared distances.
pub struct KnnTable {
    /// Neighbours per row.
    pub k: usize,
    /// Indices, `n * k`.
    pub idx: Vec<u32>,
    /// Squared distances, `n * k`.
    pub d2: Vec<f32>,
}

/// k nearest neighbours (self included) of every point of `pts`, as a table sorted by
/// `(squared distance, index)` per row (`k` is capped at the number of finite points;
/// rows of non-finite points hold index 0 at distance `f32::MAX`).
///
/// ```
/// use softsense::search::{knn_all, Parallelism};
/// let pts = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
/// let t = knn_all(&pts, 2, Parallelism::Serial);
/// assert_eq!(t.idx, vec![0, 1, 1, 0, 2, 1]);
/// ```
pub fn knn_all(pts: &[[f32; 3]], k: usize, par: Parallelism) -> KnnTable {
    let search = KnnSearch::new(pts, k);
    let k = search.k();
    let parts = search.knn(par, Vec::new, |rows: &mut Vec<(u32, u64)>, i, words| {
        words.sort_unstable();
        rows.extend(words.iter().map(|&w| (i, w)));
    });
    let mut idx = vec![0u32; pts.len() * k];
    let mut d2 = vec![f32::MAX; pts.len() * k];
    for part in parts {
        for row in part.chunks(k.max(1)) {
            let i = row[0].0 as usize;
            for (j, &(_, w)) in row.iter().enumerate() {
                idx[i * k + j] = word_index(w);
                d2[i * k + j] = word_d2(w);
            }
        }
    }
    KnnTable { k, idx, d2 }
}

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
    map_knn_with(&KnnSearch::new(positions, k), par, f)
}

/// [`map_knn`] over an index built beforehand (for instance while another thread did
/// other work).
pub(crate) fn map_knn_with<T, F>(search: &KnnSearch, par: Parallelism, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &[Neighbour]) -> T + Sync + Send,
{
    let positions = search.positions;
    // Every point starts with the answer for "no neighbours" (what non-finite points
    // keep); finite points are overwritten below.
    let mut out: Vec<T> = (0..positions.len()).map(|i| f(i, &[])).collect();
    let parts = search.knn(
        par,
        || (Vec::new(), Vec::new()),
        |(res, nb): &mut (Vec<(u32, T)>, Vec<Neighbour>), i, words| {
            words.sort_unstable();
            nb.clear();
            nb.extend(words.iter().map(|&w| Neighbour {
                index: word_index(w) as usize,
                squared_distance: word_d2(w),
            }));
            res.push((i, f(i as usize, nb)));
        },
    );
    for (i, t) in parts.into_iter().flat_map(|p| p.0) {
        out[i as usize] = t;
    }
    out
}

/// The exact k nearest neighbours of every finite point of a cloud, chunk by chunk of
/// grid cells; the grid (or, without one, the tree) is built once and serves several
/// passes ([`KnnSearch::knn`], [`KnnSearch::scan`]).
pub(crate) struct KnnSearch<'a> {
    positions: &'a [[f32; 3]],
    finite: Vec<u32>,
    k: usize,
    grid: Option<Grid>,
    tree: OnceLock<KdTree>,
}

impl<'a> KnnSearch<'a> {
    /// Indexes the finite points of `positions` for `k`-NN queries (`k` is capped at
    /// the number of finite points).
    pub(crate) fn new(positions: &'a [[f32; 3]], k: usize) -> KnnSearch<'a> {
        let finite: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| PointCloud::is_finite_point(&positions[i as usize]))
            .collect();
        let k = k.min(finite.len());
        let grid = if k == 0 {
            None
        } else {
            Grid::build(positions, &finite, k)
        };
        KnnSearch {
            positions,
            finite,
            k,
            grid,
            tree: OnceLock::new(),
        }
    }

    /// The number of neighbours each finite point gets.
    pub(crate) fn k(&self) -> usize {
        self.k
    }

    fn tree(&self) -> &KdTree {
        self.tree.get_or_init(|| KdTree::build(self.positions))
    }

    /// Calls `visit(state, i, words)` for every finite point `i` with its k nearest as
    /// packed words ([`pack`]), in no particular order (the slice may be reordered);
    /// `make` gives each chunk its state, and the states come back in chunk order (the
    /// chunking depends on the cloud only, never on the thread count).
    pub(crate) fn knn<S, M, V>(&self, par: Parallelism, make: M, visit: V) -> Vec<S>
    where
        S: Send,
        M: Fn() -> S + Sync,
        V: Fn(&mut S, u32, &mut [u64]) + Sync,
    {
        let k = self.k;
        let parts = self.scan(
            par,
            || (make(), Scratch::default()),
            |(s, sc), i, blk, margin| {
                let q = &self.positions[i as usize];
                let Some(found) = block_knn(q, blk, k, margin, sc) else {
                    return false;
                };
                visit(s, i, &mut sc.words[..found]);
                true
            },
            |(s, sc), i, tree| {
                sc.words.clear();
                sc.words.extend(
                    tree_knn(tree, &self.positions[i as usize], k)
                        .iter()
                        .map(|nb| pack(nb.squared_distance, nb.index as u32)),
                );
                visit(s, i, &mut sc.words);
            },
        );
        parts.into_iter().map(|p| p.0).collect()
    }

    /// The building block of every pass: for every finite point `i`, in chunks of
    /// cells, `try_point(state, i, block, margin)` is called with the points of the
    /// block of cells around `i`'s and the distance `margin` from `i` to the block's
    /// boundary (every point outside is at least that far; `≤ 0`: no guarantee). When
    /// it returns false, the point is tried again with the next larger block, and after
    /// [`RINGS`](cells::RINGS) blocks `fallback(state, i, tree)` answers it. Without a grid, every
    /// point goes to the fallback.
    pub(crate) fn scan<S, M, T, F>(
        &self,
        par: Parallelism,
        make: M,
        try_point: T,
        fallback: F,
    ) -> Vec<S>
    where
        S: Send,
        M: Fn() -> S + Sync,
        T: Fn(&mut S, u32, &Block, f64) -> bool + Sync,
        F: Fn(&mut S, u32, &KdTree) + Sync,
    {
        let Some(grid) = &self.grid else {
            let chunk = 1024;
            return crate::search::map_range(self.finite.len().div_ceil(chunk), par, 1, |c| {
                let mut s = make();
                let end = ((c + 1) * chunk).min(self.finite.len());
                for &i in &self.finite[c * chunk..end] {
                    fallback(&mut s, i, self.tree());
                }
                s
            });
        };
        let cells = grid.cell_keys.len();
        // Enough chunks for load balance on any machine; the split depends on the cloud
        // only.
        let chunk = (cells / 256).clamp(64, 2048);
        crate::search::map_range(cells.div_ceil(chunk), par, 1, |c| {
            let mut s = make();
            let range = c * chunk..((c + 1) * chunk).min(cells);
            let pending = grid.rings(self.positions, range, |i, blk, m| {
                try_point(&mut s, i, blk, m)
            });
            for i in pending {
                fallback(&mut s, i, self.tree());
            }
            s
        })
    }
}

/// The `k` nearest points by `(squared distance, index)` from the tree: kiddo's k
/// nearest give the k-th distance, then every point within it (inclusive, so tied
/// points are all seen) is ranked.
pub(crate) fn tree_knn(tree: &KdTree, q: &[f32; 3], k: usize) -> Vec<Neighbour> {
    let Some(last) = tree.nearest_n(q, k).last().copied() else {
        return Vec::new();
    };
    let mut all = tree_within_d2(tree, q, last.squared_distance);
    all.truncate(k);
    all
}

/// Every point at squared distance `≤ d2` from `q` (inclusive), sorted by
/// `(squared distance, index)`.
pub(crate) fn tree_within_d2(tree: &KdTree, q: &[f32; 3], d2: f32) -> Vec<Neighbour> {
    // A radius whose f32 square is ≥ d2: the widened candidate search then sees every
    // point at d² ≤ d2, and the inclusive test keeps exactly those.
    let r = (d2 as f64).sqrt() * (1.0 + 1e-6) + f64::MIN_POSITIVE;
    tree.within_radius(
        q,
        r,
        RadiusQuery {
            sorted: true,
            inclusive: true,
            ..Default::default()
        },
    )
    .into_iter()
    .filter(|nb| nb.squared_distance <= d2)
    .collect()
}

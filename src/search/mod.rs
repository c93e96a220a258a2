//! Neighbour search over a cloud's positions: a KD-tree with radius and k-NN queries.
//!
//! [`KdTree`] wraps kiddo's immutable tree. Non-finite points are never inserted, and
//! every returned index refers to the slice the tree was built from. Distances are
//! squared Euclidean distances accumulated in `f32` exactly as PCL's FLANN does,
//! `(dx*dx + dy*dy) + dz*dz`, so boundary decisions agree bit for bit with PCL; the
//! `*_f64` variants compute them in `f64` from the widened coordinates, as Open3D does.
//!
//! Semantics (the same for every query):
//! - the query point counts as its own neighbour when it is in the tree (distance 0);
//! - radius searches are strict (`d² < r²`) unless stated otherwise; `r²` is
//!   `(r * r)` computed in `f64` and rounded to `f32` (PCL's rule);
//! - results are sorted by `(squared distance, index)` when sorted output is asked for,
//!   so ties are broken by the smaller index and the order is reproducible;
//! - a cap keeps the `max` closest results.
//!
//! ```
//! use softsense::search::{KdTree, RadiusQuery};
//! let points = vec![[0.0f32, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0]];
//! let tree = KdTree::build(&points);
//! assert_eq!(tree.len(), 3); // the NaN point is not inserted
//! let near = tree.within_radius(&[0.0, 0.0, 0.0], 1.0, RadiusQuery::sorted());
//! let idx: Vec<usize> = near.iter().map(|n| n.index).collect();
//! assert_eq!(idx, vec![0, 1]); // strict: the point at distance exactly 1 is not returned
//! let knn = tree.nearest_n(&[0.9, 0.0, 0.0], 2);
//! assert_eq!(knn[0].index, 2);
//! ```

pub mod flann_order;
mod grid;
mod kdtree;
pub(crate) mod sort;

pub use flann_order::FlannTree;
pub use grid::{knn_all, map_knn, use_portable_kernels, KnnTable};
pub(crate) use grid::{map_has_neighbours, map_knn_with, radius_scan, word_index, KnnSearch};
pub(crate) use kdtree::squared_radius_f32;
pub use kdtree::{squared_distance, squared_distance_f64, KdTree, Neighbour, RadiusQuery};

/// How a stage spreads its work over threads. Results never depend on the choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Parallelism {
    /// One thread.
    Serial,
    /// rayon's global pool (serial when the `parallel` feature is off).
    #[default]
    Rayon,
}

/// `(0..n).map(f).collect()`, in parallel when asked; the output order is always `0..n`.
pub(crate) fn map_indices<T, F>(n: usize, par: Parallelism, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    map_range(n, par, 256, f)
}

/// `(a(), b())`, on two threads when asked.
pub(crate) fn join<A, B>(
    par: Parallelism,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B)
where
    A: Send,
    B: Send,
{
    #[cfg(feature = "parallel")]
    if par == Parallelism::Rayon {
        return rayon::join(a, b);
    }
    let _ = par;
    (a(), b())
}

/// [`map_indices`] with tasks of at least `min_len` items (1 for coarse items such as
/// chunks of cells: a larger minimum would run a short list of chunks on one thread).
pub(crate) fn map_range<T, F>(n: usize, par: Parallelism, min_len: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    #[cfg(feature = "parallel")]
    if par == Parallelism::Rayon {
        use rayon::prelude::*;
        return (0..n)
            .into_par_iter()
            .with_min_len(min_len)
            .map(f)
            .collect();
    }
    let _ = (par, min_len);
    (0..n).map(f).collect()
}

//! Euclidean cluster extraction with PCL 1.13 `EuclideanClusterExtraction` semantics.
//!
//! PCL: for each unprocessed point in index order a breadth-first search over strict
//! radius neighbourhoods (`d² < tol²`, `f32` arithmetic as FLANN) collects one connected
//! component; every reached point is marked at once. Components whose size is outside
//! `[min_size, max_size]` are dropped whole (not split, their points not reused).
//! Output: indices ascending within a cluster, clusters by size descending; equal sizes
//! keep discovery order (PCL does so up to 16 clusters and scrambles ties beyond, see
//! oracle-semantics section 6). Non-finite points are never clustered.
//!
//! The components of that graph do not depend on how they are searched, so softsense
//! finds them without a breadth-first search: every pair closer than the tolerance (the
//! same `f32` distance and strict test, checked against the 3x3x3 block of a grid with
//! cells of the tolerance's edge, or the KD-tree near a block's boundary) joins its two
//! points in a concurrent union-find whose roots are the smallest index of their
//! component. That smallest index is where PCL's search discovers the component, so
//! sorting components by it reproduces PCL's discovery order. Neighbour lists are not
//! stored: memory is O(n) besides the grid.

use super::{check_distance, SegmentError};
use crate::cloud::PointCloud;
use crate::search::{radius_scan, squared_radius_f32, KdTree, Parallelism, RadiusQuery};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;

/// Parameters of [`euclidean_clusters`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EuclideanParams {
    /// Cluster tolerance in metres: points closer than this (strictly) are connected.
    pub tolerance: f64,
    /// Smallest cluster kept, in points (PCL default 1).
    pub min_size: usize,
    /// Largest cluster kept, in points (PCL default unbounded).
    pub max_size: usize,
    /// Threads (the clusters never depend on it).
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for EuclideanParams {
    fn default() -> Self {
        EuclideanParams {
            tolerance: 0.005,
            min_size: 1,
            max_size: usize::MAX,
            parallelism: Parallelism::default(),
        }
    }
}

/// Clusters `positions` (see the module docs); returns clusters of indices into
/// `positions`.
///
/// ```
/// use softsense::segment::{euclidean_clusters, EuclideanParams};
/// let pts = [[0.0f32, 0.0, 0.0], [0.004, 0.0, 0.0], [1.0, 0.0, 0.0], [0.008, 0.0, 0.0]];
/// let params = EuclideanParams { tolerance: 0.005, ..Default::default() };
/// let clusters = euclidean_clusters(&pts, &params).unwrap();
/// assert_eq!(clusters, vec![vec![0, 1, 3], vec![2]]);
/// ```
pub fn euclidean_clusters(
    positions: &[[f32; 3]],
    params: &EuclideanParams,
) -> Result<Vec<Vec<usize>>, SegmentError> {
    check_distance("tolerance", params.tolerance)?;
    let tol = params.tolerance;
    let r2 = squared_radius_f32(tol);
    let tree_cell: OnceLock<KdTree> = OnceLock::new();
    let tree = || tree_cell.get_or_init(|| KdTree::build(positions));
    let dsu = Dsu::new(positions.len());
    let scanned = radius_scan(
        positions,
        tol,
        params.parallelism,
        Vec::new,
        |d2: &mut Vec<f32>, i, blk| {
            blk.distances(&positions[i as usize], d2);
            for (&j, &d) in blk.id.iter().zip(d2.iter()) {
                if j > i && d < r2 {
                    dsu.union(i, j);
                }
            }
        },
        |_, i| {
            let q = &positions[i as usize];
            for nb in tree().within_radius(q, tol, RadiusQuery::unsorted()) {
                if nb.index as u32 > i {
                    dsu.union(i, nb.index as u32);
                }
            }
        },
    );
    if scanned.is_none() {
        // No finite point, or too spread out for a grid: the breadth-first search.
        return euclidean_clusters_with_tree(positions, tree(), params);
    }
    // Components in order of their smallest index (PCL's discovery order); non-finite
    // points are in none.
    let roots: Vec<u32> = (0..positions.len() as u32)
        .map(|i| {
            if PointCloud::is_finite_point(&positions[i as usize]) {
                dsu.find(i)
            } else {
                u32::MAX
            }
        })
        .collect();
    let mut size = vec![0u32; positions.len()];
    for &r in roots.iter().filter(|&&r| r != u32::MAX) {
        size[r as usize] += 1;
    }
    let mut slot = vec![u32::MAX; positions.len()];
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    for (r, &s) in size.iter().enumerate() {
        let s = s as usize;
        if s > 0 && s >= params.min_size && s <= params.max_size {
            slot[r] = clusters.len() as u32;
            clusters.push(Vec::with_capacity(s));
        }
    }
    for (i, &r) in roots.iter().enumerate() {
        if r != u32::MAX && slot[r as usize] != u32::MAX {
            clusters[slot[r as usize] as usize].push(i);
        }
    }
    // Stable: equal sizes keep discovery order.
    clusters.sort_by_key(|c| std::cmp::Reverse(c.len()));
    Ok(clusters)
}

/// A union-find over point indices that threads may join concurrently: a root is
/// always the smallest index of its set (a larger root is linked under a smaller one,
/// so parent indices only decrease and no cycle can form), hence the final sets and
/// roots do not depend on the order of the unions.
struct Dsu {
    parent: Vec<AtomicU32>,
}

impl Dsu {
    fn new(n: usize) -> Dsu {
        Dsu {
            parent: (0..n as u32).map(AtomicU32::new).collect(),
        }
    }

    /// The root of `x`'s set, halving the path on the way.
    fn find(&self, mut x: u32) -> u32 {
        loop {
            let p = self.parent[x as usize].load(Ordering::Acquire);
            if p == x {
                return x;
            }
            let g = self.parent[p as usize].load(Ordering::Acquire);
            if g != p {
                // Any stale outcome is harmless: `g` is an ancestor of `x` either way.
                let _ = self.parent[x as usize].compare_exchange_weak(
                    p,
                    g,
                    Ordering::AcqRel,
                    Ordering::Relaxed,
                );
            }
            x = g;
        }
    }

    /// Joins the sets of `a` and `b`.
    fn union(&self, a: u32, b: u32) {
        loop {
            let (ra, rb) = (self.find(a), self.find(b));
            if ra == rb {
                return;
            }
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            // Link only if `hi` is still a root; otherwise look again.
            if self.parent[hi as usize]
                .compare_exchange(hi, lo, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
            {
                return;
            }
        }
    }
}

/// Like [`euclidean_clusters`] with a tree already built over `positions`: PCL's
/// breadth-first search itself, one thread (the reference the grid path is tested
/// against).
pub fn euclidean_clusters_with_tree(
    positions: &[[f32; 3]],
    tree: &KdTree,
    params: &EuclideanParams,
) -> Result<Vec<Vec<usize>>, SegmentError> {
    check_distance("tolerance", params.tolerance)?;
    let n = positions.len();
    let mut processed: Vec<bool> = positions
        .iter()
        .map(|p| !p.iter().all(|c| c.is_finite()))
        .collect();
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    let mut queue: Vec<usize> = Vec::new();
    for seed in 0..n {
        if processed[seed] {
            continue;
        }
        queue.clear();
        queue.push(seed);
        processed[seed] = true;
        let mut head = 0;
        while head < queue.len() {
            let cur = queue[head];
            head += 1;
            for nb in tree.within_radius(&positions[cur], params.tolerance, RadiusQuery::unsorted())
            {
                if !processed[nb.index] {
                    processed[nb.index] = true;
                    queue.push(nb.index);
                }
            }
        }
        if queue.len() >= params.min_size && queue.len() <= params.max_size {
            let mut c = queue.clone();
            c.sort_unstable();
            clusters.push(c);
        }
    }
    // Stable: equal sizes keep discovery order.
    clusters.sort_by_key(|c| std::cmp::Reverse(c.len()));
    Ok(clusters)
}

/// Per-point labels from clusters: `labels[i]` is the index of the cluster holding point
/// `i`, or `unassigned` for points in no cluster.
pub fn labels_from_clusters(n: usize, clusters: &[Vec<usize>], unassigned: u32) -> Vec<u32> {
    let mut labels = vec![unassigned; n];
    for (c, idx) in clusters.iter().enumerate() {
        for &i in idx {
            if i < n {
                labels[i] = c as u32;
            }
        }
    }
    labels
}

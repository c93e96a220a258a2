//! Euclidean cluster extraction with PCL 1.13 `EuclideanClusterExtraction` semantics.
//!
//! For each unprocessed point in index order a breadth-first search over strict radius
//! neighbourhoods (`d² < tol²`, `f32` arithmetic as FLANN) collects one connected
//! component; every reached point is marked at once. Components whose size is outside
//! `[min_size, max_size]` are dropped whole (not split, their points not reused).
//! Output: indices ascending within a cluster, clusters by size descending; equal sizes
//! keep discovery order (PCL does so up to 16 clusters and scrambles ties beyond, see
//! oracle-semantics section 6). Non-finite points are never clustered. Neighbour lists
//! are not stored: memory is O(n) besides the tree.

use super::{check_distance, SegmentError};
use crate::search::{KdTree, RadiusQuery};

/// Parameters of [`euclidean_clusters`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EuclideanParams {
    /// Cluster tolerance in metres: points closer than this (strictly) are connected.
    pub tolerance: f64,
    /// Smallest cluster kept, in points (PCL default 1).
    pub min_size: usize,
    /// Largest cluster kept, in points (PCL default unbounded).
    pub max_size: usize,
}

impl Default for EuclideanParams {
    fn default() -> Self {
        EuclideanParams {
            tolerance: 0.005,
            min_size: 1,
            max_size: usize::MAX,
        }
    }
}

/// Clusters `positions` (see the module docs); returns clusters of indices into
/// `positions`.
pub fn euclidean_clusters(
    positions: &[[f32; 3]],
    params: &EuclideanParams,
) -> Result<Vec<Vec<usize>>, SegmentError> {
    let tree = KdTree::build(positions);
    euclidean_clusters_with_tree(positions, &tree, params)
}

/// Like [`euclidean_clusters`] with a tree already built over `positions`.
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

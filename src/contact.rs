//! KD-tree contact detection (thesis Alg. 4.1, section 4.5.1.3).
//!
//! Object points with more than `min_neighbors` robot points strictly within `radius_m`
//! are contact points; they are grouped by Euclidean clustering (`tolerance_m`, groups of
//! `min_group..=max_group` points, PCL semantics: see [`crate::segment::euclidean`]) and
//! each group gives one contact: its centroid, point count and bounding box. Defaults are
//! the thesis code's: 4 mm, more than 3 neighbours, 5 mm, 10-2000 points.
//!
//! ```
//! use softsense::contact::{detect_contacts, ContactParams};
//! // A robot plate at z = 0 and an object plate 2 mm above it, both 1 mm grids.
//! let grid = |z: f32| -> Vec<[f32; 3]> {
//!     (0..20).flat_map(|i| (0..20).map(move |j| [i as f32 * 1e-3, j as f32 * 1e-3, z])).collect()
//! };
//! let contacts = detect_contacts(&grid(0.0), &grid(0.002), &ContactParams::default()).unwrap();
//! assert_eq!(contacts.len(), 1);
//! assert_eq!(contacts[0].points, 400);
//! ```

use crate::search::KdTree;
use crate::segment::euclidean::{euclidean_clusters, EuclideanParams};
use crate::segment::{check_distance, SegmentError};

/// Parameters of [`detect_contacts`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactParams {
    /// Search radius around each object point, metres (thesis r_search: 4 mm).
    pub radius_m: f64,
    /// An object point is a contact point with strictly more robot neighbours than this
    /// (thesis n_neigh: 3).
    pub min_neighbors: usize,
    /// Euclidean clustering tolerance for grouping contact points, metres (5 mm).
    pub tolerance_m: f64,
    /// Smallest group kept, points (10).
    pub min_group: usize,
    /// Largest group kept, points (2000); larger groups are dropped whole, as PCL does.
    pub max_group: usize,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams {
            radius_m: 0.004,
            min_neighbors: 3,
            tolerance_m: 0.005,
            min_group: 10,
            max_group: 2000,
        }
    }
}

/// One contact location.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Contact {
    /// Mean position of the group's object points, metres.
    pub centroid: [f32; 3],
    /// Number of contact points in the group.
    pub points: usize,
    /// Bounding box minimum corner.
    pub min: [f32; 3],
    /// Bounding box maximum corner.
    pub max: [f32; 3],
    /// Indices into the object points, ascending.
    pub indices: Vec<usize>,
}

impl Contact {
    /// Largest bounding-box side, metres.
    pub fn extent(&self) -> f32 {
        (0..3)
            .map(|a| self.max[a] - self.min[a])
            .fold(0.0, f32::max)
    }
}

/// Indices of the object points with more than `min_neighbors` robot points strictly
/// within `radius_m` (ascending).
pub fn contact_points(
    robot_tree: &KdTree,
    object: &[[f32; 3]],
    params: &ContactParams,
) -> Vec<usize> {
    let need = params.min_neighbors.saturating_add(1);
    object
        .iter()
        .enumerate()
        .filter(|(_, p)| robot_tree.count_within_radius(p, params.radius_m, false, need) >= need)
        .map(|(i, _)| i)
        .collect()
}

/// Detects contacts between `robot` and `object` points (see the module docs). Contacts
/// come in Euclidean-clustering order (largest group first).
pub fn detect_contacts(
    robot: &[[f32; 3]],
    object: &[[f32; 3]],
    params: &ContactParams,
) -> Result<Vec<Contact>, SegmentError> {
    check_distance("radius_m", params.radius_m)?;
    check_distance("tolerance_m", params.tolerance_m)?;
    let tree = KdTree::build(robot);
    let hits = contact_points(&tree, object, params);
    let hit_pos: Vec<[f32; 3]> = hits.iter().map(|&i| object[i]).collect();
    let groups = euclidean_clusters(
        &hit_pos,
        &EuclideanParams {
            tolerance: params.tolerance_m,
            min_size: params.min_group,
            max_size: params.max_group,
        },
    )?;
    Ok(groups
        .into_iter()
        .map(|g| {
            let indices: Vec<usize> = g.iter().map(|&k| hits[k]).collect();
            summarize(object, indices)
        })
        .collect())
}

/// Centroid (mean in `f64`), count and bounding box of `indices` into `points`.
pub fn summarize(points: &[[f32; 3]], indices: Vec<usize>) -> Contact {
    let mut sum = [0f64; 3];
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for &i in &indices {
        for a in 0..3 {
            sum[a] += points[i][a] as f64;
            lo[a] = lo[a].min(points[i][a]);
            hi[a] = hi[a].max(points[i][a]);
        }
    }
    let n = indices.len().max(1) as f64;
    Contact {
        centroid: sum.map(|s| (s / n) as f32),
        points: indices.len(),
        min: lo,
        max: hi,
        indices,
    }
}

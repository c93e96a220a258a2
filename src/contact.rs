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
/// within `radius_m` (ascending). Object points are first screened by an occupancy grid
/// of the robot (cells of at least `radius_m`, dilated by one cell), so that only points
/// that can have a robot point in range are queried in the tree.
pub fn contact_points(
    robot_tree: &KdTree,
    object: &[[f32; 3]],
    params: &ContactParams,
) -> Vec<usize> {
    contact_points_screened(robot_tree, None, object, params)
}

fn contact_points_screened(
    robot_tree: &KdTree,
    screen: Option<&RobotGrid>,
    object: &[[f32; 3]],
    params: &ContactParams,
) -> Vec<usize> {
    let need = params.min_neighbors.saturating_add(1);
    object
        .iter()
        .enumerate()
        .filter(|(_, p)| screen.is_none_or(|g| g.may_touch(p)))
        .filter(|(_, p)| robot_tree.count_within_radius(p, params.radius_m, false, need) >= need)
        .map(|(i, _)| i)
        .collect()
}

/// Occupancy of the robot's cells, dilated by one cell: a point outside every marked
/// cell is farther than one cell size (≥ the search radius) from every robot point.
struct RobotGrid {
    lo: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    marked: Vec<bool>,
}

/// Largest number of cells of the screening grid.
const MAX_GRID_CELLS: usize = 1 << 22;

impl RobotGrid {
    fn new(robot: &[[f32; 3]], radius: f64) -> Option<RobotGrid> {
        let finite = || robot.iter().filter(|p| p.iter().all(|c| c.is_finite()));
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in finite() {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f64);
                hi[a] = hi[a].max(p[a] as f64);
            }
        }
        if !lo[0].is_finite() {
            return None;
        }
        // Cells of at least the radius (slightly more, for rounding), coarser when the
        // robot is large, so the grid stays bounded.
        let mut cell = radius * 1.001;
        let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        cell = cell.max(extent / 128.0);
        let lo = lo.map(|v| v - 2.0 * cell);
        let dims: [usize; 3] =
            std::array::from_fn(|a| ((hi[a] + 2.0 * cell - lo[a]) / cell).ceil() as usize + 1);
        let total = dims[0].checked_mul(dims[1])?.checked_mul(dims[2])?;
        if total > MAX_GRID_CELLS {
            return None;
        }
        let mut g = RobotGrid {
            lo,
            cell,
            dims,
            marked: vec![false; total],
        };
        for p in finite() {
            let c = g.cell_of(p)?;
            for dx in 0..3 {
                for dy in 0..3 {
                    for dz in 0..3 {
                        let i = g.flat([c[0] + dx - 1, c[1] + dy - 1, c[2] + dz - 1]);
                        g.marked[i] = true;
                    }
                }
            }
        }
        Some(g)
    }

    fn cell_of(&self, p: &[f32; 3]) -> Option<[usize; 3]> {
        let mut c = [0usize; 3];
        for a in 0..3 {
            let x = ((p[a] as f64 - self.lo[a]) / self.cell).floor();
            if !(x >= 1.0 && x < (self.dims[a] - 1) as f64) {
                return None;
            }
            c[a] = x as usize;
        }
        Some(c)
    }

    fn flat(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    fn may_touch(&self, p: &[f32; 3]) -> bool {
        self.cell_of(p).is_some_and(|c| self.marked[self.flat(c)])
    }

    /// The points of `robot` in the cells of `queries` or next to them: every robot point
    /// within one cell size (≥ the search radius) of a query, in their order.
    fn near_any<'a>(
        &self,
        robot: &[[f32; 3]],
        queries: impl Iterator<Item = &'a [f32; 3]>,
    ) -> Vec<[f32; 3]> {
        let mut near = vec![false; self.marked.len()];
        let mut any = false;
        for q in queries {
            // A query the grid lets through is in its interior: its neighbours exist.
            let Some(c) = self.cell_of(q) else { continue };
            for dx in 0..3 {
                for dy in 0..3 {
                    for dz in 0..3 {
                        near[self.flat([c[0] + dx - 1, c[1] + dy - 1, c[2] + dz - 1])] = true;
                    }
                }
            }
            any = true;
        }
        if !any {
            return Vec::new();
        }
        robot
            .iter()
            .filter(|p| self.cell_of(p).is_some_and(|c| near[self.flat(c)]))
            .copied()
            .collect()
    }
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
    let grid = RobotGrid::new(robot, params.radius_m);
    // The tree holds only the robot points that can be within the radius of an object
    // point the grid lets through (those in its cell or the next ones): the same counts
    // as the whole robot's, without sorting tens of thousands of points for a few
    // hundred queries.
    let near: Vec<[f32; 3]>;
    let tree_points = match &grid {
        Some(g) => {
            near = g.near_any(robot, object.iter().filter(|p| g.may_touch(p)));
            &near[..]
        }
        None => robot,
    };
    let tree = KdTree::build(tree_points);
    let hits = contact_points_screened(&tree, grid.as_ref(), object, params);
    let hit_pos: Vec<[f32; 3]> = hits.iter().map(|&i| object[i]).collect();
    let groups = euclidean_clusters(
        &hit_pos,
        &EuclideanParams {
            tolerance: params.tolerance_m,
            min_size: params.min_group,
            max_size: params.max_group,
            ..Default::default()
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

//! Radius and statistical outlier removal, in PCL's and Open3D's semantics.

use super::{FilterError, FilterOutput};
use crate::cloud::PointCloud;
use crate::search::{
    map_has_neighbours, map_knn, squared_distance, squared_distance_f64, squared_radius_f32,
    Parallelism,
};
use serde::{Deserialize, Serialize};

/// Which library's neighbour counting and boundary rules to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OutlierMode {
    /// PCL (`RadiusOutlierRemoval`, `StatisticalOutlierRemoval`), `f32` distances.
    #[default]
    Pcl,
    /// Open3D (`remove_radius_outlier`, `remove_statistical_outlier`), `f64` distances.
    Open3d,
}

/// Parameters of [`radius_outlier_removal`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RadiusOutlierParams {
    /// Search radius, metres (`> 0`).
    pub radius: f64,
    /// Neighbours required within the radius, not counting the point itself (PCL's
    /// `MinNeighborsInRadius`, Open3D's `nb_points`).
    pub min_neighbors: usize,
    /// Counting and boundary rules.
    pub mode: OutlierMode,
    /// Threads.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for RadiusOutlierParams {
    fn default() -> Self {
        RadiusOutlierParams {
            radius: 0.005,
            min_neighbors: 5,
            mode: OutlierMode::Pcl,
            parallelism: Parallelism::default(),
        }
    }
}

/// Keeps the points that have at least `min_neighbors` other points within `radius`.
///
/// - PCL mode, cloud without non-finite points (PCL's dense path, a k-NN search):
///   neighbours at exactly the radius count (`d² ≤ r²`, `f32`).
/// - PCL mode, cloud with non-finite points (PCL's radius-search path): strict `d² < r²`.
/// - Open3D mode: strict `d² < r²` in `f64`; `min_neighbors` must be ≥ 1.
///
/// Non-finite points are always removed. Output is in input order. PCL switches to an
/// organized-image search for organized clouds; this function always searches in 3-D
/// (as PCL does on an unorganized cloud).
pub fn radius_outlier_removal(
    cloud: &PointCloud,
    params: &RadiusOutlierParams,
) -> Result<FilterOutput, FilterError> {
    cloud.validate()?;
    if !(params.radius.is_finite() && params.radius > 0.0) {
        return Err(FilterError::InvalidRadius {
            radius: params.radius,
        });
    }
    if params.mode == OutlierMode::Open3d && params.min_neighbors < 1 {
        return Err(FilterError::InvalidCount {
            name: "min_neighbors",
            min: 1,
            got: params.min_neighbors,
        });
    }
    let need = params.min_neighbors.saturating_add(1); // the point itself counts
    let inclusive = params.mode == OutlierMode::Pcl && cloud.is_dense();
    let r = params.radius;
    let r2_32 = squared_radius_f32(r);
    let r2_64 = r * r;
    // PERF: a grid of radius-sized cells instead of one tree query per point.
    let keep = match params.mode {
        OutlierMode::Pcl => {
            map_has_neighbours(&cloud.positions, r, need, params.parallelism, |q, p| {
                let d = squared_distance(q, p);
                (inclusive && d <= r2_32) || d < r2_32
            })
        }
        OutlierMode::Open3d => {
            map_has_neighbours(&cloud.positions, r, need, params.parallelism, |q, p| {
                squared_distance_f64(q, p) < r2_64
            })
        }
    };
    Ok(select_mask(cloud, &keep))
}

/// Parameters of [`statistical_outlier_removal`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StatisticalOutlierParams {
    /// Neighbours per point: PCL's `meanK` (the point itself excluded) or Open3D's
    /// `nb_neighbors` (the point itself included). PCL `meanK = K` matches Open3D
    /// `nb_neighbors = K + 1`.
    pub k: usize,
    /// Multiple of the standard deviation added to the mean for the threshold.
    pub std_ratio: f64,
    /// Counting and threshold rules.
    pub mode: OutlierMode,
    /// Threads.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for StatisticalOutlierParams {
    fn default() -> Self {
        StatisticalOutlierParams {
            k: 20,
            std_ratio: 2.0,
            mode: OutlierMode::Pcl,
            parallelism: Parallelism::default(),
        }
    }
}

/// Removes points whose mean distance to their neighbours is large compared with the
/// cloud's: threshold = mean + `std_ratio` · (sample standard deviation).
///
/// - PCL mode: per point, the mean of `sqrt(d²)` (`f32`) over the `k` nearest other
///   points; keep `d ≤ threshold`. Non-finite points get 0 and are **kept**, as PCL
///   keeps them; they do not count in the statistics. When the cloud has fewer than
///   `k + 1` finite points the mean is over the points available (PCL reads past its
///   buffer there).
/// - Open3D mode: the mean over the `k` nearest points **including** the point itself,
///   in `f64`; keep `0 < d < threshold`, so points with `k - 1` exact duplicates are
///   removed; non-finite points are removed.
///
/// Output is in input order.
pub fn statistical_outlier_removal(
    cloud: &PointCloud,
    params: &StatisticalOutlierParams,
) -> Result<FilterOutput, FilterError> {
    cloud.validate()?;
    if params.k < 1 {
        return Err(FilterError::InvalidCount {
            name: "k",
            min: 1,
            got: params.k,
        });
    }
    if !params.std_ratio.is_finite() {
        return Err(FilterError::InvalidValue {
            name: "std_ratio",
            value: params.std_ratio,
        });
    }
    // PERF: all k-NN lists at once on a grid; the mean distance does not depend on
    // which of several tied points is taken.
    let pos = &cloud.positions;
    let k = params.k;
    let keep = match params.mode {
        OutlierMode::Pcl => {
            // (mean distance, valid)
            let d: Vec<(f32, bool)> = map_knn(pos, k + 1, params.parallelism, |_, nn| {
                if nn.len() < 2 {
                    return (0.0, false);
                }
                let sum: f64 = nn[1..]
                    .iter()
                    .map(|n| n.squared_distance.sqrt() as f64)
                    .sum();
                ((sum / (nn.len() - 1) as f64) as f32, true)
            });
            let valid = d.iter().filter(|x| x.1).count() as f64;
            let (mut sum, mut sq) = (0f64, 0f64);
            for &(v, _) in &d {
                sum += v as f64;
                sq += (v * v) as f64;
            }
            let mean = sum / valid;
            let var = (sq - sum * sum / valid) / (valid - 1.0);
            let thr = mean + params.std_ratio * var.sqrt();
            d.iter()
                .map(|&(v, _)| (v as f64).partial_cmp(&thr) != Some(std::cmp::Ordering::Greater))
                .collect::<Vec<_>>()
        }
        OutlierMode::Open3d => {
            let avg: Vec<f64> = map_knn(pos, k, params.parallelism, |i, nn| {
                if nn.is_empty() {
                    return -1.0;
                }
                let s: f64 = nn
                    .iter()
                    .map(|n| squared_distance_f64(&pos[i], &pos[n.index]).sqrt())
                    .sum();
                s / nn.len() as f64
            });
            let valid = avg.iter().filter(|&&a| a >= 0.0).count() as f64;
            let mean = avg.iter().filter(|&&a| a > 0.0).sum::<f64>() / valid;
            let sq: f64 = avg
                .iter()
                .filter(|&&a| a > 0.0)
                .map(|&a| (a - mean) * (a - mean))
                .sum();
            let thr = mean + params.std_ratio * (sq / (valid - 1.0)).sqrt();
            avg.iter().map(|&a| a > 0.0 && a < thr).collect()
        }
    };
    Ok(select_mask(cloud, &keep))
}

/// The points whose mask entry is true, in input order, as a [`FilterOutput`].
fn select_mask(cloud: &PointCloud, keep: &[bool]) -> FilterOutput {
    let indices: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
    FilterOutput {
        cloud: cloud.select(&indices),
        indices,
    }
}

//! Segmentation: PCL-compatible colour region growing, Euclidean clustering, the CIELAB
//! colour model and robot selection (thesis sections 4.5.1.2-4.5.1.4).
//!
//! - [`euclidean`]: PCL `EuclideanClusterExtraction` (strict radius, size filter, clusters
//!   by size descending, indices ascending);
//! - [`mod@region_growing_rgb`]: PCL `RegionGrowingRGB`, ported step by step, with a
//!   near-linear segment adjacency and merge;
//! - [`geometric`]: our own mode (support plane, smooth growing on normals, convexity
//!   and colour merge), far closer to human labels than colour alone; pick a mode with
//!   [`SegmentMode`] and [`segment`];
//! - [`color`]: sRGB to CIELAB (D65) and ΔE;
//! - [`robot`]: which segment is the robot;
//! - [`metrics`]: adjusted Rand index and object-level scores against labels.
//!
//! ```
//! use softsense::segment::euclidean::{euclidean_clusters, EuclideanParams};
//! let pts = vec![[0.0f32, 0.0, 0.0], [0.001, 0.0, 0.0], [1.0, 0.0, 0.0]];
//! let params = EuclideanParams { tolerance: 0.005, ..Default::default() };
//! let clusters = euclidean_clusters(&pts, &params).unwrap();
//! assert_eq!(clusters, vec![vec![0, 1], vec![2]]);
//! ```

pub mod color;
pub mod euclidean;
pub mod geometric;
/// Moved to [`crate::search`]; re-exported here for existing callers.
pub mod knn {
    pub use crate::search::{knn_all, KnnTable};
}
pub mod metrics;
pub mod region_growing_rgb;
pub mod robot;
pub mod robot_color;

pub use euclidean::{euclidean_clusters, EuclideanParams};
pub use geometric::{segment_geometric, GeometricParams, GeometricSegmentation};
pub use region_growing_rgb::{region_growing_rgb, RegionGrowingParams, Segment, Segmentation};

/// Which segmentation to run, with its parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "mode", rename_all = "lowercase")]
pub enum SegmentMode {
    /// PCL 1.13 `RegionGrowingRGB`, exact ([`mod@region_growing_rgb`]).
    Pcl(RegionGrowingParams),
    /// Our geometric mode: support plane, smooth growing, convexity merge
    /// ([`segment_geometric`]).
    Geometric(GeometricParams),
}

impl Default for SegmentMode {
    fn default() -> Self {
        SegmentMode::Pcl(RegionGrowingParams::default())
    }
}

/// Segments `cloud` with the chosen mode. `support` lists the segments that are the
/// support plane (always empty in PCL mode).
pub fn segment(
    cloud: &crate::cloud::PointCloud,
    mode: &SegmentMode,
) -> Result<(Segmentation, Vec<usize>), SegmentError> {
    match mode {
        SegmentMode::Pcl(p) => Ok((region_growing_rgb(cloud, p)?, Vec::new())),
        SegmentMode::Geometric(p) => {
            let g = segment_geometric(cloud, p)?;
            Ok((g.segmentation, g.support))
        }
    }
}

/// Label given by [`Segmentation::labels`] to points that are in no segment (non-finite
/// points and points of clusters removed by the size filter).
pub const UNSEGMENTED: u32 = u32::MAX;

/// Errors of the segmentation stages.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SegmentError {
    /// A distance parameter is not finite and positive.
    #[error("{name} must be finite and > 0 (metres), got {value}")]
    InvalidDistance {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
    },
    /// A colour threshold is not finite and non-negative.
    #[error("{name} must be finite and >= 0, got {value}")]
    InvalidThreshold {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
    },
    /// A count parameter is out of range.
    #[error("{name} must be in {min}..={max}, got {value}")]
    InvalidCount {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: usize,
        /// Smallest allowed.
        min: usize,
        /// Largest allowed.
        max: usize,
    },
    /// The cloud has no colours but the stage needs them.
    #[error("the cloud has no rgb field; colour region growing needs colours")]
    NoColors,
    /// The cloud is inconsistent (field lengths).
    #[error(transparent)]
    Cloud(#[from] crate::cloud::CloudError),
    /// Normal estimation failed (geometric mode).
    #[error(transparent)]
    Features(#[from] crate::features::FeatureError),
    /// The neighbour lists of colour region growing would exceed the memory budget.
    #[error("colour region growing's neighbour lists: {0}")]
    TooLarge(#[from] crate::io::limits::TooLarge),
    /// No segment could be chosen as the robot.
    #[error("no robot segment: {0}")]
    NoRobot(String),
}

pub(crate) fn check_distance(name: &'static str, value: f64) -> Result<(), SegmentError> {
    if value.is_finite() && value > 0.0 && (value as f32) > 0.0 {
        Ok(())
    } else {
        Err(SegmentError::InvalidDistance { name, value })
    }
}

pub(crate) fn check_threshold(name: &'static str, value: f64) -> Result<(), SegmentError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(SegmentError::InvalidThreshold { name, value })
    }
}

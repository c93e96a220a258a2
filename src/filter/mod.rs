//! Point-cloud filters: pass-through and crop box, voxel grid, radius and statistical
//! outlier removal, each in PCL's and (where it differs) Open3D's semantics.
//!
//! Every filter returns a [`FilterOutput`]: the new cloud and, for each output point, the
//! index of the input point it came from (for the voxel grid, the smallest input index
//! that fell into the voxel). NaN handling is stated per filter; no filter trusts a
//! stored "dense" flag, finiteness is checked point by point.
//!
//! Principal entry points: [`pass_through`], [`crop_box`], [`voxel_grid`],
//! [`radius_outlier_removal`], [`statistical_outlier_removal`].
//!
//! ```
//! use softsense::cloud::PointCloud;
//! use softsense::filter::{pass_through, voxel_grid, Field, PassThroughParams, VoxelGridParams};
//! # fn main() -> Result<(), softsense::filter::FilterError> {
//! let cloud = PointCloud::from_positions(vec![
//!     [0.01, 0.0, 0.5], [0.012, 0.001, 0.5], [0.0, 0.0, 2.0], [f32::NAN, 0.0, 0.0],
//! ]);
//! let near = pass_through(&cloud, &PassThroughParams::new(Field::Z, 0.0, 1.0))?;
//! assert_eq!(near.indices, vec![0, 1]);
//! let grid = voxel_grid(&near.cloud, &VoxelGridParams::new(0.01))?;
//! assert_eq!(grid.cloud.len(), 1); // both points share the PCL voxel [1, 0, 50]
//! # Ok(()) }
//! ```

mod crop;
mod mask;
mod outlier;
mod voxel;

pub use crop::{
    crop_box, crop_box_indices, crop_box_indices_into, crop_box_into, pass_through,
    pass_through_indices_into, pass_through_into, CropBoxParams, Field, PassThroughParams,
};
pub use outlier::{
    radius_outlier_removal, statistical_outlier_removal, OutlierMode, RadiusOutlierParams,
    StatisticalOutlierParams,
};
pub(crate) use voxel::voxel_grid_of;
pub use voxel::{voxel_grid, VoxelGridParams, VoxelMode};

use crate::cloud::PointCloud;
use thiserror::Error;

/// The result of a filter: the filtered cloud and where each output point came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FilterOutput {
    /// The filtered cloud.
    pub cloud: PointCloud,
    /// For each output point, the input index it came from (ascending for selecting
    /// filters; for the voxel grid, the smallest input index in the voxel).
    pub indices: Vec<usize>,
}

/// Errors of the filters: bad parameters, never bad data.
#[derive(Debug, Error, PartialEq)]
pub enum FilterError {
    /// A voxel leaf size is not a finite positive number.
    #[error("voxel leaf size must be finite and > 0, got {leaf}")]
    InvalidLeafSize {
        /// The offending leaf size, metres.
        leaf: f64,
    },
    /// The leaf is so small that voxel coordinates leave the 63-bit range.
    #[error(
        "voxel leaf {leaf} m is too small for coordinates up to {extent} m (voxel index overflow)"
    )]
    LeafTooSmall {
        /// The leaf size, metres.
        leaf: f64,
        /// The largest absolute coordinate, metres.
        extent: f64,
    },
    /// A search radius is not a finite positive number.
    #[error("radius must be finite and > 0, got {radius}")]
    InvalidRadius {
        /// The offending radius, metres.
        radius: f64,
    },
    /// A neighbour count parameter is out of range.
    #[error("{name} must be at least {min}, got {got}")]
    InvalidCount {
        /// Parameter name.
        name: &'static str,
        /// Smallest allowed value.
        min: usize,
        /// The value given.
        got: usize,
    },
    /// A real-valued parameter is out of range (NaN, infinite or negative).
    #[error("{name} is invalid: {value}")]
    InvalidValue {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// The field to filter on is not present in the cloud.
    #[error("the cloud has no `{field}` field")]
    MissingField {
        /// Field name.
        field: &'static str,
    },
    /// A field name was not recognised.
    #[error("unknown field `{0}` (expected x, y, z, normal_x, normal_y, normal_z, curvature, label, r, g or b)")]
    UnknownField(String),
    /// A crop box has a NaN bound or `min > max` on some axis.
    #[error("crop box is empty or invalid: min {min:?}, max {max:?}")]
    InvalidBox {
        /// Lower corner.
        min: [f64; 3],
        /// Upper corner.
        max: [f64; 3],
    },
    /// The cloud's attribute columns are inconsistent.
    #[error(transparent)]
    Cloud(#[from] crate::cloud::CloudError),
}

/// An empty cloud with the same attribute columns (and viewpoint) as `like`.
pub(crate) fn empty_like(like: &PointCloud) -> PointCloud {
    like.select(&[])
}

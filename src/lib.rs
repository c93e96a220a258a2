//! # softsense
//!
//! softsense makes a soft robot its own force sensor. An RGB-D camera watches the robot;
//! each frame flows through a chain of point-cloud stages and ends in a small quadratic
//! program on the robot's finite-element (FE) model that says where the robot is touched
//! and how hard.
//!
//! The chain, one frame at a time (thesis section 4.5):
//!
//! 1. **read** a frame: PCD, PLY, or RGB-D images ([`io`]);
//! 2. **crop** with pass-through filters, 3. **voxel** down-sample, 4. remove **outliers**;
//! 5. **segment** the robot from touching objects by colour region growing;
//! 6. **transform** camera frame to robot frame; 7. detect **contacts** with a KD-tree;
//! 8. **cluster** contact points; 9. **map** them onto the FE surface;
//! 10. **register** FE feature points along their normal lines;
//! 11. **solve** the normal-space QP on the compliance matrices for force intensities.
//!
//! The crate stores point clouds in `f32` (like PCL) and computes the FE model and QPs in
//! `f64`, in SI units.
//!
//! ```
//! use softsense::cloud::PointCloud;
//! let cloud = PointCloud::from_positions(vec![[0.0, 0.0, 1.0], [f32::NAN, 0.0, 0.0]]);
//! assert_eq!(cloud.len(), 2);
//! assert_eq!(cloud.count_finite(), 1);
//! ```
#![warn(missing_docs, rustdoc::broken_intra_doc_links)]

pub mod calibrate;
pub mod camera;
pub mod cloud;
pub mod contact;
pub mod discrepancy;
pub mod error;
pub mod features;
pub mod fem;
pub mod filter;
pub mod geometry;
pub mod inverse;
pub mod io;
pub mod math;
pub mod pipeline;
pub mod recording;
pub mod register;
pub mod render;
pub mod scene;
pub mod search;
pub mod segment;
pub mod sense;

pub use cloud::PointCloud;
pub use error::{Error, Result};

//! # softsense
//!
//! softsense makes a soft robot its own force sensor. An RGB-D camera watches the robot;
//! each frame flows through a chain of point-cloud stages and ends in a small quadratic
//! program on the robot's finite-element (FE) model that says where the robot is touched
//! and how hard.
//!
//! What `softsense sense` runs on each frame of a recording ([`recording`], thesis 4.5):
//!
//! 1. **read** depth and colour into a cloud in the camera frame ([`io::rgbd`]);
//! 2. **transform** it to the robot frame (`robot_from_camera`, [`math::pose`]) and **crop**
//!    it to a box around the robot above the table;
//! 3. tell **robot** points from **objects** by colour ([`segment::robot_color`]);
//! 4. detect **contacts** with a KD-tree and group them ([`contact`], Algorithm 4.1);
//! 5. **map** each contact onto the FE surface and choose the touched node ([`inverse`]);
//! 6. **register** FE feature points along their normal lines ([`register`], Algorithm 4.2);
//! 7. **solve** the normal-space QP on the compliance matrices W = H K⁻¹ Hᵀ for the force
//!    intensities, with FE updates, and their uncertainty ([`inverse`], [`fem`]).
//!
//! The PCL- and Open3D-equivalent stages for clouds in general (pass-through, voxel grid,
//! outlier removal, region growing, Euclidean clustering, normals) are in [`filter`],
//! [`segment`], [`features`] and [`pipeline`] (`softsense filter`, `segment`, `cluster`).
//! Layers and modules: `docs/architecture.md`.
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

pub mod batch;
pub mod calibrate;
pub mod camera;
pub mod catheter;
pub mod cloud;
pub mod contact;
pub mod control;
pub mod discrepancy;
pub mod error;
pub mod features;
pub mod fem;
pub mod filter;
pub mod geometry;
pub mod inverse;
pub mod io;
pub mod markers;
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

//! Geometric primitives shared by the model layer ([`crate::register`]) and the workflows
//! ([`crate::scene`], [`crate::calibrate`], [`crate::discrepancy`]): ray casting against a
//! triangle surface, spheres and planes ([`raycast`]), and the closest point of a triangle
//! and a surface's vertex normals ([`triangle`]). All in `f64`, robot frame.
//!
//! ```
//! use softsense::geometry::raycast::Bvh;
//! use softsense::geometry::triangle::closest_point_on_triangle;
//! let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
//! let bvh = Bvh::new(&nodes, &[[0, 1, 2]]);
//! let hit = bvh.cast([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]).unwrap();
//! assert!((hit.t - 1.0).abs() < 1e-12);
//! let q = closest_point_on_triangle([0.2, 0.2, 1.0], nodes[0], nodes[1], nodes[2]);
//! assert!((0..3).all(|k| (q[k] - [0.2, 0.2, 0.0][k]).abs() < 1e-12));
//! ```

pub mod closed;
pub mod raycast;
pub mod rigid;
pub mod triangle;

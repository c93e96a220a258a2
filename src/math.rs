//! Small fixed-size math aliases (always 3-D, nalgebra).
//!
//! Point clouds store `f32`; the FE core and QPs use the `f64` aliases below.

/// A 3-D point in `f64`.
pub type Point3 = nalgebra::Point3<f64>;
/// A 3-D vector in `f64`.
pub type Vec3 = nalgebra::Vector3<f64>;
/// A 3x3 matrix in `f64`.
pub type Mat3 = nalgebra::Matrix3<f64>;
/// A rigid transform (rotation + translation) in `f64`.
pub type Iso3 = nalgebra::Isometry3<f64>;
/// A 3-D point in `f32`, the storage type of clouds.
pub type Point3f = nalgebra::Point3<f32>;
/// A 3-D vector in `f32`.
pub type Vec3f = nalgebra::Vector3<f32>;

//! Small fixed-size math aliases (always 3-D, nalgebra).
//!
//! Point clouds store `f32`; the FE core and QPs use the `f64` aliases below. The FE core,
//! ray caster, registration and control keep points as plain `[f64; 3]`, with the small
//! helpers below; [`rand`] holds the counter-based random draws.

pub mod pose;
pub mod rand;

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

/// The median of `v` (the mean of the two middle values for an even count; NaN when
/// empty). Reorders `v`: O(n) selection, no full sort.
pub fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return hi;
    }
    // The lower middle value is the largest of the lower part.
    let lo = v[..n / 2]
        .iter()
        .copied()
        .max_by(f64::total_cmp)
        .unwrap_or(hi);
    0.5 * (lo + hi)
}

/// `a − b` on plain arrays (the FE core, ray caster and registration keep `[f64; 3]`).
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Dot product on plain arrays.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product on plain arrays.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length on plain arrays.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`, or `a` unchanged when it has zero length.
pub fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = norm(a);
    if l > 0.0 {
        a.map(|c| c / l)
    } else {
        a
    }
}

/// Euclidean distance between two points on plain arrays.
pub fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(sub(a, b))
}

/// Two unit vectors completing the unit vector `n` to a right-handed orthonormal basis
/// (t1, t2, n): t1 is n × x, or n × y when n is within about 25° of x.
pub fn tangents(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t1 = unit(cross(n, a));
    (t1, cross(n, t1))
}

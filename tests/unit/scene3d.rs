//! The plain-data 3-D scene of a frame (`render::scene3d`): the force uncertainty
//! ellipsoid and the JSON the Python package reads.
use proptest::prelude::*;
use softsense::math::Mat3;
use softsense::render::scene3d::{sigma_ellipsoid, Entity, Level, Shape};

proptest! {
    #[test]
    fn the_sigma_ellipsoid_rebuilds_the_force_covariance(
        a in prop::array::uniform9(-1.0f64..1.0),
        scale in 0.01f64..1.0,
    ) {
        // A symmetric positive-definite covariance (N²).
        let a = Mat3::from_row_slice(&a);
        let c = a * a.transpose() + Mat3::identity() * 1e-3;
        let cov: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| c[(i, j)]));
        let (half, q) = sigma_ellipsoid(&cov, scale);
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            f64::from(q[3]), f64::from(q[0]), f64::from(q[1]), f64::from(q[2]),
        ));
        let r = q.to_rotation_matrix().into_inner();
        let d = Mat3::from_diagonal(&nalgebra::Vector3::from(half.map(|h| (f64::from(h) / scale).powi(2))));
        let rebuilt = r * d * r.transpose();
        let gap = (rebuilt - c).abs().max();
        prop_assert!(gap < 1e-5 * c.abs().max().max(1.0), "gap {gap}: {c} vs {rebuilt}");
    }
}

#[test]
fn a_degenerate_covariance_gives_a_flat_ellipsoid_not_nan() {
    let (half, q) = sigma_ellipsoid(&[[4.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], 0.5);
    assert!(half.iter().chain(q.iter()).all(|v| v.is_finite()));
    let mut sorted = half;
    sorted.sort_by(f32::total_cmp);
    assert_eq!(sorted, [0.0, 0.0, 1.0]);
}

#[test]
fn entities_serialize_with_the_kind_tags_the_python_package_reads() {
    let e = Entity {
        path: "status".into(),
        shape: Shape::Text {
            level: Level::Warn,
            text: "slow".into(),
        },
    };
    let v = serde_json::to_value(&e).unwrap();
    assert_eq!(
        v,
        serde_json::json!({"path": "status", "shape": {"kind": "text", "level": "warn", "text": "slow"}})
    );
    let z = serde_json::to_value(Shape::ZUp).unwrap();
    assert_eq!(z, serde_json::json!({"kind": "z_up"}));
    let c = serde_json::to_value(Shape::Clear).unwrap();
    assert_eq!(c, serde_json::json!({"kind": "clear"}));
}

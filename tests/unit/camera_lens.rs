//! Lenses that are not pinholes (issue 53 item 3): Brown-Conrady distortion both ways, a
//! per-pixel ray table, and the two directions of each agreeing.
use proptest::prelude::*;
use softsense::camera::{project, Distortion, DistortionModel, Lens, PinholeIntrinsics, RayTable};
use std::sync::Arc;

fn k() -> PinholeIntrinsics {
    PinholeIntrinsics {
        width: 64,
        height: 48,
        // A field of view of about 44 x 33 degrees, where every drawn distortion is
        // one-to-one (a wider one has image corners no undistorted ray reaches).
        fx: 80.0,
        fy: 82.0,
        cx: 31.2,
        cy: 23.7,
    }
}

/// The angle (rad) between the rays `(a, 1)` and `(b, 1)`.
fn angle(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (p, q) = ([a[0], a[1], 1.0], [b[0], b[1], 1.0]);
    let c = softsense::math::cross(p, q);
    let s = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let d = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    s.atan2(d)
}

/// A table of the rays a Brown-Conrady lens gives `k()`'s pixels, as `rays.npy` holds them.
fn table_of(dist: &Distortion) -> RayTable {
    let k = k();
    let lens = Lens::Distorted(*dist);
    let mut rays = Vec::new();
    for v in 0..k.height {
        for u in 0..k.width {
            let r = lens.ray(&k, f64::from(u), f64::from(v)).unwrap();
            rays.push([r[0] as f32, r[1] as f32]);
        }
    }
    RayTable::new(k.width, k.height, rays).unwrap()
}

fn coefficients() -> impl Strategy<Value = [f64; 5]> {
    (
        -0.3..0.3f64,
        -0.1..0.1f64,
        -2e-3..2e-3f64,
        -2e-3..2e-3f64,
        -0.02..0.02f64,
    )
        .prop_map(|(k1, k2, p1, p2, k3)| [k1, k2, p1, p2, k3])
}

proptest! {
    #[test]
    fn a_point_projected_through_a_distortion_and_back_projected_keeps_its_direction_to_1e_9_rad(
        c in coefficients(),
        inverse in any::<bool>(),
        x in -0.5..0.5f64,
        y in -0.5..0.5f64,
        z in 0.05..5.0f64,
    ) {
        let model = if inverse {
            DistortionModel::InverseBrownConrady
        } else {
            DistortionModel::BrownConrady
        };
        let lens = Lens::Distorted(Distortion::new(model, c).unwrap());
        let uv = lens.project(&k(), [x * z, y * z, z]).unwrap();
        let ray = lens.ray(&k(), uv[0], uv[1]).unwrap();
        prop_assert!(angle([x, y], ray) < 1e-9, "{:e} rad", angle([x, y], ray));
    }

    #[test]
    fn a_point_projected_through_a_ray_table_and_back_projected_keeps_its_direction_to_1e_9_rad(
        c in coefficients(),
        u in 0.0..63.0f64,
        v in 0.0..47.0f64,
        z in 0.05..5.0f64,
    ) {
        let table = table_of(&Distortion::new(DistortionModel::BrownConrady, c).unwrap());
        // A direction the table sees: the interpolated ray of a pixel inside it.
        let n = table.ray(u, v).unwrap();
        let lens = Lens::Rays(Arc::new(table));
        let uv = lens.project(&k(), [n[0] * z, n[1] * z, z]).unwrap();
        let ray = lens.ray(&k(), uv[0], uv[1]).unwrap();
        prop_assert!(angle(n, ray) < 1e-9, "{:e} rad", angle(n, ray));
        // And the pixel itself comes back (the table's rays are one-to-one here).
        prop_assert!((uv[0] - u).abs() < 1e-6 && (uv[1] - v).abs() < 1e-6, "{uv:?} vs {u} {v}");
    }

    #[test]
    fn the_pinhole_lens_is_the_pinhole_bit_for_bit(
        x in -2.0..2.0f64, y in -2.0..2.0f64, z in 0.01..5.0f64,
    ) {
        let k = k();
        prop_assert_eq!(Lens::Pinhole.project(&k, [x, y, z]), project([x, y, z], &k));
        let r = Lens::Pinhole.ray(&k, x, y).unwrap();
        prop_assert_eq!(r, [(x - k.cx) / k.fx, (y - k.cy) / k.fy]);
    }
}

#[test]
fn brown_conrady_projects_with_the_opencv_polynomial() {
    // One value worked by hand: x = 0.2, y = -0.1, k1 = 0.1, p1 = 0.01, the rest 0:
    // r² = 0.05, radial = 1.005, x_d = 0.2·1.005 + 2·0.01·0.2·(−0.1) = 0.2006,
    // y_d = −0.1·1.005 + 0.01·(0.05 + 0.02) = −0.0998.
    let d = Distortion::new(DistortionModel::BrownConrady, [0.1, 0.0, 0.01, 0.0, 0.0]).unwrap();
    let got = d.distort([0.2, -0.1]).unwrap();
    assert!(
        (got[0] - 0.2006).abs() < 1e-15 && (got[1] + 0.0998).abs() < 1e-15,
        "{got:?}"
    );
    // The inverse model applies the same polynomial when back-projecting.
    let inv = Distortion::new(DistortionModel::InverseBrownConrady, d.coeffs).unwrap();
    assert_eq!(inv.undistort([0.2, -0.1]), Some(got));
}

#[test]
fn a_ray_table_has_no_pixel_for_a_direction_outside_its_field_or_at_a_nan_ray() {
    let d = Distortion::new(DistortionModel::BrownConrady, [-0.1, 0.0, 0.0, 0.0, 0.0]).unwrap();
    let table = table_of(&d);
    assert_eq!(table.project([5.0, 0.0]), None);
    let mut rays: Vec<[f32; 2]> = (0..64 * 48)
        .map(|i| table.at(i % 64, i / 64).unwrap())
        .collect();
    rays[10 * 64 + 10] = [f32::NAN; 2];
    let holed = RayTable::new(64, 48, rays).unwrap();
    assert_eq!(holed.ray(10.0, 10.0), None);
    assert_eq!(holed.ray(10.5, 9.5), None);
    assert!(holed.ray(12.0, 12.0).is_some());
    let fit = table.fitted_pinhole();
    assert!(
        (fit[0] - 80.0).abs() < 8.0 && (fit[2] - 31.2).abs() < 1.0,
        "{fit:?}"
    );
}

#[test]
fn a_ray_table_of_the_wrong_length_or_with_an_infinite_ray_is_refused() {
    assert!(RayTable::new(4, 3, vec![[0.0; 2]; 11]).is_err());
    let mut rays: Vec<[f32; 2]> = (0..12).map(|i| [(i % 4) as f32, (i / 4) as f32]).collect();
    assert!(RayTable::new(4, 3, rays.clone()).is_ok());
    rays[3][0] = f32::INFINITY;
    assert!(RayTable::new(4, 3, rays).is_err());
    // Every ray NaN: nothing to project with.
    assert!(RayTable::new(4, 3, vec![[f32::NAN; 2]; 12]).is_err());
}

#[test]
fn unknown_models_and_infinite_coefficients_are_refused() {
    assert_eq!(
        DistortionModel::parse("plumb_bob"),
        Ok(Some(DistortionModel::BrownConrady))
    );
    assert_eq!(
        DistortionModel::parse("Inverse Brown Conrady"),
        Ok(Some(DistortionModel::InverseBrownConrady))
    );
    assert_eq!(DistortionModel::parse("none"), Ok(None));
    let e = DistortionModel::parse("kannala_brandt4").unwrap_err();
    assert!(e.to_string().contains("kannala_brandt4"), "{e}");
    assert!(Distortion::new(
        DistortionModel::BrownConrady,
        [f64::NAN, 0.0, 0.0, 0.0, 0.0]
    )
    .is_err());
}

//! The render toolkit: pixel-level checks of the primitives, the font, colour maps,
//! projection against the scene camera, the z-buffer, charts and overlays, and a property
//! test that no drawing call panics on any input.
use proptest::prelude::*;
use softsense::camera::Camera;
use softsense::io::intrinsics::PinholeIntrinsics;
use softsense::math::pose::PoseError;
use softsense::render::*;
use softsense::scene::camera::CameraSpec;

const RED: Rgb = [255, 0, 0];

/// Pixels that differ from `bg`.
fn painted(c: &Canvas, bg: Rgb) -> Vec<(i64, i64)> {
    let w = i64::from(c.width());
    c.pixels()
        .iter()
        .enumerate()
        .filter(|(_, p)| **p != bg)
        .map(|(i, _)| (i as i64 % w, i as i64 / w))
        .collect()
}

/// Opacity of black drawn on white, from a pixel's colour.
fn ink(p: Rgb) -> f64 {
    1.0 - f64::from(p[0]) / 255.0
}

/// Relative luminance (linear-light sRGB).
fn luminance(c: Rgb) -> f64 {
    let lin = |v: u8| {
        let s = f64::from(v) / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    };
    0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2])
}

#[test]
fn a_line_sets_its_end_pixels_and_nothing_far_from_it() {
    let mut c = Canvas::new(64, 48, WHITE).unwrap();
    c.line([10.0, 10.0], [50.0, 30.0], RED, 1.0);
    assert_eq!(c.get(10, 10), Some(RED));
    assert_eq!(c.get(50, 30), Some(RED));
    assert_eq!(c.get(30, 20), Some(RED), "the midpoint lies on the line");
    for (x, y) in painted(&c, WHITE) {
        // Distance from the pixel centre to the line through the ends: within 1 px.
        let d = (20.0 * x as f64 - 40.0 * y as f64 + 200.0).abs() / 20f64.hypot(40.0);
        assert!(d < 1.0, "pixel ({x}, {y}) is {d} px from the line");
        assert!((9..=51).contains(&x) && (9..=31).contains(&y));
    }
}

#[test]
fn a_horizontal_line_of_width_one_covers_exactly_its_row() {
    let mut c = Canvas::new(30, 15, WHITE).unwrap();
    c.line([5.0, 7.0], [20.0, 7.0], BLACK, 1.0);
    let got = painted(&c, WHITE);
    let want: Vec<(i64, i64)> = (5..=20).map(|x| (x, 7)).collect();
    assert_eq!(got, want);
    assert!(got.iter().all(|&(x, y)| c.get(x, y) == Some(BLACK)));
}

#[test]
fn a_disc_covers_its_area_within_rounding() {
    for (r, centre) in [
        (10.0, [40.0, 40.0]),
        (6.5, [30.3, 41.7]),
        (2.0, [10.5, 10.5]),
    ] {
        let mut c = Canvas::new(80, 80, WHITE).unwrap();
        c.disc(centre, r, BLACK);
        let area: f64 = c.pixels().iter().map(|&p| ink(p)).sum();
        let want = std::f64::consts::PI * r * r;
        assert!(
            (area - want).abs() < 0.03 * want + 1.0,
            "r = {r}: covered {area}, want {want}"
        );
        for (x, y) in (0..80).flat_map(|x| (0..80).map(move |y| (x, y))) {
            let d = (x as f64 - centre[0]).hypot(y as f64 - centre[1]);
            let p = c.get(x, y).unwrap();
            if d <= r - 0.5 {
                assert_eq!(p, BLACK, "({x}, {y}) at {d} inside r = {r}");
            } else if d >= r + 0.5 {
                assert_eq!(p, WHITE, "({x}, {y}) at {d} outside r = {r}");
            }
        }
    }
}

#[test]
fn a_circle_is_a_ring_and_leaves_its_centre_alone() {
    let mut c = Canvas::new(50, 50, WHITE).unwrap();
    c.circle([25.0, 25.0], 12.0, BLACK, 2.0);
    assert_eq!(c.get(25, 25), Some(WHITE));
    assert_eq!(c.get(37, 25), Some(BLACK));
    assert_eq!(c.get(25, 13), Some(BLACK));
    for (x, y) in painted(&c, WHITE) {
        let d = (x as f64 - 25.0).hypot(y as f64 - 25.0);
        assert!((d - 12.0).abs() < 1.5, "({x}, {y}) at {d}");
    }
}

#[test]
fn an_arrow_has_a_head_wider_than_its_shaft() {
    let mut c = Canvas::new(100, 40, WHITE).unwrap();
    c.arrow([5.0, 20.0], [90.0, 20.0], BLACK, 2.0);
    let column = |x: i64| (0..40).filter(|&y| c.get(x, y) != Some(WHITE)).count();
    assert!(column(30) <= 3, "shaft column has {} pixels", column(30));
    assert!(column(84) >= 5, "head column has {} pixels", column(84));
    assert_eq!(c.get(90, 20).map(ink).map(|a| a > 0.4), Some(true));
}

#[test]
fn rects_fill_and_outline_exact_integer_boxes() {
    let mut c = Canvas::new(20, 20, WHITE).unwrap();
    c.fill_rect(2, 3, 4, 5, RED);
    assert_eq!(painted(&c, WHITE).len(), 20);
    assert_eq!(c.get(2, 3), Some(RED));
    assert_eq!(c.get(5, 7), Some(RED));
    assert_eq!(c.get(6, 7), Some(WHITE));
    let mut c = Canvas::new(20, 20, WHITE).unwrap();
    c.rect(1, 1, 10, 8, BLACK, 1);
    assert_eq!(painted(&c, WHITE).len(), 2 * 10 + 2 * 6);
    assert_eq!(c.get(5, 5), Some(WHITE));
}

#[test]
fn text_renders_inside_its_box_and_nothing_outside() {
    for (text, scale) in [("Hg", 1), ("Hg 0.66 N", 2), ("two\nlines: jy", 3)] {
        let (x, y) = (7i64, 9i64);
        let mut c = Canvas::new(260, 80, WHITE).unwrap();
        c.text(x, y, text, BLACK, scale);
        let (w, h) = text_size(text, scale);
        let px = painted(&c, WHITE);
        assert!(!px.is_empty());
        let (x0, x1) = (
            px.iter().map(|p| p.0).min().unwrap(),
            px.iter().map(|p| p.0).max().unwrap(),
        );
        let (y0, y1) = (
            px.iter().map(|p| p.1).min().unwrap(),
            px.iter().map(|p| p.1).max().unwrap(),
        );
        assert!(
            x0 >= x && x1 < x + i64::from(w),
            "{text:?}: columns {x0}..={x1}, box {w}"
        );
        assert!(
            y0 >= y && y1 < y + i64::from(h),
            "{text:?}: rows {y0}..={y1}, box {h}"
        );
        assert_eq!(
            c.text_boxes(),
            &[TextBox {
                x,
                y,
                width: i64::from(w),
                height: i64::from(h)
            }],
            "the drawn text's box is recorded"
        );
    }
}

#[test]
fn every_glyph_labels_need_is_distinct_and_unknown_characters_show_as_a_question_mark() {
    let render = |ch: char| {
        let mut c = Canvas::new(12, 16, WHITE).unwrap();
        c.text(0, 0, &ch.to_string(), BLACK, 1);
        c.pixels().to_vec()
    };
    let glyphs: Vec<(char, Vec<Rgb>)> = (32u8..=126)
        .map(char::from)
        .chain("°±µ²³·×σχΔ≤≥→".chars())
        .map(|ch| (ch, render(ch)))
        .collect();
    for (i, (a, ga)) in glyphs.iter().enumerate() {
        assert!(has_glyph(*a), "{a:?} has no glyph");
        if *a != ' ' {
            assert!(ga.iter().any(|p| *p != WHITE), "{a:?} is blank");
        }
        for (b, gb) in &glyphs[i + 1..] {
            assert_ne!(ga, gb, "{a:?} and {b:?} look the same");
        }
    }
    // A character the face lacks draws as '?'.
    assert!(!has_glyph('\u{E000}'));
    assert_eq!(render('\u{E000}'), render('?'));
}

#[test]
fn a_monospaced_face_makes_text_width_proportional_to_its_length() {
    let (w1, h1) = text_size("0.66 N", 1);
    let (w2, _) = text_size("0.66 N 0.66 N", 1);
    // Widths are rounded up to whole pixels.
    let (a1, a2) = (f64::from(w1) / 6.0, f64::from(w2) / 13.0);
    assert!((a1 - a2).abs() < 0.2, "{w1} px for 6, {w2} px for 13");
    assert!((12..=16).contains(&h1), "scale 1 is about 12 px high: {h1}");
    assert!(text_size("a", 2).1 > h1);
    assert_eq!(text_size("", 1), (0, 0));
}

#[test]
fn the_sequential_map_rises_monotonically_in_luminance() {
    let l: Vec<f64> = (0..=256)
        .map(|i| luminance(ColorMap::Sequential.at(i as f64 / 256.0)))
        .collect();
    for w in l.windows(2) {
        assert!(
            w[1] >= w[0] - 1e-3,
            "luminance falls from {} to {}",
            w[0],
            w[1]
        );
    }
    assert!(l[256] - l[0] > 0.6, "range {} .. {}", l[0], l[256]);
}

#[test]
fn the_diverging_map_is_white_at_its_middle_and_darkens_both_ways() {
    let at = |t: f64| luminance(ColorMap::Diverging.at(t));
    assert!(at(0.5) > 0.9);
    for i in 0..128 {
        let t = i as f64 / 256.0;
        assert!(at(t + 1.0 / 256.0) >= at(t) - 1e-3, "blue half at {t}");
        assert!(
            at(1.0 - t - 1.0 / 256.0) >= at(1.0 - t) - 1e-3,
            "red half at {t}"
        );
    }
    let blue = ColorMap::Diverging.map(-2.0, [-2.0, 2.0]);
    let red = ColorMap::Diverging.map(2.0, [-2.0, 2.0]);
    assert!(blue[2] > blue[0] && red[0] > red[2]);
    assert_eq!(ColorMap::Diverging.map(f64::NAN, [-1.0, 1.0]), GREY);
    assert_eq!(
        ColorMap::Sequential.map(5.0, [0.0, 1.0]),
        ColorMap::Sequential.at(1.0)
    );
    assert_eq!(
        ColorMap::Sequential.map(5.0, [1.0, 1.0]),
        ColorMap::Sequential.at(0.5)
    );
    assert_eq!(symmetric_range(&[-3.0, 1.0, f64::NAN]), [-3.0, 3.0]);
    assert_eq!(finite_range(&[f64::INFINITY, 2.0, -1.0]), Some([-1.0, 2.0]));
    assert_eq!(finite_range(&[f64::NAN]), None);
}

#[test]
fn values_are_labelled_with_three_significant_digits() {
    let cases = [
        (0.66, "0.66"),
        (0.655, "0.655"),
        (1.0, "1"),
        (-57.25, "-57.2"),
        (412.0, "412"),
        (12345.0, "12345"),
        (0.0, "0"),
        (1e-7, "1.00e-7"),
        (2.5e6, "2.50e6"),
        (f64::NAN, "NaN"),
        (f64::NEG_INFINITY, "-inf"),
    ];
    for (v, want) in cases {
        assert_eq!(format_value(v), want, "{v}");
    }
}

#[test]
fn projection_inverts_the_scene_cameras_back_projection() {
    let s = CameraSpec::default();
    let cam = s.camera().unwrap();
    let pose = camera_from_robot(&cam.robot_from_camera().to_matrix()).unwrap();
    let k = s.intrinsics();
    for (u, v, z) in [
        (0.0, 0.0, 0.3),
        (319.5, 239.5, 0.5),
        (600.2, 17.9, 1.7),
        (-40.0, 500.0, 0.05),
    ] {
        let p_robot = cam.backproject(u, v, z);
        let p_cam = pose.apply(p_robot);
        assert!((p_cam[2] - z).abs() < 1e-12, "depth {} vs {z}", p_cam[2]);
        let uv = project(p_cam, s.fx, s.fy, s.cx, s.cy).unwrap();
        assert!(
            (uv[0] - u).abs() < 1e-9 && (uv[1] - v).abs() < 1e-9,
            "{uv:?} vs ({u}, {v})"
        );
        let view = Camera::from_camera_from_robot(k, pose);
        let (uv2, z2) = view.project_robot(p_robot).unwrap();
        assert!((uv2[0] - u).abs() < 1e-9 && (uv2[1] - v).abs() < 1e-9 && (z2 - z).abs() < 1e-12);
    }
    // The same through the conveniences a `sense` caller uses.
    let view = Camera::from_matrix(k, &cam.robot_from_camera().to_matrix()).unwrap();
    let tip = cam.backproject(300.0, 200.0, 0.45);
    let (uv, _) = view.project_robot(tip).unwrap();
    assert!((uv[0] - 300.0).abs() < 1e-9 && (uv[1] - 200.0).abs() < 1e-9);
    let arrow = ForceArrow::from_robot(view.camera_from_robot(), tip, [0.0, 0.0, -1.0], None);
    assert!((arrow.start_in_camera[2] - 0.45).abs() < 1e-12);
    // Gravity points down in the image (+v) for this camera looking down at the robot.
    let f = arrow.force_in_camera;
    assert!((f.iter().map(|c| c * c).sum::<f64>() - 1.0).abs() < 1e-12 && f[1] > 0.5);
    assert_eq!(project([0.0, 0.0, -1.0], 500.0, 500.0, 0.0, 0.0), None);
    assert_eq!(project([0.0, 0.0, 0.0], 500.0, 500.0, 0.0, 0.0), None);
    assert_eq!(project([f64::NAN, 0.0, 1.0], 500.0, 500.0, 0.0, 0.0), None);
}

#[test]
fn poses_invert_rigidly_and_reject_non_rigid_matrices() {
    let m = CameraSpec::default()
        .camera()
        .unwrap()
        .robot_from_camera()
        .to_matrix();
    let pose = Pose::from_matrix(&m).unwrap();
    assert_eq!(pose.to_matrix(), m);
    let p = [0.1, -0.2, 0.3];
    let back = pose.inverse().apply(pose.apply(p));
    assert!((0..3).all(|k| (back[k] - p[k]).abs() < 1e-14));
    let mut scaled = m;
    for row in scaled.iter_mut().take(3) {
        for v in row.iter_mut().take(3) {
            *v *= 1.01;
        }
    }
    assert!(matches!(
        Pose::from_matrix(&scaled),
        Err(PoseError::NotRigid { .. })
    ));
    let mut mirrored = m;
    for row in mirrored.iter_mut().take(3) {
        row[0] = -row[0];
    }
    assert!(matches!(
        Pose::from_matrix(&mirrored),
        Err(PoseError::NotRigid { .. })
    ));
    let mut bad = m;
    bad[3] = [0.0, 0.0, 1.0, 1.0];
    assert!(Pose::from_matrix(&bad).is_err());
    bad = m;
    bad[0][3] = f64::NAN;
    assert!(camera_from_robot(&bad).is_err());
}

/// A 100x100 camera at the origin looking along +z.
fn straight_view() -> Camera {
    Camera::from_camera_from_robot(
        PinholeIntrinsics {
            width: 100,
            height: 100,
            fx: 100.0,
            fy: 100.0,
            cx: 49.5,
            cy: 49.5,
        },
        Pose::identity(),
    )
}

/// A triangle at depth z facing the camera at the origin (normal towards −z), size s.
fn facing_triangle(z: f64, s: f64) -> [[f64; 3]; 3] {
    [[-s, -s, z], [0.0, s, z], [s, -s, z]]
}

#[test]
fn an_orbit_view_frames_every_point_in_front_of_the_camera() {
    let points: Vec<[f64; 3]> = (0..27)
        .map(|i| {
            [
                (i % 3) as f64 * 0.1,
                (i / 3 % 3) as f64 * 0.05,
                (i / 9) as f64 * 0.02 + 1.0,
            ]
        })
        .chain([[f64::NAN, 0.0, 0.0]])
        .collect();
    for (az, el) in [(0.0, 0.0), (-60.0, 30.0), (135.0, -45.0), (90.0, 80.0)] {
        let view = Camera::orbit(&points, az, el, 320, 200).unwrap();
        for p in points.iter().filter(|p| p[0].is_finite()) {
            let (uv, z) = view.project_robot(*p).unwrap();
            assert!(z > 0.0);
            assert!(
                (0.0..320.0).contains(&uv[0]) && (0.0..200.0).contains(&uv[1]),
                "{uv:?} at az {az} el {el}"
            );
        }
        // Robot +z points up in the image (smaller v).
        let (lo, _) = view.project_robot([0.1, 0.05, 1.0]).unwrap();
        let (hi, _) = view.project_robot([0.1, 0.05, 1.04]).unwrap();
        assert!(hi[1] < lo[1]);
    }
    assert!(Camera::orbit(&points, 0.0, 90.0, 320, 200).is_none());
    assert!(Camera::orbit(&[], 0.0, 0.0, 320, 200).is_none());
    assert!(Camera::orbit(&points, 0.0, 0.0, 0, 200).is_none());
}

#[test]
fn the_z_buffer_shows_the_nearer_of_two_overlapping_triangles() {
    let near = facing_triangle(1.0, 0.2);
    let far = facing_triangle(2.0, 0.8);
    for near_first in [true, false] {
        let (tris, values) = if near_first {
            ([near, far], [1.0, 0.0])
        } else {
            ([far, near], [0.0, 1.0])
        };
        let vertices: Vec<[f64; 3]> = tris.iter().flatten().copied().collect();
        let triangles = [[0, 1, 2], [3, 4, 5]];
        let mesh = SurfaceMesh {
            vertices_in_robot: &vertices,
            triangles: &triangles,
            values: SurfaceValues::PerTriangle(&values),
            markers: &[],
        };
        let params = SurfaceMapParams {
            range: Some([0.0, 1.0]),
            ..SurfaceMapParams::default()
        };
        let pic = surface_map(&mesh, &straight_view(), &params).unwrap();
        assert_eq!(
            (pic.width(), pic.height()),
            (100 + COLORBAR_PANEL, 100 + TITLE_BAND)
        );
        let at = |u: i64, v: i64| pic.get(u, v + i64::from(TITLE_BAND)).unwrap();
        // Centre: both triangles cover it; the near one (value 1, yellow) must show.
        let centre = at(50, 50);
        assert!(
            centre[0] > 150 && centre[1] > 150 && centre[2] < 100,
            "centre {centre:?} (near_first {near_first})"
        );
        // Outside the near triangle but inside the far one: purple.
        let side = at(50, 85);
        assert!(side[2] > side[1] && side[0] < 100, "side {side:?}");
        // Outside both: background.
        assert_eq!(at(2, 2), WHITE);
    }
}

#[test]
fn triangles_facing_away_are_culled_unless_asked_not_to() {
    let t = facing_triangle(1.0, 0.3);
    let vertices = vec![t[0], t[2], t[1]]; // reversed winding: faces away
    let triangles = [[0, 1, 2]];
    let mesh = SurfaceMesh {
        vertices_in_robot: &vertices,
        triangles: &triangles,
        values: SurfaceValues::None,
        markers: &[],
    };
    let view = straight_view();
    let culled = surface_map(&mesh, &view, &SurfaceMapParams::default()).unwrap();
    assert_eq!(culled.get(50, 50 + i64::from(TITLE_BAND)), Some(WHITE));
    let kept = surface_map(
        &mesh,
        &view,
        &SurfaceMapParams {
            cull_back_faces: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert_ne!(kept.get(50, 50 + i64::from(TITLE_BAND)), Some(WHITE));
}

#[test]
fn per_vertex_values_are_interpolated_across_a_triangle() {
    let t = facing_triangle(1.0, 0.4);
    let values = [0.0, 1.0, 0.0]; // 1 at the top vertex (image row small)
    let triangles = [[0, 1, 2]];
    let mesh = SurfaceMesh {
        vertices_in_robot: &t,
        triangles: &triangles,
        values: SurfaceValues::PerVertex(&values),
        markers: &[],
    };
    let pic = surface_map(
        &mesh,
        &straight_view(),
        &SurfaceMapParams {
            range: Some([0.0, 1.0]),
            ..Default::default()
        },
    )
    .unwrap();
    // The vertex with value 1 projects to v = 49.5 + 40 = 89.5 (y down); value 0 at v = 9.5.
    let lum = |v: i64| luminance(pic.get(50, v + i64::from(TITLE_BAND)).unwrap());
    assert!(
        lum(80) > lum(50) && lum(50) > lum(15),
        "{} {} {}",
        lum(15),
        lum(50),
        lum(80)
    );
}

#[test]
fn surface_map_rejects_bad_indices_and_value_counts() {
    let t = facing_triangle(1.0, 0.4);
    let view = straight_view();
    let p = SurfaceMapParams::default();
    let bad_tri = [[0, 1, 3]];
    let m = SurfaceMesh {
        vertices_in_robot: &t,
        triangles: &bad_tri,
        values: SurfaceValues::None,
        markers: &[],
    };
    assert!(matches!(
        surface_map(&m, &view, &p),
        Err(RenderError::TriangleIndex { index: 3, .. })
    ));
    let tri = [[0, 1, 2]];
    let m = SurfaceMesh {
        vertices_in_robot: &t,
        triangles: &tri,
        values: SurfaceValues::PerVertex(&[1.0]),
        markers: &[],
    };
    assert!(matches!(
        surface_map(&m, &view, &p),
        Err(RenderError::Length {
            expected: 3,
            got: 1,
            ..
        })
    ));
    let m = SurfaceMesh {
        vertices_in_robot: &t,
        triangles: &tri,
        values: SurfaceValues::PerTriangle(&[]),
        markers: &[],
    };
    assert!(surface_map(&m, &view, &p).is_err());
}

#[test]
fn markers_hidden_behind_the_surface_are_not_drawn() {
    let t = facing_triangle(1.0, 0.4);
    let tri = [[0, 1, 2]];
    let markers = [([0.0, 0.0, 2.0], 1.0), ([0.3, 0.3, 0.5], 1.0)];
    let m = SurfaceMesh {
        vertices_in_robot: &t,
        triangles: &tri,
        values: SurfaceValues::PerTriangle(&[0.0]),
        markers: &markers,
    };
    let p = SurfaceMapParams {
        range: Some([0.0, 1.0]),
        ..Default::default()
    };
    let pic = surface_map(&m, &straight_view(), &p).unwrap();
    let yellow = ColorMap::Sequential.at(1.0);
    let band = i64::from(TITLE_BAND);
    assert_ne!(
        pic.get(50, 50 + band),
        Some(yellow),
        "the marker behind the triangle shows"
    );
    // The one in front, at u = v = 49.5 + 100·0.3/0.5 = 109.5: outside the 100-px image, so
    // take a visible one instead.
    let markers = [([0.1, 0.1, 0.5], 1.0)];
    let m = SurfaceMesh {
        markers: &markers,
        ..m
    };
    let pic = surface_map(&m, &straight_view(), &p).unwrap();
    assert_eq!(
        pic.get(70, 70 + band),
        Some(yellow),
        "the marker in front is missing"
    );
}

#[test]
fn bar_charts_survive_negative_zero_nan_and_infinite_values() {
    let labels = ["a", "b", "c", "d", "e", "f"];
    let values = [3.0, -2.0, 0.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
    let c = bar_chart("criterion", &labels, &values, Some(1), 300, 200).unwrap();
    assert_eq!((c.width(), c.height()), (300, 200));
    assert!(c.pixels().contains(&BAR_HIGHLIGHT));
    assert!(c.pixels().contains(&BAR));
    let huge = [f64::MAX, -f64::MAX, 1e-300];
    assert!(bar_chart("", &labels[..3], &huge, None, 200, 100).is_ok());
    assert!(matches!(
        bar_chart("t", &labels, &[1.0], None, 100, 100),
        Err(RenderError::Length { .. })
    ));
    let empty = bar_chart("nothing", &[], &[], Some(4), 100, 60).unwrap();
    assert!(!empty.pixels().contains(&BAR));
}

#[test]
fn a_longer_bar_means_a_larger_value() {
    let c = bar_chart("", &["x", "y"], &[1.0, 3.0], None, 300, 100).unwrap();
    let row_len = |y: i64| (0..300).filter(|&x| c.get(x, y) == Some(BAR)).count();
    let rows: Vec<usize> = (0..100).map(row_len).filter(|&n| n > 0).collect();
    let (short, long) = (
        rows.first().copied().unwrap(),
        rows.last().copied().unwrap(),
    );
    assert!(
        (long as f64 / short as f64 - 3.0).abs() < 0.1,
        "{short} vs {long}"
    );
}

#[test]
fn the_sense_overlay_draws_forces_contacts_and_features_where_they_project() {
    let k = PinholeIntrinsics {
        width: 160,
        height: 120,
        fx: 150.0,
        fy: 150.0,
        cx: 79.5,
        cy: 59.5,
    };
    let frame = Canvas::new(160, 120, [90, 90, 90]).unwrap();
    let mask = vec![true; 160 * 120];
    let features = [
        FeatureMark {
            pixel: [30.0, 30.0],
            visible: true,
            matched: Some([34.0, 33.0]),
        },
        FeatureMark {
            pixel: [130.0, 30.0],
            visible: false,
            matched: None,
        },
    ];
    let contacts = [ContactMark {
        pixel: [20.0, 100.0],
        label: "c1".into(),
    }];
    let forces = [ForceArrow {
        start_in_camera: [0.0, 0.0, 0.5],
        force_in_camera: [0.0, 0.5, 0.0],
        label: None,
    }];
    let overlay = SenseOverlay {
        title: "t",
        robot_mask: Some(&mask),
        features: &features,
        contacts: &contacts,
        forces: &forces,
    };
    let params = OverlayParams {
        intrinsics: k,
        metres_per_newton: Some(0.1),
        legend: false,
        ..Default::default()
    };
    let pic = sense_overlay(&frame, &overlay, &params).unwrap();
    assert_eq!((pic.width(), pic.height()), (160, 120));
    if let Some(dir) = std::env::var_os("RENDER_TEST_OUT") {
        pic.save_png(std::path::Path::new(&dir).join("overlay_test.png"))
            .unwrap();
    }
    assert_eq!(pic.get(30, 30), Some(FEATURE_VISIBLE));
    assert_eq!(pic.get(130, 30), Some(FEATURE_HIDDEN));
    assert_eq!(
        pic.get(30, 100),
        Some(CONTACT),
        "the contact ring at radius 10"
    );
    // The force starts at the principal point and ends 0.05 m lower at 0.5 m: 15 px down.
    assert_eq!(pic.get(80, 60), Some(FORCE));
    assert_eq!(pic.get(80, 68), Some(FORCE));
    // The magnitude label "0.50 N" is drawn in the force colour beside the head.
    let label_px = (0..160)
        .flat_map(|x| (76..100).map(move |y| (x, y)))
        .filter(|&(x, y)| pic.get(x, y) == Some(FORCE) && x != 80)
        .count();
    assert!(label_px > 20, "{label_px} label pixels");
    // The tint changed the background where nothing else was drawn.
    assert_ne!(pic.get(5, 115), Some([90, 90, 90]));
    let short = vec![true; 10];
    let bad = SenseOverlay {
        robot_mask: Some(&short),
        ..overlay
    };
    assert!(matches!(
        sense_overlay(&frame, &bad, &params),
        Err(RenderError::Length { .. })
    ));
}

#[test]
fn panels_sit_side_by_side_under_their_titles() {
    let a = Canvas::new(30, 20, RED).unwrap();
    let b = Canvas::new(40, 50, BLACK).unwrap();
    let c = side_by_side(&[("before", &a), ("after", &b)], WHITE).unwrap();
    assert_eq!((c.width(), c.height()), (30 + 8 + 40, 50 + 28));
    assert_eq!(c.get(0, 28), Some(RED));
    assert_eq!(c.get(29, 47), Some(RED));
    assert_eq!(c.get(0, 48), Some(WHITE));
    assert_eq!(c.get(38, 28), Some(BLACK));
    assert_eq!(c.get(77, 77), Some(BLACK));
    assert!(side_by_side(&[], WHITE).unwrap().pixels().is_empty());
}

#[test]
fn masks_from_indices_mark_exactly_those_pixels() {
    let m = mask_from_indices(4, 3, &[0, 5, 11, 12, usize::MAX]);
    assert_eq!(m.len(), 12);
    let set: Vec<usize> = (0..12).filter(|&i| m[i]).collect();
    assert_eq!(set, vec![0, 5, 11]);
}

#[test]
fn canvases_round_trip_through_png_and_refuse_bad_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.png");
    let mut c = Canvas::new(17, 9, WHITE).unwrap();
    c.text(1, 1, "ok", RED, 1);
    c.save_png(&path).unwrap();
    assert_eq!(Canvas::from_png(&path).unwrap(), c);
    assert!(matches!(
        Canvas::from_png(dir.path().join("missing.png")),
        Err(RenderError::Image { .. })
    ));
    assert!(Canvas::new(0, 0, WHITE)
        .unwrap()
        .save_png(dir.path().join("e.png"))
        .is_err());
    assert!(matches!(
        Canvas::new(MAX_SIDE + 1, 1, WHITE),
        Err(RenderError::TooLarge { .. })
    ));
    assert!(matches!(
        Canvas::new(MAX_SIDE, MAX_SIDE, WHITE),
        Err(RenderError::TooLarge { .. })
    ));
    assert!(matches!(
        Canvas::from_rgb(2, 2, vec![WHITE; 3]),
        Err(RenderError::Length {
            expected: 4,
            got: 3,
            ..
        })
    ));
    let e: softsense::Error = RenderError::TooLarge {
        width: 1,
        height: 2,
    }
    .into();
    assert!(e.to_string().contains("1x2"));
}

/// Any f64, with the interesting ones (NaN, ±inf, huge, canvas-sized) well represented.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        -50.0f64..100.0,
        any::<f64>(),
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(1e300),
        Just(-1e300),
        Just(f64::MAX),
    ]
}

fn point() -> impl Strategy<Value = [f64; 2]> {
    [coord(), coord()]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn no_drawing_call_panics_for_any_coordinates_or_size(
        w in 0u32..40, h in 0u32..40,
        a in point(), b in point(), c in point(),
        r in coord(), width in coord(), alpha in coord(),
        ix in any::<i64>(), iy in any::<i64>(), small in -60i64..60,
        text in "\\PC{0,12}", scale in 0u32..5,
        values in prop::collection::vec(coord(), 0..6),
    ) {
        let mut canvas = Canvas::new(w, h, WHITE).unwrap();
        canvas.set(ix, iy, RED);
        canvas.set(small, small, RED);
        canvas.blend(small, small / 2, RED, alpha);
        canvas.line(a, b, RED, width);
        canvas.line(a, b, RED, 1.0);
        canvas.arrow(a, b, RED, width);
        canvas.arrow(a, b, RED, 2.0);
        canvas.fill_triangle(a, b, c, RED);
        canvas.disc(a, r, RED);
        canvas.circle(a, r, RED, width);
        canvas.cross(a, r, RED, 1.0);
        canvas.fill_rect(ix, iy, small, small, RED);
        canvas.fill_rect(small, small, ix, iy, RED);
        canvas.rect(small, small, ix, iy, RED, 3);
        canvas.blend_rect(ix, iy, ix, iy, RED, alpha);
        canvas.text(ix, iy, &text, RED, scale);
        canvas.text(small, small, &text, RED, scale);
        canvas.label(small, small, &text, RED, WHITE, scale);
        colorbar(&mut canvas, [small, small, ix, iy], ColorMap::Diverging, [r, width], &text);
        colorbar(&mut canvas, [2, 2, 5, small], ColorMap::Sequential, [r, width], &text);
        legend(&mut canvas, ix, iy, &[(Swatch::Ring(RED), "r")]);
        legend(&mut canvas, small, small, &[(Swatch::Arrow(RED), text.as_str()), (Swatch::Cross(RED), "x")]);
        let other = canvas.clone();
        canvas.blit(&other, ix, iy);
        canvas.blit(&other, small, small);
        prop_assert_eq!(canvas.pixels().len(), (w * h) as usize);
        let _ = format_value(r);
        let _ = project([a[0], a[1], r], width, alpha, b[0], b[1]);
        let labels: Vec<&str> = values.iter().map(|_| text.as_str()).collect();
        let chart = bar_chart(&text, &labels, &values, Some(small.unsigned_abs() as usize), w * 5, h * 5).unwrap();
        prop_assert_eq!(chart.width(), w * 5);
        let frame = canvas.clone();
        let k = PinholeIntrinsics { width: w, height: h, fx: r, fy: width, cx: a[0], cy: a[1] };
        let forces = [ForceArrow { start_in_camera: [a[0], a[1], r], force_in_camera: [b[0], b[1], alpha], label: None }];
        let features = [FeatureMark { pixel: a, visible: true, matched: Some(b) }, FeatureMark { pixel: c, visible: false, matched: None }];
        let contacts = [ContactMark { pixel: c, label: text.clone() }];
        let overlay = SenseOverlay { title: &text, robot_mask: None, features: &features, contacts: &contacts, forces: &forces };
        let params = OverlayParams { intrinsics: k, metres_per_newton: (r > 0.5).then_some(width), arrow_fraction: alpha, fade: alpha, mask_alpha: r, legend: true };
        let drawn = sense_overlay(&frame, &overlay, &params);
        prop_assert!(drawn.is_ok());
        // A surface seen from a random camera.
        let vertices = [[a[0], a[1], r], [b[0], b[1], width], [c[0], c[1], alpha], [0.0, 0.0, 1.0]];
        let triangles = [[0, 1, 2], [0, 2, 3], [1, 3, 2]];
        let per_vertex: Vec<f64> = (0..4).map(|i| values.get(i).copied().unwrap_or(r)).collect();
        let view = Camera::from_camera_from_robot(k, Pose { rotation: Pose::identity().rotation, translation: [b[0], c[1], a[1]] });
        let markers = [([a[0], b[1], 1.0], r)];
        let mesh = SurfaceMesh { vertices_in_robot: &vertices, triangles: &triangles, values: SurfaceValues::PerVertex(&per_vertex), markers: &markers };
        let map_params = SurfaceMapParams { range: Some([r, width]), ..Default::default() };
        let map = surface_map(&mesh, &view, &map_params);
        prop_assert!(map.is_ok());
        let _ = Camera::orbit(&vertices, r, width, w, h);
    }
}

#[test]
fn a_label_asked_for_past_the_canvas_edge_is_moved_inside_whole() {
    let mut c = Canvas::new(200, 100, BLACK).unwrap();
    let mut placer = LabelPlacer::default();
    let (w, h) = text_size("0: 0.509 N", 2);
    let pad = 4;
    let left = placer.place(&mut c, -60, 40, "0: 0.509 N", RED, 2);
    assert_eq!(left, Some((pad, 40)));
    let right = placer.place(&mut c, 190, 10, "1: 0.795 N", RED, 2).unwrap();
    assert_eq!(right.0 + i64::from(w) + pad, 200, "{right:?}");
    let low = placer.place(&mut c, 20, 95, "2: 0.3 N", RED, 2).unwrap();
    assert!(
        low.1 + i64::from(h) + pad <= 100,
        "{low:?} leaves the canvas"
    );
    // Text wider than the canvas is not drawn, and the caller is told.
    let wide = "a label much wider than this small canvas is";
    assert_eq!(placer.place(&mut c, -5, 0, wide, RED, 2), None);
    assert_eq!(c.text_boxes().len(), 3);
}

#[test]
fn labels_asked_for_at_the_same_spot_are_moved_apart_and_do_not_overlap() {
    let mut c = Canvas::new(200, 200, BLACK).unwrap();
    let mut placer = LabelPlacer::default();
    let title = TextBox {
        x: 0,
        y: 0,
        width: 200,
        height: 30,
    };
    placer.block(title);
    let (_, h) = text_size("0.35 N", 2);
    let a = placer.place(&mut c, 50, 90, "0.35 N", RED, 2);
    assert_eq!(a, Some((50, 90)), "the first label goes where it was asked");
    for (text, at) in [
        ("c1 node 659", (50, 90)),
        ("third", (60, 92)),
        ("top", (10, 0)),
    ] {
        assert!(placer.place(&mut c, at.0, at.1, text, RED, 2).is_some());
    }
    let boxes = c.text_boxes();
    assert_eq!(boxes.len(), 4);
    for (i, p) in boxes.iter().enumerate() {
        assert!(!p.overlaps(&title), "{p:?} covers the blocked title");
        for q in &boxes[i + 1..] {
            assert!(!p.overlaps(q), "{p:?} and {q:?} overlap");
        }
    }
    // The text of the first label is still there: red pixels on its row band.
    let red_in_band = (90..90 + i64::from(h))
        .flat_map(|y| (50..120).map(move |x| (x, y)))
        .filter(|&(x, y)| c.get(x, y) == Some(RED))
        .count();
    assert!(
        red_in_band > 10,
        "first label overwritten: {red_in_band} red pixels"
    );
}

#[test]
fn a_full_canvas_refuses_further_labels_instead_of_overlapping_them() {
    let mut c = Canvas::new(120, 40, BLACK).unwrap();
    let mut placer = LabelPlacer::default();
    let mut placed = 0;
    while placer.place(&mut c, 0, 0, "label", RED, 1).is_some() {
        placed += 1;
        assert!(placed < 100, "a 120x40 canvas cannot hold 100 labels");
    }
    assert!(placed >= 2, "{placed}");
    let boxes = c.text_boxes();
    for (i, p) in boxes.iter().enumerate() {
        for q in &boxes[i + 1..] {
            assert!(!p.overlaps(q), "{p:?} and {q:?} overlap");
        }
    }
}

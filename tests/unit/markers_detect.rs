//! Coloured-marker detection on synthetic images: colour test, blobs, the centre on a
//! plane, the area check, identities across frames.
use softsense::camera::{Camera, PinholeIntrinsics};
use softsense::markers::detect::{
    colour_mask, detect_frame, find_blobs, track_detections, DetectParams,
};
use softsense::markers::tracks::{MarkerTracks, TrackFrame};

#[test]
fn the_colour_test_accepts_shaded_paint_and_refuses_other_colours() {
    let p = DetectParams::default(); // paint [30, 60, 230]
    let pixels = [
        [30, 60, 230],   // the paint
        [12, 24, 92],    // the paint at 40% light
        [34, 57, 226],   // with colour noise
        [40, 200, 60],   // the robot
        [150, 150, 160], // the table
        [5, 9, 35],      // the paint's hue but too dark to tell
        [220, 40, 40],   // the probe
    ];
    assert_eq!(
        colour_mask(&pixels, &p),
        [true, true, true, false, false, false, false]
    );
}

#[test]
fn blobs_are_8_connected_and_small_ones_are_dropped() {
    let (w, h) = (12, 8);
    let mut mask = vec![false; w * h];
    // A 3x3 square, a diagonal chain of 4 touching at corners, a lone pixel.
    for v in 1..4 {
        for u in 1..4 {
            mask[v * w + u] = true;
        }
    }
    for k in 0..4 {
        mask[(2 + k) * w + 6 + k] = true;
    }
    mask[7 * w] = true;
    let blobs = find_blobs(&mask, w, 2);
    assert_eq!(blobs.len(), 2);
    assert_eq!(blobs[0].len(), 9);
    assert_eq!(blobs[1], vec![2 * w + 6, 3 * w + 7, 4 * w + 8, 5 * w + 9]);
    assert_eq!(find_blobs(&mask, w, 1).len(), 3);
    assert!(find_blobs(&mask, w, 10).is_empty());
}

/// A 200x160 camera 0.3 m from the plane z = 0, looking down at it 45° off its normal, and
/// the image of that plane with paint discs of `radius` at `centres` (every pixel's exact
/// point, camera frame). The second disc's pixels left of column `hide_left_of` are unpainted.
fn plane_image(
    centres: &[[f64; 3]],
    radius: f64,
    hide_left_of: usize,
) -> (Camera, Vec<[u8; 3]>, Vec<[f32; 3]>) {
    let k = PinholeIntrinsics {
        width: 200,
        height: 160,
        fx: 300.0,
        fy: 300.0,
        cx: 99.5,
        cy: 79.5,
    };
    let s = 0.3 / 2f64.sqrt();
    let cam = Camera::look_at(k, [0.0, -s, s], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let (mut colours, mut points) = (Vec::new(), Vec::new());
    for v in 0..160 {
        for u in 0..200 {
            let (e, d) = (cam.eye(), cam.ray(u as f64, v as f64));
            let t = -e[2] / d[2];
            let p = [0, 1, 2].map(|i| e[i] + t * d[i]);
            let inside = |c: &[f64; 3]| {
                (0..3).map(|i| (p[i] - c[i]).powi(2)).sum::<f64>() <= radius * radius
            };
            let painted = (centres.iter().enumerate())
                .any(|(k, c)| inside(c) && (k != 1 || u >= hide_left_of));
            let shade = 0.8;
            colours.push(if painted {
                [30.0 * shade, 60.0 * shade, 230.0 * shade].map(|c: f64| c as u8)
            } else {
                [40, 200, 60]
            });
            let q = cam.point_in_camera(u as f64, v as f64, t);
            points.push(q.map(|c| c as f32));
        }
    }
    (cam, colours, points)
}

#[test]
fn a_disc_on_a_plane_is_located_at_its_centre_and_a_half_hidden_one_is_left_out() {
    let r = 0.006;
    // Paint discs of 6 mm at 0.3 m, about 80 pixels each.
    let centres = [[-0.03, 0.01, 0.0], [0.025, -0.02, 0.0]];
    let (cam, colours, points) = plane_image(&centres, r, 0);
    let params = DetectParams {
        radius: r,
        ..Default::default()
    };
    let detect = |colours: &[[u8; 3]], points: &[[f32; 3]]| {
        detect_frame(
            colours,
            points,
            &cam.intrinsics,
            cam.robot_from_camera(),
            &params,
        )
        .unwrap()
    };
    let found = detect(&colours, &points);
    assert_eq!(found.len(), 2);
    for d in &found {
        let err = centres
            .iter()
            .map(|c| {
                (0..3)
                    .map(|i| (d.position[i] - c[i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        // A pixel is 1 x 1.4 mm on the plane here (about 80 in a disc); the digitised
        // disc's centroid is within a small fraction of one.
        assert!(err < 3e-4, "{d:?}: error {err} m");
        assert!(d.position[2].abs() < 1e-6, "on the plane: {d:?}");
        assert!((d.area_ratio - 1.0).abs() < 0.15, "{d:?}");
    }
    // The second disc half hidden (its left half unpainted): the area check drops it.
    let (u_mid, _) = cam.project_robot(centres[1]).unwrap();
    let (_, colours, points) = plane_image(&centres, r, u_mid[0].round() as usize);
    let found = detect(&colours, &points);
    assert_eq!(found.len(), 1);
    assert!((found[0].position[0] - centres[0][0]).abs() < 3e-4);
}

#[test]
fn bad_buffers_and_options_are_errors() {
    let (cam, colours, points) = plane_image(&[], 0.006, 0);
    let p = DetectParams::default();
    let k = &cam.intrinsics;
    assert!(detect_frame(&colours[1..], &points, k, cam.robot_from_camera(), &p).is_err());
    let bad = DetectParams {
        max_angle_deg: f64::NAN,
        ..Default::default()
    };
    assert!(detect_frame(&colours, &points, k, cam.robot_from_camera(), &bad).is_err());
}

#[test]
fn identities_follow_the_nearest_last_position() {
    let a = [0.0, 0.0, 0.0];
    let b = [0.05, 0.0, 0.0];
    let frames = vec![
        (0, vec![a, b]),
        // Swapped order, both moved 2 mm.
        (1, vec![[0.052, 0.0, 0.0], [0.002, 0.0, 0.0]]),
        // b hidden; a new marker appears far away.
        (2, vec![[0.003, 0.0, 0.0], [0.0, 0.1, 0.0]]),
        // b back near its last position.
        (3, vec![[0.053, 0.0, 0.0]]),
    ];
    let (t, dropped) = track_detections(&frames, None, 0.01);
    assert_eq!(dropped, 0);
    assert_eq!(t.names, ["m0", "m1", "m2"]);
    assert_eq!(t.frames[1].positions[0], Some([0.002, 0.0, 0.0]));
    assert_eq!(t.frames[1].positions[1], Some([0.052, 0.0, 0.0]));
    assert_eq!(t.frames[2].positions[1], None);
    assert_eq!(t.frames[2].positions[2], Some([0.0, 0.1, 0.0]));
    assert_eq!(t.frames[0].positions[2], None);
    assert_eq!(t.frames[3].positions[1], Some([0.053, 0.0, 0.0]));
    // With a reference layout the names are its, and a far detection is dropped.
    let reference = MarkerTracks {
        names: vec!["left".into(), "right".into()],
        frames: vec![TrackFrame {
            frame: 0,
            positions: vec![Some(a), Some(b)],
        }],
    };
    let (t, dropped) = track_detections(&frames, Some(&reference), 0.01);
    assert_eq!(t.names, ["left", "right"]);
    assert_eq!(dropped, 1);
    assert_eq!(t.frames[1].positions[1], Some([0.052, 0.0, 0.0]));
}

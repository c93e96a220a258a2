//! RGB-D conversion and intrinsics readers: synthetic images in a temp dir, plus the
//! real Kinect frames PCL converted itself (`$SOFTSENSE_DATA/pcl/grabber_sequence`).

use crate::common;
use image::{ImageBuffer, Luma, Rgb, Rgba};
use proptest::prelude::*;
use softsense::io::intrinsics::{
    parse_open3d_json, parse_pcl_xml, read_camera_model, Arithmetic, CameraModel, DepthParams,
    PinholeIntrinsics,
};
use softsense::io::rgbd::{
    depth_to_cloud, read_color_image, read_depth_image, read_frame, RgbdError,
};
use softsense::io::IoError;
use std::path::{Path, PathBuf};

fn intr(width: u32, height: u32) -> PinholeIntrinsics {
    PinholeIntrinsics {
        width,
        height,
        fx: 525.0,
        fy: 520.0,
        cx: (width as f64 - 1.0) / 2.0,
        cy: (height as f64 - 1.0) / 2.0,
    }
}

fn rgbd_err(e: IoError) -> (PathBuf, RgbdError) {
    match e {
        IoError::Rgbd { path, source } => (path, source),
        other => panic!("expected IoError::Rgbd, got {other:?}"),
    }
}

fn write_depth_png(dir: &Path, name: &str, w: u32, h: u32, f: impl Fn(u32, u32) -> u16) -> PathBuf {
    let p = dir.join(name);
    ImageBuffer::<Luma<u16>, _>::from_fn(w, h, |u, v| Luma([f(u, v)]))
        .save(&p)
        .expect("write depth png");
    p
}

fn write_rgb(dir: &Path, name: &str, w: u32, h: u32) -> PathBuf {
    let p = dir.join(name);
    ImageBuffer::<Rgb<u8>, _>::from_fn(w, h, |u, v| Rgb([u as u8, v as u8, 7]))
        .save(&p)
        .expect("write colour image");
    p
}

// ---------------------------------------------------------------- depth_to_cloud

#[test]
fn zero_depth_gives_nan_and_keeps_the_organized_shape() {
    let depth = [0u16, 1000, 2000, 0, 1500, 0];
    let cloud = depth_to_cloud(&depth, None, &intr(3, 2), &DepthParams::default()).unwrap();
    assert_eq!((cloud.width, cloud.height, cloud.len()), (3, 2, 6));
    for (i, p) in cloud.positions.iter().enumerate() {
        if depth[i] == 0 {
            assert!(p.iter().all(|c| c.is_nan()), "pixel {i}: {p:?}");
        } else {
            assert_eq!(p[2], depth[i] as f32 * 0.001f32);
        }
    }
    assert_eq!(cloud.count_finite(), 3);
}

#[test]
fn back_projection_follows_the_pinhole_model() {
    let k = PinholeIntrinsics {
        width: 4,
        height: 3,
        fx: 500.0,
        fy: 400.0,
        cx: 1.0,
        cy: 2.0,
    };
    let depth = vec![2000u16; 12];
    for arithmetic in [Arithmetic::Pcl, Arithmetic::Open3d] {
        let params = DepthParams {
            arithmetic,
            ..DepthParams::default()
        };
        let cloud = depth_to_cloud(&depth, None, &k, &params).unwrap();
        // pixel (u=3, v=0): x = (3-1)*2/500, y = (0-2)*2/400
        let p = cloud.positions[3];
        assert!((p[0] - 0.008).abs() < 1e-7, "{arithmetic:?} {p:?}");
        assert!((p[1] + 0.01).abs() < 1e-7, "{arithmetic:?} {p:?}");
        assert_eq!(p[2], 2.0);
    }
}

/// Six pixels of a real Kinect frame (`frame_20121214T142256.068683`, fx = fy = 525,
/// c = (320, 240), millimetres) with the exact bits PCL's grabber wrote for them. They were
/// chosen where both the other f32 order, (u − cx)·(1/fx)·z, and the f64 formula give a
/// different float, so only PCL's own order passes. (u, v, raw depth, [x, y, z] bits.)
const PCL_PIXELS: [(u32, u32, u16, [u32; 3]); 6] = [
    (397, 353, 833, [0x3dfa3605, 0x3e3798ac, 0x3f553f7e]),
    (408, 247, 880, [0x3e170b7d, 0x3c403d2b, 0x3f6147af]),
    (447, 446, 734, [0x3e35d1ca, 0x3e9375bd, 0x3f3be76d]),
    (138, 222, 781, [0xbe8a9f4e, 0xbcdb5bbe, 0x3f47ef9e]),
    (167, 75, 1381, [0xbece0f9c, 0xbede38fe, 0x3fb0c49c]),
    (131, 31, 1536, [0xbf0d8eca, 0xbf1c8995, 0x3fc49ba6]),
];

#[test]
fn pcl_arithmetic_reproduces_pcls_bits_where_other_orders_differ() {
    let k = PinholeIntrinsics {
        width: 640,
        height: 480,
        fx: 525.0,
        fy: 525.0,
        cx: 320.0,
        cy: 240.0,
    };
    let mut depth = vec![0u16; 640 * 480];
    for &(u, v, raw, _) in &PCL_PIXELS {
        depth[(v * 640 + u) as usize] = raw;
    }
    let cloud = depth_to_cloud(&depth, None, &k, &DepthParams::default()).unwrap();
    for &(u, v, _, bits) in &PCL_PIXELS {
        let p = cloud.positions[(v * 640 + u) as usize];
        assert_eq!(p.map(f32::to_bits), bits, "pixel ({u}, {v}): {p:?}");
    }
}

#[test]
fn depth_at_or_beyond_trunc_is_invalid() {
    // 2999 mm stays, 3000 mm (= trunc) and beyond go, as in Open3D.
    let depth = [2999u16, 3000, 3001];
    for arithmetic in [Arithmetic::Pcl, Arithmetic::Open3d] {
        let params = DepthParams {
            depth_trunc: 3.0,
            arithmetic,
            ..DepthParams::default()
        };
        let cloud = depth_to_cloud(&depth, None, &intr(3, 1), &params).unwrap();
        assert!(cloud.positions[0][2].is_finite());
        assert!(cloud.positions[1][2].is_nan(), "{arithmetic:?}");
        assert!(cloud.positions[2][2].is_nan(), "{arithmetic:?}");
    }
}

#[test]
fn depth_scale_sets_the_units() {
    // TUM: 5000 units per metre.
    let params = DepthParams {
        depth_scale: 5000.0,
        ..DepthParams::default()
    };
    let cloud = depth_to_cloud(&[5000, 10000], None, &intr(2, 1), &params).unwrap();
    assert_eq!(cloud.positions[0][2], 1.0);
    assert_eq!(cloud.positions[1][2], 2.0);
}

#[test]
fn colours_are_kept_for_every_pixel_including_invalid_ones() {
    let colors = [[1, 2, 3], [4, 5, 6]];
    let cloud = depth_to_cloud(
        &[0, 800],
        Some(&colors),
        &intr(2, 1),
        &DepthParams::default(),
    )
    .unwrap();
    assert_eq!(cloud.colors.as_deref(), Some(&colors[..]));
    assert_eq!(cloud.field_names(), vec!["x", "y", "z", "rgb"]);
}

#[test]
fn buffer_length_mismatch_is_a_typed_error() {
    let e = depth_to_cloud(&[1, 2, 3], None, &intr(2, 2), &DepthParams::default()).unwrap_err();
    assert!(
        matches!(
            e,
            RgbdError::SizeMismatch {
                expected: (2, 2),
                ..
            }
        ),
        "{e:?}"
    );
    let e = depth_to_cloud(
        &[1, 2, 3, 4],
        Some(&[[0; 3]; 3]),
        &intr(2, 2),
        &DepthParams::default(),
    )
    .unwrap_err();
    assert!(matches!(e, RgbdError::SizeMismatch { .. }), "{e:?}");
}

#[test]
fn bad_params_name_the_field() {
    for (params, field) in [
        (
            DepthParams {
                depth_scale: 0.0,
                ..DepthParams::default()
            },
            "depth_scale",
        ),
        (
            DepthParams {
                depth_trunc: -1.0,
                ..DepthParams::default()
            },
            "depth_trunc",
        ),
    ] {
        let e = depth_to_cloud(&[1], None, &intr(1, 1), &params).unwrap_err();
        assert!(
            matches!(&e, RgbdError::BadIntrinsics { field: f, .. } if f == field),
            "{e:?}"
        );
    }
    let mut k = intr(1, 1);
    k.fy = f64::NAN;
    let e = depth_to_cloud(&[1], None, &k, &DepthParams::default()).unwrap_err();
    assert!(
        matches!(&e, RgbdError::BadIntrinsics { field, .. } if field == "fy"),
        "{e:?}"
    );
}

proptest! {
    #[test]
    fn every_valid_point_projects_back_onto_its_own_pixel(
        w in 1u32..20, h in 1u32..20,
        fx in 100.0f64..1000.0, fy in 100.0f64..1000.0,
        seed in any::<u64>(),
        open3d in any::<bool>(),
    ) {
        let k = PinholeIntrinsics { width: w, height: h, fx, fy, cx: w as f64 / 2.0, cy: h as f64 / 3.0 };
        let n = (w * h) as usize;
        let depth: Vec<u16> = (0..n as u64)
            .map(|i| (seed.wrapping_add(i).wrapping_mul(6364136223846793005).rotate_left(17) >> 48) as u16)
            .collect();
        let params = DepthParams {
            arithmetic: if open3d { Arithmetic::Open3d } else { Arithmetic::Pcl },
            ..DepthParams::default()
        };
        // 0 and 65535 are no measurement, and 20 m (20000 raw) is the default range.
        let dropped = |d: u16| d == 0 || d == u16::MAX || d >= 19_990;
        let cloud = match depth_to_cloud(&depth, None, &k, &params) {
            Ok(c) => c,
            Err(RgbdError::NoUsableDepth { .. }) => {
                prop_assert!(depth.iter().all(|&d| dropped(d)));
                return Ok(());
            }
            Err(e) => panic!("{e}"),
        };
        prop_assert_eq!(cloud.len(), n);
        for (i, p) in cloud.positions.iter().enumerate() {
            if p[2].is_nan() || depth[i] == 0 {
                prop_assert!(dropped(depth[i]), "{} dropped", depth[i]);
                prop_assert!(p[0].is_nan() && p[1].is_nan() && p[2].is_nan());
                continue;
            }
            let (u, v) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
            let z = p[2] as f64;
            prop_assert!((z - depth[i] as f64 / 1000.0).abs() <= 1e-6 * z.max(1.0));
            prop_assert!((fx * p[0] as f64 / z + k.cx - u).abs() < 1e-3, "u {} {:?}", u, p);
            prop_assert!((fy * p[1] as f64 / z + k.cy - v).abs() < 1e-3, "v {} {:?}", v, p);
        }
    }
}

proptest! {
    #[test]
    fn every_point_is_either_valid_in_front_of_the_camera_or_all_nan(
        raw in proptest::collection::vec(any::<u16>(), 6),
        log_scale in -3.0f64..45.0,
        trunc in prop_oneof![Just(f64::INFINITY), 0.001f64..100.0],
        open3d in any::<bool>(),
    ) {
        let params = DepthParams {
            depth_scale: 10f64.powf(log_scale),
            depth_trunc: trunc,
            arithmetic: if open3d { Arithmetic::Open3d } else { Arithmetic::Pcl },
        };
        let cloud = match depth_to_cloud(&raw, None, &intr(3, 2), &params) {
            Ok(c) => c,
            // Every pixel saturated or beyond the range: refused, not read as empty.
            Err(RgbdError::NoUsableDepth { .. }) => return Ok(()),
            Err(e) => panic!("{e}"),
        };
        for p in &cloud.positions {
            let all_nan = p.iter().all(|c| c.is_nan());
            let valid = p.iter().all(|c| c.is_finite()) && p[2] > 0.0 && f64::from(p[2]) < trunc;
            prop_assert!(all_nan || valid, "{:?} with {:?}", p, params);
        }
    }
}

// ---------------------------------------------------------------- image files

#[test]
fn reads_a_png_frame_with_rgb_colour() {
    let dir = tempfile::tempdir().unwrap();
    let d = write_depth_png(dir.path(), "d.png", 4, 3, |u, v| (u * 100 + v * 10) as u16);
    let c = write_rgb(dir.path(), "c.png", 4, 3);
    let camera = CameraModel {
        intrinsics: intr(4, 3),
        params: DepthParams::default(),
    };
    let cloud = read_frame(&d, Some(c.as_path()), &camera).unwrap();
    assert_eq!((cloud.width, cloud.height), (4, 3));
    assert!(cloud.positions[0][2].is_nan()); // (0,0) has depth 0
    assert_eq!(cloud.positions[4 + 2][2], 210.0f32 * 0.001); // (u=2, v=1): 210 mm
    assert_eq!(cloud.colors.as_ref().unwrap()[4 + 2], [2, 1, 7]);
}

#[test]
fn reads_16_bit_tiff_depth() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("d.tiff");
    ImageBuffer::<Luma<u16>, _>::from_fn(3, 2, |u, v| Luma([(u + 3 * v) as u16 * 1000]))
        .save(&p)
        .unwrap();
    let img = read_depth_image(&p).unwrap();
    assert_eq!((img.width, img.height), (3, 2));
    assert_eq!(img.data, vec![0, 1000, 2000, 3000, 4000, 5000]);
}

#[test]
fn rgba_colour_takes_red_green_blue_not_alpha() {
    // Open3D 0.20 would give (10, 20, 255) here (alpha in place of blue).
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("c.png");
    ImageBuffer::<Rgba<u8>, _>::from_pixel(2, 2, Rgba([10, 20, 30, 255]))
        .save(&p)
        .unwrap();
    let img = read_color_image(&p).unwrap();
    assert_eq!(img.data, vec![[10, 20, 30]; 4]);
}

#[test]
fn eight_bit_or_rgb_depth_is_rejected_with_a_typed_error() {
    let dir = tempfile::tempdir().unwrap();
    let p8 = dir.path().join("d8.png");
    ImageBuffer::<Luma<u8>, _>::from_pixel(2, 2, Luma([9]))
        .save(&p8)
        .unwrap();
    let (path, e) = rgbd_err(read_depth_image(&p8).unwrap_err());
    assert_eq!(path, p8);
    assert_eq!(
        e,
        RgbdError::UnsupportedDepthType {
            found: "8-bit grey".into()
        }
    );
    let rgb = write_rgb(dir.path(), "rgb.png", 2, 2);
    let (_, e) = rgbd_err(read_depth_image(&rgb).unwrap_err());
    assert_eq!(
        e,
        RgbdError::UnsupportedDepthType {
            found: "8-bit RGB".into()
        }
    );
}

#[test]
fn sixteen_bit_or_grey_colour_is_rejected_with_a_typed_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = write_depth_png(dir.path(), "d.png", 2, 2, |_, _| 5);
    let (path, e) = rgbd_err(read_color_image(&d).unwrap_err());
    assert_eq!(path, d);
    assert_eq!(
        e,
        RgbdError::UnsupportedColorType {
            found: "16-bit grey".into()
        }
    );
}

#[test]
fn colour_and_depth_of_different_sizes_are_rejected_naming_the_colour_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = write_depth_png(dir.path(), "d.png", 4, 3, |_, _| 1000);
    let c = write_rgb(dir.path(), "c.png", 3, 4);
    let camera = CameraModel {
        intrinsics: intr(4, 3),
        params: DepthParams::default(),
    };
    let (path, e) = rgbd_err(read_frame(&d, Some(c.as_path()), &camera).unwrap_err());
    assert_eq!(path, c);
    assert!(
        matches!(
            e,
            RgbdError::SizeMismatch {
                expected: (4, 3),
                found: (3, 4),
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn depth_of_a_different_size_than_the_intrinsics_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let d = write_depth_png(dir.path(), "d.png", 4, 3, |_, _| 1000);
    let camera = CameraModel {
        intrinsics: intr(640, 480),
        params: DepthParams::default(),
    };
    let (path, e) = rgbd_err(read_frame(&d, None, &camera).unwrap_err());
    assert_eq!(path, d);
    assert!(
        matches!(
            e,
            RgbdError::SizeMismatch {
                expected: (640, 480),
                found: (4, 3),
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn intrinsics_without_size_take_the_depth_image_size() {
    let dir = tempfile::tempdir().unwrap();
    let d = write_depth_png(dir.path(), "d.png", 5, 2, |_, _| 1000);
    let mut camera = CameraModel::default();
    camera.intrinsics.width = 0;
    camera.intrinsics.height = 0;
    let cloud = read_frame(&d, None, &camera).unwrap();
    assert_eq!((cloud.width, cloud.height), (5, 2));
}

#[test]
fn corrupt_and_missing_images_are_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = write_depth_png(dir.path(), "d.png", 8, 8, |u, v| (u * v) as u16);
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.path().join("cut.png");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let (_, e) = rgbd_err(read_depth_image(&cut).unwrap_err());
    assert!(matches!(e, RgbdError::Image { .. }), "{e:?}");
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"not an image at all").unwrap();
    let (_, e) = rgbd_err(read_depth_image(&junk).unwrap_err());
    assert!(matches!(e, RgbdError::Image { .. }), "{e:?}");
    let missing = dir.path().join("missing.png");
    assert!(matches!(
        read_depth_image(&missing).unwrap_err(),
        IoError::Os { path, .. } if path == missing
    ));
}

// ---------------------------------------------------------------- intrinsics

#[test]
fn open3d_json_is_column_major() {
    let cam = parse_open3d_json(
        r#"{"width": 640, "height": 480, "intrinsic_matrix": [525.0, 0, 0, 0, 520.5, 0, 319.5, 239.5, 1]}"#,
    )
    .unwrap();
    assert_eq!(
        cam.intrinsics,
        PinholeIntrinsics {
            width: 640,
            height: 480,
            fx: 525.0,
            fy: 520.5,
            cx: 319.5,
            cy: 239.5
        }
    );
    assert_eq!(cam.params, DepthParams::default());
    // Byte for byte what Open3D 0.20's write_pinhole_camera_intrinsic writes.
    let written =
        "{\n\t\"height\" : 480,\n\t\"intrinsic_matrix\" : [ 525.0, 0.0, 0.0, 0.0, 525.0, \
                   0.0, 319.5, 239.5, 1.0 ],\n\t\"width\" : 640\n}";
    assert_eq!(
        parse_open3d_json(written).unwrap().intrinsics,
        PinholeIntrinsics::prime_sense_default()
    );
}

#[test]
fn open3d_json_with_a_depth_scale_uses_it_and_keeps_the_other_depth_defaults() {
    // Open3D's RGB-D video metadata (e.g. a RealSense recording at 0.1 mm units).
    let cam = parse_open3d_json(
        r#"{"width": 640, "height": 480, "depth_scale": 10000.0,
            "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]}"#,
    )
    .unwrap();
    assert_eq!(
        cam.params,
        DepthParams {
            depth_scale: 10000.0,
            ..DepthParams::default()
        }
    );
}

fn field_of(e: RgbdError) -> String {
    match e {
        RgbdError::BadIntrinsics { field, .. } => field,
        other => panic!("expected BadIntrinsics, got {other:?}"),
    }
}

#[test]
fn open3d_json_errors_name_the_field() {
    let m = r#""intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]"#;
    let cases = [
        (format!(r#"{{"height": 480, {m}}}"#), "width"),
        (format!(r#"{{"width": 0, "height": 480, {m}}}"#), "width"),
        (format!(r#"{{"width": 640, "height": -3, {m}}}"#), "height"),
        (format!(r#"{{"width": 640, "height": 1e12, {m}}}"#), "height"),
        (r#"{"width": 640, "height": 480}"#.to_string(), "intrinsic_matrix"),
        (
            r#"{"width": 640, "height": 480, "intrinsic_matrix": [1, 2, 3]}"#.to_string(),
            "intrinsic_matrix",
        ),
        (
            r#"{"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0.5, 525, 0, 319.5, 239.5, 1]}"#
                .to_string(),
            "intrinsic_matrix[3]",
        ),
        (
            r#"{"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, "x", 0, 319.5, 239.5, 1]}"#
                .to_string(),
            "intrinsic_matrix[4]",
        ),
        (
            r#"{"width": 640, "height": 480, "intrinsic_matrix": [-525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]}"#
                .to_string(),
            "fx",
        ),
        ("[1, 2]".to_string(), "(root)"),
        (format!(r#"{{"width": 640, "height": 480, {m}, "depth_scale": 0}}"#), "depth_scale"),
        (format!(r#"{{"width": 640, "height": 480, {m}, "depth_scale": "mm"}}"#), "depth_scale"),
    ];
    for (text, field) in cases {
        let e = parse_open3d_json(&text).unwrap_err();
        assert_eq!(field_of(e), field, "{text}");
    }
    assert!(matches!(
        parse_open3d_json("{\"width\": 640,").unwrap_err(),
        RgbdError::IntrinsicsSyntax { .. }
    ));
}

const PCL_XML: &str = r#"<?xml version="1.0" encoding="utf-8"?>
<rgb>
	<focal_length_x>500</focal_length_x>
	<focal_length_y>500</focal_length_y>
	<principal_point_x>300</principal_point_x>
	<principal_point_y>200</principal_point_y>
</rgb>
<depth>
	<!-- <focal_length_x>1</focal_length_x> -->
	<focal_length_x>525</focal_length_x>
	<focal_length_y>526.5</focal_length_y>
	<principal_point_x>320</principal_point_x>
	<principal_point_y>240</principal_point_y>
	<z_multiplication_factor>0.0002</z_multiplication_factor>
</depth>
"#;

#[test]
fn pcl_xml_reads_the_depth_section() {
    let cam = parse_pcl_xml(PCL_XML).unwrap();
    assert_eq!(
        cam.intrinsics,
        PinholeIntrinsics {
            width: 0,
            height: 0,
            fx: 525.0,
            fy: 526.5,
            cx: 320.0,
            cy: 240.0
        }
    );
    assert!((cam.params.depth_scale - 5000.0).abs() < 1e-9);
    // Without the factor, PCL's default (millimetres) applies.
    let no_factor = PCL_XML.replace(
        "<z_multiplication_factor>0.0002</z_multiplication_factor>",
        "",
    );
    assert_eq!(
        parse_pcl_xml(&no_factor).unwrap().params.depth_scale,
        1000.0
    );
}

#[test]
fn pcl_xml_errors_name_the_element() {
    let cases = [
        (
            PCL_XML.replace("<focal_length_y>526.5</focal_length_y>", ""),
            "focal_length_y",
        ),
        (
            PCL_XML.replace("<principal_point_x>320<", "<principal_point_x>abc<"),
            "principal_point_x",
        ),
        (
            PCL_XML.replace("<focal_length_x>525<", "<focal_length_x>0<"),
            "focal_length_x",
        ),
        (
            PCL_XML.replace(">0.0002<", ">-1<"),
            "z_multiplication_factor",
        ),
        (PCL_XML.replace("depth>", "dept>"), "depth"),
    ];
    for (text, field) in cases {
        assert_eq!(field_of(parse_pcl_xml(&text).unwrap_err()), field);
    }
    assert!(matches!(
        parse_pcl_xml("<depth><focal_length_x>525").unwrap_err(),
        RgbdError::IntrinsicsSyntax { .. }
    ));
}

#[test]
fn intrinsics_format_is_chosen_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    let x = dir.path().join("cam.xml");
    std::fs::write(&x, PCL_XML).unwrap();
    assert_eq!(read_camera_model(&x).unwrap().intrinsics.fx, 525.0);
    let y = dir.path().join("cam.yaml");
    std::fs::write(&y, PCL_XML).unwrap();
    let (path, e) = rgbd_err(read_camera_model(&y).unwrap_err());
    assert_eq!((path, e), (y, RgbdError::UnknownIntrinsicsFormat));
}

// ---------------------------------------------------------------- real data vs PCL

/// PCL's image grabber wrote an organized PCD of each of these frames; ours must match:
/// same validity mask, coordinates within 1e-6 m (bitwise with PCL arithmetic), same
/// colours. Open3D's arithmetic must stay within 1e-6 m of PCL's.
#[test]
fn grabber_frames_match_pcls_own_pcd() {
    let Some(dir) = common::data_dir("grabber_frames_match_pcls_own_pcd") else {
        return;
    };
    let dir = dir.join("pcl/grabber_sequence");
    let mut frames: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    frames.sort();
    assert_eq!(
        frames.len(),
        3,
        "expected three frames in {}",
        dir.display()
    );
    let mut max_pcl = 0.0f64;
    let mut max_o3d = 0.0f64;
    for xml in &frames {
        let stem = xml.with_extension("");
        let stem = stem.to_str().unwrap();
        let depth = PathBuf::from(format!("{stem}_depth.tiff"));
        let color = PathBuf::from(format!("{stem}_rgb.tiff"));
        let reference = softsense::io::pcd::read_pcd(&xml.with_extension("pcd")).unwrap();
        let mut camera = read_camera_model(xml).unwrap();
        let ours = read_frame(&depth, Some(color.as_path()), &camera).unwrap();
        camera.params.arithmetic = Arithmetic::Open3d;
        let o3d = read_frame(&depth, Some(color.as_path()), &camera).unwrap();
        assert_eq!(
            (ours.width, ours.height),
            (reference.width, reference.height)
        );
        assert_eq!(ours.len(), reference.len());
        assert_eq!(ours.colors, reference.colors, "{}", xml.display());
        for (i, r) in reference.positions.iter().enumerate() {
            let (a, b) = (ours.positions[i], o3d.positions[i]);
            let valid = r[2].is_finite();
            assert_eq!(
                a[2].is_finite(),
                valid,
                "mask differs at {i} in {}",
                xml.display()
            );
            assert_eq!(b[2].is_finite(), valid, "open3d mask differs at {i}");
            if valid {
                for k in 0..3 {
                    max_pcl = max_pcl.max((a[k] as f64 - r[k] as f64).abs());
                    max_o3d = max_o3d.max((b[k] as f64 - r[k] as f64).abs());
                }
            }
        }
    }
    eprintln!(
        "max |ours - PCL| = {max_pcl:e} m (PCL arithmetic), {max_o3d:e} m (Open3D arithmetic)"
    );
    // PCL's arithmetic is reproduced exactly, not just within the 1e-6 m acceptance bound.
    assert_eq!(max_pcl, 0.0);
    assert!(max_o3d <= 1e-6, "{max_o3d}");
}

// ---------------------------------------------------------------- committed bad-input corpus

/// What a corpus file must fail with: the variant's name and a fragment of its message.
const MALFORMED: &[(&str, &str, &str)] = &[
    ("depth_grey8.png", "UnsupportedDepthType", "8-bit grey"),
    ("depth_rgb8.png", "UnsupportedDepthType", "8-bit RGB"),
    ("depth_rgb16.png", "UnsupportedDepthType", "16-bit RGB"),
    ("depth_float32.tiff", "UnsupportedDepthType", "cannot read"),
    ("depth_truncated.png", "Image", "decode"),
    ("depth_not_an_image.png", "Image", "decode"),
    ("depth_huge_dims.png", "Image", "limit"),
    ("depth_implausible_dims.png", "ImplausibleSize", "8000x8000"),
    ("depth_small.png", "SizeMismatch", "(320, 240)"),
    ("color_grey8.png", "UnsupportedColorType", "8-bit grey"),
    ("color_grey16.png", "UnsupportedColorType", "16-bit grey"),
    ("color_small.png", "SizeMismatch", "(8, 6)"),
    (
        "intrinsics_missing_height.json",
        "BadIntrinsics",
        "`height`",
    ),
    (
        "intrinsics_skew.json",
        "BadIntrinsics",
        "`intrinsic_matrix[3]`",
    ),
    ("intrinsics_short_matrix.json", "BadIntrinsics", "9 numbers"),
    ("intrinsics_huge_width.json", "BadIntrinsics", "`width`"),
    ("intrinsics_syntax.json", "IntrinsicsSyntax", "malformed"),
    (
        "intrinsics_missing_fy.xml",
        "BadIntrinsics",
        "`focal_length_y`",
    ),
    (
        "intrinsics_bad_factor.xml",
        "BadIntrinsics",
        "`z_multiplication_factor`",
    ),
    (
        "intrinsics_unclosed.xml",
        "IntrinsicsSyntax",
        "never closed",
    ),
    (
        "intrinsics.yaml",
        "UnknownIntrinsicsFormat",
        "unknown intrinsics format",
    ),
];

/// Each file in `tests/fixtures/rgbd/malformed` is tried in the role its name says
/// (`depth_*` as the depth image of the demo frame, `color_*` as its colour image,
/// `intrinsics*` as its camera) and must give the listed typed error naming the file.
#[test]
fn committed_malformed_rgbd_inputs_give_typed_errors_naming_the_file() {
    let fixtures = common::project_root().join("tests/fixtures/rgbd");
    let dir = fixtures.join("malformed");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = MALFORMED.iter().map(|m| m.0.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed, "corpus and table disagree");
    let camera = read_camera_model(fixtures.join("intrinsics.json")).unwrap();
    let (depth, color) = (fixtures.join("depth.png"), fixtures.join("color.png"));
    for &(name, variant, fragment) in MALFORMED {
        let bad = dir.join(name);
        let result = if name.starts_with("depth") {
            read_frame(&bad, Some(color.as_path()), &camera)
        } else if name.starts_with("color") {
            read_frame(&depth, Some(bad.as_path()), &camera)
        } else {
            read_camera_model(&bad).map(|_| Default::default())
        };
        let err = result.expect_err(name);
        let message = err.to_string();
        let (path, source) = rgbd_err(err);
        assert_eq!(path, bad, "{name}");
        assert!(
            format!("{source:?}").starts_with(variant),
            "{name}: {source:?}"
        );
        assert!(message.contains(fragment), "{name}: {message}");
    }
}

// ---------------------------------------------------------------- fuzzing

/// Applies `edits` (position, byte) to a copy of `bytes`, and cuts it to `keep` of its length.
fn mutate(bytes: &[u8], edits: &[(usize, u8)], keep: f64) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for &(i, b) in edits {
        if !out.is_empty() {
            let n = out.len();
            out[i % n] = b;
        }
    }
    out.truncate((out.len() as f64 * keep).ceil() as usize);
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn intrinsics_parsers_never_panic_on_random_or_mutated_text(
        random in ".{0,200}",
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6),
        keep in 0.0f64..=1.0,
    ) {
        let _ = parse_open3d_json(&random);
        let _ = parse_pcl_xml(&random);
        let json = br#"{"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]}"#;
        let _ = parse_open3d_json(&String::from_utf8_lossy(&mutate(json, &edits, keep)));
        let _ = parse_pcl_xml(&String::from_utf8_lossy(&mutate(PCL_XML.as_bytes(), &edits, keep)));
    }

    #[test]
    fn image_readers_never_panic_on_mutated_files(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        keep in 0.0f64..=1.0,
        tiff in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let name = if tiff { "d.tiff" } else { "d.png" };
        let good = dir.path().join(name);
        ImageBuffer::<Luma<u16>, _>::from_fn(7, 5, |u, v| Luma([(u * 300 + v * 7) as u16]))
            .save(&good)
            .unwrap();
        let bad = dir.path().join(format!("bad_{name}"));
        std::fs::write(&bad, mutate(&std::fs::read(&good).unwrap(), &edits, keep)).unwrap();
        if let Ok(img) = read_depth_image(&bad) {
            prop_assert_eq!(img.data.len(), img.width as usize * img.height as usize);
        }
        let _ = read_color_image(&bad);
    }
}

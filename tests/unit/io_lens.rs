//! Camera files with a lens (issue 53 item 3): distortion keys, ray tables in `.npy`, JPEG
//! colour, and the Punyo recording's clouds rebuilt from its ray table.
use crate::common;
use image::{ImageBuffer, Rgb};
use softsense::camera::{Distortion, DistortionModel, Lens};
use softsense::io::intrinsics::{
    parse_lens_keys, read_camera_file, read_camera_model, DepthParams, LensKeys, PinholeIntrinsics,
};
use softsense::io::npy::{parse_npy_f32, NpyError};
use softsense::io::rgbd::{depth_to_cloud, depth_to_cloud_through, read_color_image};
use softsense::io::IoError;
use std::path::{Path, PathBuf};

/// A `.npy` file's bytes: version 1, the given header dictionary, then `data`.
fn npy(header: &str, data: &[f32]) -> Vec<u8> {
    let mut b = b"\x93NUMPY\x01\x00".to_vec();
    b.extend_from_slice(&(header.len() as u16).to_le_bytes());
    b.extend_from_slice(header.as_bytes());
    for x in data {
        b.extend_from_slice(&x.to_le_bytes());
    }
    b
}

fn f4(shape: &str) -> String {
    format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape}, }}\n")
}

const JSON_4X3: &str = r#""width": 4, "height": 3,
    "intrinsic_matrix": [500, 0, 0, 0, 500, 0, 1.5, 1, 1]"#;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn npy_files_other_than_c_order_float32_are_refused_with_the_reason() {
    let ok = parse_npy_f32(&npy(&f4("(3, 1)"), &[1.0, 2.0, 3.0])).unwrap();
    assert_eq!((ok.shape, ok.data), (vec![3, 1], vec![1.0, 2.0, 3.0]));
    let dtype = "{'descr': '<f8', 'fortran_order': False, 'shape': (1,), }";
    assert!(
        matches!(parse_npy_f32(&npy(dtype, &[0.0, 0.0])), Err(NpyError::Dtype(d)) if d == "<f8")
    );
    let fortran = "{'descr': '<f4', 'fortran_order': True, 'shape': (1,), }";
    assert!(matches!(
        parse_npy_f32(&npy(fortran, &[0.0])),
        Err(NpyError::FortranOrder)
    ));
    assert!(matches!(
        parse_npy_f32(&npy(&f4("(3, 1)"), &[1.0, 2.0])),
        Err(NpyError::Length {
            expected: 12,
            found: 8,
            ..
        })
    ));
    assert!(matches!(
        parse_npy_f32(b"PK\x03\x04 not numpy"),
        Err(NpyError::NotNpy)
    ));
    let mut v3 = npy(&f4("(1,)"), &[0.0]);
    v3[6] = 3;
    assert!(matches!(parse_npy_f32(&v3), Err(NpyError::Version(3, 0))));
    let cut = npy(&f4("(1,)"), &[0.0]);
    assert!(matches!(
        parse_npy_f32(&cut[..20]),
        Err(NpyError::Header(_))
    ));
    // A shape over the memory budget is refused before any allocation.
    let huge = npy(&f4("(100000, 100000, 1000)"), &[]);
    assert!(matches!(parse_npy_f32(&huge), Err(NpyError::TooLarge(_))));
}

#[test]
fn distortion_keys_are_read_as_realsense_and_opencv_write_them() {
    let d = |body: &str| parse_lens_keys(&format!("{{{JSON_4X3}, {body}}}"));
    let c = [0.1, -0.05, 1e-3, -2e-3, 0.01];
    let want = Distortion::new(DistortionModel::BrownConrady, c).unwrap();
    let got = d(
        r#""distortion_model": "plumb_bob", "distortion_coeffs": [0.1, -0.05, 0.001, -0.002, 0.01]"#,
    );
    assert_eq!(got.unwrap(), LensKeys::Distorted(want));
    // Four coefficients: k3 = 0; no model: Brown-Conrady.
    let four = d(r#""distortion_coeffs": [0.1, 0, 0, 0]"#).unwrap();
    assert!(matches!(four, LensKeys::Distorted(x) if x.coeffs == [0.1, 0.0, 0.0, 0.0, 0.0]));
    // All zero is the pinhole's own path.
    let zero =
        d(r#""distortion_model": "inverse_brown_conrady", "distortion_coeffs": [0, 0, 0, 0, 0]"#);
    assert_eq!(zero.unwrap(), LensKeys::Pinhole);
    for (body, names) in [
        (
            r#""distortion_model": "fisheye", "distortion_coeffs": [0, 0, 0, 0]"#,
            "fisheye",
        ),
        (r#""distortion_coeffs": [0.1, 0.2]"#, "distortion_coeffs"),
        (
            r#""distortion_coeffs": [0.1, 0, 0, "x"]"#,
            "distortion_coeffs[3]",
        ),
        (
            r#""distortion_model": "brown_conrady""#,
            "distortion_coeffs",
        ),
        (
            r#""distortion_coeffs": [0.1, 0, 0, 0], "rays": "rays.npy""#,
            "rays",
        ),
    ] {
        let e = d(body).unwrap_err().to_string();
        assert!(e.contains(names), "{body}: {e}");
    }
}

#[test]
fn a_ray_table_of_the_wrong_shape_or_type_is_refused_naming_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let json = format!(r#"{{{JSON_4X3}, "depth_scale": 10000, "rays": "rays.npy"}}"#);
    let cam = write(dir.path(), "intrinsics.json", json.as_bytes());
    let grid: Vec<f32> = (0..24).map(|i| i as f32 * 0.01).collect();
    for (npy_bytes, says) in [
        (npy(&f4("(4, 3, 2)"), &grid), "ray table vs intrinsics"),
        (npy(&f4("(3, 8)"), &grid), "height x width x 2"),
        (npy(&f4("(3, 4, 2)"), &grid[..20]), "needs 96"),
        (
            npy(
                "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 4, 1), }",
                &grid,
            ),
            "<f8",
        ),
    ] {
        let rays = write(dir.path(), "rays.npy", &npy_bytes);
        let e = read_camera_file(&cam).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(says) && text.contains(&rays.display().to_string()),
            "{text}"
        );
    }
    write(dir.path(), "rays.npy", &npy(&f4("(3, 4, 2)"), &grid));
    let (model, lens) = read_camera_file(&cam).unwrap();
    assert_eq!(model.params.depth_scale, 10000.0);
    assert!(matches!(&lens, Lens::Rays(t) if t.at(1, 0) == Some([0.02, 0.03])));
    // The pinhole-only reader refuses the file rather than drop its rays.
    assert!(matches!(read_camera_model(&cam), Err(IoError::Rgbd { .. })));
    std::fs::remove_file(dir.path().join("rays.npy")).unwrap();
    assert!(
        matches!(read_camera_file(&cam), Err(IoError::Os { path, .. }) if path.ends_with("rays.npy"))
    );
}

#[test]
fn a_distorted_depth_image_back_projects_along_the_undistorted_rays() {
    let k = PinholeIntrinsics {
        width: 4,
        height: 3,
        fx: 500.0,
        fy: 500.0,
        cx: 1.5,
        cy: 1.0,
    };
    let dist = Distortion::new(DistortionModel::BrownConrady, [0.2, 0.0, 0.0, 0.0, 0.0]).unwrap();
    let lens = Lens::Distorted(dist);
    let depth = [
        1000u16, 0, 2000, 65535, 1500, 1500, 1500, 1500, 1000, 1000, 1000, 1000,
    ];
    let params = DepthParams::default();
    let cloud = depth_to_cloud_through(&depth, None, &k, &params, &lens).unwrap();
    assert!(cloud.positions[1][2].is_nan() && cloud.positions[3][2].is_nan());
    for (i, p) in cloud
        .positions
        .iter()
        .enumerate()
        .filter(|(_, p)| p[2].is_finite())
    {
        let uv = lens.project(&k, p.map(f64::from)).unwrap();
        let (u, v) = ((i % 4) as f64, (i / 4) as f64);
        assert!(
            (uv[0] - u).abs() < 1e-3 && (uv[1] - v).abs() < 1e-3,
            "{i}: {uv:?}"
        );
    }
    // The pinhole lens is depth_to_cloud, bit for bit.
    let pinhole = depth_to_cloud_through(&depth, None, &k, &params, &Lens::Pinhole).unwrap();
    let plain = depth_to_cloud(&depth, None, &k, &params).unwrap();
    assert_eq!(
        format!("{:?}", pinhole.positions),
        format!("{:?}", plain.positions)
    );
}

#[test]
fn jpeg_colour_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("color_0000.jpg");
    ImageBuffer::<Rgb<u8>, _>::from_fn(16, 8, |_, _| Rgb([200, 100, 50]))
        .save(&p)
        .unwrap();
    let c = read_color_image(&p).unwrap();
    assert_eq!((c.width, c.height, c.data.len()), (16, 8, 128));
    let px = c.data[40];
    assert!(
        px.iter()
            .zip([200u8, 100, 50])
            .all(|(a, b)| a.abs_diff(b) <= 3),
        "{px:?}"
    );
    // A corrupt JPEG is an error naming the file, not a panic.
    let bad = write(
        dir.path(),
        "bad.jpg",
        &[0xFF, 0xD8, 0xFF, 0xE0, 0, 0x10, 1, 2, 3],
    );
    let e = read_color_image(&bad).unwrap_err().to_string();
    assert!(e.contains("bad.jpg"), "{e}");
}

/// The Punyo ray table parsed by the test itself: `(height, width, rays)`.
fn punyo_rays(path: &Path) -> (usize, usize, Vec<f32>) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
    let len = usize::from(u16::from_le_bytes([b[8], b[9]]));
    let header = std::str::from_utf8(&b[10..10 + len]).unwrap();
    assert!(
        header.contains("'<f4'") && header.contains("(480, 640, 2)"),
        "{header}"
    );
    let data = b[10 + len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    (480, 640, data)
}

#[test]
fn reading_punyo_rebuilds_the_sources_clouds_to_1e_6_m() {
    let test = "reading_punyo_rebuilds_the_sources_clouds_to_1e_6_m";
    let Some(punyo) =
        common::data_file(test, "punyo/rays.npy").map(|p| p.parent().unwrap().to_path_buf())
    else {
        return;
    };
    // The recording is read in place: its frames are linked into a folder with a camera
    // file naming its ray table (the pinhole is the README's fit, for pinhole consumers).
    let dir = tempfile::tempdir().unwrap();
    let json = format!(
        r#"{{"width": 640, "height": 480, "intrinsic_matrix": [434.3, 0, 0, 0, 433.3, 0, 313.7, 247.5, 1],
            "depth_scale": 10000, "rays": {:?}}}"#,
        punyo.join("rays.npy").display().to_string()
    );
    write(dir.path(), "intrinsics.json", json.as_bytes());
    let frames = [0usize, 70, 149];
    for f in frames {
        for name in [format!("depth_{f:04}.png"), format!("color_{f:04}.jpg")] {
            std::os::unix::fs::symlink(punyo.join(&name), dir.path().join(&name)).unwrap();
        }
    }
    let (h, w, rays) = punyo_rays(&punyo.join("rays.npy"));
    let rec = softsense::recording::Recording::open(dir.path()).unwrap();
    assert_eq!(rec.frames, frames);
    for f in frames {
        let cloud = rec.read_frame(f).unwrap();
        assert_eq!((cloud.width, cloud.height), (w as u32, h as u32));
        assert_eq!(
            cloud.colors.as_ref().map(Vec::len),
            Some(w * h),
            "frame {f}: JPEG colour"
        );
        let depth = image::open(punyo.join(format!("depth_{f:04}.png")))
            .unwrap()
            .into_luma16();
        let (mut valid, mut worst) = (0usize, 0.0f64);
        for (i, (p, raw)) in cloud.positions.iter().zip(depth.pixels()).enumerate() {
            let raw = raw.0[0];
            let (rx, ry) = (rays[2 * i], rays[2 * i + 1]);
            if raw == 0 || raw == u16::MAX || rx.is_nan() || ry.is_nan() {
                assert!(p.iter().all(|c| c.is_nan()), "frame {f} pixel {i}: {p:?}");
                continue;
            }
            let z = f64::from(raw) * 1e-4;
            let want = [f64::from(rx) * z, f64::from(ry) * z, z];
            for c in 0..3 {
                worst = worst.max((f64::from(p[c]) - want[c]).abs());
            }
            valid += 1;
        }
        eprintln!("punyo frame {f}: {valid} valid pixels, worst {worst:e} m");
        assert!(valid > 100_000, "frame {f}: only {valid} valid pixels");
        assert!(
            worst <= 1e-6,
            "frame {f}: {worst:e} m off the source's cloud"
        );
    }
    // The table is the same in every frame.
    projects_back_to_its_pixel(&rec, frames[0], &rays, w);
}

/// The point at 0.1 m on every 53rd pixel's ray (`rays` as the source's table), where the
/// pixel has finite rays all round (the interpolant is defined on its four cells),
/// projects through the frame's lens to its own pixel within 1e-6 px: the inverse of the
/// ray table, on real rays. (Through the cloud's `f32` points it is 3e-5 px: their
/// rounding.)
fn projects_back_to_its_pixel(
    rec: &softsense::recording::Recording,
    f: usize,
    rays: &[f32],
    w: usize,
) {
    let lens = rec.lens_of(f).unwrap();
    let Lens::Rays(table) = lens else {
        panic!("frame {f}: the lens is not the ray table");
    };
    let k = rec.camera_of(f).unwrap().intrinsics;
    let inside = |u: i64, v: i64| {
        (-1..=1).all(|dv| {
            (-1..=1).all(|du| {
                let (a, b) = (u + du, v + dv);
                a >= 0
                    && b >= 0
                    && table
                        .at(a as u32, b as u32)
                        .is_some_and(|r| r.iter().all(|c| c.is_finite()))
            })
        })
    };
    let (mut checked, mut worst) = (0, 0.0f64);
    for i in (0..rays.len() / 2).step_by(53) {
        let (u, v) = (i % w, i / w);
        if !inside(u as i64, v as i64) {
            continue;
        }
        let z = 0.1;
        let p = [
            f64::from(rays[2 * i]) * z,
            f64::from(rays[2 * i + 1]) * z,
            z,
        ];
        let uv = lens.project(&k, p);
        let uv = uv.unwrap_or_else(|| panic!("frame {f}: pixel ({u}, {v}) does not project"));
        worst = worst.max((uv[0] - u as f64).hypot(uv[1] - v as f64));
        checked += 1;
    }
    eprintln!("punyo frame {f}: {checked} points projected back, worst {worst:e} px");
    assert!(
        worst < 1e-6,
        "frame {f}: a point projects {worst:e} px off its pixel"
    );
}

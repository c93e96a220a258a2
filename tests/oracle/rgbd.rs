//! Issue 2 acceptance: RGB-D conversion of the three real Kinect frames in
//! `$SOFTSENSE_DATA/pcl/grabber_sequence` against PCL's PCD of the same frames, PCL's own
//! `ImageGrabber` run live, and Open3D's `create_from_rgbd_image`.

use crate::common::data_file;
use crate::common::oracle::{self, Lib, RawPcd};
use serde_json::json;
use softsense::cloud::PointCloud;
use softsense::io::intrinsics::{read_camera_model, Arithmetic, CameraModel};
use softsense::io::pcd::read_pcd;
use softsense::io::rgbd::read_frame;
use std::path::{Path, PathBuf};

const FRAMES: [&str; 3] = [
    "frame_20121214T142255.814212",
    "frame_20121214T142256.068683",
    "frame_20121214T142256.332395",
];

struct Frame {
    depth: PathBuf,
    color: PathBuf,
    pcd: PathBuf,
    camera: CameraModel,
}

fn frames(test: &str) -> Option<Vec<Frame>> {
    let mut out = Vec::new();
    for name in FRAMES {
        let base = |suffix: &str| data_file(test, &format!("pcl/grabber_sequence/{name}{suffix}"));
        let xml = base(".xml")?;
        let camera = read_camera_model(&xml).unwrap_or_else(|e| panic!("{e}"));
        out.push(Frame {
            depth: base("_depth.tiff")?,
            color: base("_rgb.tiff")?,
            pcd: base(".pcd")?,
            camera,
        });
    }
    Some(out)
}

/// Same organized size, the same NaN mask, coordinates within 1e-6 m and, at valid
/// pixels (or everywhere when `colours_everywhere`), the same colours.
fn assert_matches(
    what: &str,
    ours: &PointCloud,
    w: usize,
    h: usize,
    pos: &[[f32; 3]],
    rgb: &[[u8; 4]],
    colours_everywhere: bool,
) {
    assert_eq!(
        (ours.width as usize, ours.height as usize),
        (w, h),
        "{what}: organized size"
    );
    let colors = ours.colors.as_ref().expect("our frame has colours");
    let mut valid = 0;
    for (i, (a, b)) in ours.positions.iter().zip(pos).enumerate() {
        let (va, vb) = (
            PointCloud::is_finite_point(a),
            PointCloud::is_finite_point(b),
        );
        assert_eq!(va, vb, "{what}: validity of pixel {i} ({a:?} vs {b:?})");
        if va {
            valid += 1;
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-6,
                    "{what}: pixel {i} axis {k}: {} vs {}",
                    a[k],
                    b[k]
                );
            }
        }
        if va || colours_everywhere {
            assert_eq!(colors[i][..], rgb[i][..3], "{what}: colour of pixel {i}");
        }
    }
    assert!(
        valid > 200_000,
        "{what}: only {valid} valid pixels; wrong frame?"
    );
}

fn ours(frame: &Frame, arithmetic: Arithmetic) -> PointCloud {
    let mut camera = frame.camera;
    camera.params.arithmetic = arithmetic;
    read_frame(&frame.depth, Some(frame.color.as_path()), &camera).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn rgbd_frames_equal_the_pcd_pcl_wrote_of_them() {
    let Some(frames) = frames("rgbd_frames_equal_the_pcd_pcl_wrote_of_them") else {
        return;
    };
    for f in &frames {
        let shipped = read_pcd(&f.pcd).unwrap_or_else(|e| panic!("{e}"));
        let rgb: Vec<[u8; 4]> = shipped
            .colors
            .as_ref()
            .expect("colours")
            .iter()
            .map(|c| [c[0], c[1], c[2], 0])
            .collect();
        let what = format!("{} vs PCL's PCD", f.depth.display());
        let w = shipped.width as usize;
        let h = shipped.height as usize;
        assert_matches(
            &what,
            &ours(f, Arithmetic::Pcl),
            w,
            h,
            &shipped.positions,
            &rgb,
            true,
        );
    }
}

fn intrinsics_params(f: &Frame) -> serde_json::Value {
    let i = f.camera.intrinsics;
    json!({"color": f.color, "fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy,
           "depth_units": 1.0 / f.camera.params.depth_scale, "depth_scale": f.camera.params.depth_scale})
}

fn oracle_frame(lib: Lib, f: &Frame) -> Option<RawPcd> {
    let r = oracle::run(
        lib,
        "rgbd_to_cloud",
        Path::new(&f.depth),
        intrinsics_params(f),
    )?;
    Some(r.raw_cloud())
}

#[test]
fn rgbd_frames_equal_pcl_image_grabber() {
    let Some(frames) = frames("rgbd_frames_equal_pcl_image_grabber") else {
        return;
    };
    for f in &frames {
        let Some(pcl) = oracle_frame(Lib::Pcl, f) else {
            return;
        };
        let what = format!("{} vs pcl::ImageGrabber", f.depth.display());
        let rgb = pcl.rgba().expect("colour");
        assert_matches(
            &what,
            &ours(f, Arithmetic::Pcl),
            pcl.width,
            pcl.height,
            &pcl.positions(),
            &rgb,
            true,
        );
    }
}

#[test]
fn rgbd_frames_equal_open3d_create_from_rgbd_image() {
    let Some(frames) = frames("rgbd_frames_equal_open3d_create_from_rgbd_image") else {
        return;
    };
    for f in &frames {
        let Some(o3d) = oracle_frame(Lib::Open3d, f) else {
            return;
        };
        let what = format!("{} vs Open3D", f.depth.display());
        let rgb = o3d.rgba().expect("colour");
        // Open3D gives invalid pixels colour 0, so colours are compared at valid pixels.
        assert_matches(
            &what,
            &ours(f, Arithmetic::Open3d),
            o3d.width,
            o3d.height,
            &o3d.positions(),
            &rgb,
            false,
        );
    }
}

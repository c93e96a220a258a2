//! RGB-D to cloud speed at 640x480 (307,200 pixels): the back-projection alone on a
//! seeded synthetic depth image (both arithmetics), and the whole `read_frame` (TIFF
//! decode + conversion) on a real Kinect frame from `$SOFTSENSE_DATA` (skipped with a
//! message when unset). A 30 Hz camera leaves 33 ms per frame for everything.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use softsense::io::intrinsics::{read_camera_model, Arithmetic, DepthParams, PinholeIntrinsics};
use softsense::io::rgbd::{depth_to_cloud, read_frame};
use std::hint::black_box;

/// A seeded 640x480 depth image in millimetres: a tilted plane, about 12 % holes.
fn kinect_like_depth() -> (Vec<u16>, Vec<[u8; 3]>) {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut depth = Vec::with_capacity(640 * 480);
    let mut color = Vec::with_capacity(640 * 480);
    for v in 0..480u32 {
        for u in 0..640u32 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let hole = state % 8 == 0;
            depth.push(if hole { 0 } else { 800 + (v + u / 4) as u16 });
            color.push([u as u8, v as u8, (state >> 56) as u8]);
        }
    }
    (depth, color)
}

fn bench_back_projection(c: &mut Criterion) {
    let (depth, color) = kinect_like_depth();
    let k = PinholeIntrinsics::prime_sense_default();
    let mut group = c.benchmark_group("rgbd_back_projection");
    group.throughput(Throughput::Elements(depth.len() as u64));
    for (name, arithmetic) in [("pcl", Arithmetic::Pcl), ("open3d", Arithmetic::Open3d)] {
        let params = DepthParams {
            arithmetic,
            ..DepthParams::default()
        };
        group.bench_with_input(BenchmarkId::new(name, "640x480"), &params, |b, p| {
            b.iter(|| depth_to_cloud(black_box(&depth), Some(&color), &k, p))
        });
    }
    group.finish();
}

fn bench_real_frame(c: &mut Criterion) {
    let Some(dir) = std::env::var_os("SOFTSENSE_DATA") else {
        eprintln!("SKIPPED real-data RGB-D bench: SOFTSENSE_DATA is not set");
        return;
    };
    let stem = std::path::Path::new(&dir).join("pcl/grabber_sequence/frame_20121214T142256.068683");
    let s = stem.to_string_lossy();
    let camera = read_camera_model(format!("{s}.xml")).expect("grabber XML");
    let (depth, color) = (format!("{s}_depth.tiff"), format!("{s}_rgb.tiff"));
    let mut group = c.benchmark_group("rgbd_read_frame");
    group.throughput(Throughput::Elements(640 * 480));
    group.bench_function("grabber_tiff_xml", |b| {
        b.iter(|| read_frame(&depth, Some(std::path::Path::new(&color)), &camera))
    });
    group.finish();
}

criterion_group!(benches, bench_back_projection, bench_real_frame);
criterion_main!(benches);

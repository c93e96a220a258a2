//! Cloud file reading speed: the real 640x480 `binary_compressed` PCD from
//! `$SOFTSENSE_DATA` (skipped with a message when unset), and a generated 307,200-point
//! organized cloud in every PCD encoding and in binary PLY. Files are parsed from memory,
//! so the numbers are decode time, not disk time.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use softsense::cloud::PointCloud;
use softsense::io::{pcd, ply, Encoding};
use std::hint::black_box;

/// A seeded 640x480 cloud like a Kinect frame: a tilted plane with noise, 20 % NaN
/// pixels, colours and alpha.
fn kinect_like_cloud() -> PointCloud {
    let (w, h) = (640u32, 480u32);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut positions = Vec::with_capacity((w * h) as usize);
    let mut colors = Vec::with_capacity((w * h) as usize);
    for v in 0..h {
        for u in 0..w {
            let z = 1.0 + 0.001 * v as f32 + 0.002 * next();
            if next() < 0.2 {
                positions.push([f32::NAN; 3]);
            } else {
                positions.push([
                    (u as f32 - 320.0) * z / 525.0,
                    (v as f32 - 240.0) * z / 525.0,
                    z,
                ]);
            }
            colors.push([(u % 256) as u8, (v % 256) as u8, (next() * 255.0) as u8]);
        }
    }
    let mut cloud = PointCloud::from_positions(positions);
    cloud.width = w;
    cloud.height = h;
    cloud.colors = Some(colors);
    cloud.alpha = Some(vec![255; (w * h) as usize]);
    cloud
}

fn bench_real(c: &mut Criterion) {
    let Some(dir) = std::env::var_os("SOFTSENSE_DATA") else {
        eprintln!("SKIPPED real-data I/O bench: SOFTSENSE_DATA is not set");
        return;
    };
    let path = std::path::Path::new(&dir).join("pcl/milk_cartoon_all_small_clorox.pcd");
    let bytes =
        std::fs::read(&path).expect("SOFTSENSE_DATA is set but the milk cartoon PCD is missing");
    let mut g = c.benchmark_group("read_real_pcd");
    g.throughput(Throughput::Elements(307_200));
    g.bench_function("milk_cartoon_parse_from_memory", |b| {
        b.iter(|| pcd::parse_pcd(black_box(&bytes)).expect("valid file"))
    });
    g.bench_function("milk_cartoon_read_file", |b| {
        b.iter(|| pcd::read_pcd(black_box(&path)).expect("valid file"))
    });
    g.finish();
}

fn bench_generated(c: &mut Criterion) {
    let cloud = kinect_like_cloud();
    let mut g = c.benchmark_group("read_generated_307200");
    g.throughput(Throughput::Elements(cloud.len() as u64));
    g.sample_size(20);
    for (name, enc) in [
        ("pcd_binary_compressed", Encoding::BinaryCompressed),
        ("pcd_binary", Encoding::Binary),
        ("pcd_ascii", Encoding::Ascii),
    ] {
        let bytes = pcd::to_pcd_bytes(&cloud, enc);
        g.bench_with_input(BenchmarkId::new("parse", name), &bytes, |b, bytes| {
            b.iter(|| pcd::parse_pcd(black_box(bytes)).expect("valid file"))
        });
    }
    let bytes = ply::to_ply_bytes(&cloud, Encoding::Binary);
    g.bench_with_input(
        BenchmarkId::new("parse", "ply_binary"),
        &bytes,
        |b, bytes| b.iter(|| ply::parse_ply(black_box(bytes)).expect("valid file")),
    );
    g.bench_function("write_pcd_binary_compressed", |b| {
        b.iter(|| pcd::to_pcd_bytes(black_box(&cloud), Encoding::BinaryCompressed))
    });
    g.finish();
}

criterion_group!(benches, bench_real, bench_generated);
criterion_main!(benches);

//! Segmentation benchmarks on real data (needs SOFTSENSE_DATA; prints a SKIPPED line and
//! does nothing without it):
//! - `contacts+clustering`: Alg. 4.1 on the mOSD stacked-box scene learn17 at full
//!   resolution, the first labelled object as the robot and every other labelled point as
//!   the object cloud (the KD-tree build over the robot is included);
//! - `region_growing_rgb`: thesis parameters on the raw 640x480 milk frame and on its
//!   5 mm voxel version;
//! - `geometric`: the geometric mode (default parameters) on the 5 mm voxel version of
//!   the mOSD scene learn17 (the protocol of the mOSD quality table).

use criterion::{criterion_group, criterion_main, Criterion};
use softsense::contact::{detect_contacts, ContactParams};
use softsense::filter::{voxel_grid, VoxelGridParams};
use softsense::io::read_cloud;
use softsense::segment::{
    region_growing_rgb, segment_geometric, GeometricParams, RegionGrowingParams,
};
use std::path::PathBuf;
use std::time::Duration;

fn data() -> Option<PathBuf> {
    let d = std::env::var_os("SOFTSENSE_DATA").map(PathBuf::from);
    if d.is_none() {
        eprintln!("SKIPPED benches/segment: SOFTSENSE_DATA is not set");
    }
    d
}

fn contacts(c: &mut Criterion) {
    let Some(dir) = data() else { return };
    let cloud = read_cloud(dir.join("mosd/learn17.pcd")).expect("learn17");
    let labels = cloud.labels.clone().expect("labels");
    let pts: Vec<([f32; 3], u32)> = cloud
        .positions
        .iter()
        .zip(&labels)
        .filter(|&(p, &l)| l != 0 && p.iter().all(|v| v.is_finite()))
        .map(|(p, &l)| (*p, l))
        .collect();
    let robot_label = pts
        .iter()
        .map(|x| x.1)
        .filter(|&l| l >= 20)
        .min()
        .expect("an object");
    let robot: Vec<[f32; 3]> = pts
        .iter()
        .filter(|x| x.1 == robot_label)
        .map(|x| x.0)
        .collect();
    let object: Vec<[f32; 3]> = pts
        .iter()
        .filter(|x| x.1 != robot_label)
        .map(|x| x.0)
        .collect();
    let params = ContactParams::default();
    let n = detect_contacts(&robot, &object, &params)
        .expect("contacts")
        .len();
    eprintln!(
        "contacts bench: robot {} points, object {} points, {n} contacts",
        robot.len(),
        object.len()
    );
    c.bench_function("contacts+clustering learn17 full resolution", |b| {
        b.iter(|| detect_contacts(&robot, &object, &params).expect("contacts"))
    });
}

fn region_growing(c: &mut Criterion) {
    let Some(dir) = data() else { return };
    let raw = read_cloud(dir.join("pcl/milk_cartoon_all_small_clorox.pcd")).expect("milk");
    let vox = voxel_grid(&raw, &VoxelGridParams::new(0.005))
        .expect("voxel")
        .cloud;
    let params = RegionGrowingParams::thesis();
    let mut g = c.benchmark_group("region_growing_rgb");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("milk 5 mm voxels, thesis params", |b| {
        b.iter(|| region_growing_rgb(&vox, &params).expect("rg"))
    });
    g.bench_function("milk raw 640x480, thesis params", |b| {
        b.iter(|| region_growing_rgb(&raw, &params).expect("rg"))
    });
    g.finish();
}

fn geometric(c: &mut Criterion) {
    let Some(dir) = data() else { return };
    let raw = read_cloud(dir.join("mosd/learn17.pcd")).expect("learn17");
    let mut vox = voxel_grid(&raw, &VoxelGridParams::new(0.005))
        .expect("voxel")
        .cloud;
    vox.labels = None;
    let params = GeometricParams::default();
    let mut g = c.benchmark_group("geometric");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("mOSD learn17 5 mm voxels, default params", |b| {
        b.iter(|| segment_geometric(&vox, &params).expect("geometric"))
    });
    g.finish();
}

criterion_group!(benches, contacts, region_growing, geometric);
criterion_main!(benches);

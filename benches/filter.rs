//! Filter stages and the crop + voxel + radius-outlier chain on real 640x480 clouds
//! (`$SOFTSENSE_DATA/pcl/*.pcd`); skipped with a message when SOFTSENSE_DATA is unset.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use softsense::features::{estimate_normals, NormalParams};
use softsense::filter::*;
use softsense::pipeline::{ChainParams, Pipeline};
use std::hint::black_box;

fn clouds() -> Vec<(String, softsense::PointCloud)> {
    let Some(dir) = std::env::var_os("SOFTSENSE_DATA") else {
        eprintln!("SKIPPED benches/filter: SOFTSENSE_DATA is not set");
        return Vec::new();
    };
    [
        "milk_cartoon_all_small_clorox",
        "table_scene_mug_stereo_textured",
    ]
    .iter()
    .map(|n| {
        let p = std::path::Path::new(&dir)
            .join("pcl")
            .join(format!("{n}.pcd"));
        (
            n.to_string(),
            softsense::io::read_cloud(&p).expect("bench cloud"),
        )
    })
    .collect()
}

fn stages(c: &mut Criterion) {
    let mut g = c.benchmark_group("filter");
    g.sample_size(10);
    for (name, cloud) in clouds() {
        g.throughput(Throughput::Elements(cloud.len() as u64));
        let pt = PassThroughParams::new(Field::Z, 0.5, 1.5);
        g.bench_with_input(BenchmarkId::new("passthrough", &name), &cloud, |b, c| {
            b.iter(|| pass_through(black_box(c), &pt))
        });
        for mode in [VoxelMode::Pcl, VoxelMode::Open3d] {
            let p = VoxelGridParams {
                mode,
                ..VoxelGridParams::new(0.005)
            };
            g.bench_with_input(
                BenchmarkId::new(format!("voxel_5mm_{mode:?}"), &name),
                &cloud,
                |b, c| b.iter(|| voxel_grid(black_box(c), &p)),
            );
        }
        let ror = RadiusOutlierParams {
            radius: 0.005,
            min_neighbors: 5,
            ..Default::default()
        };
        g.bench_with_input(
            BenchmarkId::new("radius_outlier_5mm_5", &name),
            &cloud,
            |b, c| b.iter(|| radius_outlier_removal(black_box(c), &ror)),
        );
        let sor = StatisticalOutlierParams {
            k: 20,
            std_ratio: 2.0,
            ..Default::default()
        };
        g.bench_with_input(
            BenchmarkId::new("statistical_outlier_20", &name),
            &cloud,
            |b, c| b.iter(|| statistical_outlier_removal(black_box(c), &sor)),
        );
        g.bench_with_input(BenchmarkId::new("normals_k10", &name), &cloud, |b, c| {
            b.iter(|| estimate_normals(black_box(c), &NormalParams::knn(10)))
        });
        let chain = ChainParams {
            crop: vec![PassThroughParams::new(Field::Z, 0.0, 1.5)],
            voxel: Some(VoxelGridParams::new(0.005)),
            radius_outlier: Some(RadiusOutlierParams {
                radius: 0.01,
                min_neighbors: 5,
                ..Default::default()
            }),
            statistical_outlier: None,
            normals: None,
        };
        let mut pipe = Pipeline::new(chain);
        g.bench_with_input(
            BenchmarkId::new("chain_crop_voxel5mm_ror", &name),
            &cloud,
            |b, c| b.iter(|| pipe.step(black_box(c))),
        );
    }
    g.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);

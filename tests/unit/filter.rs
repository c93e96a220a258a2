//! Filters against brute-force references, library-specific corner cases, serial == parallel.

use proptest::prelude::*;
use softsense::cloud::PointCloud;
use softsense::filter::*;
use softsense::search::{squared_distance, squared_distance_f64, Parallelism};
use std::collections::BTreeMap;

/// Random clouds: lattice points (duplicates, exact distances), uniform points, NaN.
fn positions() -> impl Strategy<Value = Vec<[f32; 3]>> {
    prop::collection::vec(
        prop_oneof![
            6 => (0i32..5, 0i32..5, 0i32..5).prop_map(|(x, y, z)| [x as f32 * 0.1, y as f32 * 0.1, z as f32 * 0.1]),
            6 => (-0.5f32..0.5, -0.5f32..0.5, -0.5f32..0.5).prop_map(|(x, y, z)| [x, y, z]),
            1 => Just([f32::NAN, f32::NAN, f32::NAN]),
        ],
        0..150,
    )
}

fn with_attributes(pos: Vec<[f32; 3]>) -> PointCloud {
    let n = pos.len();
    let mut c = PointCloud::from_positions(pos);
    c.colors = Some(
        (0..n)
            .map(|i| {
                [
                    (i * 37 % 256) as u8,
                    (i * 91 % 256) as u8,
                    (i * 13 % 256) as u8,
                ]
            })
            .collect(),
    );
    c.labels = Some((0..n).map(|i| (i % 3) as u32).collect());
    c.normals = Some(
        (0..n)
            .map(|i| {
                if i % 2 == 0 {
                    [0.0, 0.0, 1.0]
                } else {
                    [0.0, 1.0, 0.0]
                }
            })
            .collect(),
    );
    c.curvature = Some((0..n).map(|i| i as f32 * 0.01).collect());
    c
}

/// Clouds equal with positions compared bit for bit (NaN points included).
fn same_bits(a: &PointCloud, b: &PointCloud) -> bool {
    let bits = |c: &PointCloud| -> Vec<[u32; 3]> {
        c.positions.iter().map(|p| p.map(f32::to_bits)).collect()
    };
    let rest = |c: &PointCloud| PointCloud {
        positions: Vec::new(),
        ..c.clone()
    };
    bits(a) == bits(b) && rest(a) == rest(b)
}

fn finite(p: &[f32; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

proptest! {
    #[test]
    fn pass_through_keeps_exactly_the_points_inside_inclusive_bounds(
        pos in positions(), lo in -0.3f32..0.3, w in 0.0f32..0.5, negative in any::<bool>(), axis in 0usize..3,
    ) {
        let cloud = PointCloud::from_positions(pos.clone());
        let field = [Field::X, Field::Y, Field::Z][axis];
        let hi = lo + w;
        let p = PassThroughParams { negative, ..PassThroughParams::new(field, lo, hi) };
        let out = pass_through(&cloud, &p).unwrap();
        let want: Vec<usize> = (0..pos.len()).filter(|&i| {
            let v = pos[i][axis];
            finite(&pos[i]) && ((lo <= v && v <= hi) != negative)
        }).collect();
        prop_assert_eq!(&out.indices, &want);
        prop_assert_eq!(out.cloud.len(), want.len());
        let org = pass_through(&cloud, &PassThroughParams { keep_organized: true, ..p }).unwrap();
        prop_assert_eq!(org.cloud.len(), pos.len());
        prop_assert_eq!(org.indices, want);
    }

    #[test]
    fn crop_box_keeps_exactly_the_points_inside_in_f64(pos in positions(), lo in -0.3f64..0.0, hi in 0.0f64..0.3, invert in any::<bool>()) {
        let cloud = PointCloud::from_positions(pos.clone());
        let out = crop_box(&cloud, &CropBoxParams { min: [lo; 3], max: [hi; 3], invert }).unwrap();
        let want: Vec<usize> = (0..pos.len()).filter(|&i| {
            let inside = pos[i].iter().all(|&c| lo <= c as f64 && c as f64 <= hi);
            inside != invert
        }).collect();
        prop_assert_eq!(out.indices, want);
    }

    #[test]
    fn crop_box_bounds_at_and_next_to_point_coordinates_compare_in_f64(
        pos in positions(),
        pick in 0usize..64,
        nudge in prop_oneof![Just(0.0f64), Just(1e-12), Just(-1e-12), Just(1e-9), Just(-1e-9)],
        invert in any::<bool>(),
    ) {
        // Bounds on (or a hair off) a point's own f32 coordinates: the f32 bounds the
        // crop uses internally must decide exactly as the f64 comparison does.
        let Some(p) = pos.iter().filter(|p| finite(p)).nth(pick % pos.len().max(1)).copied() else {
            return Ok(());
        };
        let lo: [f64; 3] = std::array::from_fn(|a| p[a] as f64 + nudge - 0.05);
        let hi: [f64; 3] = std::array::from_fn(|a| p[a] as f64 + nudge);
        let cloud = PointCloud::from_positions(pos.clone());
        let out = crop_box(&cloud, &CropBoxParams { min: lo, max: hi, invert }).unwrap();
        let want: Vec<usize> = (0..pos.len()).filter(|&i| {
            let inside = (0..3).all(|a| lo[a] <= pos[i][a] as f64 && pos[i][a] as f64 <= hi[a]);
            inside != invert
        }).collect();
        prop_assert_eq!(out.indices, want);
    }

    #[test]
    fn pcl_voxel_grid_matches_a_brute_force_grid(pos in positions(), leaf in prop_oneof![Just(0.1f64), Just(0.05), 0.02f64..0.4], min_pts in 0usize..3) {
        let cloud = with_attributes(pos.clone());
        let params = VoxelGridParams { min_points_per_voxel: min_pts, ..VoxelGridParams::new(leaf) };
        let out = voxel_grid(&cloud, &params).unwrap();
        let inv = 1.0f32 / leaf as f32;
        let mut cells: BTreeMap<(i64, i64, i64), Vec<usize>> = BTreeMap::new();
        for (i, p) in pos.iter().enumerate().filter(|(_, p)| finite(p)) {
            let c = |a: usize| (p[a] * inv).floor() as i64;
            cells.entry((c(2), c(1), c(0))).or_default().push(i);
        }
        let cells: Vec<Vec<usize>> = cells.into_values().filter(|v| v.len() >= min_pts).collect();
        prop_assert_eq!(out.cloud.len(), cells.len());
        let colors = cloud.colors.as_ref().unwrap();
        for (v, members) in cells.iter().enumerate() {
            prop_assert_eq!(out.indices[v], members[0]);
            for a in 0..3 {
                let mean = members.iter().map(|&i| pos[i][a] as f64).sum::<f64>() / members.len() as f64;
                prop_assert!((out.cloud.positions[v][a] as f64 - mean).abs() <= 1e-6);
                let csum: u32 = members.iter().map(|&i| colors[i][a] as u32).sum();
                prop_assert_eq!(out.cloud.colors.as_ref().unwrap()[v][a], (csum as f32 / members.len() as f32) as u8);
            }
            let n = out.cloud.normals.as_ref().unwrap()[v];
            prop_assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn open3d_voxel_grid_matches_a_brute_force_grid(pos in positions(), leaf in 0.02f64..0.4) {
        let cloud = PointCloud::from_positions(pos.clone());
        let out = voxel_grid(&cloud, &VoxelGridParams { mode: VoxelMode::Open3d, ..VoxelGridParams::new(leaf) }).unwrap();
        let fin: Vec<&[f32; 3]> = pos.iter().filter(|p| finite(p)).collect();
        let mut cells: BTreeMap<(i64, i64, i64), Vec<[f32; 3]>> = BTreeMap::new();
        if !fin.is_empty() {
            let min: Vec<f64> = (0..3).map(|a| fin.iter().map(|p| p[a] as f64).fold(f64::INFINITY, f64::min)).collect();
            for p in &fin {
                let c = |a: usize| ((p[a] as f64 - (min[a] - leaf / 2.0)) / leaf).floor() as i64;
                cells.entry((c(2), c(1), c(0))).or_default().push(**p);
            }
        }
        prop_assert_eq!(out.cloud.len(), cells.len());
        for (v, members) in cells.values().enumerate() {
            for a in 0..3 {
                let mean = members.iter().map(|p| p[a] as f64).sum::<f64>() / members.len() as f64;
                prop_assert_eq!(out.cloud.positions[v][a], mean as f32);
            }
        }
    }

    #[test]
    fn radius_outlier_removal_matches_brute_force_counts(pos in positions(), r in prop_oneof![Just(0.1f64), Just(0.2), 0.01f64..0.3], min in 0usize..5) {
        let cloud = PointCloud::from_positions(pos.clone());
        let dense = pos.iter().all(finite);
        let r2 = (r * r) as f32;
        for mode in [OutlierMode::Pcl, OutlierMode::Open3d] {
            let res = radius_outlier_removal(&cloud, &RadiusOutlierParams { radius: r, min_neighbors: min, mode, ..Default::default() });
            if mode == OutlierMode::Open3d && min == 0 {
                prop_assert!(res.is_err());
                continue;
            }
            let want: Vec<usize> = (0..pos.len()).filter(|&i| finite(&pos[i]) && {
                let c = pos.iter().filter(|q| finite(q)).filter(|q| match mode {
                    OutlierMode::Pcl if dense => squared_distance(&pos[i], q) <= r2,
                    OutlierMode::Pcl => squared_distance(&pos[i], q) < r2,
                    OutlierMode::Open3d => squared_distance_f64(&pos[i], q) < r * r,
                }).count();
                c > min
            }).collect();
            prop_assert_eq!(res.unwrap().indices, want);
        }
    }

    #[test]
    fn statistical_outlier_removal_matches_brute_force(pos in positions(), k in 1usize..8, ratio in 0.0f64..2.0) {
        let cloud = PointCloud::from_positions(pos.clone());
        let fin: Vec<usize> = (0..pos.len()).filter(|&i| finite(&pos[i])).collect();
        let sorted_d = |i: usize| {
            let mut d: Vec<f32> = fin.iter().map(|&j| squared_distance(&pos[i], &pos[j])).collect();
            d.sort_by(|a, b| a.partial_cmp(b).unwrap());
            d
        };
        // PCL
        let mut dist = vec![0f32; pos.len()];
        let mut valid = 0usize;
        for &i in &fin {
            let d = sorted_d(i);
            let take = d.len().min(k + 1);
            if take >= 2 {
                let s: f64 = d[1..take].iter().map(|x| x.sqrt() as f64).sum();
                dist[i] = (s / (take - 1) as f64) as f32;
                valid += 1;
            }
        }
        let (s, sq) = dist.iter().fold((0f64, 0f64), |(s, q), &v| (s + v as f64, q + (v * v) as f64));
        let (vn, mean) = (valid as f64, s / valid as f64);
        let thr = mean + ratio * ((sq - s * s / vn) / (vn - 1.0)).sqrt();
        let want: Vec<usize> = (0..pos.len()).filter(|&i| (dist[i] as f64).partial_cmp(&thr) != Some(std::cmp::Ordering::Greater)).collect();
        let got = statistical_outlier_removal(&cloud, &StatisticalOutlierParams { k, std_ratio: ratio, ..Default::default() }).unwrap();
        prop_assert_eq!(got.indices, want);
        // Open3D
        let avg: Vec<f64> = (0..pos.len()).map(|i| {
            if !finite(&pos[i]) || fin.is_empty() { return -1.0; }
            let mut d: Vec<f64> = fin.iter().map(|&j| squared_distance_f64(&pos[i], &pos[j])).collect();
            d.sort_by(|a, b| a.partial_cmp(b).unwrap());
            d.truncate(k);
            d.iter().map(|x| x.sqrt()).sum::<f64>() / d.len() as f64
        }).collect();
        let vn = avg.iter().filter(|&&a| a >= 0.0).count() as f64;
        let mean = avg.iter().filter(|&&a| a > 0.0).sum::<f64>() / vn;
        let sq: f64 = avg.iter().filter(|&&a| a > 0.0).map(|a| (a - mean) * (a - mean)).sum();
        let thr = mean + ratio * (sq / (vn - 1.0)).sqrt();
        let want: Vec<usize> = (0..pos.len()).filter(|&i| avg[i] > 0.0 && avg[i] < thr).collect();
        let got = statistical_outlier_removal(&cloud, &StatisticalOutlierParams { k, std_ratio: ratio, mode: OutlierMode::Open3d, ..Default::default() }).unwrap();
        // A k-th neighbour tie in f32 vs f64 cannot change the sum of distances, so exact.
        prop_assert_eq!(got.indices, want);
    }

    #[test]
    fn selecting_filters_match_brute_force_on_runs_of_kept_and_removed_points(
        runs in prop::collection::vec((1usize..90, 0u8..5), 0..12),
        lo in -0.3f32..0.1, w in 0.0f32..0.5, axis in 0usize..3, negative in any::<bool>(),
        infinite_bounds in any::<bool>(),
    ) {
        // Runs as in a depth frame (rows of valid depth between NaN holes) crossing the
        // 64-point mask words, plus infinite coordinates, which only a test of every axis
        // (not of z alone) rejects.
        let mut pos = Vec::new();
        for (k, &(len, kind)) in runs.iter().enumerate() {
            for i in 0..len {
                let t = ((k * 131 + i * 17) % 97) as f32 / 97.0 - 0.5;
                pos.push(match kind {
                    0 => [f32::NAN; 3],
                    1 => [t, -t, 0.5 * t],
                    2 => [t, 0.1, 0.1],
                    3 => [[f32::INFINITY, 0.0, 0.0], [0.0, f32::NEG_INFINITY, 0.0], [0.0, 0.0, f32::INFINITY]][i % 3],
                    _ => [0.2 * t, 0.05, t],
                });
            }
        }
        let cloud = with_attributes(pos.clone());
        let field = [Field::X, Field::Y, Field::Z][axis];
        let (lo, hi) = if infinite_bounds { (f32::NEG_INFINITY, f32::INFINITY) } else { (lo, lo + w) };
        let p = PassThroughParams { negative, ..PassThroughParams::new(field, lo, hi) };
        let want: Vec<usize> = (0..pos.len()).filter(|&i| {
            let v = pos[i][axis];
            finite(&pos[i]) && ((lo <= v && v <= hi) != negative)
        }).collect();
        let out = pass_through(&cloud, &p).unwrap();
        prop_assert_eq!(&out.indices, &want);
        if want.len() < pos.len() {
            prop_assert!(same_bits(&out.cloud, &cloud.select(&want)));
        }
        let all_finite = pass_through(&cloud, &PassThroughParams::default()).unwrap();
        prop_assert_eq!(all_finite.indices, (0..pos.len()).filter(|&i| finite(&pos[i])).collect::<Vec<_>>());
        let b = CropBoxParams { min: [lo as f64; 3], max: [hi as f64; 3], invert: negative };
        let want: Vec<usize> = (0..pos.len()).filter(|&i| {
            let inside = pos[i].iter().all(|&c| b.min[0] <= c as f64 && c as f64 <= b.max[0]);
            inside != negative
        }).collect();
        let out = crop_box(&cloud, &b).unwrap();
        prop_assert_eq!(&out.indices, &want);
        prop_assert!(same_bits(&out.cloud, &cloud.select(&want)));
    }

    #[test]
    fn every_filter_gives_the_same_output_serial_and_parallel(pos in prop::collection::vec((-0.5f32..0.5, -0.5f32..0.5, -0.5f32..0.5).prop_map(|(x, y, z)| [x, y, z]), 0..3000)) {
        let cloud = with_attributes(pos);
        for mode in [VoxelMode::Pcl, VoxelMode::Open3d] {
            let p = VoxelGridParams { mode, ..VoxelGridParams::new(0.05) };
            let s = voxel_grid(&cloud, &VoxelGridParams { parallelism: Parallelism::Serial, ..p }).unwrap();
            prop_assert_eq!(s, voxel_grid(&cloud, &p).unwrap());
        }
        for mode in [OutlierMode::Pcl, OutlierMode::Open3d] {
            let p = RadiusOutlierParams { radius: 0.08, min_neighbors: 3, mode, ..Default::default() };
            let s = radius_outlier_removal(&cloud, &RadiusOutlierParams { parallelism: Parallelism::Serial, ..p }).unwrap();
            prop_assert_eq!(s, radius_outlier_removal(&cloud, &p).unwrap());
            let p = StatisticalOutlierParams { k: 8, std_ratio: 1.0, mode, ..Default::default() };
            let s = statistical_outlier_removal(&cloud, &StatisticalOutlierParams { parallelism: Parallelism::Serial, ..p }).unwrap();
            prop_assert_eq!(s, statistical_outlier_removal(&cloud, &p).unwrap());
        }
    }
}

#[test]
fn pass_through_rejects_nan_in_both_modes_and_keeps_organization_when_nothing_is_removed() {
    let mut c = PointCloud::from_positions(vec![
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0000001],
        [f32::NAN, 0.0, 0.5],
    ]);
    let p = PassThroughParams::new(Field::Z, 0.0, 1.0);
    assert_eq!(pass_through(&c, &p).unwrap().indices, vec![0, 1]);
    let neg = PassThroughParams {
        negative: true,
        ..p
    };
    assert_eq!(pass_through(&c, &neg).unwrap().indices, vec![2]);
    c.positions[3] = [0.0, 0.0, 0.5];
    c.width = 2;
    c.height = 2;
    let all = pass_through(&c, &PassThroughParams::new(Field::Z, 0.0, 2.0)).unwrap();
    assert_eq!((all.cloud.width, all.cloud.height), (2, 2));
    let org = pass_through(
        &c,
        &PassThroughParams {
            keep_organized: true,
            ..p
        },
    )
    .unwrap();
    assert_eq!((org.cloud.width, org.cloud.height), (2, 2));
    assert!(org.cloud.positions[2][0].is_nan());
    assert!(matches!(
        pass_through(&c, &PassThroughParams::new(Field::Curvature, 0.0, 1.0)),
        Err(FilterError::MissingField { .. })
    ));
    assert_eq!("normal_x".parse::<Field>().unwrap(), Field::NormalX);
    assert!("w".parse::<Field>().is_err());
}

#[test]
fn crop_box_with_invert_keeps_nan_points_and_rejects_inverted_boxes() {
    let c =
        PointCloud::from_positions(vec![[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [2.0, 0.0, 0.0]]);
    let b = CropBoxParams {
        min: [-1.0; 3],
        max: [1.0; 3],
        invert: false,
    };
    assert_eq!(crop_box(&c, &b).unwrap().indices, vec![0]);
    assert_eq!(
        crop_box(&c, &CropBoxParams { invert: true, ..b })
            .unwrap()
            .indices,
        vec![1, 2]
    );
    assert!(crop_box(
        &c,
        &CropBoxParams {
            min: [1.0; 3],
            max: [-1.0; 3],
            invert: false
        }
    )
    .is_err());
}

#[test]
fn pcl_voxel_grid_uses_float_inverse_leaf_indexing() {
    // 0.7f * 10f rounds to 7.0 (cell 7) while 0.65f lands in cell 6 (oracle-semantics 2).
    let c = PointCloud::from_positions(vec![[0.7, 0.0, 0.0], [0.69, 0.0, 0.0], [0.65, 0.0, 0.0]]);
    let out = voxel_grid(&c, &VoxelGridParams::new(0.1)).unwrap();
    assert_eq!(out.indices, vec![1, 0]); // cell 6 holds 0.69 and 0.65; cell 7 holds 0.7
    assert_eq!(out.cloud.positions[1], [0.7, 0.0, 0.0]);
}

#[test]
fn voxel_colours_are_truncated_in_pcl_mode_and_rounded_in_open3d_mode_labels_vote() {
    let mut c = PointCloud::from_positions(vec![
        [0.01, 0.01, 0.01],
        [0.02, 0.02, 0.02],
        [0.03, 0.03, 0.03],
        [0.04, 0.04, 0.04],
    ]);
    c.colors = Some(vec![[0, 0, 0], [255, 255, 255], [0, 0, 0], [255, 255, 255]]);
    c.labels = Some(vec![5, 2, 5, 2]);
    let p = voxel_grid(&c, &VoxelGridParams::new(1.0)).unwrap();
    assert_eq!(p.cloud.colors.as_ref().unwrap()[0], [127; 3]);
    assert_eq!(p.cloud.labels.as_ref().unwrap()[0], 2);
    let o = voxel_grid(
        &c,
        &VoxelGridParams {
            mode: VoxelMode::Open3d,
            ..VoxelGridParams::new(1.0)
        },
    )
    .unwrap();
    assert_eq!(o.cloud.colors.as_ref().unwrap()[0], [128; 3]);
}

#[test]
fn voxel_leaf_errors_are_typed_and_tiny_leaves_never_pass_the_input_through() {
    let c = PointCloud::from_positions(vec![[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-50] {
        assert!(
            matches!(
                voxel_grid(&c, &VoxelGridParams::new(bad)),
                Err(FilterError::InvalidLeafSize { .. })
            ),
            "{bad}"
        );
    }
    // PCL would overflow its 32-bit index here (1e9 cells per axis) and return the input.
    let out = voxel_grid(&c, &VoxelGridParams::new(1e-9)).unwrap();
    assert_eq!(out.cloud.len(), 2);
    let far = PointCloud::from_positions(vec![[1e30, 0.0, 0.0]]);
    assert!(matches!(
        voxel_grid(&far, &VoxelGridParams::new(1e-20)),
        Err(FilterError::LeafTooSmall { .. })
    ));
}

#[test]
fn empty_and_one_point_clouds_are_handled_by_every_filter() {
    for pts in [vec![], vec![[0.1f32, 0.2, 0.3]], vec![[f32::NAN; 3]]] {
        let c = PointCloud::from_positions(pts.clone());
        let n_fin = pts.iter().filter(|p| finite(p)).count();
        assert_eq!(
            voxel_grid(&c, &VoxelGridParams::new(0.1))
                .unwrap()
                .cloud
                .len(),
            n_fin
        );
        assert_eq!(
            radius_outlier_removal(
                &c,
                &RadiusOutlierParams {
                    min_neighbors: 0,
                    ..Default::default()
                }
            )
            .unwrap()
            .indices
            .len(),
            n_fin
        );
        assert!(radius_outlier_removal(&c, &RadiusOutlierParams::default())
            .unwrap()
            .indices
            .is_empty());
        // PCL keeps single and NaN points (no statistics to judge them); Open3D drops them.
        assert_eq!(
            statistical_outlier_removal(&c, &StatisticalOutlierParams::default())
                .unwrap()
                .indices
                .len(),
            pts.len()
        );
        let o3d = StatisticalOutlierParams {
            mode: OutlierMode::Open3d,
            ..Default::default()
        };
        assert!(statistical_outlier_removal(&c, &o3d)
            .unwrap()
            .indices
            .is_empty());
    }
}

#[test]
fn pcl_radius_outlier_boundary_is_inclusive_for_dense_clouds_and_strict_otherwise() {
    let dense = PointCloud::from_positions(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    let p = RadiusOutlierParams {
        radius: 1.0,
        min_neighbors: 1,
        ..Default::default()
    };
    assert_eq!(
        radius_outlier_removal(&dense, &p).unwrap().indices,
        vec![0, 1]
    );
    let mut sparse = dense.clone();
    sparse.positions.push([f32::NAN; 3]);
    sparse.width = 3;
    assert!(radius_outlier_removal(&sparse, &p)
        .unwrap()
        .indices
        .is_empty());
    let o = RadiusOutlierParams {
        mode: OutlierMode::Open3d,
        ..p
    };
    assert!(radius_outlier_removal(&dense, &o)
        .unwrap()
        .indices
        .is_empty());
    assert!(radius_outlier_removal(&dense, &RadiusOutlierParams { radius: 0.0, ..p }).is_err());
}

#[test]
fn open3d_statistical_removal_drops_exact_duplicates_and_pcl_keeps_nan() {
    let c = PointCloud::from_positions(vec![
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.1, 0.0, 0.0],
        [f32::NAN; 3],
    ]);
    let o = StatisticalOutlierParams {
        k: 2,
        std_ratio: 10.0,
        mode: OutlierMode::Open3d,
        ..Default::default()
    };
    assert_eq!(
        statistical_outlier_removal(&c, &o).unwrap().indices,
        vec![2, 3]
    );
    let p = StatisticalOutlierParams {
        k: 1,
        std_ratio: 10.0,
        ..Default::default()
    };
    assert_eq!(
        statistical_outlier_removal(&c, &p).unwrap().indices,
        vec![0, 1, 2, 3, 4]
    );
}

/// A Kinect-sized cloud (307200 points, every 20th NaN), large enough for the parallel
/// paths of the crop and voxel filters.
fn big_cloud() -> PointCloud {
    let mut c = crate::filter_golden::data::synthetic_cloud(3, 640 * 480);
    c.positions
        .iter_mut()
        .step_by(20)
        .for_each(|p| *p = [f32::NAN; 3]);
    c.labels = Some((0..c.len()).map(|i| (i % 3) as u32).collect());
    c
}

#[test]
fn large_clouds_give_brute_force_crops_and_thread_independent_voxels() {
    let cloud = big_cloud();
    let pos = &cloud.positions;
    // Pass-through and crop box against a plain filter, and the `_into` variants reusing
    // a buffer that held a different result.
    let pt = PassThroughParams::new(Field::Z, 0.75, 0.85);
    let want: Vec<usize> = (0..pos.len())
        .filter(|&i| finite(&pos[i]) && (0.75..=0.85).contains(&pos[i][2]))
        .collect();
    assert!(want.len() > 1000 && want.len() < pos.len() / 2);
    let mut reused = FilterOutput::default();
    crop_box_into(&cloud, &CropBoxParams::default(), &mut reused).unwrap();
    pass_through_into(&cloud, &pt, &mut reused).unwrap();
    assert_eq!(reused.indices, want);
    assert_eq!(reused, pass_through(&cloud, &pt).unwrap());
    assert_eq!(reused.cloud, cloud.select(&want));
    let mut idx = vec![7; 3];
    pass_through_indices_into(&cloud, &pt, &mut idx).unwrap();
    assert_eq!(idx, want);
    let cb = CropBoxParams {
        min: [-0.05, -0.1, 0.7],
        max: [0.1, 0.05, 0.85],
        invert: false,
    };
    let want: Vec<usize> = (0..pos.len())
        .filter(|&i| (0..3).all(|a| cb.min[a] <= pos[i][a] as f64 && pos[i][a] as f64 <= cb.max[a]))
        .collect();
    assert!(want.len() > 1000 && want.len() < pos.len() / 2);
    crop_box_into(&cloud, &cb, &mut reused).unwrap();
    assert_eq!(reused.indices, want);
    assert_eq!(reused.cloud, cloud.select(&want));
    // Voxels: the parallel averaging cuts the sorted points into chunks; same output as
    // one thread, and as the voxel grid of an explicitly selected sub-cloud.
    for mode in [VoxelMode::Pcl, VoxelMode::Open3d] {
        for leaf in [0.002, 0.01] {
            let p = VoxelGridParams {
                mode,
                ..VoxelGridParams::new(leaf)
            };
            let s = voxel_grid(
                &cloud,
                &VoxelGridParams {
                    parallelism: Parallelism::Serial,
                    ..p
                },
            )
            .unwrap();
            assert!(s.cloud.len() > 1000);
            assert_eq!(s, voxel_grid(&cloud, &p).unwrap());
        }
    }
}

//! segment: Euclidean clusters against a brute-force union-find, region growing on
//! hand-made scenes, the colour model, robot selection and the metrics.

use proptest::prelude::*;
use softsense::search::{KdTree, Parallelism};
use softsense::segment::color::{delta_e, rgb_f64_to_lab, rgb_to_lab};
use softsense::segment::euclidean::{
    euclidean_clusters, euclidean_clusters_with_tree, EuclideanParams,
};
use softsense::segment::metrics::{adjusted_rand_index, object_scores, singletons_for};
use softsense::segment::robot::{select_robot, ChosenBy, RobotRule};
use softsense::segment::robot_color::RobotColorModel;
use softsense::segment::{region_growing_rgb, RegionGrowingParams, SegmentError, UNSEGMENTED};
use softsense::PointCloud;

fn brute_components(p: &[[f32; 3]], tol: f64) -> Vec<Vec<usize>> {
    let n = p.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], x: usize) -> usize {
        if p[x] != x {
            let r = find(p, p[x]);
            p[x] = r;
        }
        p[x]
    }
    let r2 = (tol * tol) as f32;
    for i in 0..n {
        for j in 0..n {
            let d = softsense::search::squared_distance(&p[i], &p[j]);
            if d < r2 {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                parent[a] = b;
            }
        }
    }
    let mut groups = std::collections::BTreeMap::<usize, Vec<usize>>::new();
    for i in 0..n {
        let r = find(&mut parent, i);
        groups.entry(r).or_default().push(i);
    }
    groups.into_values().collect()
}

proptest! {
    #[test]
    fn euclidean_clusters_are_the_connected_components_filtered_by_size(
        pts in prop::collection::vec(prop::array::uniform3(0.0f32..0.1), 1..120),
        tol in 0.002f64..0.03,
        min in 1usize..5,
        max in 3usize..60,
    ) {
        let ours = euclidean_clusters(&pts, &EuclideanParams { tolerance: tol, min_size: min, max_size: max, ..Default::default() }).unwrap();
        let mut expected: Vec<Vec<usize>> = brute_components(&pts, tol)
            .into_iter()
            .filter(|c| c.len() >= min && c.len() <= max)
            .collect();
        // Discovery order = order of smallest index; then stable by size descending.
        expected.sort_by_key(|c| c[0]);
        expected.sort_by_key(|c| std::cmp::Reverse(c.len()));
        prop_assert_eq!(ours, expected);
    }
}

/// Clouds that stress the grid path: clumps, exact duplicates, NaN points and points on
/// a lattice whose spacing is the tolerance itself (pairs exactly at the tolerance,
/// which must not connect, and points on cell boundaries).
fn tricky_cloud() -> impl Strategy<Value = (Vec<[f32; 3]>, f64)> {
    (
        prop::collection::vec(
            (0u8..10, prop::array::uniform3(0.0f32..0.05), 0u32..40),
            0..600,
        ),
        prop::sample::select(vec![0.0025f64, 0.004, 0.005, 0.01]),
    )
        .prop_map(|(spec, tol)| {
            let mut pts: Vec<[f32; 3]> = Vec::new();
            for (kind, p, lattice) in spec {
                let q = match kind {
                    0 => [f32::NAN, p[1], p[2]],
                    1 if !pts.is_empty() => pts[lattice as usize % pts.len()],
                    2 | 3 => {
                        let t = tol as f32;
                        let (a, b) = (lattice % 7, lattice / 7);
                        [a as f32 * t, b as f32 * t, 0.25]
                    }
                    _ => p,
                };
                pts.push(q);
            }
            (pts, tol)
        })
}

proptest! {
    #[test]
    fn grid_clusters_equal_the_breadth_first_search_for_any_thread_count(
        (pts, tol) in tricky_cloud(),
        min in 1usize..4,
        max in 2usize..400,
    ) {
        let params = |parallelism| EuclideanParams {
            tolerance: tol,
            min_size: min,
            max_size: max,
            parallelism,
        };
        let reference =
            euclidean_clusters_with_tree(&pts, &KdTree::build(&pts), &params(Parallelism::Serial))
                .unwrap();
        let serial = euclidean_clusters(&pts, &params(Parallelism::Serial)).unwrap();
        let parallel = euclidean_clusters(&pts, &params(Parallelism::Rayon)).unwrap();
        prop_assert_eq!(&serial, &reference);
        prop_assert_eq!(&parallel, &reference);
    }
}

#[test]
fn euclidean_tolerance_is_strict_and_oversized_clusters_vanish() {
    // Points exactly 0.5 apart (exact in f32) do not connect at tolerance 0.5.
    let pts = vec![
        [0.0f32, 0.0, 0.0],
        [0.5, 0.0, 0.0],
        [0.25, 4.0, 0.0],
        [0.25, 4.25, 0.0],
    ];
    let c = euclidean_clusters(
        &pts,
        &EuclideanParams {
            tolerance: 0.5,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(c, vec![vec![2, 3], vec![0], vec![1]]);
    // A 20-point chain with max 10 is dropped entirely, not split.
    let chain: Vec<[f32; 3]> = (0..20).map(|i| [i as f32 * 0.01, 0.0, 0.0]).collect();
    let c = euclidean_clusters(
        &chain,
        &EuclideanParams {
            tolerance: 0.015,
            min_size: 1,
            max_size: 10,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(c.is_empty());
    assert!(matches!(
        euclidean_clusters(
            &chain,
            &EuclideanParams {
                tolerance: 0.0,
                ..Default::default()
            }
        ),
        Err(SegmentError::InvalidDistance { .. })
    ));
}

fn two_colour_scene() -> PointCloud {
    // Two touching 10x10 patches 1 cm apart, red and blue, plus one NaN point.
    let mut pos = Vec::new();
    let mut col = Vec::new();
    for i in 0..20 {
        for j in 0..10 {
            let jitter = ((i * 31 + j * 17) % 7) as f32 * 1e-5;
            pos.push([i as f32 * 0.01 + jitter, j as f32 * 0.01, 1.0]);
            col.push(if i < 10 { [200, 20, 20] } else { [20, 20, 200] });
        }
    }
    pos.push([f32::NAN; 3]);
    col.push([0, 0, 0]);
    let mut c = PointCloud::from_positions(pos);
    c.colors = Some(col);
    c
}

#[test]
fn region_growing_separates_colours_and_reports_segments() {
    let cloud = two_colour_scene();
    let s = region_growing_rgb(&cloud, &RegionGrowingParams::default()).unwrap();
    assert_eq!(s.segments.len(), 2);
    assert_eq!(s.segments[0].indices, (0..100).collect::<Vec<_>>());
    assert_eq!(s.segments[1].indices, (100..200).collect::<Vec<_>>());
    assert_eq!(s.segments[0].mean_color, [200.0, 20.0, 20.0]);
    assert!(
        (s.segments[1].min[0] - 0.10).abs() < 1e-3 && (s.segments[1].max[1] - 0.09).abs() < 1e-6
    );
    assert_eq!(s.labels[200], UNSEGMENTED);
    // With a point colour threshold above the colour difference, one segment.
    let p = RegionGrowingParams {
        point_color: 300.0,
        ..Default::default()
    };
    assert_eq!(region_growing_rgb(&cloud, &p).unwrap().segments.len(), 1);
}

/// A noisy coloured height field with many small segments: the partition does not
/// depend on the thread count (the neighbour search runs in parallel chunks).
#[test]
fn region_growing_is_the_same_serial_and_parallel() {
    use softsense::search::Parallelism;
    let (w, h) = (120usize, 90usize);
    let mut pos = Vec::new();
    let mut col = Vec::new();
    for j in 0..w * h {
        let (u, v) = ((j % w) as f32, (j / w) as f32);
        let r = (j * 2654435761) % 1000;
        pos.push([u * 0.002, v * 0.002, 1.0 + (r % 5) as f32 * 0.0004]);
        col.push([(r % 7 * 40) as u8, (u as usize % 40 + r % 4) as u8, 50]);
    }
    let mut cloud = PointCloud::from_positions(pos);
    cloud.colors = Some(col);
    for p in [
        RegionGrowingParams::default(),
        RegionGrowingParams::thesis(),
    ] {
        let serial = region_growing_rgb(
            &cloud,
            &RegionGrowingParams {
                parallelism: Parallelism::Serial,
                ..p
            },
        )
        .unwrap();
        let parallel = region_growing_rgb(&cloud, &p).unwrap();
        assert!(
            serial.grown_segments > 10,
            "too few segments to mean anything"
        );
        assert_eq!(serial, parallel);
    }
}

#[test]
fn small_segments_merge_into_the_nearest_unless_switched_off() {
    let mut cloud = two_colour_scene();
    // Three green points inside the red patch: a segment below the minimum size.
    let colors = cloud.colors.as_mut().unwrap();
    for k in [44, 45, 54] {
        colors[k] = [20, 200, 20];
    }
    let merged = region_growing_rgb(&cloud, &RegionGrowingParams::default()).unwrap();
    assert_eq!(merged.segments.len(), 2);
    assert_eq!(merged.segments[0].len(), 100);
    let off = RegionGrowingParams {
        merge_small: false,
        ..Default::default()
    };
    let s = region_growing_rgb(&cloud, &off).unwrap();
    assert_eq!(s.segments.len(), 2);
    assert_eq!(s.segments[0].len(), 97);
    assert_eq!(s.labels[44], UNSEGMENTED);
    let none = RegionGrowingParams {
        merge_small: false,
        min_cluster_size: 1,
        ..Default::default()
    };
    assert_eq!(region_growing_rgb(&cloud, &none).unwrap().segments.len(), 3);
}

#[test]
fn region_growing_needs_colours_and_valid_parameters() {
    let c = PointCloud::from_positions(vec![[0.0, 0.0, 0.0]]);
    assert_eq!(
        region_growing_rgb(&c, &RegionGrowingParams::default()),
        Err(SegmentError::NoColors)
    );
    let p = RegionGrowingParams {
        region_neighbours: 0,
        ..Default::default()
    };
    assert!(region_growing_rgb(&two_colour_scene(), &p).is_err());
}

#[test]
fn lab_of_primaries_matches_published_values() {
    // Published sRGB D65 values (CIE76): red L 53.24 a 80.09 b 67.20.
    let red = rgb_to_lab([255, 0, 0]);
    assert!(
        (red[0] - 53.24).abs() < 0.05
            && (red[1] - 80.09).abs() < 0.1
            && (red[2] - 67.20).abs() < 0.1,
        "{red:?}"
    );
    let black = rgb_to_lab([0, 0, 0]);
    assert_eq!(black, [0.0, 0.0, 0.0]);
    assert!(delta_e(rgb_to_lab([10, 10, 10]), rgb_to_lab([11, 10, 10])) < 1.0);
}

#[test]
fn lab_of_a_byte_colour_equals_lab_of_its_float_to_the_last_bit() {
    // rgb_to_lab reads the gamma expansion from a table: it must be the same numbers.
    for c in 0..=255u8 {
        for rgb in [
            [c, 0, 0],
            [0, c, 0],
            [0, 0, c],
            [c, 255 - c, c / 2],
            [c, c, c],
        ] {
            let f = rgb_f64_to_lab(rgb.map(|v| v as f64 / 255.0));
            assert_eq!(rgb_to_lab(rgb), f, "{rgb:?}");
        }
    }
}

#[test]
fn robot_rule_reports_how_the_robot_was_chosen() {
    let s = region_growing_rgb(&two_colour_scene(), &RegionGrowingParams::default()).unwrap();
    let rule = RobotRule::Color(RobotColorModel::with_reference([0, 0, 255]));
    let c = select_robot(&s.segments, &rule).unwrap();
    assert_eq!(c.segment, 1);
    assert!(
        matches!(c.chosen_by, ChosenBy::Color { hue_difference_deg } if hue_difference_deg < 25.0)
    );
    let c = select_robot(&s.segments, &RobotRule::Largest).unwrap();
    assert_eq!((c.segment, c.chosen_by), (0, ChosenBy::Largest));
    let green = RobotRule::Color(RobotColorModel {
        hue_tolerance_deg: 10.0,
        ..RobotColorModel::with_reference([0, 255, 0])
    });
    assert!(matches!(
        select_robot(&s.segments, &green),
        Err(SegmentError::NoRobot(_))
    ));
}

#[test]
fn adjusted_rand_index_is_one_for_renamed_partitions_and_low_for_unrelated_ones() {
    assert!((adjusted_rand_index(&[1, 1, 2, 2, 3], &[7, 7, 0, 0, 9]) - 1.0).abs() < 1e-12);
    let a: Vec<u32> = (0..1000).map(|i| i % 2).collect();
    let b: Vec<u32> = (0..1000).map(|i| (i / 2) % 2).collect();
    assert!(adjusted_rand_index(&a, &b).abs() < 0.01);
    assert_eq!(
        singletons_for(&[0, UNSEGMENTED, UNSEGMENTED], UNSEGMENTED),
        vec![0, 1, 2]
    );
}

#[test]
fn object_scores_count_matches_at_iou_half() {
    let reference = [Some(1), Some(1), Some(2), Some(2), Some(3), Some(3), None];
    let predicted = [0, 0, 1, 1, 1, 1, 5];
    let s = object_scores(&reference, |r| r >= 2, &predicted, UNSEGMENTED, 0.5);
    // Object 2 has IoU 2/4 = 0.5 with segment 1 (found); object 3 too: both found.
    assert_eq!(
        (s.objects, s.objects_found, s.segments, s.segments_correct),
        (2, 2, 2, 2)
    );
    let s = object_scores(&reference, |r| r >= 2, &predicted, UNSEGMENTED, 0.51);
    assert_eq!((s.objects_found, s.segments_correct), (0, 1));
}

/// The grid k-NN equals brute force (sorted by (d², index)) on a jittered dense sheet
/// with a sparse far cluster (which forces the KD-tree fallback).
#[test]
fn knn_all_equals_brute_force() {
    use softsense::search::knn_all;
    use softsense::search::{squared_distance, Parallelism};
    let mut pts = Vec::new();
    for i in 0..60 {
        for j in 0..40 {
            let s = ((i * 7919 + j * 104729) % 1000) as f32 * 1e-6;
            pts.push([i as f32 * 0.002 + s, j as f32 * 0.002 - s, 1.0 + 3.0 * s]);
        }
    }
    for i in 0..30 {
        pts.push([5.0 + i as f32 * 0.37, -2.0, 3.0 + (i % 3) as f32]);
    }
    let k = 25;
    let t = knn_all(&pts, k, Parallelism::Serial);
    for (i, q) in pts.iter().enumerate() {
        let mut all: Vec<(f32, u32)> = pts
            .iter()
            .enumerate()
            .map(|(j, p)| (squared_distance(q, p), j as u32))
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let want: Vec<u32> = all[..k].iter().map(|x| x.1).collect();
        assert_eq!(&t.idx[i * k..(i + 1) * k], &want[..], "point {i}");
    }
}

/// PCL's `RegionGrowingRGB` written out literally (oracle-semantics section 5): brute-force
/// K lists, whole region neighbour lists gathered, sentinel-marked and re-sorted on every
/// merge, as PCL does. PCL sorts the region lists with an unstable sort, so its order of
/// equal distances is unspecified; ours (and this reference's) is the order of the
/// segments' own lists, segment by segment.
fn region_growing_reference(cloud: &PointCloud, p: &RegionGrowingParams) -> Vec<Vec<usize>> {
    use softsense::search::squared_distance;
    let pts = &cloud.positions;
    let cols = cloud.colors.as_ref().unwrap();
    let n = pts.len();
    let sq = |t: f64| (t as f32) * (t as f32);
    let (p_thr, r_thr, d_thr) = (sq(p.point_color), sq(p.region_color), sq(p.distance_m));
    let cdist = |a: [u32; 3], b: [u32; 3]| -> f32 {
        (0..3)
            .map(|c| (a[c] as i64 - b[c] as i64).pow(2))
            .sum::<i64>() as f32
    };
    let col = |i: usize| cols[i].map(u32::from);
    let k = p.region_neighbours.min(n);
    // Step 1: K nearest by (d², index), self included.
    let knn: Vec<Vec<usize>> = (0..n)
        .map(|i| {
            let mut all: Vec<(f32, usize)> = (0..n)
                .map(|j| (squared_distance(&pts[i], &pts[j]), j))
                .collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            all.into_iter().take(k).map(|x| x.1).collect()
        })
        .collect();
    // Steps 2-3: breadth-first growth from seeds in index order.
    let mut seg = vec![usize::MAX; n];
    let mut segments: Vec<Vec<usize>> = Vec::new();
    for seed in 0..n {
        if seg[seed] != usize::MAX {
            continue;
        }
        let s = segments.len();
        seg[seed] = s;
        let mut queue = vec![seed];
        let mut head = 0;
        while head < queue.len() {
            let cur = queue[head];
            head += 1;
            for &q in knn[cur].iter().take(p.neighbours.min(k)) {
                if seg[q] == usize::MAX && cdist(col(cur), col(q)) <= p_thr {
                    seg[q] = s;
                    queue.push(q);
                }
            }
        }
        queue.sort_unstable();
        segments.push(queue);
    }
    let ns = segments.len();
    // Step 4: each segment's K nearest segments, descending, larger segment first on ties.
    let seg_nb: Vec<Vec<(f32, usize)>> = (0..ns)
        .map(|s| {
            let mut best = vec![f32::MAX; ns];
            for &a in &segments[s] {
                for &b in &knn[a] {
                    if seg[b] != s {
                        let d = squared_distance(&pts[a], &pts[b]);
                        best[seg[b]] = best[seg[b]].min(d);
                    }
                }
            }
            let mut l: Vec<(f32, usize)> = (0..ns)
                .filter(|&t| best[t] != f32::MAX)
                .map(|t| (best[t], t))
                .collect();
            l.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            l.truncate(p.region_neighbours);
            l.reverse();
            l
        })
        .collect();
    // Step 5: truncated mean colours.
    let mean: Vec<[u32; 3]> = segments
        .iter()
        .map(|m| {
            let mut sum = [0u32; 3];
            for &i in m {
                for (acc, v) in sum.iter_mut().zip(col(i)) {
                    *acc += v;
                }
            }
            sum.map(|v| (v as f32 / m.len() as f32) as u32)
        })
        .collect();
    // Step 6: greedy colour merge.
    let mut region = vec![usize::MAX; ns];
    let mut count: Vec<usize> = Vec::new();
    for i in 0..ns {
        if region[i] == usize::MAX {
            region[i] = count.len();
            count.push(segments[i].len());
        }
        for &(d, j) in &seg_nb[i] {
            if d <= d_thr && region[j] == usize::MAX && cdist(mean[i], mean[j]) < r_thr {
                region[j] = region[i];
                count[region[i]] += segments[j].len();
            }
        }
    }
    let nr = count.len();
    if p.merge_small {
        // Step 7: region lists; an entry is (d², order key, segment), the key being its
        // position in the concatenation of the segments' lists.
        let mut key = 0usize;
        let mut lists: Vec<Vec<(f32, usize, usize)>> = vec![Vec::new(); nr];
        for s in 0..ns {
            for &(d, t) in &seg_nb[s] {
                if region[t] != region[s] {
                    lists[region[s]].push((d, key, t));
                }
                key += 1;
            }
        }
        let sort = |l: &mut Vec<(f32, usize, usize)>| {
            l.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        };
        lists.iter_mut().for_each(sort);
        // Step 8: small regions join the owner of their nearest entry.
        for r in 0..nr {
            if count[r] >= p.min_cluster_size {
                continue;
            }
            let Some(&(d, _, t)) = lists[r].first() else {
                continue;
            };
            if d == f32::MAX {
                continue;
            }
            let target = region[t];
            for owner in region.iter_mut().filter(|o| **o == r) {
                *owner = target;
            }
            count[target] += count[r];
            count[r] = 0;
            for e in lists[target].iter_mut() {
                if region[e.2] == target {
                    *e = (f32::MAX, usize::MAX, 0);
                }
            }
            let moved: Vec<_> = std::mem::take(&mut lists[r])
                .into_iter()
                .filter(|e| region[e.2] != target)
                .collect();
            lists[target].extend(moved);
            sort(&mut lists[target]);
        }
    }
    // Steps 9-10: assembly, PCL's empty-slot swaps, size filter.
    let mut clusters: Vec<Vec<usize>> = vec![Vec::new(); nr];
    for i in 0..n {
        clusters[region[seg[i]]].push(i);
    }
    // The first empty slot takes the last non-empty cluster, until none is left behind
    // an empty one; then the trailing empties go.
    loop {
        let first_empty = clusters.iter().position(|c| c.is_empty());
        let last_full = clusters.iter().rposition(|c| !c.is_empty());
        match (first_empty, last_full) {
            (Some(e), Some(f)) if e < f => clusters.swap(e, f),
            _ => break,
        }
    }
    clusters.retain(|c| !c.is_empty());
    clusters.retain(|c| c.len() >= p.min_cluster_size && c.len() <= p.max_cluster_size);
    clusters
}

/// Points on a coarse integer grid (many exactly equal distances, some duplicates) in a
/// few colours with small noise, and parameters that make many small segments merge.
fn tie_heavy_scene() -> impl Strategy<Value = (PointCloud, RegionGrowingParams)> {
    (
        prop::collection::vec(((0u8..6, 0u8..6, 0u8..3), (0u8..3, 0u8..4)), 1..120),
        (
            2usize..10,
            1usize..8,
            1usize..12,
            0.0f64..30.0,
            any::<bool>(),
        ),
    )
        .prop_map(|(raw, (k, n, min, region_color, merge))| {
            let palette = [[200u8, 30, 30], [30, 200, 30], [30, 30, 200]];
            let pos = raw
                .iter()
                .map(|&((x, y, z), _)| [x as f32 * 0.01, y as f32 * 0.01, 1.0 + z as f32 * 0.01])
                .collect();
            let mut cloud = PointCloud::from_positions(pos);
            cloud.colors = Some(
                raw.iter()
                    .map(|&(_, (c, noise))| palette[c as usize].map(|v| v + 3 * noise))
                    .collect(),
            );
            let params = RegionGrowingParams {
                distance_m: 0.015,
                point_color: 8.0,
                region_color,
                min_cluster_size: min,
                neighbours: n,
                region_neighbours: k,
                merge_small: merge,
                ..Default::default()
            };
            (cloud, params)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn region_growing_equals_pcls_literal_algorithm_with_ties_and_duplicates(
        (cloud, params) in tie_heavy_scene()
    ) {
        let ours = region_growing_rgb(&cloud, &params).unwrap();
        prop_assert_eq!(ours.clusters(), region_growing_reference(&cloud, &params));
        let serial = RegionGrowingParams { parallelism: Parallelism::Serial, ..params };
        prop_assert_eq!(region_growing_rgb(&cloud, &serial).unwrap(), ours);
    }
}

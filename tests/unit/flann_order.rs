//! The FLANN-order tree (`search::FlannTree`): exact k-NN against brute force, and
//! FLANN's choice among points tied at the k-th distance on hand-made cases.

use proptest::prelude::*;
use softsense::search::{squared_distance, FlannTree, Parallelism};

fn finite(p: &[f32; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

proptest! {
    #[test]
    fn flann_order_knn_distances_are_the_brute_force_k_smallest(
        points in crate::search::lattice_cloud(400),
        k in 1usize..30,
        qi in 0usize..400,
        free in (-1.2f32..1.6, -1.2f32..1.6, -1.2f32..1.6),
        from_cloud in any::<bool>(),
    ) {
        let tree = FlannTree::build(&points);
        let n_finite = points.iter().filter(|p| finite(p)).count();
        prop_assert_eq!(tree.len(), n_finite);
        let q = match points.get(qi % points.len().max(1)) {
            Some(p) if from_cloud && finite(p) => *p,
            _ => [free.0, free.1, free.2],
        };
        let got = tree.nearest_k(&q, k);
        let mut want: Vec<f32> = points
            .iter()
            .filter(|p| finite(p))
            .map(|p| squared_distance(&q, p))
            .collect();
        want.sort_by(f32::total_cmp);
        want.truncate(k);
        // Sorted by distance, the k smallest distances as a multiset.
        let dists: Vec<f32> = got.iter().map(|n| n.squared_distance).collect();
        prop_assert_eq!(&dists, &want);
        // Each result is a distinct finite point at the distance it reports.
        let mut idx: Vec<usize> = got.iter().map(|n| n.index).collect();
        for n in &got {
            prop_assert!(finite(&points[n.index]));
            prop_assert_eq!(n.squared_distance, squared_distance(&q, &points[n.index]));
        }
        idx.sort_unstable();
        idx.dedup();
        prop_assert_eq!(idx.len(), got.len());
    }
}

/// 16 points on the x axis (y = z = 0): the root splits, two leaves of 8.
fn line(xs: &[f32]) -> Vec<[f32; 3]> {
    xs.iter().map(|&x| [x, 0.0, 0.0]).collect()
}

fn knn_indices(tree: &FlannTree, q: &[f32; 3], k: usize) -> Vec<usize> {
    tree.nearest_k(q, k).iter().map(|n| n.index).collect()
}

#[test]
fn a_tie_goes_to_the_child_searched_first() {
    // Index 1 (x = 11) has two neighbours at squared distance 1: index 0 (x = 10) and
    // index 2 (x = 12). FLANN's build: 16 > 15 points, so the root splits; only x has a
    // span, so it is the split dimension, cut = (0 + 21) / 2 = 10.5. planeSplit puts the
    // 8 points below 10.5 first (lim1 = lim2 = 8 = count / 2, so the split index is 8):
    // index 0 goes to the first child, indices 1 and 2 to the second. The stored bounds
    // are the first child's max (10) and the second's min (11). The query x = 11 gives
    // (11 − 10) + (11 − 11) = 1 ≥ 0, so the second child is searched first and fills
    // k = 2 with {1 (d 0), 2 (d 1)}; the first child is still visited (its lower bound
    // (11 − 10)² = 1 ≤ 1), but index 0 at distance 1 is not strictly closer than the
    // k-th: rejected. So FLANN (and PCL) answer [1, 2], where "smaller index wins"
    // would answer [1, 0].
    let mut xs = vec![10.0, 11.0, 12.0];
    xs.extend((0..7).map(|x| x as f32));
    xs.extend((16..22).map(|x| x as f32));
    let pts = line(&xs);
    let tree = FlannTree::build(&pts);
    assert_eq!(knn_indices(&tree, &pts[1], 2), vec![1, 2]);
    // With k = 3 the tie is not at the boundary: all three, sorted by distance, the two
    // at distance 1 in the order found (2 in the first searched leaf).
    assert_eq!(knn_indices(&tree, &pts[1], 3), vec![1, 2, 0]);
}

#[test]
fn a_tie_inside_a_leaf_goes_to_the_point_first_in_the_partitioned_order() {
    // Indices 0..8 hold the large x (20, 21, 22, 30..34), indices 8..16 the small x
    // (0..7). Root: split on x at (0 + 34) / 2 = 17, split index 8. planeSplit's first
    // pass walks from both ends and swaps every out-of-place pair: (0, 15), (1, 14), …,
    // (7, 8), so the second leaf holds indices 7, 6, …, 0 in that order: reversed. The
    // query index 1 (x = 21) has index 0 (x = 20) and index 2 (x = 22) at squared
    // distance 1; its search goes to the second leaf first ((21 − 7) + (21 − 20) > 0),
    // meets index 2 before index 1 and index 0, and keeps {1, 2}; index 0 arrives when
    // the k-th distance is already 1 and is rejected. The first leaf is pruned
    // ((21 − 7)² = 196 > 1).
    let mut xs = vec![20.0, 21.0, 22.0, 30.0, 31.0, 32.0, 33.0, 34.0];
    xs.extend((0..8).map(|x| x as f32));
    let pts = line(&xs);
    let tree = FlannTree::build(&pts);
    assert_eq!(knn_indices(&tree, &pts[1], 2), vec![1, 2]);
}

#[test]
fn nan_points_are_skipped_and_indices_refer_to_the_input() {
    // FLANN's dataset holds only the finite points; PCL maps its indices back.
    let mut pts = vec![[f32::NAN, 0.0, 0.0]; 3];
    pts.extend(line(&[0.0, 1.0, 2.0]));
    let tree = FlannTree::build(&pts);
    assert_eq!(tree.len(), 3);
    assert_eq!(knn_indices(&tree, &[0.9, 0.0, 0.0], 2), vec![4, 3]);
    // k above the number of points is capped, as PCL does.
    assert_eq!(tree.nearest_k(&[0.0; 3], 10).len(), 3);
    assert!(FlannTree::build(&[]).nearest_k(&[0.0; 3], 3).is_empty());
}

#[test]
fn serial_and_parallel_builds_answer_the_same() {
    // An organised-grid-like cloud, large enough for the parallel build to split work.
    let pts: Vec<[f32; 3]> = (0..40_000)
        .map(|i| {
            let (u, v) = ((i % 200) as f32, (i / 200) as f32);
            [
                u * 0.002,
                v * 0.002,
                1.0 + 0.001 * ((u * 0.3).sin() + (v * 0.2).cos()),
            ]
        })
        .collect();
    let a = FlannTree::build_with(&pts, Parallelism::Serial);
    let b = FlannTree::build_with(&pts, Parallelism::Rayon);
    for i in (0..pts.len()).step_by(97) {
        assert_eq!(
            a.nearest_k(&pts[i], 10),
            b.nearest_k(&pts[i], 10),
            "point {i}"
        );
    }
}

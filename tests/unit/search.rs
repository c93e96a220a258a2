//! KD-tree searches against brute force.

use proptest::prelude::*;
use softsense::search::{
    knn_all, map_knn, squared_distance, squared_distance_f64, KdTree, Parallelism, RadiusQuery,
};

/// Random clouds on a coarse lattice (many exact duplicates and exact boundary
/// distances), with some NaN points.
fn cloud_strategy() -> impl Strategy<Value = Vec<[f32; 3]>> {
    lattice_cloud(200)
}

/// [`cloud_strategy`] with up to `max_points` points.
pub(crate) fn lattice_cloud(max_points: usize) -> impl Strategy<Value = Vec<[f32; 3]>> {
    prop::collection::vec(
        prop_oneof![
            8 => (0i32..6, 0i32..6, 0i32..6).prop_map(|(x, y, z)| [x as f32 * 0.25, y as f32 * 0.25, z as f32 * 0.25]),
            4 => (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0).prop_map(|(x, y, z)| [x, y, z]),
            1 => Just([f32::NAN, 0.0, 0.0]),
        ],
        0..max_points,
    )
}

fn brute_radius(points: &[[f32; 3]], q: &[f32; 3], r: f64, inclusive: bool) -> Vec<(usize, f32)> {
    let r2 = (r * r) as f32;
    let mut v: Vec<(usize, f32)> = points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
        .map(|(i, p)| (i, squared_distance(q, p)))
        .filter(|&(_, d)| if inclusive { d <= r2 } else { d < r2 })
        .collect();
    v.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap().then(a.0.cmp(&b.0)));
    v
}

proptest! {
    #[test]
    fn radius_search_matches_brute_force_at_exact_boundaries(
        points in cloud_strategy(),
        qi in 0usize..200,
        r in prop_oneof![Just(0.25f64), Just(0.5), Just(0.3535533905932738), 0.01f64..1.5],
        inclusive in any::<bool>(),
    ) {
        let tree = KdTree::build(&points);
        let q = if points.is_empty() { [0.0; 3] } else { points[qi % points.len()] };
        let want = brute_radius(&points, &q, r, inclusive);
        let got = tree.within_radius(&q, r, RadiusQuery { sorted: true, max_results: None, inclusive });
        let got: Vec<(usize, f32)> = got.iter().map(|n| (n.index, n.squared_distance)).collect();
        if q.iter().all(|c| c.is_finite()) {
            prop_assert_eq!(&got, &want);
        } else {
            prop_assert!(got.is_empty());
        }
        // Unsorted: same set, index order.
        let mut unsorted: Vec<usize> = tree
            .within_radius(&q, r, RadiusQuery { inclusive, ..RadiusQuery::unsorted() })
            .iter().map(|n| n.index).collect();
        let mut want_set: Vec<usize> = got.iter().map(|x| x.0).collect();
        want_set.sort_unstable();
        prop_assert!(unsorted.windows(2).all(|w| w[0] < w[1]));
        unsorted.sort_unstable();
        prop_assert_eq!(unsorted, want_set);
        // Count agrees.
        prop_assert_eq!(tree.count_within_radius(&q, r, inclusive, usize::MAX), got.len());
        for stop in 1..12 {
            prop_assert_eq!(tree.count_within_radius(&q, r, inclusive, stop), got.len().min(stop));
            let n64 = points.iter().filter(|p| p.iter().all(|c| c.is_finite()) && squared_distance_f64(&q, p) < r * r).count();
            let n64 = if q.iter().all(|c| c.is_finite()) { n64 } else { 0 };
            prop_assert_eq!(tree.count_within_radius_f64(&q, r, stop), n64.min(stop));
        }
    }

    #[test]
    fn capped_radius_search_returns_the_closest(points in cloud_strategy(), qi in 0usize..200, cap in 1usize..10) {
        let tree = KdTree::build(&points);
        let q = if points.is_empty() { [0.0; 3] } else { points[qi % points.len()] };
        let want = brute_radius(&points, &q, 0.6, false);
        let got = tree.within_radius(&q, 0.6, RadiusQuery { sorted: true, max_results: Some(cap), inclusive: false });
        let got: Vec<(usize, f32)> = got.iter().map(|n| (n.index, n.squared_distance)).collect();
        if q.iter().all(|c| c.is_finite()) {
            prop_assert_eq!(got, want.into_iter().take(cap).collect::<Vec<_>>());
        }
    }

    #[test]
    fn f64_radius_search_matches_brute_force(points in cloud_strategy(), qi in 0usize..200, r in 0.01f64..1.5) {
        let tree = KdTree::build(&points);
        let q = if points.is_empty() { [0.0; 3] } else { points[qi % points.len()] };
        prop_assume!(q.iter().all(|c| c.is_finite()));
        let mut want: Vec<usize> = points.iter().enumerate()
            .filter(|(_, p)| p.iter().all(|c| c.is_finite()) && squared_distance_f64(&q, p) < r * r)
            .map(|(i, _)| i).collect();
        want.sort_unstable();
        let got: Vec<usize> = tree.within_radius_f64(&q, r, RadiusQuery::unsorted()).iter().map(|n| n.index).collect();
        prop_assert_eq!(got, want);
    }

    #[test]
    fn knn_distances_match_brute_force(points in cloud_strategy(), k in 1usize..20, q in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)) {
        let q = [q.0, q.1, q.2];
        let tree = KdTree::build(&points);
        let mut all: Vec<f32> = points.iter().filter(|p| p.iter().all(|c| c.is_finite()))
            .map(|p| squared_distance(&q, p)).collect();
        all.sort_by(|a, b| a.partial_cmp(b).unwrap());
        all.truncate(k);
        let got = tree.nearest_n(&q, k);
        let d: Vec<f32> = got.iter().map(|n| n.squared_distance).collect();
        // Tied points may be exchanged, so compare the distance multiset and check
        // each index really is at its reported distance.
        prop_assert_eq!(d, all);
        for n in &got {
            prop_assert_eq!(squared_distance(&q, &points[n.index]), n.squared_distance);
        }
    }
}

#[test]
fn the_query_point_is_its_own_neighbour_and_nan_points_are_not_in_the_tree() {
    let pts = vec![[1.0f32, 2.0, 3.0], [f32::NAN, 0.0, 0.0], [1.0, 2.0, 3.5]];
    let tree = KdTree::build(&pts);
    assert_eq!(tree.len(), 2);
    assert_eq!(tree.source_len(), 3);
    let knn = tree.nearest_n(&pts[0], 3);
    assert_eq!(knn.iter().map(|n| n.index).collect::<Vec<_>>(), vec![0, 2]);
    assert_eq!(knn[0].squared_distance, 0.0);
    assert!(tree.nearest_n(&pts[1], 2).is_empty());
    assert!(tree
        .within_radius(&pts[1], 10.0, RadiusQuery::sorted())
        .is_empty());
}

#[test]
fn empty_tree_answers_nothing() {
    let tree = KdTree::build(&[]);
    assert!(tree.is_empty());
    assert!(tree.nearest_n(&[0.0; 3], 3).is_empty());
    assert!(tree
        .within_radius(&[0.0; 3], 1.0, RadiusQuery::sorted())
        .is_empty());
    assert_eq!(tree.count_within_radius(&[0.0; 3], 1.0, true, 5), 0);
}

#[test]
fn radius_boundary_is_strict_by_default_and_inclusive_on_request() {
    let pts = vec![[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let tree = KdTree::build(&pts);
    assert_eq!(
        tree.within_radius(&pts[0], 1.0, RadiusQuery::sorted())
            .len(),
        1
    );
    let q = RadiusQuery {
        inclusive: true,
        ..RadiusQuery::sorted()
    };
    assert_eq!(tree.within_radius(&pts[0], 1.0, q).len(), 2);
    assert!(tree
        .within_radius(&pts[0], 0.0, RadiusQuery::sorted())
        .is_empty());
}

/// The k nearest finite points of point `i` by `(squared distance, index)`, brute force.
fn brute_knn(points: &[[f32; 3]], i: usize, k: usize) -> Vec<(usize, f32)> {
    if !points[i].iter().all(|c| c.is_finite()) {
        return Vec::new();
    }
    let mut v = brute_radius(points, &points[i], f64::INFINITY, true);
    v.truncate(k);
    v
}

/// A sensor-like surface: a quantised height field on a regular pixel lattice, so that
/// many neighbours tie at the k-th distance, plus a few far outliers and NaN pixels.
fn surface_strategy() -> impl Strategy<Value = Vec<[f32; 3]>> {
    (
        5usize..40,
        5usize..40,
        prop::collection::vec(0u8..4, 1600),
        0.0005f32..0.003,
    )
        .prop_map(|(w, h, z, s)| {
            let mut pts: Vec<[f32; 3]> = (0..w * h)
                .map(|j| {
                    let (u, v) = ((j % w) as f32, (j / w) as f32);
                    match z[j % z.len()] {
                        0 if j % 7 == 0 => [f32::NAN; 3],
                        q => [u * s, v * s, 1.0 + q as f32 * s],
                    }
                })
                .collect();
            pts.push([5.0, 5.0, 5.0]);
            pts.push([-3.0, 0.0, 1.0]);
            pts
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn all_knn_lists_match_brute_force_with_ties_to_the_smaller_index(
        points in prop_oneof![cloud_strategy(), surface_strategy()],
        k in 1usize..25,
    ) {
        let lists = map_knn(&points, k, Parallelism::Serial, |_, nb| {
            nb.iter().map(|n| (n.index, n.squared_distance)).collect::<Vec<_>>()
        });
        for (i, got) in lists.iter().enumerate() {
            prop_assert_eq!(got, &brute_knn(&points, i, k), "point {}", i);
        }
        let par = map_knn(&points, k, Parallelism::Rayon, |_, nb| {
            nb.iter().map(|n| (n.index, n.squared_distance)).collect::<Vec<_>>()
        });
        prop_assert_eq!(lists, par);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    /// The table form (the region growing's K = 100 and beyond) on clouds full of exact
    /// duplicates and distance ties: every finite row is the brute-force selection, the
    /// same with any thread count.
    #[test]
    fn knn_tables_match_brute_force_for_large_k_with_duplicates_and_ties(
        points in prop_oneof![cloud_strategy(), surface_strategy()],
        k in 1usize..130,
    ) {
        let t = knn_all(&points, k, Parallelism::Serial);
        let finite = points.iter().filter(|p| p.iter().all(|c| c.is_finite())).count();
        prop_assert_eq!(t.k, k.min(finite));
        for i in 0..points.len() {
            let want = brute_knn(&points, i, t.k);
            if want.is_empty() {
                continue; // a NaN point: its row is padding
            }
            let got: Vec<(usize, f32)> = (0..t.k)
                .map(|j| (t.idx[i * t.k + j] as usize, t.d2[i * t.k + j]))
                .collect();
            prop_assert_eq!(got, want, "point {}", i);
        }
        let par = knn_all(&points, k, Parallelism::Rayon);
        prop_assert_eq!(t.idx, par.idx);
    }
}

/// A cloud large enough for the grid to choose its cell size on a subsample (over
/// 65 536 points): a dense wavy sheet, a sparse far cluster and NaN; every sampled
/// point's k nearest are the brute-force ones, and two threads agree with one.
#[test]
fn knn_on_a_large_cloud_sized_from_a_subsample_equals_brute_force() {
    let mut s = 99u64;
    let mut rnd = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut pts: Vec<[f32; 3]> = Vec::new();
    for v in 0..300 {
        for u in 0..280 {
            let (x, y) = (u as f32 * 0.002, v as f32 * 0.002);
            pts.push([x, y, 1.0 + 0.01 * (x * 40.0).sin() + 0.0005 * rnd()]);
        }
    }
    for _ in 0..2000 {
        pts.push([3.0 + rnd(), 3.0 + rnd(), 5.0 + rnd()]);
    }
    pts.push([f32::NAN; 3]);
    for k in [1, 11, 30] {
        let lists = map_knn(&pts, k, Parallelism::Serial, |_, nb| {
            nb.iter()
                .map(|n| (n.index, n.squared_distance))
                .collect::<Vec<_>>()
        });
        for i in (0..pts.len()).step_by(397) {
            assert_eq!(lists[i], brute_knn(&pts, i, k), "k {k}, point {i}");
        }
        let par = map_knn(&pts, k, Parallelism::Rayon, |_, nb| {
            nb.iter()
                .map(|n| (n.index, n.squared_distance))
                .collect::<Vec<_>>()
        });
        assert_eq!(lists, par, "k {k}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// The k-NN kernel's portable code (what CPUs without AVX2 run) and its AVX2 code
    /// give the same, brute-force, lists (ties, duplicates and NaN included).
    #[test]
    fn portable_and_avx2_knn_kernels_give_the_same_lists(
        points in prop_oneof![cloud_strategy(), surface_strategy()],
        k in 1usize..40,
    ) {
        let run = |portable| {
            softsense::search::use_portable_kernels(portable);
            let lists = map_knn(&points, k, Parallelism::Serial, |_, nb| {
                nb.iter().map(|n| (n.index, n.squared_distance)).collect::<Vec<_>>()
            });
            softsense::search::use_portable_kernels(false);
            lists
        };
        let portable = run(true);
        for (i, got) in portable.iter().enumerate() {
            prop_assert_eq!(got, &brute_knn(&points, i, k), "point {}", i);
        }
        prop_assert_eq!(portable, run(false));
    }
}

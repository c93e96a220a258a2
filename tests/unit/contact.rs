//! contact: Alg. 4.1 on hand-made scenes against a brute-force count, and the mOSD
//! stacked-box evaluation (each labelled object in turn as the robot) against contacts
//! derived from the labels.

use crate::common;
use proptest::prelude::*;
use softsense::contact::{contact_points, detect_contacts, summarize, ContactParams};
use softsense::search::{squared_distance, KdTree};
use softsense::segment::euclidean::{euclidean_clusters, EuclideanParams};

fn plate(n: usize, step: f32, z: f32, x0: f32) -> Vec<[f32; 3]> {
    (0..n)
        .flat_map(|i| (0..n).map(move |j| [x0 + i as f32 * step, j as f32 * step, z]))
        .collect()
}

proptest! {
    #[test]
    fn contact_points_are_those_with_more_than_n_robot_points_strictly_within_r(
        robot in prop::collection::vec(prop::array::uniform3(0.0f32..0.02), 1..80),
        object in prop::collection::vec(prop::array::uniform3(0.0f32..0.02), 1..80),
        r in 0.001f64..0.01,
        n in 0usize..5,
    ) {
        let params = ContactParams { radius_m: r, min_neighbors: n, ..Default::default() };
        let ours = contact_points(&KdTree::build(&robot), &object, &params);
        let r2 = (r * r) as f32;
        let brute: Vec<usize> = (0..object.len())
            .filter(|&i| robot.iter().filter(|q| squared_distance(&object[i], q) < r2).count() > n)
            .collect();
        prop_assert_eq!(&ours, &brute);
        // The screened path inside detect_contacts finds the same points (as one group
        // when min_group is 1 and the tolerance spans the box).
        let all = ContactParams { tolerance_m: 1.0, min_group: 1, max_group: usize::MAX, ..params };
        let groups = detect_contacts(&robot, &object, &all).unwrap();
        let mut screened: Vec<usize> = groups.iter().flat_map(|g| g.indices.clone()).collect();
        screened.sort_unstable();
        prop_assert_eq!(screened, brute);
    }
}

#[test]
fn two_touching_plates_give_one_contact_and_distant_plates_none() {
    let robot = plate(20, 0.001, 0.0, 0.0);
    let near = plate(20, 0.001, 0.002, 0.0);
    let c = detect_contacts(&robot, &near, &ContactParams::default()).unwrap();
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].points, 400);
    assert!((c[0].centroid[0] - 0.0095).abs() < 1e-6 && (c[0].centroid[2] - 0.002).abs() < 1e-7);
    assert!((c[0].extent() - 0.019).abs() < 1e-6);
    let far = plate(20, 0.001, 0.0045, 0.0);
    assert!(detect_contacts(&robot, &far, &ContactParams::default())
        .unwrap()
        .is_empty());
    // Two separate touching patches give two contacts, larger first.
    let mut two = plate(10, 0.001, 0.002, 0.0);
    two.extend(plate(5, 0.001, 0.002, 0.015));
    let c = detect_contacts(&robot, &two, &ContactParams::default()).unwrap();
    assert_eq!(
        c.iter().map(|c| c.points).collect::<Vec<_>>(),
        vec![100, 25]
    );
    let bad = ContactParams {
        radius_m: -1.0,
        ..Default::default()
    };
    assert!(detect_contacts(&robot, &two, &bad).is_err());
}

/// Contacts derived from labels: for each other label, its points with at least
/// `min_hits` robot points within `r`, grouped by Euclidean clustering (5 mm, ≥ 10
/// points); one centroid per group. The definition is `min_hits` = 1.
fn label_contacts(
    robot: &[[f32; 3]],
    others: &[([f32; 3], u32)],
    r: f64,
    min_hits: usize,
) -> Vec<([f32; 3], Vec<[f32; 3]>)> {
    let tree = KdTree::build(robot);
    let mut by_label = std::collections::BTreeMap::<u32, Vec<[f32; 3]>>::new();
    for (p, l) in others {
        if tree.count_within_radius(p, r, false, min_hits) >= min_hits {
            by_label.entry(*l).or_default().push(*p);
        }
    }
    let mut out = Vec::new();
    for pts in by_label.values() {
        let groups = euclidean_clusters(
            pts,
            &EuclideanParams {
                tolerance: 0.005,
                min_size: 10,
                max_size: usize::MAX,
                ..Default::default()
            },
        )
        .unwrap();
        for g in groups {
            let members: Vec<[f32; 3]> = g.iter().map(|&i| pts[i]).collect();
            out.push((summarize(pts, g).centroid, members));
        }
    }
    out
}

fn within(a: &[f32; 3], b: &[f32; 3], d: f32) -> bool {
    squared_distance(a, b) <= d * d
}

/// Centroid matching within 1 cm: (detected centroids near a label-contact centroid,
/// label-contact centroids near a detected centroid).
fn centroid_matches(detected: &[[f32; 3]], truth: &[([f32; 3], Vec<[f32; 3]>)]) -> (usize, usize) {
    (
        detected
            .iter()
            .filter(|d| truth.iter().any(|t| within(d, &t.0, 0.01)))
            .count(),
        truth
            .iter()
            .filter(|t| detected.iter().any(|d| within(d, &t.0, 0.01)))
            .count(),
    )
}

#[test]
fn contacts_on_mosd_stacked_boxes_agree_with_label_contacts() {
    let Some(dir) = common::data_dir("contacts on mOSD stacked boxes") else {
        return;
    };
    let params = ContactParams::default();
    println!("centroid: a detected centroid within 1 cm of a label-contact centroid (and back);");
    println!("region: a detected centroid within 1 cm of any label-contact point; a label contact");
    println!("recalled when any detected contact point is within 1 cm of one of its points.");
    println!(
        "scene    robots  label-contacts  detected  centroid-P  centroid-R  region-P  region-R"
    );
    let (mut det_all, mut det_ok, mut gt_all, mut gt_ok) = (0, 0, 0, 0);
    let (mut l_det_ok, mut l_gt_ok) = (0, 0);
    let (mut s_n, mut s_d_ok, mut s_g_ok) = (0, 0, 0);
    for scene in ["learn17", "learn19", "learn21", "learn23"] {
        let cloud = softsense::io::read_cloud(dir.join(format!("mosd/{scene}.pcd"))).expect("read");
        let labels = cloud.labels.clone().expect("mOSD has labels");
        let pts: Vec<([f32; 3], u32)> = cloud
            .positions
            .iter()
            .zip(&labels)
            .filter(|&(p, &l)| l != 0 && p.iter().all(|c| c.is_finite()))
            .map(|(p, &l)| (*p, l))
            .collect();
        let mut objects: Vec<u32> = pts.iter().map(|x| x.1).filter(|&l| l >= 20).collect();
        objects.sort_unstable();
        objects.dedup();
        let (mut d_n, mut d_ok, mut g_n, mut g_ok) = (0, 0, 0, 0);
        let (mut l_d_ok, mut l_g_ok) = (0, 0);
        for &l in &objects {
            let robot: Vec<[f32; 3]> = pts.iter().filter(|x| x.1 == l).map(|x| x.0).collect();
            let others: Vec<([f32; 3], u32)> = pts.iter().filter(|x| x.1 != l).copied().collect();
            let object: Vec<[f32; 3]> = others.iter().map(|x| x.0).collect();
            let contacts = detect_contacts(&robot, &object, &params).unwrap();
            let detected: Vec<[f32; 3]> = contacts.iter().map(|c| c.centroid).collect();
            let truth = label_contacts(&robot, &others, params.radius_m, 1);
            d_n += detected.len();
            g_n += truth.len();
            let (a, b) = centroid_matches(&detected, &truth);
            d_ok += a;
            g_ok += b;
            // The same comparison against label contacts under the detector's own rule
            // (more than n_neigh robot points), to separate the neighbour rule's effect.
            let same_rule =
                label_contacts(&robot, &others, params.radius_m, params.min_neighbors + 1);
            let (a, b) = centroid_matches(&detected, &same_rule);
            s_n += same_rule.len();
            s_d_ok += a;
            s_g_ok += b;
            // Region view: a detected centroid within 1 cm of any label-contact point; a
            // label contact touched by any detected contact point within 1 cm.
            l_d_ok += detected
                .iter()
                .filter(|d| truth.iter().any(|t| t.1.iter().any(|q| within(d, q, 0.01))))
                .count();
            l_g_ok += truth
                .iter()
                .filter(|t| {
                    contacts.iter().any(|c| {
                        c.indices
                            .iter()
                            .any(|&i| t.1.iter().any(|q| within(&object[i], q, 0.01)))
                    })
                })
                .count();
        }
        let ratio = |a: usize, b: usize| if b == 0 { 1.0 } else { a as f64 / b as f64 };
        println!(
            "{scene:8} {:6}  {g_n:14}  {d_n:8}  {:10.3}  {:10.3}  {:8.3}  {:8.3}",
            objects.len(),
            ratio(d_ok, d_n),
            ratio(g_ok, g_n),
            ratio(l_d_ok, d_n),
            ratio(l_g_ok, g_n)
        );
        l_det_ok += l_d_ok;
        l_gt_ok += l_g_ok;
        det_all += d_n;
        det_ok += d_ok;
        gt_all += g_n;
        gt_ok += g_ok;
    }
    let precision = det_ok as f64 / det_all.max(1) as f64;
    let recall = gt_ok as f64 / gt_all.max(1) as f64;
    println!(
        "overall: {gt_all} label contacts, {det_all} detected; centroid precision {precision:.3}, recall {recall:.3}; region precision {:.3}, recall {:.3}",
        l_det_ok as f64 / det_all.max(1) as f64,
        l_gt_ok as f64 / gt_all.max(1) as f64
    );
    println!(
        "against label contacts under the detector's rule (> {} robot points within r): {s_n} label contacts; centroid precision {:.3}, recall {:.3}",
        params.min_neighbors,
        s_d_ok as f64 / det_all.max(1) as f64,
        s_g_ok as f64 / s_n.max(1) as f64
    );
    assert!(
        gt_all > 0 && det_all > 0,
        "no contacts at all: vacuous evaluation"
    );
}

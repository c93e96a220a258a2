//! segment::geometric on synthetic tabletop scenes seen from the origin (camera looking
//! along +z, table at z = 1 m): boxes on the table, a box stacked on another, faces of
//! different colours, missing support, bad parameters.

use softsense::search::Parallelism;
use softsense::segment::geometric::{segment_geometric, GeometricParams};
use softsense::segment::{
    region_growing_rgb, segment, RegionGrowingParams, SegmentError, SegmentMode, UNSEGMENTED,
};
use softsense::PointCloud;

const S: f32 = 0.005;

/// An axis-aligned box standing at depth `base` (its bottom face), `h` tall towards the
/// camera, with the faces the origin sees. Returns (points, face id per point).
struct Scene {
    pts: Vec<[f32; 3]>,
    colors: Vec<[u8; 3]>,
    truth: Vec<u32>,
    noise: u64,
}

impl Scene {
    fn new() -> Scene {
        Scene {
            pts: Vec::new(),
            colors: Vec::new(),
            truth: Vec::new(),
            noise: 12345,
        }
    }

    /// Deterministic depth noise, uniform in ±0.5 mm.
    fn jitter(&mut self) -> f32 {
        self.noise ^= self.noise << 13;
        self.noise ^= self.noise >> 7;
        self.noise ^= self.noise << 17;
        ((self.noise % 1001) as f32 / 1000.0 - 0.5) * 0.001
    }

    fn push(&mut self, p: [f32; 3], c: [u8; 3], label: u32) {
        let j = self.jitter();
        self.pts.push([p[0], p[1], p[2] + j]);
        self.colors.push(c);
        self.truth.push(label);
    }

    /// The table at z = 1 from -0.2 to 0.2 in x and y, minus the footprints in `holes`.
    fn table(&mut self, holes: &[([f32; 2], [f32; 2])]) {
        let n = (0.4 / S) as i32;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (-0.2 + i as f32 * S, -0.2 + j as f32 * S);
                if holes
                    .iter()
                    .any(|(lo, hi)| x >= lo[0] && x <= hi[0] && y >= lo[1] && y <= hi[1])
                {
                    continue;
                }
                self.push([x, y, 1.0], [120, 90, 60], 0);
            }
        }
    }

    /// A box over `[lo, hi]` in x, y from depth `base` up to `base - h`, faces coloured
    /// `top`, `side_x`, `side_y`; only faces turned to the origin are sampled.
    #[allow(clippy::too_many_arguments)]
    fn cuboid(
        &mut self,
        lo: [f32; 2],
        hi: [f32; 2],
        base: f32,
        h: f32,
        top: [u8; 3],
        side_x: [u8; 3],
        side_y: [u8; 3],
        label: u32,
    ) {
        let cells = |a: f32, b: f32| ((b - a) / S).round() as i32;
        let (nx, ny, nz) = (cells(lo[0], hi[0]), cells(lo[1], hi[1]), cells(0.0, h));
        let z_top = base - h;
        for i in 0..=nx {
            for j in 0..=ny {
                self.push(
                    [lo[0] + i as f32 * S, lo[1] + j as f32 * S, z_top],
                    top,
                    label,
                );
            }
        }
        let x_face = if lo[0] > 0.0 { lo[0] } else { hi[0] };
        let y_face = if lo[1] > 0.0 { lo[1] } else { hi[1] };
        for k in 1..nz {
            let z = z_top + k as f32 * S;
            for j in 0..=ny {
                self.push([x_face, lo[1] + j as f32 * S, z], side_x, label);
            }
            for i in 0..=nx {
                self.push([lo[0] + i as f32 * S, y_face, z], side_y, label);
            }
        }
    }

    fn cloud(&self) -> PointCloud {
        let mut c = PointCloud::from_positions(self.pts.clone());
        c.colors = Some(self.colors.clone());
        c
    }
}

/// The table with one box (label 1) standing on it over `[lo, hi]`, `h` tall.
fn one_box(lo: [f32; 2], hi: [f32; 2], h: f32, faces: [[u8; 3]; 3]) -> Scene {
    let mut s = Scene::new();
    s.table(&[(lo, hi)]);
    s.cuboid(lo, hi, 1.0, h, faces[0], faces[1], faces[2], 1);
    s
}

/// For each truth label, the best IoU of any predicted segment.
fn best_iou(truth: &[u32], pred: &[u32], label: u32) -> f64 {
    let mut best = 0.0f64;
    let preds: std::collections::BTreeSet<u32> =
        pred.iter().copied().filter(|&p| p != UNSEGMENTED).collect();
    for p in preds {
        let inter = truth
            .iter()
            .zip(pred)
            .filter(|&(&t, &q)| t == label && q == p)
            .count();
        let union = truth
            .iter()
            .zip(pred)
            .filter(|&(&t, &q)| t == label || q == p)
            .count();
        best = best.max(inter as f64 / union as f64);
    }
    best
}

const GREY: [u8; 3] = [200, 200, 200];

#[test]
fn geometric_mode_finds_two_separate_boxes_and_the_table() {
    let mut s = Scene::new();
    s.table(&[([0.03, 0.03], [0.09, 0.09]), ([-0.12, 0.03], [-0.06, 0.1])]);
    s.cuboid([0.03, 0.03], [0.09, 0.09], 1.0, 0.06, GREY, GREY, GREY, 1);
    s.cuboid([-0.12, 0.03], [-0.06, 0.1], 1.0, 0.08, GREY, GREY, GREY, 2);
    let out = segment_geometric(&s.cloud(), &GeometricParams::default()).unwrap();
    assert_eq!(out.segmentation.segments.len(), 3);
    assert_eq!(out.support.len(), 1);
    let labels = &out.segmentation.labels;
    for l in 0..3 {
        let iou = best_iou(&s.truth, labels, l);
        assert!(iou > 0.9, "object {l}: best IoU {iou}");
    }
    let plane = out.plane.expect("plane");
    assert!(plane[2].abs() > 0.999 && (plane[3].abs() - 1.0).abs() < 2e-3);
}

#[test]
fn geometric_mode_separates_a_box_stacked_on_another() {
    let mut s = Scene::new();
    s.table(&[([0.02, 0.02], [0.12, 0.12])]);
    s.cuboid([0.02, 0.02], [0.12, 0.12], 1.0, 0.05, GREY, GREY, GREY, 1);
    // The upper box stands on the lower one's top face (depth 0.95), set back from its
    // visible edges so that the lower box's top is seen in front of it.
    s.cuboid([0.05, 0.05], [0.1, 0.1], 0.95, 0.05, GREY, GREY, GREY, 2);
    // Drop the lower box's top-face points hidden under the upper box.
    let keep: Vec<usize> = (0..s.pts.len())
        .filter(|&i| {
            let p = s.pts[i];
            !(s.truth[i] == 1
                && (p[2] - 0.95).abs() < 0.002
                && p[0] > 0.05
                && p[0] <= 0.1
                && p[1] > 0.05
                && p[1] <= 0.1)
        })
        .collect();
    let mut cloud = s.cloud();
    cloud = cloud.select(&keep);
    let truth: Vec<u32> = keep.iter().map(|&i| s.truth[i]).collect();
    let out = segment_geometric(&cloud, &GeometricParams::default()).unwrap();
    let labels = &out.segmentation.labels;
    for l in 0..3 {
        let iou = best_iou(&truth, labels, l);
        assert!(iou > 0.85, "object {l}: best IoU {iou}");
    }
    assert_eq!(out.segmentation.segments.len(), 3);
}

#[test]
fn geometric_mode_keeps_a_box_with_differently_coloured_faces_whole() {
    let faces = [[250, 20, 20], [20, 250, 20], [20, 20, 250]];
    let s = one_box([0.03, 0.03], [0.11, 0.11], 0.07, faces);
    let out = segment_geometric(&s.cloud(), &GeometricParams::default()).unwrap();
    assert_eq!(out.segmentation.segments.len(), 2, "table and one box");
    assert!(best_iou(&s.truth, &out.segmentation.labels, 1) > 0.9);
}

#[test]
fn geometric_mode_without_a_support_plane_removes_nothing() {
    let mut s = Scene::new();
    s.cuboid([0.03, 0.03], [0.11, 0.11], 1.0, 0.07, GREY, GREY, GREY, 1);
    let out = segment_geometric(&s.cloud(), &GeometricParams::default()).unwrap();
    // The mode assumes a support: without a table, the box's top face (about 40% of the
    // points, above plane_min_fraction) is taken as the support plane. Documented
    // behaviour, checked here so that a change is noticed; no point is lost either way.
    assert_eq!(out.support.len(), 1);
    let segmented = out
        .segmentation
        .labels
        .iter()
        .filter(|&&l| l != UNSEGMENTED)
        .count();
    assert!(segmented as f64 > 0.95 * s.pts.len() as f64);
    let strict = GeometricParams {
        plane_min_fraction: 0.9,
        ..Default::default()
    };
    let out = segment_geometric(&s.cloud(), &strict).unwrap();
    assert!(out.plane.is_none() && out.support.is_empty());
    assert_eq!(out.segmentation.segments.len(), 1, "one box");
}

#[test]
fn geometric_mode_labels_every_input_point_and_leaves_nan_unsegmented() {
    let s = one_box([0.03, 0.03], [0.09, 0.09], 0.06, [GREY; 3]);
    let mut cloud = s.cloud();
    cloud.positions.insert(7, [f32::NAN, 0.0, 1.0]);
    cloud.colors.as_mut().unwrap().insert(7, [0, 0, 0]);
    cloud.width += 1;
    let out = segment_geometric(&cloud, &GeometricParams::default()).unwrap();
    assert_eq!(out.segmentation.labels.len(), cloud.len());
    assert_eq!(out.segmentation.labels[7], UNSEGMENTED);
    for (k, seg) in out.segmentation.segments.iter().enumerate() {
        assert!(seg.indices.windows(2).all(|w| w[0] < w[1]));
        assert!(seg
            .indices
            .iter()
            .all(|&i| out.segmentation.labels[i] == k as u32));
        assert!(seg.len() >= out.min_points);
    }
    let sizes: Vec<usize> = out.segmentation.segments.iter().map(|s| s.len()).collect();
    assert!(sizes.windows(2).all(|w| w[0] >= w[1]), "by size descending");
    // Without colours the mode still runs.
    cloud.colors = None;
    assert!(segment_geometric(&cloud, &GeometricParams::default()).is_ok());
}

#[test]
fn geometric_mode_does_not_depend_on_threads() {
    let s = one_box([0.03, 0.03], [0.09, 0.09], 0.06, [GREY; 3]);
    let serial = GeometricParams {
        parallelism: Parallelism::Serial,
        ..Default::default()
    };
    let a = segment_geometric(&s.cloud(), &serial).unwrap();
    let b = segment_geometric(&s.cloud(), &GeometricParams::default()).unwrap();
    assert_eq!(a, b);
}

#[test]
fn geometric_mode_rejects_bad_parameters() {
    let cloud = PointCloud::from_positions(vec![[0.0, 0.0, 1.0]; 5]);
    let bad = [
        GeometricParams {
            normal_radius_m: 0.0,
            ..Default::default()
        },
        GeometricParams {
            connect_radius_m: f64::NAN,
            ..Default::default()
        },
        GeometricParams {
            smoothness_deg: -1.0,
            ..Default::default()
        },
        GeometricParams {
            max_neighbours: 0,
            ..Default::default()
        },
        GeometricParams {
            ransac_iterations: 0,
            ..Default::default()
        },
    ];
    for p in bad {
        let e = segment_geometric(&cloud, &p).unwrap_err();
        assert!(matches!(
            e,
            SegmentError::InvalidDistance { .. }
                | SegmentError::InvalidThreshold { .. }
                | SegmentError::InvalidCount { .. }
        ));
    }
    // Fewer than three finite points: nothing to segment, no error.
    let tiny = PointCloud::from_positions(vec![[0.0, 0.0, 1.0], [f32::NAN; 3]]);
    let out = segment_geometric(&tiny, &GeometricParams::default()).unwrap();
    assert_eq!(out.segmentation.labels, vec![UNSEGMENTED; 2]);
}

#[test]
fn segment_mode_pcl_is_region_growing_rgb() {
    let s = one_box([0.03, 0.03], [0.09, 0.09], 0.06, [[250, 0, 0], GREY, GREY]);
    let p = RegionGrowingParams::thesis();
    let (seg, support) = segment(&s.cloud(), &SegmentMode::Pcl(p)).unwrap();
    assert_eq!(seg, region_growing_rgb(&s.cloud(), &p).unwrap());
    assert!(support.is_empty());
    let (geo, support) = segment(&s.cloud(), &SegmentMode::Geometric(Default::default())).unwrap();
    assert_eq!(support.len(), 1);
    assert_eq!(geo.segments.len(), 2);
}

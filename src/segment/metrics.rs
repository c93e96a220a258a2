//! Segmentation quality against reference labels: adjusted Rand index and object-level
//! precision and recall at an IoU threshold.
//!
//! ```
//! use softsense::segment::metrics::adjusted_rand_index;
//! assert!((adjusted_rand_index(&[0, 0, 1, 1], &[5, 5, 7, 7]) - 1.0).abs() < 1e-12);
//! ```

use std::collections::HashMap;

/// Adjusted Rand index (Hubert and Arabie) of two labelings of the same points.
/// 1 for identical partitions (up to renaming), about 0 for random ones. Two labelings
/// of fewer than two points, or both putting everything in one cluster, give 1.
pub fn adjusted_rand_index(a: &[u32], b: &[u32]) -> f64 {
    assert_eq!(a.len(), b.len(), "labelings of different lengths");
    let n = a.len() as f64;
    let comb2 = |x: f64| x * (x - 1.0) / 2.0;
    let mut joint: HashMap<(u32, u32), f64> = HashMap::new();
    let mut ca: HashMap<u32, f64> = HashMap::new();
    let mut cb: HashMap<u32, f64> = HashMap::new();
    for (&x, &y) in a.iter().zip(b) {
        *joint.entry((x, y)).or_default() += 1.0;
        *ca.entry(x).or_default() += 1.0;
        *cb.entry(y).or_default() += 1.0;
    }
    let index: f64 = joint.values().map(|&v| comb2(v)).sum();
    let sa: f64 = ca.values().map(|&v| comb2(v)).sum();
    let sb: f64 = cb.values().map(|&v| comb2(v)).sum();
    let total = comb2(n);
    if total == 0.0 {
        return 1.0;
    }
    let expected = sa * sb / total;
    let max = (sa + sb) / 2.0;
    if (max - expected).abs() < 1e-12 {
        return 1.0;
    }
    (index - expected) / (max - expected)
}

/// Labels where every point of `unassigned` becomes its own singleton cluster (so that
/// unsegmented points are neither rewarded nor merged), for [`adjusted_rand_index`].
pub fn singletons_for(labels: &[u32], unassigned: u32) -> Vec<u32> {
    let mut next = labels
        .iter()
        .filter(|&&l| l != unassigned)
        .max()
        .map_or(0, |&m| m + 1);
    labels
        .iter()
        .map(|&l| {
            if l == unassigned {
                next += 1;
                next - 1
            } else {
                l
            }
        })
        .collect()
}

/// Object-level scores of predicted segments against reference regions.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ObjectScores {
    /// Reference objects matched by a predicted segment at IoU ≥ the threshold.
    pub objects_found: usize,
    /// Reference objects.
    pub objects: usize,
    /// Predicted segments matching any reference region at IoU ≥ the threshold.
    pub segments_correct: usize,
    /// Predicted segments.
    pub segments: usize,
}

impl ObjectScores {
    /// objects_found / objects (1 when there are no objects).
    pub fn recall(&self) -> f64 {
        ratio(self.objects_found, self.objects)
    }
    /// segments_correct / segments (1 when there are no segments).
    pub fn precision(&self) -> f64 {
        ratio(self.segments_correct, self.segments)
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        1.0
    } else {
        a as f64 / b as f64
    }
}

/// Object-level scores. `reference[i]` is the reference region of point `i` (`None`: the
/// point is ignored), `is_object(region)` says which reference regions count as objects
/// for recall (all regions count for precision); `predicted[i]` is the segment of point
/// `i` or `unassigned`. IoU is over the points that have a reference region.
pub fn object_scores(
    reference: &[Option<u32>],
    is_object: impl Fn(u32) -> bool,
    predicted: &[u32],
    unassigned: u32,
    iou_threshold: f64,
) -> ObjectScores {
    assert_eq!(
        reference.len(),
        predicted.len(),
        "labelings of different lengths"
    );
    let mut ref_size: HashMap<u32, usize> = HashMap::new();
    let mut pred_size: HashMap<u32, usize> = HashMap::new();
    let mut inter: HashMap<(u32, u32), usize> = HashMap::new();
    for (r, &p) in reference.iter().zip(predicted) {
        let Some(r) = *r else { continue };
        *ref_size.entry(r).or_default() += 1;
        if p != unassigned {
            *pred_size.entry(p).or_default() += 1;
            *inter.entry((r, p)).or_default() += 1;
        }
    }
    let mut ref_hit: HashMap<u32, bool> = HashMap::new();
    let mut pred_hit: HashMap<u32, bool> = HashMap::new();
    for (&(r, p), &i) in &inter {
        let union = ref_size[&r] + pred_size[&p] - i;
        if i as f64 / union as f64 >= iou_threshold {
            ref_hit.insert(r, true);
            pred_hit.insert(p, true);
        }
    }
    let objects = ref_size.keys().filter(|&&r| is_object(r)).count();
    let objects_found = ref_size
        .keys()
        .filter(|&&r| is_object(r) && ref_hit.contains_key(&r))
        .count();
    ObjectScores {
        objects_found,
        objects,
        segments_correct: pred_hit.len(),
        segments: pred_size.len(),
    }
}

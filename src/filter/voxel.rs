//! Voxel-grid down-sampling: PCL `VoxelGrid` and Open3D `voxel_down_sample` grids.

use super::{empty_like, FilterError, FilterOutput};
use crate::cloud::PointCloud;
use crate::search::sort::{bits_for, radix_sort_packed};
use crate::search::Parallelism;
use serde::{Deserialize, Serialize};

/// Which library's grid and averaging rules to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VoxelMode {
    /// PCL `VoxelGrid`: cells at multiples of the leaf from the world origin, key
    /// `floor(f32(p * f32(1/leaf)))`; colours are truncated means, normals renormalised.
    #[default]
    Pcl,
    /// Open3D `voxel_down_sample`: origin `min - leaf/2`, key `floor((p - origin)/leaf)`
    /// in `f64`; colours are rounded means, normals plain means (not renormalised).
    Open3d,
}

/// Parameters of [`voxel_grid`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VoxelGridParams {
    /// Leaf edge per axis, metres (`> 0`, finite).
    pub leaf_size: [f64; 3],
    /// Grid and averaging rules.
    pub mode: VoxelMode,
    /// Voxels with fewer points are dropped (PCL's `min_points_per_voxel`; 0 or 1 keeps all).
    pub min_points_per_voxel: usize,
    /// Threads.
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for VoxelGridParams {
    fn default() -> Self {
        VoxelGridParams::new(0.005)
    }
}

impl VoxelGridParams {
    /// A cubic leaf of `leaf` metres, PCL mode.
    pub fn new(leaf: f64) -> Self {
        VoxelGridParams {
            leaf_size: [leaf; 3],
            mode: VoxelMode::Pcl,
            min_points_per_voxel: 0,
            parallelism: Parallelism::default(),
        }
    }
}

/// Largest absolute voxel coordinate we accept, so that differences fit in `i64`.
const MAX_CELL: f64 = (1u64 << 61) as f64;

/// Down-samples to one point per occupied voxel: the centroid of its points, with the
/// other attributes averaged as the chosen library does (labels: majority vote, ties to
/// the smallest label; curvature: mean). Non-finite points are always ignored (PCL does
/// so only when the cloud is flagged non-dense; Open3D emits a NaN voxel).
///
/// Voxel keys are 64-bit and the output holds at most one point per input point, so no
/// leaf size overflows and memory is bounded by the input; the only errors are a leaf
/// that is not finite and positive, or so small that voxel coordinates exceed 2^61.
///
/// Output order: ascending `(k, j, i)` voxel coordinates, x fastest; that is PCL's
/// linear-index order in PCL mode. Open3D's own order is its hash map's; compare
/// against it after sorting. Positions are averaged in `f64` (PCL sums in `f32`; the
/// difference is within a few ulp). `indices[v]` is the smallest input index in voxel `v`.
pub fn voxel_grid(
    cloud: &PointCloud,
    params: &VoxelGridParams,
) -> Result<FilterOutput, FilterError> {
    cloud.validate()?;
    for &leaf in &params.leaf_size {
        let leaf32 = leaf as f32;
        if !(leaf.is_finite() && leaf > 0.0 && leaf32 > 0.0 && (1.0f32 / leaf32).is_finite()) {
            return Err(FilterError::InvalidLeafSize { leaf });
        }
    }
    let finite = cloud.finite_indices();
    let Some((lo, hi)) = cloud.bounds() else {
        return Ok(FilterOutput {
            cloud: empty_like(cloud),
            indices: Vec::new(),
        });
    };
    let extent = (0..3)
        .map(|a| (lo[a].abs()).max(hi[a].abs()) as f64)
        .fold(0.0, f64::max);
    let too_small = || FilterError::LeafTooSmall {
        leaf: params
            .leaf_size
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min),
        extent,
    };

    // Per-axis cell coordinate of a point, in the chosen library's arithmetic.
    let inv32: [f32; 3] = std::array::from_fn(|a| 1.0f32 / params.leaf_size[a] as f32);
    let origin: [f64; 3] = std::array::from_fn(|a| lo[a] as f64 - params.leaf_size[a] / 2.0);
    let mode = params.mode;
    let leaf = params.leaf_size;
    let cell = move |p: &[f32; 3], a: usize| -> f64 {
        match mode {
            VoxelMode::Pcl => (p[a] * inv32[a]).floor() as f64,
            VoxelMode::Open3d => ((p[a] as f64 - origin[a]) / leaf[a]).floor(),
        }
    };
    let mut cmin = [0i64; 3];
    let mut dims = [0u128; 3];
    for a in 0..3 {
        let (c0, c1) = (cell(&lo, a), cell(&hi, a));
        if !(c0.is_finite() && c1.is_finite() && c0.abs() < MAX_CELL && c1.abs() < MAX_CELL) {
            return Err(too_small());
        }
        cmin[a] = c0 as i64;
        dims[a] = (c1 as i64 - c0 as i64 + 1) as u128;
    }
    // Cell coordinates are monotone in p, so min/max points bound every key.
    let rel = |p: &[f32; 3]| -> [u64; 3] {
        std::array::from_fn(|a| (cell(p, a) as i64 - cmin[a]) as u64)
    };

    // Sort (key, index) pairs; keys are unique with the index, so the order is total
    // and independent of the sort's stability or thread count.
    let total = dims[0]
        .checked_mul(dims[1])
        .and_then(|d| d.checked_mul(dims[2]));
    let groups: Vec<std::ops::Range<usize>>;
    let order: Vec<u32>;
    match total {
        Some(t) if t <= 1u128 << 32 => {
            // PERF: the common case: keys fit in 32 bits, packed above the index and
            // radix-sorted (stable, so indices stay ascending within a voxel).
            let (dx, dxy) = (dims[0] as u64, (dims[0] * dims[1]) as u64);
            let mut words: Vec<u64> = Vec::with_capacity(finite.len());
            words.extend(finite.iter().map(|&i| {
                let r = rel(&cloud.positions[i]);
                ((r[0] + r[1] * dx + r[2] * dxy) << 32) | i as u64
            }));
            radix_sort_packed(&mut words, bits_for(t as u64));
            groups = runs_by(&words, |w| w >> 32);
            order = words.into_iter().map(|w| w as u32).collect();
        }
        Some(t) if t <= u64::MAX as u128 => {
            let (dx, dxy) = (dims[0] as u64, (dims[0] * dims[1]) as u64);
            let mut pairs: Vec<(u64, u32)> = finite
                .iter()
                .map(|&i| {
                    let r = rel(&cloud.positions[i]);
                    (r[0] + r[1] * dx + r[2] * dxy, i as u32)
                })
                .collect();
            sort_pairs(&mut pairs, params.parallelism);
            groups = runs_by(&pairs, |p| p.0);
            order = pairs.into_iter().map(|(_, i)| i).collect();
        }
        _ => {
            let mut pairs: Vec<([u64; 3], u32)> = finite
                .iter()
                .map(|&i| {
                    let r = rel(&cloud.positions[i]);
                    ([r[2], r[1], r[0]], i as u32)
                })
                .collect();
            sort_pairs(&mut pairs, params.parallelism);
            groups = runs_by(&pairs, |p| p.0);
            order = pairs.into_iter().map(|(_, i)| i).collect();
        }
    }
    let groups: Vec<_> = groups
        .into_iter()
        .filter(|g| g.len() >= params.min_points_per_voxel)
        .collect();
    Ok(average_groups(cloud, &order, &groups, params))
}

fn sort_pairs<K: Ord + Copy + Send>(pairs: &mut [(K, u32)], par: Parallelism) {
    #[cfg(feature = "parallel")]
    if par == Parallelism::Rayon {
        use rayon::prelude::*;
        pairs.par_sort_unstable();
        return;
    }
    let _ = par;
    pairs.sort_unstable();
}

/// Ranges of equal keys in a sorted slice.
fn runs_by<T, K: PartialEq>(items: &[T], key: impl Fn(&T) -> K) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=items.len() {
        if i == items.len() || key(&items[i]) != key(&items[start]) {
            out.push(start..i);
            start = i;
        }
    }
    out
}

/// The output cloud: one averaged point per group of `order` (input indices, ascending
/// within a group).
fn average_groups(
    cloud: &PointCloud,
    order: &[u32],
    groups: &[std::ops::Range<usize>],
    params: &VoxelGridParams,
) -> FilterOutput {
    let pcl = params.mode == VoxelMode::Pcl;
    let members = |g: usize| order[groups[g].clone()].iter().map(|&i| i as usize);
    let par = params.parallelism;
    let m = groups.len();
    let positions = crate::search::map_indices(m, par, |g| {
        let mut s = [0f64; 3];
        for i in members(g) {
            let p = cloud.positions[i];
            (0..3).for_each(|a| s[a] += p[a] as f64);
        }
        let n = groups[g].len() as f64;
        s.map(|v| (v / n) as f32)
    });
    let byte_mean = |sum: u64, n: usize| -> u8 {
        if pcl {
            // PCL: float sum / n, truncated.
            (sum as f32 / n as f32) as u8
        } else {
            (sum as f64 / n as f64).round() as u8
        }
    };
    let colors = cloud.colors.as_ref().map(|c| {
        crate::search::map_indices(m, par, |g| {
            let mut s = [0u64; 3];
            for i in members(g) {
                (0..3).for_each(|a| s[a] += c[i][a] as u64);
            }
            s.map(|v| byte_mean(v, groups[g].len()))
        })
    });
    let alpha = cloud.alpha.as_ref().map(|c| {
        crate::search::map_indices(m, par, |g| {
            byte_mean(members(g).map(|i| c[i] as u64).sum(), groups[g].len())
        })
    });
    let normals = cloud.normals.as_ref().map(|nrm| {
        crate::search::map_indices(m, par, |g| {
            let mut s = [0f64; 3];
            for i in members(g) {
                let v = nrm[i];
                if pcl || v.iter().all(|c| c.is_finite()) {
                    (0..3).for_each(|a| s[a] += v[a] as f64);
                }
            }
            let d = if pcl {
                (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
            } else {
                groups[g].len() as f64
            };
            s.map(|v| (v / d) as f32)
        })
    });
    let curvature = cloud.curvature.as_ref().map(|c| {
        crate::search::map_indices(m, par, |g| {
            (members(g).map(|i| c[i] as f64).sum::<f64>() / groups[g].len() as f64) as f32
        })
    });
    let labels = cloud.labels.as_ref().map(|l| {
        crate::search::map_indices(m, par, |g| {
            let mut v: Vec<u32> = members(g).map(|i| l[i]).collect();
            v.sort_unstable();
            majority(&v)
        })
    });
    let indices: Vec<usize> = (0..m).map(|g| order[groups[g].start] as usize).collect();
    FilterOutput {
        cloud: PointCloud {
            positions,
            colors,
            alpha,
            normals,
            curvature,
            labels,
            width: u32::try_from(m).unwrap_or(u32::MAX),
            height: 1,
            viewpoint: cloud.viewpoint,
        },
        indices,
    }
}

/// The most frequent value of a sorted slice; ties go to the smallest value.
fn majority(sorted: &[u32]) -> u32 {
    let (mut best, mut best_n) = (0u32, 0usize);
    let mut i = 0;
    while i < sorted.len() {
        let j = i + sorted[i..].iter().take_while(|&&v| v == sorted[i]).count();
        if j - i > best_n {
            best = sorted[i];
            best_n = j - i;
        }
        i = j;
    }
    best
}

//! Voxel-grid down-sampling: PCL `VoxelGrid` and Open3D `voxel_down_sample` grids.

use super::{empty_like, FilterError, FilterOutput};
use crate::cloud::PointCloud;
use crate::search::sort::{bits_for, radix_sort_packed, set_len, with_word_buffers};
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
///
/// Memory: besides the output, 16 bytes per finite point for sorting. The calling thread
/// keeps those buffers for its next call (a stream of frames then does not fault them
/// into memory again every frame); buffers larger than 32 MiB each are freed after use.
pub fn voxel_grid(
    cloud: &PointCloud,
    params: &VoxelGridParams,
) -> Result<FilterOutput, FilterError> {
    cloud.validate()?;
    voxel_grid_of(cloud, None, params)
}

/// The points a voxel grid runs on: all of a cloud's, or a list of them.
#[derive(Clone, Copy)]
struct Members<'a> {
    list: Option<&'a [usize]>,
    count: usize,
}

impl Members<'_> {
    /// Points per chunk of the parallel passes (fixed, so results never depend on the
    /// thread count).
    const CHUNK: usize = 1 << 15;

    fn get(&self, j: usize) -> usize {
        self.list.map_or(j, |l| l[j])
    }

    fn chunks(&self) -> usize {
        self.count.div_ceil(Self::CHUNK)
    }

    /// The input indices of chunk `c`.
    fn chunk(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let end = ((c + 1) * Self::CHUNK).min(self.count);
        (c * Self::CHUNK..end).map(|j| self.get(j))
    }

    fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.count).map(|j| self.get(j))
    }
}

/// [`voxel_grid`] of the points `members` of `cloud` (ascending input indices, in range;
/// `None`: all), as if run on `cloud.select(members)`, but with `indices` into `cloud`:
/// the chain uses it to down-sample a crop without building the cropped cloud. `cloud`
/// must be valid.
pub(crate) fn voxel_grid_of(
    cloud: &PointCloud,
    members: Option<&[usize]>,
    params: &VoxelGridParams,
) -> Result<FilterOutput, FilterError> {
    let members = Members {
        list: members,
        count: members.map_or(cloud.len(), <[usize]>::len),
    };
    for &leaf in &params.leaf_size {
        let leaf32 = leaf as f32;
        if !(leaf.is_finite() && leaf > 0.0 && leaf32 > 0.0 && (1.0f32 / leaf32).is_finite()) {
            return Err(FilterError::InvalidLeafSize { leaf });
        }
    }
    let pos = &cloud.positions;
    // PERF: bounds and finite counts per chunk, in parallel (min and max are exact in
    // any order).
    let chunk_bounds = crate::search::map_range(members.chunks(), params.parallelism, 1, |c| {
        bounds_of(pos, members.chunk(c))
    });
    let Some((lo, hi, finite)) = chunk_bounds.iter().flatten().copied().reduce(|a, b| {
        (
            std::array::from_fn(|k| a.0[k].min(b.0[k])),
            std::array::from_fn(|k| a.1[k].max(b.1[k])),
            a.2 + b.2,
        )
    }) else {
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
    // Cell coordinates are monotone in p, so min/max points bound every key, and every
    // finite point's cell is within ±2^61: the fast floors below are exact.
    // PERF: `floor` is a libm call without SSE4.1; truncation plus a correction is not,
    // and each mode gets its own key loop.
    let grid = Grid {
        cmin,
        dims,
        finite,
        chunk_finite: chunk_bounds.iter().map(|b| b.map_or(0, |b| b.2)).collect(),
    };
    Ok(match mode {
        VoxelMode::Pcl => group_and_average(cloud, members, &grid, params, |p| {
            std::array::from_fn(|a| floor_f32(p[a] * inv32[a]))
        }),
        VoxelMode::Open3d => group_and_average(cloud, members, &grid, params, |p| {
            std::array::from_fn(|a| floor_f64((p[a] as f64 - origin[a]) / leaf[a]))
        }),
    })
}

/// The occupied cell range: smallest cell per axis, cells per axis, finite point count
/// (in all and per chunk of the members).
struct Grid {
    cmin: [i64; 3],
    dims: [u128; 3],
    finite: usize,
    chunk_finite: Vec<usize>,
}

/// Sorts the finite `members` (ascending) by the voxel key of `cell(p)` and averages each
/// voxel. Keys are unique with the index, so the order is total and independent of the
/// sort's stability or thread count.
fn group_and_average(
    cloud: &PointCloud,
    members: Members<'_>,
    grid: &Grid,
    params: &VoxelGridParams,
    cell: impl Fn(&[f32; 3]) -> [i64; 3] + Sync,
) -> FilterOutput {
    let finite = |i: &usize| PointCloud::is_finite_point(&cloud.positions[*i]);
    let (pos, cmin, dims) = (&cloud.positions, grid.cmin, grid.dims);
    let rel = |p: &[f32; 3]| -> [u64; 3] {
        let c = cell(p);
        std::array::from_fn(|a| (c[a] - cmin[a]) as u64)
    };
    let total = dims[0]
        .checked_mul(dims[1])
        .and_then(|d| d.checked_mul(dims[2]));
    match total {
        Some(t) if t <= 1u128 << 32 && pos.len() <= 1 << 32 => {
            // PERF: the common case: keys fit in 32 bits, packed above the index and
            // radix-sorted (stable, so indices stay ascending within a voxel).
            let (dx, dxy) = (dims[0] as u64, (dims[0] * dims[1]) as u64);
            with_word_buffers(|words, buf| {
                // PERF: each chunk of members writes its finite points' words into its
                // own slice, in parallel.
                set_len(words, grid.finite);
                let mut rest = &mut words[..];
                let mut slices = Vec::with_capacity(grid.chunk_finite.len());
                for (c, &n) in grid.chunk_finite.iter().enumerate() {
                    let (mine, tail) = rest.split_at_mut(n);
                    slices.push((c, mine));
                    rest = tail;
                }
                for_each(slices, params.parallelism, |(c, out)| {
                    for (w, i) in out.iter_mut().zip(members.chunk(c).filter(finite)) {
                        let r = rel(&pos[i]);
                        *w = ((r[0] + r[1] * dx + r[2] * dxy) << 32) | i as u64;
                    }
                });
                radix_sort_packed(words, buf, bits_for(t as u64));
                average_sorted(
                    cloud,
                    words,
                    |w| w >> 32,
                    |w| (w & 0xffff_ffff) as usize,
                    params,
                )
            })
        }
        Some(t) if t <= u64::MAX as u128 => {
            let (dx, dxy) = (dims[0] as u64, (dims[0] * dims[1]) as u64);
            let mut pairs: Vec<(u64, usize)> = members
                .iter()
                .filter(finite)
                .map(|i| {
                    let r = rel(&pos[i]);
                    (r[0] + r[1] * dx + r[2] * dxy, i)
                })
                .collect();
            sort_pairs(&mut pairs, params.parallelism);
            average_sorted(cloud, &pairs, |p| p.0, |p| p.1, params)
        }
        _ => {
            let mut pairs: Vec<([u64; 3], usize)> = members
                .iter()
                .filter(finite)
                .map(|i| {
                    let r = rel(&pos[i]);
                    ([r[2], r[1], r[0]], i)
                })
                .collect();
            sort_pairs(&mut pairs, params.parallelism);
            average_sorted(cloud, &pairs, |p| p.0, |p| p.1, params)
        }
    }
}

/// `v.round()` for `0 ≤ v < 2^52`. PERF: `round` is a libm call without SSE4.1; the
/// fraction `v - trunc(v)` is exact, so this gives the same result.
#[inline]
fn round_half_away(v: f64) -> u64 {
    let t = v as u64;
    t + u64::from(v - t as f64 >= 0.5)
}

/// `floor(v)` as an integer, exact for finite `|v| < 2^63`.
#[inline]
fn floor_f32(v: f32) -> i64 {
    let t = v as i64;
    t - i64::from(t as f32 > v)
}

/// `floor(v)` as an integer, exact for finite `|v| < 2^63`.
#[inline]
fn floor_f64(v: f64) -> i64 {
    let t = v as i64;
    t - i64::from(t as f64 > v)
}

/// Bounds `(min, max, count)` of the finite points among `members`, or `None` if there
/// are none.
fn bounds_of(
    pos: &[[f32; 3]],
    members: impl Iterator<Item = usize>,
) -> Option<([f32; 3], [f32; 3], usize)> {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let mut n = 0;
    for i in members {
        let p = &pos[i];
        if PointCloud::is_finite_point(p) {
            n += 1;
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    (n > 0).then_some((lo, hi, n))
}

/// Calls `f` on every item, in parallel with rayon.
fn for_each<T: Send>(items: Vec<T>, par: Parallelism, f: impl Fn(T) + Sync + Send) {
    #[cfg(feature = "parallel")]
    if par == Parallelism::Rayon {
        use rayon::prelude::*;
        items.into_par_iter().for_each(f);
        return;
    }
    let _ = par;
    items.into_iter().for_each(f);
}

fn sort_pairs<K: Ord + Copy + Send>(pairs: &mut [(K, usize)], par: Parallelism) {
    #[cfg(feature = "parallel")]
    if par == Parallelism::Rayon {
        use rayon::prelude::*;
        pairs.par_sort_unstable();
        return;
    }
    let _ = par;
    pairs.sort_unstable();
}

/// The output cloud's columns, filled voxel by voxel.
#[derive(Default)]
struct Columns {
    positions: Vec<[f32; 3]>,
    colors: Vec<[u8; 3]>,
    alpha: Vec<u8>,
    normals: Vec<[f32; 3]>,
    curvature: Vec<f32>,
    labels: Vec<u32>,
    indices: Vec<usize>,
}

impl Columns {
    fn append(&mut self, mut other: Columns) {
        self.positions.append(&mut other.positions);
        self.colors.append(&mut other.colors);
        self.alpha.append(&mut other.alpha);
        self.normals.append(&mut other.normals);
        self.curvature.append(&mut other.curvature);
        self.labels.append(&mut other.labels);
        self.indices.append(&mut other.indices);
    }
}

/// The output cloud from `items` sorted by voxel key: one averaged point per run of equal
/// keys with at least `min_points_per_voxel` members (input indices ascending within a
/// run). PERF: one pass per run over all fields; with rayon, the items are cut at run
/// boundaries into chunks averaged in parallel and concatenated in order, so the result
/// (every sum in ascending index order) does not depend on the thread count.
fn average_sorted<T, K>(
    cloud: &PointCloud,
    items: &[T],
    key: impl Fn(&T) -> K + Sync,
    index: impl Fn(&T) -> usize + Sync,
    params: &VoxelGridParams,
) -> FilterOutput
where
    T: Sync,
    K: PartialEq,
{
    let run_end = |s: usize| {
        let k = key(&items[s]);
        s + 1 + items[s + 1..].iter().take_while(|t| key(t) == k).count()
    };
    let chunk = |range: std::ops::Range<usize>| -> Columns {
        let mut cols = Columns::default();
        let mut members: Vec<usize> = Vec::new();
        let mut s = range.start;
        while s < range.end {
            let e = run_end(s);
            if e - s >= params.min_points_per_voxel {
                members.clear();
                members.extend(items[s..e].iter().map(&index));
                average_one(cloud, &members, params.mode, &mut cols);
            }
            s = e;
        }
        cols
    };
    let n = items.len();
    // Chunk starts: about `parts` equal slices, each moved forward to a run start.
    let parts = match params.parallelism {
        #[cfg(feature = "parallel")]
        Parallelism::Rayon if n >= 1 << 14 => 4 * rayon::current_num_threads(),
        _ => 1,
    };
    let mut starts: Vec<usize> = (0..parts)
        .map(|p| {
            let mut s = p * n / parts;
            while s > 0 && s < n && key(&items[s]) == key(&items[s - 1]) {
                s += 1;
            }
            s
        })
        .collect();
    starts.push(n);
    starts.dedup();
    let ranges: Vec<_> = starts.windows(2).map(|w| w[0]..w[1]).collect();
    #[cfg(feature = "parallel")]
    let pieces: Vec<Columns> = if ranges.len() > 1 {
        use rayon::prelude::*;
        ranges.into_par_iter().map(chunk).collect()
    } else {
        ranges.into_iter().map(chunk).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let pieces: Vec<Columns> = ranges.into_iter().map(chunk).collect();
    let mut cols = Columns::default();
    for p in pieces {
        cols.append(p);
    }
    let m = cols.positions.len();
    FilterOutput {
        cloud: PointCloud {
            positions: cols.positions,
            colors: cloud.colors.as_ref().map(|_| cols.colors),
            alpha: cloud.alpha.as_ref().map(|_| cols.alpha),
            normals: cloud.normals.as_ref().map(|_| cols.normals),
            curvature: cloud.curvature.as_ref().map(|_| cols.curvature),
            labels: cloud.labels.as_ref().map(|_| cols.labels),
            width: u32::try_from(m).unwrap_or(u32::MAX),
            height: 1,
            viewpoint: cloud.viewpoint,
        },
        indices: cols.indices,
    }
}

/// Appends the averaged point of one voxel (`members`: input indices, ascending) to `out`.
fn average_one(cloud: &PointCloud, members: &[usize], mode: VoxelMode, out: &mut Columns) {
    let pcl = mode == VoxelMode::Pcl;
    let len = members.len();
    let n = len as f64;
    let mut s = [0f64; 3];
    for &i in members {
        let p = cloud.positions[i];
        (0..3).for_each(|a| s[a] += p[a] as f64);
    }
    out.positions.push(s.map(|v| (v / n) as f32));
    out.indices.push(members[0]);
    let byte_mean = |sum: u64| -> u8 {
        if pcl {
            // PCL: float sum / n, truncated.
            (sum as f32 / len as f32) as u8
        } else {
            round_half_away(sum as f64 / n) as u8
        }
    };
    if let Some(c) = &cloud.colors {
        let mut s = [0u64; 3];
        for &i in members {
            (0..3).for_each(|a| s[a] += c[i][a] as u64);
        }
        out.colors.push(s.map(byte_mean));
    }
    if let Some(c) = &cloud.alpha {
        out.alpha
            .push(byte_mean(members.iter().map(|&i| c[i] as u64).sum()));
    }
    if let Some(nrm) = &cloud.normals {
        let mut s = [0f64; 3];
        for &i in members {
            let v = nrm[i];
            if pcl || v.iter().all(|c| c.is_finite()) {
                (0..3).for_each(|a| s[a] += v[a] as f64);
            }
        }
        let d = if pcl {
            (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
        } else {
            n
        };
        out.normals.push(s.map(|v| (v / d) as f32));
    }
    if let Some(c) = &cloud.curvature {
        out.curvature
            .push((members.iter().map(|&i| c[i] as f64).sum::<f64>() / n) as f32);
    }
    if let Some(l) = &cloud.labels {
        let mut v: Vec<u32> = members.iter().map(|&i| l[i]).collect();
        v.sort_unstable();
        out.labels.push(majority(&v));
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

//! Colour region growing with PCL 1.13 `RegionGrowingRGB` semantics (normal test off).
//!
//! The steps follow `../shared/docs/oracle-semantics.md` section 5 literally; two of PCL's
//! quadratic parts are replaced by near-linear equivalents that give the same result:
//! segment adjacency is computed segment by segment (in parallel) with a scratch array
//! reset through a touched list (PCL allocates one entry per segment for every segment),
//! and the small-region merge keeps, per region, a heap over its segments' sorted
//! neighbour lists with lazy deletion and merges regions with a union-find (PCL rewrites
//! and re-sorts whole lists on every merge).
//!
//! 1. every finite point gets its `region_neighbours` (K = 100) nearest neighbours, self
//!    included, sorted by (`f32` squared distance, index);
//! 2. seeds in ascending index order; breadth-first growth over the first
//!    `min(neighbours, K)` entries of the popped point's list, accepting unlabelled points
//!    whose squared RGB distance to the *popped* point is `≤ point_color²`;
//! 3. segment adjacency: for each segment, the minimum squared point distance to each
//!    other segment seen in its points' K lists, the K nearest kept;
//! 4. segment mean colour: per channel `trunc(f32(sum) / f32(count))`;
//! 5. greedy colour merge: segments in order open a region when unlabelled, and give
//!    their region to unlabelled neighbours with distance `≤ distance²` and mean-colour
//!    distance `< region_color²` (strict);
//! 6. small-region merge (switchable): regions in order whose current size is below
//!    `min_cluster_size` join the region owning their nearest neighbouring segment, with
//!    no colour or distance test;
//! 7. assembly in region order with PCL's empty-slot swaps, then clusters outside
//!    `[min_cluster_size, max_cluster_size]` are removed.
//!
//! Thresholds are squared in `f32` as PCL stores them. Exact ties of distances can be
//! ordered differently from FLANN and from PCL's unstable sorts (oracle-semantics trap 12).

use super::{check_distance, check_threshold, SegmentError, UNSEGMENTED};
use crate::cloud::PointCloud;
use crate::search::{squared_distance, word_index, KnnSearch, Parallelism};
use std::cmp::Reverse;
use std::collections::binary_heap::PeekMut;
use std::collections::BinaryHeap;

/// Parameters of [`region_growing_rgb`]. `Default` is PCL 1.13's defaults.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RegionGrowingParams {
    /// Segment distance threshold in metres (PCL `setDistanceThreshold`; default √0.05).
    pub distance_m: f64,
    /// Point-to-point colour threshold in 0-255 RGB units, inclusive (default 35).
    pub point_color: f64,
    /// Region colour threshold in 0-255 RGB units, strict (default √10).
    pub region_color: f64,
    /// Smallest cluster size in points; also the small-region merge limit (default 10).
    pub min_cluster_size: usize,
    /// Largest cluster size in points (default unbounded).
    pub max_cluster_size: usize,
    /// Neighbours examined when growing (PCL `setNumberOfNeighbours`, default 30).
    pub neighbours: usize,
    /// Neighbours found per point and neighbouring segments kept per segment (PCL
    /// `setNumberOfRegionNeighbours`, default 100).
    pub region_neighbours: usize,
    /// Run the small-region merge (step 6); PCL always does.
    pub merge_small: bool,
    /// Threads for the neighbour search (results do not depend on it).
    #[serde(skip)]
    pub parallelism: Parallelism,
}

impl Default for RegionGrowingParams {
    fn default() -> Self {
        RegionGrowingParams {
            distance_m: 0.05f64.sqrt(),
            point_color: 35.0,
            region_color: 10f64.sqrt(),
            min_cluster_size: 10,
            max_cluster_size: usize::MAX,
            neighbours: 30,
            region_neighbours: 100,
            merge_small: true,
            parallelism: Parallelism::default(),
        }
    }
}

impl RegionGrowingParams {
    /// The thesis code's parameters (SoftRobots `PointCloudProcessing`): distance 0.01 m,
    /// point colour 6, region colour 4, min cluster 100; the rest PCL's defaults.
    pub fn thesis() -> Self {
        RegionGrowingParams {
            distance_m: 0.01,
            point_color: 6.0,
            region_color: 4.0,
            min_cluster_size: 100,
            ..Default::default()
        }
    }
}

/// Largest `region_neighbours` accepted (the K lists take 4 bytes per point and
/// neighbour).
pub const MAX_REGION_NEIGHBOURS: usize = 1000;

/// One output segment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Segment {
    /// Input indices, ascending.
    pub indices: Vec<usize>,
    /// Mean colour (0-255, exact mean).
    pub mean_color: [f32; 3],
    /// Bounding box minimum corner (metres).
    pub min: [f32; 3],
    /// Bounding box maximum corner (metres).
    pub max: [f32; 3],
}

impl Segment {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.indices.len()
    }
    /// True when the segment has no points (never for a returned segment).
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }
}

/// The result of [`region_growing_rgb`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Segmentation {
    /// Segments in PCL's cluster order.
    pub segments: Vec<Segment>,
    /// Per input point: index into `segments`, or [`UNSEGMENTED`].
    pub labels: Vec<u32>,
    /// Segments after growing (step 2; geometric mode: smooth regions).
    pub grown_segments: usize,
    /// Regions after the colour merge (step 5; geometric mode: segments kept, support
    /// parts included).
    pub colour_regions: usize,
}

impl Segmentation {
    /// The clusters as index lists, in order.
    pub fn clusters(&self) -> Vec<Vec<usize>> {
        self.segments.iter().map(|s| s.indices.clone()).collect()
    }
}

fn color_dist2(a: [u32; 3], b: [u32; 3]) -> f32 {
    let d = |i: usize| {
        let x = a[i] as i64 - b[i] as i64;
        x * x
    };
    (d(0) + d(1) + d(2)) as f32
}

/// Every point's K list as point indices, chunk by chunk as the search returns them.
/// Each row's first entries are the growth candidates: the `grow_n` nearest that pass
/// the point colour test (their number is kept per point), then the rest in any order.
struct KLists {
    /// Rows of K indices.
    rows: Vec<u32>,
    /// The points of the rows, in row order.
    ids: Vec<u32>,
    /// Growth candidates at the start of each row.
    grow: Vec<u16>,
}

/// Step 3 for the segments `range`: for each, every other segment seen in its points'
/// K lists with the smallest squared distance, the K nearest by `(d², segment)` kept,
/// stored in the order step 6 pops them from the end: descending by d², and among
/// equal d² ascending by segment. `members` lists the points of segment `s` at
/// `seg_start[s]..seg_start[s + 1]`; `row(p)` is point `p`'s K list.
fn segment_neighbours<'r>(
    range: std::ops::Range<usize>,
    members: &[u32],
    seg_start: &[u32],
    seg: &[u32],
    pts: &[[f32; 3]],
    row: impl Fn(usize) -> &'r [u32],
    keep: usize,
) -> Vec<Vec<(f32, u32)>> {
    let mut best = vec![f32::MAX; seg_start.len() - 1];
    let mut touched: Vec<u32> = Vec::new();
    range
        .map(|s| {
            for &p in &members[seg_start[s] as usize..seg_start[s + 1] as usize] {
                let p = p as usize;
                for &q in row(p) {
                    let t = seg[q as usize];
                    if t as usize == s {
                        continue;
                    }
                    let d = squared_distance(&pts[p], &pts[q as usize]);
                    let b = &mut best[t as usize];
                    if *b == f32::MAX {
                        touched.push(t);
                    }
                    if d < *b {
                        *b = d;
                    }
                }
            }
            let mut list: Vec<(f32, u32)> = touched
                .iter()
                .map(|&t| (std::mem::replace(&mut best[t as usize], f32::MAX), t))
                .collect();
            touched.clear();
            list.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            list.truncate(keep);
            // Stored as a stack for step 6, which takes entries from the end in PCL's
            // order: ascending distance, and among equal distances the larger segment
            // first (PCL's list is the K nearest by (d², segment) reversed).
            list.reverse();
            for run in list.chunk_by_mut(|a, b| a.0 == b.0) {
                run.reverse();
            }
            list
        })
        .collect()
}

/// Segments `cloud` by colour (see the module docs). Needs colours; non-finite points get
/// [`UNSEGMENTED`].
pub fn region_growing_rgb(
    cloud: &PointCloud,
    params: &RegionGrowingParams,
) -> Result<Segmentation, SegmentError> {
    cloud.validate()?;
    check_params(params)?;
    let colors = cloud.colors.as_ref().ok_or(SegmentError::NoColors)?;
    let finite = cloud.finite_indices();
    let pts: Vec<[f32; 3]> = finite.iter().map(|&i| cloud.positions[i]).collect();
    // PERF: 3 bytes per point keep the colour lookups of the K lists in cache.
    let cols: Vec<[u8; 3]> = finite.iter().map(|&i| colors[i]).collect();
    let m = pts.len();
    let mut labels = vec![UNSEGMENTED; cloud.len()];
    if m == 0 {
        return Ok(Segmentation {
            segments: Vec::new(),
            labels,
            grown_segments: 0,
            colour_regions: 0,
        });
    }
    let squared = |t: f64| {
        let t = t as f32;
        t * t
    };
    let (p_thr, r_thr, d_thr) = (
        squared(params.point_color),
        squared(params.region_color),
        squared(params.distance_m),
    );
    let par = params.parallelism;
    // The K lists dominate (1.2 GB for 3M points at K = 100): refuse rather than abort
    // when they cannot fit. Per point: K indices, its place and counts, position, colour.
    crate::io::limits::check("points", m as u64, 4 * params.region_neighbours as u64 + 32)?;
    // Steps 1 and 2: the K lists, then region growing over their growth candidates.
    let lists = NeighbourLists::new(&pts, &cols, params, p_thr);
    let grown = Grown::new(m, |p| lists.grow_row(p));
    let n_seg = grown.seg_start.len() - 1;
    let seg_count: Vec<u32> = grown.seg_start.windows(2).map(|w| w[1] - w[0]).collect();

    // Step 3: segment adjacency, K nearest segments, stored as stacks (see
    // `segment_neighbours`).
    let chunk = 1024;
    let mut seg_nb: Vec<Vec<(f32, u32)>> =
        crate::search::map_range(n_seg.div_ceil(chunk), par, 1, |c| {
            segment_neighbours(
                c * chunk..((c + 1) * chunk).min(n_seg),
                &grown.members,
                &grown.seg_start,
                &grown.seg,
                &pts,
                |p| lists.row(p),
                params.region_neighbours,
            )
        })
        .into_iter()
        .flatten()
        .collect();
    drop(lists);

    // Steps 4 and 5: truncated mean colours, greedy colour merge.
    let seg_color = mean_colors(&grown.seg, &cols, &seg_count);
    let (seg_region, mut region_count) = colour_merge(
        &seg_nb,
        &seg_count,
        &seg_color,
        params.region_neighbours,
        d_thr,
        r_thr,
    );
    let n_reg = region_count.len();

    // Step 6: small-region merge on a union-find over regions.
    let mut parent: Vec<u32> = (0..n_reg as u32).collect();
    if params.merge_small {
        small_region_merge(
            &mut seg_nb,
            &seg_region,
            &mut region_count,
            &mut parent,
            params.min_cluster_size as u64,
        );
    }
    let final_region: Vec<u32> = (0..n_seg)
        .map(|s| find(&mut parent, seg_region[s]))
        .collect();

    // Step 7: assembly in region order, PCL's empty-slot swaps, size filter.
    let mut clusters: Vec<Vec<usize>> = vec![Vec::new(); n_reg];
    for (p, &s) in grown.seg.iter().enumerate() {
        clusters[final_region[s as usize] as usize].push(p);
    }
    remove_empty_like_pcl(&mut clusters);
    clusters.retain(|c| c.len() >= params.min_cluster_size && c.len() <= params.max_cluster_size);

    let segments: Vec<Segment> = clusters
        .into_iter()
        .enumerate()
        .map(|(label, c)| {
            let indices: Vec<usize> = c.iter().map(|&p| finite[p]).collect();
            for &i in &indices {
                labels[i] = label as u32;
            }
            describe(cloud, indices)
        })
        .collect();
    Ok(Segmentation {
        segments,
        labels,
        grown_segments: n_seg,
        colour_regions: n_reg,
    })
}

fn check_params(params: &RegionGrowingParams) -> Result<(), SegmentError> {
    check_distance("distance_m", params.distance_m)?;
    check_threshold("point_color", params.point_color)?;
    check_threshold("region_color", params.region_color)?;
    if params.region_neighbours == 0 || params.region_neighbours > MAX_REGION_NEIGHBOURS {
        return Err(SegmentError::InvalidCount {
            name: "region_neighbours",
            value: params.region_neighbours,
            min: 1,
            max: MAX_REGION_NEIGHBOURS,
        });
    }
    Ok(())
}

/// Step 1: the K nearest neighbours of every point, stored as indices (4 bytes per
/// point and neighbour; PCL stores 8). The first `grow_n` of a K list are the `grow_n`
/// nearest (the order is total); the growth only needs them as a set filtered by the
/// point colour test (which points it reaches does not depend on their order), so those
/// are moved to the front, and their number kept.
struct NeighbourLists {
    /// The search's chunks of rows.
    lists: Vec<KLists>,
    /// Where each point's row is: (chunk, row within the chunk).
    loc: Vec<(u32, u32)>,
    /// Neighbours per row.
    k: usize,
}

impl NeighbourLists {
    fn new(
        pts: &[[f32; 3]],
        cols: &[[u8; 3]],
        params: &RegionGrowingParams,
        p_thr: f32,
    ) -> NeighbourLists {
        let search = KnnSearch::new(pts, params.region_neighbours);
        let k = search.k();
        let grow_n = params.neighbours.min(k);
        let lists = search.knn(
            params.parallelism,
            || KLists {
                rows: Vec::new(),
                ids: Vec::new(),
                grow: Vec::new(),
            },
            |out: &mut KLists, i, words| {
                let c = cols[i as usize].map(u32::from);
                let passes =
                    |w: u64| color_dist2(c, cols[word_index(w) as usize].map(u32::from)) <= p_thr;
                // The `grow_n` nearest first (words are distinct, so they are exact), then
                // the colour-compatible among them first (their order does not matter).
                let near = if grow_n < words.len() {
                    words.select_nth_unstable(grow_n - 1);
                    grow_n
                } else {
                    words.len()
                };
                let mut n_grow = 0;
                for j in 0..near {
                    if passes(words[j]) {
                        words.swap(n_grow, j);
                        n_grow += 1;
                    }
                }
                out.grow.push(n_grow as u16);
                let start = out.rows.len();
                out.rows.extend(words.iter().map(|&w| word_index(w)));
                // Every finite point has k neighbours; pad defensively with itself.
                out.rows.resize(start + k, i);
                out.ids.push(i);
            },
        );
        let mut loc = vec![(0u32, 0u32); pts.len()];
        for (c, l) in lists.iter().enumerate() {
            for (r, &i) in l.ids.iter().enumerate() {
                loc[i as usize] = (c as u32, r as u32);
            }
        }
        NeighbourLists { lists, loc, k }
    }

    /// Point `p`'s K list.
    fn row(&self, p: usize) -> &[u32] {
        let (c, r) = self.loc[p];
        let (r, k) = (r as usize, self.k);
        &self.lists[c as usize].rows[r * k..(r + 1) * k]
    }

    /// Point `p`'s growth candidates.
    fn grow_row(&self, p: usize) -> &[u32] {
        let (c, r) = self.loc[p];
        let l = &self.lists[c as usize];
        let (r, k) = (r as usize, self.k);
        &l.rows[r * k..r * k + l.grow[r] as usize]
    }
}

/// Step 2's segments: region growing, breadth first.
struct Grown {
    /// Per point: its segment.
    seg: Vec<u32>,
    /// The growth queue, which ends up holding every segment's points together.
    members: Vec<u32>,
    /// Segment `s`'s points are `members[seg_start[s]..seg_start[s + 1]]`.
    seg_start: Vec<u32>,
}

impl Grown {
    /// Grows segments over `m` points, from each point not yet reached, through the
    /// growth candidates `grow_row(point)`.
    fn new<'r>(m: usize, grow_row: impl Fn(usize) -> &'r [u32]) -> Grown {
        let mut seg = vec![u32::MAX; m];
        let mut members: Vec<u32> = Vec::with_capacity(m);
        let mut seg_start: Vec<u32> = Vec::new();
        for seed in 0..m {
            if seg[seed] != u32::MAX {
                continue;
            }
            let s = seg_start.len() as u32;
            let mut head = members.len();
            seg_start.push(head as u32);
            seg[seed] = s;
            members.push(seed as u32);
            while head < members.len() {
                let cur = members[head] as usize;
                head += 1;
                for &q in grow_row(cur) {
                    if seg[q as usize] == u32::MAX {
                        seg[q as usize] = s;
                        members.push(q);
                    }
                }
            }
        }
        seg_start.push(m as u32);
        Grown {
            seg,
            members,
            seg_start,
        }
    }
}

/// Step 4: each segment's mean colour, truncated to integers as PCL does.
fn mean_colors(seg: &[u32], cols: &[[u8; 3]], seg_count: &[u32]) -> Vec<[u32; 3]> {
    let mut sums = vec![[0u32; 3]; seg_count.len()];
    for (p, &s) in seg.iter().enumerate() {
        for c in 0..3 {
            sums[s as usize][c] = sums[s as usize][c].wrapping_add(u32::from(cols[p][c]));
        }
    }
    sums.iter()
        .zip(seg_count)
        .map(|(sum, &n)| sum.map(|v| (v as f32 / n as f32) as u32))
        .collect()
}

/// Step 5: greedy colour merge. Each segment not yet in a region starts one; its `keep`
/// nearest segments within `d_thr` (squared) that are in no region yet and whose colour
/// is within `r_thr` (squared) join it. Returns each segment's region and each region's
/// point count.
fn colour_merge(
    seg_nb: &[Vec<(f32, u32)>],
    seg_count: &[u32],
    seg_color: &[[u32; 3]],
    keep: usize,
    d_thr: f32,
    r_thr: f32,
) -> (Vec<u32>, Vec<u64>) {
    let n_seg = seg_count.len();
    let mut seg_region = vec![u32::MAX; n_seg];
    let mut region_count: Vec<u64> = Vec::new();
    for i in 0..n_seg {
        let cur = if seg_region[i] == u32::MAX {
            let r = region_count.len() as u32;
            seg_region[i] = r;
            region_count.push(seg_count[i] as u64);
            r
        } else {
            seg_region[i]
        };
        for &(d, j) in seg_nb[i].iter().take(keep) {
            let j = j as usize;
            if d > d_thr || seg_region[j] != u32::MAX {
                continue;
            }
            if color_dist2(seg_color[i], seg_color[j]) < r_thr {
                seg_region[j] = cur;
                region_count[cur as usize] += seg_count[j] as u64;
            }
        }
    }
    (seg_region, region_count)
}

/// Size, mean colour and bounding box of a set of input indices.
pub(crate) fn describe(cloud: &PointCloud, indices: Vec<usize>) -> Segment {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    let mut sum = [0f64; 3];
    for &i in &indices {
        let p = cloud.positions[i];
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
        if let Some(c) = &cloud.colors {
            for a in 0..3 {
                sum[a] += c[i][a] as f64;
            }
        }
    }
    let n = indices.len().max(1) as f64;
    Segment {
        mean_color: sum.map(|s| (s / n) as f32),
        min: lo,
        max: hi,
        indices,
    }
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    let mut root = x;
    while parent[root as usize] != root {
        root = parent[root as usize];
    }
    while parent[x as usize] != root {
        let next = parent[x as usize];
        parent[x as usize] = root;
        x = next;
    }
    root
}

/// One entry of a region's heap: a segment of the region whose stack of neighbours is not
/// empty, keyed by the squared distance of its stack's top entry and then by the segment
/// (a distance is `≥ +0`, so its bits order like its value), packed into one integer.
type HeapEntry = Reverse<u64>;

fn heap_entry(d: f32, s: usize) -> HeapEntry {
    Reverse(((d.to_bits() as u64) << 32) | s as u64)
}

/// PCL's step 8. PCL gives every region the concatenation of its segments' neighbour
/// lists (in segment order), sorted by distance with ties in that order, and replaces
/// entries that point into the region by a `(FLT_MAX, 0)` sentinel. The same order
/// comes from a heap over the region's segments, each segment's list a stack popped in
/// that order (see `segment_neighbours`): the heap's top is the region's nearest entry,
/// entries into the region itself are popped lazily, and merging regions appends heaps.
/// PERF: the heaps hold one entry per segment, not one per neighbour entry.
fn small_region_merge(
    seg_nb: &mut [Vec<(f32, u32)>],
    seg_region: &[u32],
    region_count: &mut [u64],
    parent: &mut [u32],
    min_size: u64,
) {
    let n_reg = region_count.len();
    // Sizes only grow, so a region at least `min_size` large is never examined: its
    // heap is never read and is not built.
    let mut entries: Vec<Vec<HeapEntry>> = vec![Vec::new(); n_reg];
    for (s, list) in seg_nb.iter().enumerate() {
        let r = seg_region[s] as usize;
        if region_count[r] >= min_size {
            continue;
        }
        if let Some(&(d, _)) = list.last() {
            entries[r].push(heap_entry(d, s));
        }
    }
    let mut heaps: Vec<BinaryHeap<HeapEntry>> = entries.into_iter().map(BinaryHeap::from).collect();
    for r in 0..n_reg {
        if region_count[r] >= min_size {
            continue;
        }
        // Nearest entry whose segment is not in r (r is a root: only earlier regions
        // have merged away).
        let target = loop {
            let Some(mut top) = heaps[r].peek_mut() else {
                break None;
            };
            let s = top.0 as u32 as usize;
            let stack = &mut seg_nb[s];
            let Some(&(_, t)) = stack.last() else {
                PeekMut::pop(top); // not reached: a segment in a heap has entries left
                continue;
            };
            let owner = find(parent, seg_region[t as usize]);
            if owner as usize != r {
                break Some(owner);
            }
            stack.pop();
            match stack.last() {
                Some(&(d, _)) => *top = heap_entry(d, s),
                None => {
                    PeekMut::pop(top);
                }
            }
        };
        let Some(target) = target else {
            continue;
        };
        parent[r] = target;
        region_count[target as usize] += region_count[r];
        region_count[r] = 0;
        let mut moved = std::mem::take(&mut heaps[r]);
        if (target as usize) < r || region_count[target as usize] >= min_size {
            continue; // the target is never examined again: its heap is dead
        }
        let tgt = &mut heaps[target as usize];
        if moved.len() > tgt.len() {
            std::mem::swap(&mut moved, tgt);
        }
        tgt.append(&mut moved);
    }
}

/// PCL's `assembleRegions` removal of empty clusters: the first empty slot takes the last
/// non-empty cluster, and so on; trailing empties are dropped.
fn remove_empty_like_pcl(clusters: &mut Vec<Vec<usize>>) {
    if clusters.is_empty() {
        return;
    }
    let mut i1 = 0usize;
    let mut i2 = clusters.len() - 1;
    while i1 < i2 {
        while !clusters[i1].is_empty() && i1 < i2 {
            i1 += 1;
        }
        while clusters[i2].is_empty() && i1 < i2 {
            i2 -= 1;
        }
        if i1 != i2 {
            clusters.swap(i1, i2);
        }
    }
    if clusters[i2].is_empty() {
        clusters.truncate(i2);
    }
}

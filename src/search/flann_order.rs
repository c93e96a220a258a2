//! A k-NN search that returns exactly what PCL's `KdTreeFLANN` returns, ties included.
//!
//! PCL's `pcl::search::KdTree` (used by `NormalEstimation` and most PCL stages) asks
//! FLANN 1.9's `KDTreeSingleIndex<L2_Simple<float>>`, built with at most 15 points per
//! leaf over the finite points of the cloud (in cloud order; indices are mapped back to
//! cloud indices). When several points lie at exactly the k-th squared distance (common
//! on an organised sensor grid), the k nearest are not defined by distance alone and
//! FLANN keeps the one it visits first: its `KNNSimpleResultSet` (used for k ≤ 250)
//! rejects a candidate whose distance is not strictly below the current k-th. The
//! visiting order is that of FLANN's tree, so reproducing the choice needs that tree
//! rebuilt point for point. [`FlannTree`] does that, in the same `f32` arithmetic:
//!
//! - build (`divideTree` / `middleSplit`): a node with at most 15 points is a leaf.
//!   Otherwise the split dimension is the widest of the node's *approximate* bounding box
//!   (the parent's box cut at the parent's split value; first dimension on equal spans),
//!   replaced by another dimension only if that one's *actual* spread over the node's
//!   points is larger; the split value is the middle of the actual min and max on that
//!   dimension. A three-way partition (`planeSplit`) puts the points `< cut` first, then
//!   `== cut`, then `> cut` (two Hoare-style passes whose swaps decide the order inside
//!   each leaf); the split index is the end of the `<` block if that is beyond half, the
//!   end of the `≤` block if that is before half, else half. An inner node stores the
//!   actual max of its first child and the actual min of its second on the split
//!   dimension; a node's box becomes the union of its children's actual boxes.
//! - search (`searchLevel`): descend into the child on the query's side of the two
//!   stored bounds first (first child when `(q − lo) + (q − hi) < 0`), then visit the other
//!   child when the incrementally updated lower bound `mindist + cut² − old` is `≤` the
//!   current k-th distance (`eps` = 0). In a leaf, points are scanned in the leaf's
//!   order; squared distances are `(dx² + dy²) + dz²` in `f32`. The result is sorted by
//!   distance, equal distances in the order they were found.
//!
//! PERF: building the tree costs a partition of all points per level, so callers use
//! it only for the queries whose answer is ambiguous (a tie at the k-th distance); the
//! others take the unique k nearest from the faster grid search.
//!
//! ```
//! use softsense::search::FlannTree;
//! // A point with two neighbours at distance 1: FLANN keeps the one in the subtree it
//! // descends into first (here the one at x = 12, index 2), not the smaller index.
//! let mut pts: Vec<[f32; 3]> = vec![[10.0, 0.0, 0.0], [11.0, 0.0, 0.0], [12.0, 0.0, 0.0]];
//! pts.extend((0..7).map(|x| [x as f32, 0.0, 0.0]));
//! pts.extend((16..22).map(|x| [x as f32, 0.0, 0.0]));
//! let tree = FlannTree::build(&pts);
//! let nn: Vec<usize> = tree.nearest_k(&pts[1], 2).iter().map(|n| n.index).collect();
//! assert_eq!(nn, vec![1, 2]);
//! ```

use super::{squared_distance, Neighbour, Parallelism};
use crate::cloud::PointCloud;

/// FLANN's leaf size as PCL sets it (`KDTreeSingleIndexParams(15)`).
const LEAF_MAX: usize = 15;

/// Subtrees with at least this many points are built in parallel (when asked).
const PAR_MIN: usize = 16_384;

/// Per dimension `[low, high]`.
type BBox = [[f32; 2]; 3];

/// A point of FLANN's dataset and its index in the cloud.
type Item = ([f32; 3], u32);

enum Node {
    /// Points `left..right` of the reordered arrays.
    Leaf { left: u32, right: u32 },
    Inner {
        /// Split dimension.
        feat: u8,
        /// Actual max of the first child's points on `feat`.
        lo: f32,
        /// Actual min of the second child's points on `feat`.
        hi: f32,
        children: Box<(Node, Node)>,
    },
}

/// FLANN 1.9's single KD-tree as PCL 1.13's `KdTreeFLANN` builds it; see the module docs.
pub struct FlannTree {
    /// Finite points with their cloud indices, in the tree's (reordered) order.
    data: Vec<Item>,
    root: Option<Node>,
    bbox: BBox,
}

impl FlannTree {
    /// Builds the tree over the finite points of `positions` (serially).
    pub fn build(positions: &[[f32; 3]]) -> FlannTree {
        FlannTree::build_with(positions, Parallelism::Serial)
    }

    /// Builds the tree; with [`Parallelism::Rayon`] large subtrees are built on separate
    /// threads (the tree is the same).
    pub fn build_with(positions: &[[f32; 3]], par: Parallelism) -> FlannTree {
        // FLANN's dataset: the finite points in cloud order (PCL's index mapping), each
        // with its cloud index. PERF: the build permutes these pairs where FLANN
        // permutes an index array, so the partitions read memory sequentially; the
        // sequence of swaps, hence the resulting order, is FLANN's.
        let mut items: Vec<Item> = positions
            .iter()
            .enumerate()
            .filter(|(_, p)| PointCloud::is_finite_point(p))
            .map(|(i, p)| (*p, i as u32))
            .collect();
        if items.is_empty() {
            return FlannTree {
                data: Vec::new(),
                root: None,
                bbox: [[0.0; 2]; 3],
            };
        }
        let mut bbox = actual_box(&items);
        let root = divide(&mut items, 0, &mut bbox, par == Parallelism::Rayon);
        FlannTree {
            data: items,
            root: Some(root),
            bbox,
        }
    }

    /// Number of points in the tree.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the tree holds no point.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The `k` nearest points to `query` (a finite point) as FLANN returns them for
    /// PCL's `nearestKSearch`: sorted by squared distance, equal distances in the order
    /// FLANN found them (so a tie at the k-th distance keeps the first found). `k` is
    /// capped at the number of points, as PCL does.
    pub fn nearest_k(&self, query: &[f32; 3], k: usize) -> Vec<Neighbour> {
        let k = k.min(self.data.len());
        let Some(root) = &self.root else {
            return Vec::new();
        };
        if k == 0 {
            return Vec::new();
        }
        let mut res = SimpleResultSet::new(k);
        // computeInitialDistances: the query's squared distance to the root box.
        let mut dists = [0f32; 3];
        let mut distsq = 0f32;
        for d in 0..3 {
            if query[d] < self.bbox[d][0] {
                dists[d] = accum(query[d], self.bbox[d][0]);
                distsq += dists[d];
            }
            if query[d] > self.bbox[d][1] {
                dists[d] = accum(query[d], self.bbox[d][1]);
                distsq += dists[d];
            }
        }
        self.search(&mut res, query, root, distsq, &mut dists);
        res.items
            .into_iter()
            .take(res.count)
            .map(|(d, j)| Neighbour {
                index: self.data[j as usize].1 as usize,
                squared_distance: d,
            })
            .collect()
    }

    fn search(
        &self,
        res: &mut SimpleResultSet,
        q: &[f32; 3],
        node: &Node,
        mindistsq: f32,
        dists: &mut [f32; 3],
    ) {
        match node {
            Node::Leaf { left, right } => {
                // FLANN reads the k-th distance once per leaf; the result set re-checks.
                let worst = res.worst;
                for j in *left..*right {
                    let d = squared_distance(q, &self.data[j as usize].0);
                    if d < worst {
                        res.add(d, j);
                    }
                }
            }
            Node::Inner {
                feat,
                lo,
                hi,
                children,
            } => {
                let f = *feat as usize;
                let val = q[f];
                let (diff1, diff2) = (val - lo, val - hi);
                let (best, other, cut) = if diff1 + diff2 < 0.0 {
                    (&children.0, &children.1, accum(val, *hi))
                } else {
                    (&children.1, &children.0, accum(val, *lo))
                };
                self.search(res, q, best, mindistsq, dists);
                let dst = dists[f];
                let mindistsq = mindistsq + cut - dst;
                dists[f] = cut;
                if mindistsq <= res.worst {
                    self.search(res, q, other, mindistsq, dists);
                }
                dists[f] = dst;
            }
        }
    }
}

/// FLANN's `accum_dist` for `L2_Simple<float>`.
#[inline]
fn accum(a: f32, b: f32) -> f32 {
    (a - b) * (a - b)
}

/// FLANN's `KNNSimpleResultSet`: a sorted array of capacity `k`; a candidate must be
/// strictly closer than the k-th (`f32::MAX` until full) and goes after equal distances.
struct SimpleResultSet {
    items: Vec<(f32, u32)>,
    count: usize,
    worst: f32,
}

impl SimpleResultSet {
    fn new(k: usize) -> Self {
        SimpleResultSet {
            items: vec![(f32::MAX, u32::MAX); k],
            count: 0,
            worst: f32::MAX,
        }
    }

    fn add(&mut self, d: f32, j: u32) {
        if d >= self.worst {
            return;
        }
        let cap = self.items.len();
        if self.count < cap {
            self.count += 1;
        }
        let mut i = self.count - 1;
        while i > 0 && self.items[i - 1].0 > d {
            self.items[i] = self.items[i - 1];
            i -= 1;
        }
        self.items[i] = (d, j);
        self.worst = self.items[cap - 1].0;
    }
}

/// `divideTree` over `items` (the node's slice of the permuted dataset, `offset` its
/// start in the whole array). On return `bbox` is the actual box of the node's points.
/// Recursion depth is the tree depth: logarithmic in the point count, except that
/// lopsided splits may add levels, each of which halves a spread; `f32`'s exponent range
/// bounds those to under a thousand.
fn divide(items: &mut [Item], offset: u32, bbox: &mut BBox, par: bool) -> Node {
    let count = items.len();
    if count <= LEAF_MAX {
        return divide_leaf(items, offset, bbox);
    }
    let (idx, feat, cut) = middle_split(items, bbox);
    if idx == 0 || idx == count {
        // Only when `(min + max) / 2` overflows to infinity (coordinates near
        // `f32::MAX`), where FLANN's own assertion would fail: stop splitting.
        return divide_leaf(items, offset, bbox);
    }
    let mut left_box = *bbox;
    left_box[feat][1] = cut;
    let mut right_box = *bbox;
    right_box[feat][0] = cut;
    let (lv, rv) = items.split_at_mut(idx);
    let roff = offset + idx as u32;
    let (c1, c2) = if par && count >= PAR_MIN {
        join(
            || divide(lv, offset, &mut left_box, par),
            || divide(rv, roff, &mut right_box, par),
        )
    } else {
        (
            divide(lv, offset, &mut left_box, par),
            divide(rv, roff, &mut right_box, par),
        )
    };
    for d in 0..3 {
        bbox[d][0] = left_box[d][0].min(right_box[d][0]);
        bbox[d][1] = left_box[d][1].max(right_box[d][1]);
    }
    Node::Inner {
        feat: feat as u8,
        lo: left_box[feat][1],
        hi: right_box[feat][0],
        children: Box::new((c1, c2)),
    }
}

#[cfg(feature = "parallel")]
fn join<A: Send, B: Send>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B + Send) -> (A, B) {
    rayon::join(a, b)
}

#[cfg(not(feature = "parallel"))]
fn join<A, B>(a: impl FnOnce() -> A, b: impl FnOnce() -> B) -> (A, B) {
    (a(), b())
}

/// A leaf over `items`; sets `bbox` to its points' actual box.
fn divide_leaf(items: &[Item], offset: u32, bbox: &mut BBox) -> Node {
    *bbox = actual_box(items);
    Node::Leaf {
        left: offset,
        right: offset + items.len() as u32,
    }
}

/// Actual min and max of the points on every dimension (FLANN's `computeMinMax` and
/// leaf box, in one pass: the values do not depend on how they are gathered).
fn actual_box(items: &[Item]) -> BBox {
    #[cfg(target_arch = "x86_64")]
    {
        let bbox = actual_box_sse(items);
        // Equal up to the sign of a zero (`==`), checked in every debug test run.
        debug_assert!(bbox == actual_box_portable(items));
        bbox
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        actual_box_portable(items)
    }
}

/// [`actual_box`] with branches (equal values keep the first, as FLANN's `<` and `>`).
fn actual_box_portable(items: &[Item]) -> BBox {
    let first = items[0].0;
    let mut bbox = [
        [first[0], first[0]],
        [first[1], first[1]],
        [first[2], first[2]],
    ];
    for (p, _) in &items[1..] {
        for d in 0..3 {
            if p[d] < bbox[d][0] {
                bbox[d][0] = p[d];
            }
            if p[d] > bbox[d][1] {
                bbox[d][1] = p[d];
            }
        }
    }
    bbox
}

/// [`actual_box`] four lanes at a time: an item (`[f32; 3]` and a `u32`, 16 bytes) is one
/// SSE register, whose fourth lane is ignored. PERF: the branches of the portable loop
/// were 60% of the tree build. Bounds can differ from it only in the sign of a zero
/// (`minps` returns its second operand for `±0`), which no comparison or distance of
/// the build or the search can see.
#[cfg(target_arch = "x86_64")]
fn actual_box_sse(items: &[Item]) -> BBox {
    use std::arch::x86_64::*;
    const _: () = assert!(std::mem::size_of::<Item>() == 16 && std::mem::offset_of!(Item, 0) == 0);
    let ptr = items.as_ptr() as *const f32;
    // SAFETY: SSE is part of the x86-64 baseline; `Item` is 16 bytes with the three
    // coordinates at offset 0 (both checked at compile time above), so item `j` is the
    // four floats at `ptr + 4 j`, all inside the slice, and `loadu` needs no alignment.
    // The fourth lane (the index's bits) is never read back.
    unsafe {
        let mut lo = [_mm_loadu_ps(ptr); 2];
        let mut hi = lo;
        let n = items.len();
        let mut j = 1;
        while j + 1 < n {
            let (a, b) = (
                _mm_loadu_ps(ptr.add(4 * j)),
                _mm_loadu_ps(ptr.add(4 * j + 4)),
            );
            lo[0] = _mm_min_ps(lo[0], a);
            hi[0] = _mm_max_ps(hi[0], a);
            lo[1] = _mm_min_ps(lo[1], b);
            hi[1] = _mm_max_ps(hi[1], b);
            j += 2;
        }
        if j < n {
            let a = _mm_loadu_ps(ptr.add(4 * j));
            lo[0] = _mm_min_ps(lo[0], a);
            hi[0] = _mm_max_ps(hi[0], a);
        }
        let (mut l, mut h) = ([0f32; 4], [0f32; 4]);
        _mm_storeu_ps(l.as_mut_ptr(), _mm_min_ps(lo[0], lo[1]));
        _mm_storeu_ps(h.as_mut_ptr(), _mm_max_ps(hi[0], hi[1]));
        [[l[0], h[0]], [l[1], h[1]], [l[2], h[2]]]
    }
}

/// FLANN's `middleSplit` (the one `divideTree` calls): returns the split index within
/// `items` (which it partitions), the dimension and the cut value.
fn middle_split(items: &mut [Item], bbox: &BBox) -> (usize, usize, f32) {
    // Widest dimension of the approximate box, the first on equal spans.
    let mut max_span = bbox[0][1] - bbox[0][0];
    let mut feat = 0;
    for (d, b) in bbox.iter().enumerate().skip(1) {
        let span = b[1] - b[0];
        if span > max_span {
            max_span = span;
            feat = d;
        }
    }
    // PERF: FLANN scans the points once per dimension it examines; one scan gives all.
    let actual = actual_box(items);
    let [lo, hi] = actual[feat];
    let mut cut = (lo + hi) / 2.0;
    max_span = hi - lo;
    // Another dimension whose approximate span exceeds that actual spread may win on
    // its own actual spread.
    let first = feat;
    for (d, b) in bbox.iter().enumerate() {
        if d == first {
            continue;
        }
        if b[1] - b[0] > max_span {
            let [lo, hi] = actual[d];
            let span = hi - lo;
            if span > max_span {
                max_span = span;
                feat = d;
                cut = (lo + hi) / 2.0;
            }
        }
    }
    let (lim1, lim2) = plane_split(items, feat, cut);
    let count = items.len();
    let idx = if lim1 > count / 2 {
        lim1
    } else if lim2 < count / 2 {
        lim2
    } else {
        count / 2
    };
    (idx, feat, cut)
}

/// FLANN's `planeSplit`: `< cut` first, then `== cut`, then `> cut`, with its exact
/// swap sequence. Returns the ends of the first two blocks.
fn plane_split(items: &mut [Item], feat: usize, cut: f32) -> (usize, usize) {
    let lim1 = partition_pass(items, 0, |p| p[feat] < cut);
    let lim2 = partition_pass(items, lim1, |p| p[feat] <= cut);
    (lim1, lim2)
}

/// One pass of `planeSplit` over `items[start..]`: a cursor from the start skips points
/// that belong in front, one from the end skips points that do not, and each
/// out-of-place pair is swapped. Returns where the front block ends.
fn partition_pass(items: &mut [Item], start: usize, front: impl Fn(&[f32; 3]) -> bool) -> usize {
    // Signed cursors as in FLANN (`right` may drop to -1).
    let mut left = start as isize;
    let mut right = items.len() as isize - 1;
    loop {
        while left <= right && front(&items[left as usize].0) {
            left += 1;
        }
        while left <= right && !front(&items[right as usize].0) {
            right -= 1;
        }
        if left > right {
            return left as usize;
        }
        items.swap(left as usize, right as usize);
        left += 1;
        right -= 1;
    }
}

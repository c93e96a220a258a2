//! Exact k nearest neighbours of every point of a cloud at once, on a uniform grid: the
//! one grid k-NN of the crate ([`map_knn`], [`knn_all`] and the region growing use it).
//!
//! Dense sensor clouds put a handful of points in every cell of a grid whose edge is a
//! little more than the k-th neighbour distance. The points are sorted by cell (radix
//! sort of packed keys); for each occupied cell, the points of the 3x3x3 block around
//! it are gathered once into a structure-of-arrays copy and every point of the cell
//! computes its distances to all of them and picks its k closest. Only candidates
//! closer than the block boundary (with a relative margin far above `f32` rounding)
//! compete: when at least k of them exist, they are provably the k nearest of the whole
//! cloud, since every point outside the block is farther. Otherwise the point is tried
//! again on the 5x5x5 block, and so on up to [`RINGS`], and then a KD-tree built on
//! first need answers, with the same tie rule.
//!
//! Result: for each point, its k nearest finite points (itself included) by
//! `(squared distance, index)`; a tie at the k-th place goes to the smaller index, so
//! the answer is unique, equal to a brute-force selection, and independent of threads
//! and of the chunking. Distances are [`squared_distance`] (`f32`, FLANN's order).

use super::sort::{bits_for, radix_sort_packed, with_word_buffers};
use super::{squared_distance, KdTree, Neighbour, Parallelism, RadiusQuery};
use crate::cloud::PointCloud;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

/// Relative margin between the k-th squared distance and the squared distance to the
/// block boundary; `f32` distance rounding is below 1e-6 relative.
pub(crate) const MARGIN: f64 = 1e-4;

/// About how many points [`Grid::build`] samples to choose a large cloud's cell size.
const SAMPLE: usize = 32_768;

/// Largest block radius (in cells) tried before asking the tree. PERF: the tree costs
/// a build over the whole cloud (about 8 ms for a 640x480 frame); the dozen isolated
/// points of such a frame that blocks up to 9x9x9 cells could not answer are answered
/// by blocks up to 17x17x17 for far less.
const RINGS: u64 = 8;

/// A neighbour as one word, `(d² bits << 32) | index`. A squared distance is `≥ +0` and
/// never NaN here, so its bits order like its value and the words order like
/// `(squared distance, index)`: one `u64` comparison replaces a tuple comparison.
#[inline]
pub(crate) fn pack(d2: f32, index: u32) -> u64 {
    ((d2.to_bits() as u64) << 32) | index as u64
}

/// The index of a packed neighbour word.
#[inline]
pub(crate) fn word_index(w: u64) -> u32 {
    w as u32
}

/// The squared distance of a packed neighbour word.
#[inline]
pub(crate) fn word_d2(w: u64) -> f32 {
    f32::from_bits((w >> 32) as u32)
}

/// Row-major `n x k` neighbour indices and squared distances.
pub struct KnnTable {
    /// Neighbours per row.
    pub k: usize,
    /// Indices, `n * k`.
    pub idx: Vec<u32>,
    /// Squared distances, `n * k`.
    pub d2: Vec<f32>,
}

/// k nearest neighbours (self included) of every point of `pts`, as a table sorted by
/// `(squared distance, index)` per row (`k` is capped at the number of finite points;
/// rows of non-finite points hold index 0 at distance `f32::MAX`).
///
/// ```
/// use softsense::search::{knn_all, Parallelism};
/// let pts = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
/// let t = knn_all(&pts, 2, Parallelism::Serial);
/// assert_eq!(t.idx, vec![0, 1, 1, 0, 2, 1]);
/// ```
pub fn knn_all(pts: &[[f32; 3]], k: usize, par: Parallelism) -> KnnTable {
    let search = KnnSearch::new(pts, k);
    let k = search.k();
    let parts = search.knn(par, Vec::new, |rows: &mut Vec<(u32, u64)>, i, words| {
        words.sort_unstable();
        rows.extend(words.iter().map(|&w| (i, w)));
    });
    let mut idx = vec![0u32; pts.len() * k];
    let mut d2 = vec![f32::MAX; pts.len() * k];
    for part in parts {
        for row in part.chunks(k.max(1)) {
            let i = row[0].0 as usize;
            for (j, &(_, w)) in row.iter().enumerate() {
                idx[i * k + j] = word_index(w);
                d2[i * k + j] = word_d2(w);
            }
        }
    }
    KnnTable { k, idx, d2 }
}

/// Calls `f(i, neighbours)` for every point `i` of `positions` with its `k` nearest
/// finite points sorted by `(squared distance, index)` (fewer when the cloud has fewer
/// finite points; none for a non-finite point), and returns the results in input order.
///
/// ```
/// use softsense::search::{map_knn, Parallelism};
/// let pts = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0]];
/// let nn = map_knn(&pts, 2, Parallelism::Serial, |_, nb| nb.iter().map(|n| n.index).collect::<Vec<_>>());
/// assert_eq!(nn, vec![vec![0, 1], vec![1, 0], vec![2, 1], vec![]]); // 1's tie: 0 before 2
/// ```
pub fn map_knn<T, F>(positions: &[[f32; 3]], k: usize, par: Parallelism, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &[Neighbour]) -> T + Sync + Send,
{
    map_knn_with(&KnnSearch::new(positions, k), par, f)
}

/// [`map_knn`] over an index built beforehand (for instance while another thread did
/// other work).
pub(crate) fn map_knn_with<T, F>(search: &KnnSearch, par: Parallelism, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize, &[Neighbour]) -> T + Sync + Send,
{
    let positions = search.positions;
    // Every point starts with the answer for "no neighbours" (what non-finite points
    // keep); finite points are overwritten below.
    let mut out: Vec<T> = (0..positions.len()).map(|i| f(i, &[])).collect();
    let parts = search.knn(
        par,
        || (Vec::new(), Vec::new()),
        |(res, nb): &mut (Vec<(u32, T)>, Vec<Neighbour>), i, words| {
            words.sort_unstable();
            nb.clear();
            nb.extend(words.iter().map(|&w| Neighbour {
                index: word_index(w) as usize,
                squared_distance: word_d2(w),
            }));
            res.push((i, f(i as usize, nb)));
        },
    );
    for (i, t) in parts.into_iter().flat_map(|p| p.0) {
        out[i as usize] = t;
    }
    out
}

/// The points of a block of cells as a structure of arrays (distances to all of them
/// vectorise).
pub(crate) struct Block {
    /// x coordinates.
    pub x: Vec<f32>,
    /// y coordinates.
    pub y: Vec<f32>,
    /// z coordinates.
    pub z: Vec<f32>,
    /// Point indices.
    pub id: Vec<u32>,
}

impl Block {
    fn new() -> Block {
        Block {
            x: Vec::new(),
            y: Vec::new(),
            z: Vec::new(),
            id: Vec::new(),
        }
    }

    fn clear(&mut self) {
        self.x.clear();
        self.y.clear();
        self.z.clear();
        self.id.clear();
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// [`squared_distance`] from `q` to every point, into `out`.
    pub fn distances(&self, q: &[f32; 3], out: &mut Vec<f32>) {
        out.clear();
        out.extend(
            self.x
                .iter()
                .zip(&self.y)
                .zip(&self.z)
                .map(|((&x, &y), &z)| squared_distance(q, &[x, y, z])),
        );
    }
}

/// Per-chunk scratch of the k-NN kernel.
struct Scratch {
    d2: Vec<f32>,
    words: Vec<u64>,
    /// The last point answered from a block and its k-th distance (not squared).
    last: Option<([f32; 3], f64)>,
    /// Whether the kernel runs its AVX2 code: decided once per chunk, not per query.
    avx2: bool,
}

impl Default for Scratch {
    fn default() -> Self {
        #[cfg(target_arch = "x86_64")]
        let avx2 = !PORTABLE.load(Ordering::Relaxed) && std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        Self {
            d2: Vec::new(),
            words: Vec::new(),
            last: None,
            avx2,
        }
    }
}

/// The exact k nearest neighbours of every finite point of a cloud, chunk by chunk of
/// grid cells; the grid (or, without one, the tree) is built once and serves several
/// passes ([`KnnSearch::knn`], [`KnnSearch::scan`]).
pub(crate) struct KnnSearch<'a> {
    positions: &'a [[f32; 3]],
    finite: Vec<u32>,
    k: usize,
    grid: Option<Grid>,
    tree: OnceLock<KdTree>,
}

impl<'a> KnnSearch<'a> {
    /// Indexes the finite points of `positions` for `k`-NN queries (`k` is capped at
    /// the number of finite points).
    pub(crate) fn new(positions: &'a [[f32; 3]], k: usize) -> KnnSearch<'a> {
        let finite: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| PointCloud::is_finite_point(&positions[i as usize]))
            .collect();
        let k = k.min(finite.len());
        let grid = if k == 0 {
            None
        } else {
            Grid::build(positions, &finite, k)
        };
        KnnSearch {
            positions,
            finite,
            k,
            grid,
            tree: OnceLock::new(),
        }
    }

    /// The number of neighbours each finite point gets.
    pub(crate) fn k(&self) -> usize {
        self.k
    }

    fn tree(&self) -> &KdTree {
        self.tree.get_or_init(|| KdTree::build(self.positions))
    }

    /// Calls `visit(state, i, words)` for every finite point `i` with its k nearest as
    /// packed words ([`pack`]), in no particular order (the slice may be reordered);
    /// `make` gives each chunk its state, and the states come back in chunk order (the
    /// chunking depends on the cloud only, never on the thread count).
    pub(crate) fn knn<S, M, V>(&self, par: Parallelism, make: M, visit: V) -> Vec<S>
    where
        S: Send,
        M: Fn() -> S + Sync,
        V: Fn(&mut S, u32, &mut [u64]) + Sync,
    {
        let k = self.k;
        let parts = self.scan(
            par,
            || (make(), Scratch::default()),
            |(s, sc), i, blk, margin| {
                let q = &self.positions[i as usize];
                let Some(found) = block_knn(q, blk, k, margin, sc) else {
                    return false;
                };
                visit(s, i, &mut sc.words[..found]);
                true
            },
            |(s, sc), i, tree| {
                sc.words.clear();
                sc.words.extend(
                    tree_knn(tree, &self.positions[i as usize], k)
                        .iter()
                        .map(|nb| pack(nb.squared_distance, nb.index as u32)),
                );
                visit(s, i, &mut sc.words);
            },
        );
        parts.into_iter().map(|p| p.0).collect()
    }

    /// The building block of every pass: for every finite point `i`, in chunks of
    /// cells, `try_point(state, i, block, margin)` is called with the points of the
    /// block of cells around `i`'s and the distance `margin` from `i` to the block's
    /// boundary (every point outside is at least that far; `≤ 0`: no guarantee). When
    /// it returns false, the point is tried again with the next larger block, and after
    /// [`RINGS`] blocks `fallback(state, i, tree)` answers it. Without a grid, every
    /// point goes to the fallback.
    pub(crate) fn scan<S, M, T, F>(
        &self,
        par: Parallelism,
        make: M,
        try_point: T,
        fallback: F,
    ) -> Vec<S>
    where
        S: Send,
        M: Fn() -> S + Sync,
        T: Fn(&mut S, u32, &Block, f64) -> bool + Sync,
        F: Fn(&mut S, u32, &KdTree) + Sync,
    {
        let Some(grid) = &self.grid else {
            let chunk = 1024;
            return super::map_range(self.finite.len().div_ceil(chunk), par, 1, |c| {
                let mut s = make();
                let end = ((c + 1) * chunk).min(self.finite.len());
                for &i in &self.finite[c * chunk..end] {
                    fallback(&mut s, i, self.tree());
                }
                s
            });
        };
        let cells = grid.cell_keys.len();
        // Enough chunks for load balance on any machine; the split depends on the cloud
        // only.
        let chunk = (cells / 256).clamp(64, 2048);
        super::map_range(cells.div_ceil(chunk), par, 1, |c| {
            let mut s = make();
            let range = c * chunk..((c + 1) * chunk).min(cells);
            let pending = grid.rings(self.positions, range, |i, blk, m| {
                try_point(&mut s, i, blk, m)
            });
            for i in pending {
                fallback(&mut s, i, self.tree());
            }
            s
        })
    }
}

/// The k nearest of `q` among the block's points when they are provably its k nearest
/// in the whole cloud: at least k candidates within a threshold below the block
/// boundary (`margin`, with [`MARGIN`] to spare) exist, so every point within it is in
/// the block and the k nearest are among them; the k smallest words of those are moved
/// to the front of `sc.words`, ascending (for at most [`RANK_MAX`] of them; otherwise
/// in no order). Returns `Some(k)`, or `None` when the block cannot prove the answer.
///
/// PERF: the previous point `p` answered bounds the k-th distance of `q` from above by
/// `d_k(p) + |p − q|` (p's k neighbours are that close to `q`) and from below by
/// `d_k(p) − |p − q|`. Candidates are counted within [`RUNGS`] thresholds spread
/// between the two, and only those within the lowest threshold holding k of them are
/// kept and ranked: about k instead of every candidate of the block. The thresholds
/// only filter; the count proves the answer, so they need no rounding allowance.
#[inline]
fn block_knn(q: &[f32; 3], blk: &Block, k: usize, margin: f64, sc: &mut Scratch) -> Option<usize> {
    #[cfg(target_arch = "x86_64")]
    if sc.avx2 {
        // SAFETY: the CPU supports AVX2 (`Scratch::default` checked it).
        return unsafe { block_knn_avx2(q, blk, k, margin, sc) };
    }
    block_knn_body::<false>(q, blk, k, margin, sc)
}

/// Set: the k-NN kernel runs its portable code even where the CPU has AVX2.
static PORTABLE: AtomicBool = AtomicBool::new(false);

/// Makes the grid k-NN use its portable kernel (`true`) or the fastest the CPU supports
/// (`false`, the default), for testing that both give the same answers.
#[doc(hidden)]
pub fn use_portable_kernels(portable: bool) {
    PORTABLE.store(portable, Ordering::Relaxed);
}

/// [`block_knn`] compiled for AVX2: eight distances, comparisons and counts at once.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn block_knn_avx2(
    q: &[f32; 3],
    blk: &Block,
    k: usize,
    margin: f64,
    sc: &mut Scratch,
) -> Option<usize> {
    block_knn_body::<true>(q, blk, k, margin, sc)
}

/// Thresholds tried by [`block_knn`], the last of them the block bound.
const RUNGS: usize = 4;

/// `AVX`: compiled into [`block_knn_avx2`], so AVX2 instructions may be used.
#[inline(always)]
fn block_knn_body<const AVX: bool>(
    q: &[f32; 3],
    blk: &Block,
    k: usize,
    margin: f64,
    sc: &mut Scratch,
) -> Option<usize> {
    let n = blk.len();
    if n < k || margin <= 0.0 {
        return None;
    }
    // Candidates strictly closer than the bound: `d ≤ below`. Rounding the bound to
    // f32 moves it by 6e-8 relative, far inside MARGIN.
    let bound = (margin * margin / (1.0 + MARGIN)) as f32;
    if bound.is_nan() || bound <= 0.0 {
        return None;
    }
    let below = f32::from_bits(bound.to_bits() - 1);
    // Distances, padded with +inf to whole groups of eight.
    let padded = n.div_ceil(8) * 8;
    sc.d2.resize(padded, f32::INFINITY);
    let (xs, ys, zs) = (&blk.x[..n], &blk.y[..n], &blk.z[..n]);
    for (i, d) in sc.d2[..n].iter_mut().enumerate() {
        *d = squared_distance(q, &[xs[i], ys[i], zs[i]]);
    }
    sc.d2[n..].fill(f32::INFINITY);
    let mut rungs = [below; RUNGS];
    if let Some((p, dk)) = sc.last {
        let s = squared_distance(&p, q).sqrt() as f64;
        let (lo, hi) = ((dk - s).max(0.0), dk + s);
        for (j, t) in rungs[..RUNGS - 1].iter_mut().enumerate() {
            let r = lo + (hi - lo) * (j + 1) as f64 / (RUNGS - 1) as f64;
            *t = ((r * r) as f32).min(below);
        }
    }
    let counts = count_within(&sc.d2, &rungs);
    let j = counts.iter().position(|&c| c as usize >= k)?;
    let (t, found) = (rungs[j], counts[j] as usize);
    // Room for a whole group of eight past the last word.
    if sc.words.len() < found + 8 {
        sc.words.resize(found + 8, 0);
    }
    let c = compact_words::<AVX>(&sc.d2, &blk.id, t, &mut sc.words);
    debug_assert_eq!(c, found);
    if found <= RANK_MAX {
        rank_sort_body(&mut sc.words, found, k);
    } else {
        sc.words[..found].select_nth_unstable(k - 1);
    }
    let kth = word_d2(sc.words[..k].iter().copied().max().unwrap_or(0)) as f64;
    sc.last = Some((*q, kth.sqrt()));
    Some(k)
}

/// The number of `d2` values `≤` each threshold (`d2` in whole groups of eight).
#[inline(always)]
fn count_within(d2: &[f32], thresholds: &[f32; RUNGS]) -> [u32; RUNGS] {
    // Per-lane counts, summed at the end.
    let mut lanes = [[0u32; 8]; RUNGS];
    for group in d2.chunks_exact(8) {
        for (lane, &t) in lanes.iter_mut().zip(thresholds) {
            for b in 0..8 {
                lane[b] += u32::from(group[b] <= t);
            }
        }
    }
    lanes.map(|l| l.iter().sum::<u32>())
}

/// Packs the candidates with `d2[j] ≤ t` as words ([`pack`], with `id[j]`) to the front
/// of `words`, in order; returns their number. `d2` is padded with `+inf` to whole groups
/// of eight (`id` is not), and `words` has room for eight past the last packed word.
#[inline(always)]
fn compact_words<const AVX: bool>(d2: &[f32], id: &[u32], t: f32, words: &mut [u64]) -> usize {
    let full = id.len() / 8;
    let mut c = 0;
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is true only inside `block_knn_avx2`, which runs after the CPU
        // was found to support AVX2.
        c = unsafe { compact_words_avx2(&d2[..8 * full], &id[..8 * full], t, words) };
    }
    let done = if AVX && cfg!(target_arch = "x86_64") {
        full
    } else {
        0
    };
    for (g, group) in d2.chunks_exact(8).enumerate().skip(done) {
        for (b, &d) in group.iter().enumerate() {
            if d <= t {
                words[c] = pack(d, id[8 * g + b]);
                c += 1;
            }
        }
    }
    c
}

/// The whole groups of eight of [`compact_words`], by AVX2 left-packing: a comparison
/// gives an 8-bit mask, a table turns it into the permutation that moves the kept lanes
/// to the front, distances and indices are interleaved into words, and all eight are
/// stored (the count advances by the number kept).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn compact_words_avx2(d2: &[f32], id: &[u32], t: f32, words: &mut [u64]) -> usize {
    use std::arch::x86_64::*;
    debug_assert_eq!(d2.len(), id.len());
    debug_assert_eq!(d2.len() % 8, 0);
    let tv = _mm256_set1_ps(t);
    let mut c = 0;
    for g in 0..d2.len() / 8 {
        // SAFETY: `8 g + 7 < len` for both slices; `loadu` needs no alignment. `words`
        // has room for eight words at `c` (c counts words kept so far, at most `found`).
        let (dv, iv) = (
            _mm256_loadu_ps(d2.as_ptr().add(8 * g)),
            _mm256_loadu_si256(id.as_ptr().add(8 * g) as *const __m256i),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(dv, tv)) as usize;
        let perm = _mm256_loadu_si256(LEFT_PACK[mask].as_ptr() as *const __m256i);
        let dp = _mm256_castps_si256(_mm256_permutevar8x32_ps(dv, perm));
        let ip = _mm256_permutevar8x32_epi32(iv, perm);
        // Words 0, 1, 4, 5 and 2, 3, 6, 7 (index low, distance high), then in order.
        let (lo, hi) = (_mm256_unpacklo_epi32(ip, dp), _mm256_unpackhi_epi32(ip, dp));
        assert!(c + 8 <= words.len());
        let out = words.as_mut_ptr().add(c) as *mut __m256i;
        _mm256_storeu_si256(out, _mm256_permute2x128_si256::<0x20>(lo, hi));
        _mm256_storeu_si256(out.add(1), _mm256_permute2x128_si256::<0x31>(lo, hi));
        c += mask.count_ones() as usize;
    }
    c
}

/// For each 8-bit mask, the lanes of its set bits in ascending order, then zeros.
#[cfg(target_arch = "x86_64")]
static LEFT_PACK: [[u32; 8]; 256] = {
    let mut table = [[0u32; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut n = 0;
        let mut b = 0;
        while b < 8 {
            if m & (1 << b) != 0 {
                table[m][n] = b as u32;
                n += 1;
            }
            b += 1;
        }
        m += 1;
    }
    table
};

/// Largest number of candidates ranked by counting in [`rank_sort_body`]; more go
/// to a selection.
const RANK_MAX: usize = 32;

/// Moves the `k` smallest of the distinct words `words[..n]` to `words[..k]`,
/// ascending (`k ≤ n ≤ RANK_MAX`).
///
/// PERF: branch-free: each word's rank is the number of smaller words, and the word is
/// stored at its rank (or in a discard slot past `k`). For the 10-30 candidates of a
/// typical query this is several times cheaper than a selection followed by a sort,
/// whose branches the random order mispredicts.
#[inline(always)]
fn rank_sort_body(words: &mut [u64], n: usize, k: usize) {
    let mut out = [0u64; RANK_MAX + 1];
    // A word's top bit is 0 (the bits of a non-negative f32 shifted up 32), so signed
    // comparison orders words as unsigned; it vectorises where unsigned does not.
    let w = &words[..n];
    for &wi in w {
        let r = w
            .iter()
            .fold(0usize, |r, &x| r + usize::from((x as i64) < (wi as i64)));
        out[r.min(k)] = wi;
    }
    words[..k].copy_from_slice(&out[..k]);
}

/// The `k` nearest points by `(squared distance, index)` from the tree: kiddo's k
/// nearest give the k-th distance, then every point within it (inclusive, so tied
/// points are all seen) is ranked.
pub(crate) fn tree_knn(tree: &KdTree, q: &[f32; 3], k: usize) -> Vec<Neighbour> {
    let Some(last) = tree.nearest_n(q, k).last().copied() else {
        return Vec::new();
    };
    let mut all = tree_within_d2(tree, q, last.squared_distance);
    all.truncate(k);
    all
}

/// Every point at squared distance `≤ d2` from `q` (inclusive), sorted by
/// `(squared distance, index)`.
pub(crate) fn tree_within_d2(tree: &KdTree, q: &[f32; 3], d2: f32) -> Vec<Neighbour> {
    // A radius whose f32 square is ≥ d2: the widened candidate search then sees every
    // point at d² ≤ d2, and the inclusive test keeps exactly those.
    let r = (d2 as f64).sqrt() * (1.0 + 1e-6) + f64::MIN_POSITIVE;
    tree.within_radius(
        q,
        r,
        RadiusQuery {
            sorted: true,
            inclusive: true,
            ..Default::default()
        },
    )
    .into_iter()
    .filter(|nb| nb.squared_distance <= d2)
    .collect()
}

/// For every point `i` of `positions`, whether at least `need` finite points `p`
/// (itself included) satisfy `inside(q, p)`, where `inside` must imply
/// `|p − q| ≤ radius`. Non-finite points get `false`. Used by radius outlier removal
/// (see [`radius_scan`]; queries the grid cannot answer for certain ask the tree).
pub(crate) fn map_has_neighbours<I>(
    positions: &[[f32; 3]],
    radius: f64,
    need: usize,
    par: Parallelism,
    inside: I,
) -> Vec<bool>
where
    I: Fn(&[f32; 3], &[f32; 3]) -> bool + Sync + Send,
{
    let n = positions.len();
    if need == 0 {
        return positions.iter().map(PointCloud::is_finite_point).collect();
    }
    let tree_cell: OnceLock<KdTree> = OnceLock::new();
    let tree = || tree_cell.get_or_init(|| KdTree::build(positions));
    let by_tree = |q: &[f32; 3]| {
        PointCloud::is_finite_point(q)
            && tree().count_matching(q, radius, need, |p| inside(q, p)) >= need
    };
    let parts = radius_scan(
        positions,
        radius,
        par,
        Vec::new,
        |out: &mut Vec<(u32, bool)>, i, blk| {
            let q = &positions[i as usize];
            let mut count = 0;
            for j in 0..blk.len() {
                count += usize::from(inside(q, &[blk.x[j], blk.y[j], blk.z[j]]));
                if count >= need {
                    break;
                }
            }
            out.push((i, count >= need));
        },
        |out, i| out.push((i, by_tree(&positions[i as usize]))),
    );
    let Some(parts) = parts else {
        return super::map_indices(n, par, |i| by_tree(&positions[i]));
    };
    let mut keep = vec![false; n];
    for (i, ok) in parts.into_iter().flatten() {
        keep[i as usize] = ok;
    }
    keep
}

/// One pass over every finite point `i` of `positions` with the candidates for its
/// neighbours within `radius` (metres, `> 0`): a grid with cells of edge `radius`
/// (widened by 1e-3) holds every point within `radius` of `i` in the 3x3x3 block of
/// cells around `i`'s. `on_block(state, i, block)` gets that block when `i` is far
/// enough inside it for this to be certain despite rounding (by [`MARGIN`]);
/// otherwise `on_tree(state, i)` must answer `i` another way (a tree search). Points
/// come chunk by chunk of cells, each chunk with its own `make()` state; the states
/// are returned in cell order (so the split depends on the cloud only, never on the
/// thread count). `None` when there is no finite point or the cloud is too spread out
/// for a grid of that cell size (more than 2^32 cells).
pub(crate) fn radius_scan<S, M, B, T>(
    positions: &[[f32; 3]],
    radius: f64,
    par: Parallelism,
    make: M,
    on_block: B,
    on_tree: T,
) -> Option<Vec<S>>
where
    S: Send,
    M: Fn() -> S + Sync,
    B: Fn(&mut S, u32, &Block) + Sync,
    T: Fn(&mut S, u32) + Sync,
{
    if !(radius.is_finite() && radius > 0.0) {
        return None;
    }
    let finite: Vec<u32> = (0..positions.len() as u32)
        .filter(|&i| PointCloud::is_finite_point(&positions[i as usize]))
        .collect();
    let (lo, hi) = Grid::bounds(positions, &finite)?;
    let grid = Grid::with_cell(positions, &finite, lo, hi, radius * (1.0 + 1e-3))?;
    let r2 = radius * radius * (1.0 + MARGIN);
    let chunk = 512;
    let n_chunks = grid.cell_keys.len().div_ceil(chunk);
    Some(super::map_range(n_chunks, par, 1, |c| {
        let mut state = make();
        let cells: Vec<usize> = (c * chunk..((c + 1) * chunk).min(grid.cell_keys.len())).collect();
        let mut blk = Block::new();
        grid.blocks(1, &cells, &mut blk, |c, blk| {
            for &i in grid.cell(c) {
                let m = grid.margin_r(&positions[i as usize], 1.0);
                if m > 0.0 && r2 < m * m {
                    on_block(&mut state, i, blk);
                } else {
                    on_tree(&mut state, i);
                }
            }
        });
        state
    }))
}

/// Points sorted by cell, with the occupied cells' keys and start offsets.
struct Grid {
    /// Cell edge, metres.
    h: f64,
    /// Grid origin (the low corner of cell 0, one padding cell below the bounds).
    origin: [f64; 3],
    /// Key strides of y and z (x stride 1).
    stride: [u64; 2],
    /// Sorted occupied cell keys.
    cell_keys: Vec<u64>,
    /// `cell_start[c]..cell_start[c + 1]` are cell `c`'s points in `sorted`.
    cell_start: Vec<u32>,
    /// Point indices sorted by cell, ascending within a cell.
    sorted: Vec<u32>,
    /// The coordinates of `sorted`, axis by axis, so that a block is gathered by
    /// copying whole ranges.
    coords: [Vec<f32>; 3],
}

impl Grid {
    /// A grid whose cells hold about `k` points on average (surface-like clouds then
    /// have their k-th neighbour within a cell's edge), or `None` when the cloud is too
    /// spread out for 32-bit cell keys.
    fn build(positions: &[[f32; 3]], finite: &[u32], k: usize) -> Option<Grid> {
        let (lo, hi) = Grid::bounds(positions, finite)?;
        let ext: Vec<f64> = {
            let mut e: Vec<f64> = (0..3).map(|a| hi[a] - lo[a]).collect();
            e.sort_by(f64::total_cmp);
            e
        };
        // First guess: points spread over the two largest extents as a surface.
        let area = (ext[1] * ext[2]).max(ext[2] * ext[2] * 1e-6);
        let spacing = (area / finite.len() as f64).sqrt();
        let mut h = spacing * (k as f64).sqrt();
        if !(h.is_finite() && h > 0.0) {
            h = 1.0;
        }
        // Points per cell as seen from a point (dense regions weigh as they cost): a
        // surface crosses about 9 cells of a 3x3x3 block, so this many times 9
        // candidates are scanned per query. About 1.5 k keeps nearly every k-th
        // neighbour inside the block (at k/2, a third of the queries of a Kinect frame
        // had to retry with a 5x5x5 block); the scan of the larger block is vectorised
        // and only about k candidates are ranked (see `block_knn`).
        let target = 1.5 * k as f64;
        // PERF: a large cloud tries cell sizes on an even subsample (every `stride`-th
        // finite point, about SAMPLE of them) and is sorted into cells once, at the
        // chosen size. A cell holding `c` points holds about `f c` sampled ones, with
        // binomial spread, so `c² ≈ (c_s² − (1 − f) c_s) / f²`.
        let stride = finite.len() / SAMPLE;
        if stride >= 2 {
            let sample: Vec<u32> = finite.iter().step_by(stride).copied().collect();
            let f = sample.len() as f64 / finite.len() as f64;
            for _ in 0..3 {
                let Some(g) = Grid::with_cell(positions, &sample, lo, hi, h) else {
                    h *= 2.0;
                    continue;
                };
                let sum_sq = (0..g.cell_keys.len())
                    .map(|c| {
                        let c = g.cell(c).len() as f64;
                        c * c - (1.0 - f) * c
                    })
                    .sum::<f64>();
                let occupancy = sum_sq / (f * f) / finite.len() as f64;
                let ratio = target / occupancy.max(1.0);
                if (0.7..=1.4).contains(&ratio) {
                    break;
                }
                h *= ratio.sqrt().clamp(0.25, 4.0);
            }
            return Grid::with_cell(positions, finite, lo, hi, h);
        }
        let mut best = None;
        for _ in 0..3 {
            let Some(g) = Grid::with_cell(positions, finite, lo, hi, h) else {
                h *= 2.0;
                continue;
            };
            let occupancy = (0..g.cell_keys.len())
                .map(|c| (g.cell(c).len() as f64).powi(2))
                .sum::<f64>()
                / finite.len() as f64;
            let ratio = target / occupancy;
            best = Some(g);
            if (0.7..=1.4).contains(&ratio) {
                break;
            }
            h *= ratio.sqrt().clamp(0.25, 4.0);
        }
        best
    }

    /// Bounds of the finite points, `None` when there are none (or too many for
    /// 32-bit indices).
    fn bounds(positions: &[[f32; 3]], finite: &[u32]) -> Option<([f64; 3], [f64; 3])> {
        if finite.is_empty() || finite.len() > u32::MAX as usize / 2 {
            return None;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &i in finite {
            let p = positions[i as usize];
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f64);
                hi[a] = hi[a].max(p[a] as f64);
            }
        }
        Some((lo, hi))
    }

    fn with_cell(
        positions: &[[f32; 3]],
        finite: &[u32],
        lo: [f64; 3],
        hi: [f64; 3],
        h: f64,
    ) -> Option<Grid> {
        // One padding cell on each side so that x ± 1 never wraps into another row.
        let origin: [f64; 3] = std::array::from_fn(|a| lo[a] - h);
        let dims: [u64; 3] = std::array::from_fn(|a| ((hi[a] - origin[a]) / h) as u64 + 2);
        let total = (dims[0] as u128) * (dims[1] as u128) * (dims[2] as u128);
        if total > 1u128 << 32 {
            return None;
        }
        let stride = [dims[0], dims[0] * dims[1]];
        let (cell_keys, cell_start, sorted) = with_word_buffers(|words, buf| {
            words.clear();
            words.extend(finite.iter().map(|&i| {
                let c = cell_of(&positions[i as usize], origin, h);
                ((c[0] + c[1] * stride[0] + c[2] * stride[1]) << 32) | i as u64
            }));
            radix_sort_packed(words, buf, bits_for(total as u64));
            let mut cell_keys = Vec::new();
            let mut cell_start = Vec::new();
            for (j, w) in words.iter().enumerate() {
                let key = w >> 32;
                if cell_keys.last() != Some(&key) {
                    cell_keys.push(key);
                    cell_start.push(j as u32);
                }
            }
            cell_start.push(words.len() as u32);
            let sorted: Vec<u32> = words.iter().map(|&w| w as u32).collect();
            (cell_keys, cell_start, sorted)
        });
        let coords =
            std::array::from_fn(|a| sorted.iter().map(|&i| positions[i as usize][a]).collect());
        Some(Grid {
            h,
            origin,
            stride,
            cell_keys,
            cell_start,
            sorted,
            coords,
        })
    }

    /// Calls `visit(cell, block)` for every cell of `cells` (indices into `cell_keys`,
    /// ascending) with the points of the block of cells within `r` cells of it
    /// (`(2r+1)³` cells; near the grid's edge a row may wrap into the next one, which
    /// only adds candidates).
    fn blocks(
        &self,
        r: i64,
        cells: &[usize],
        blk: &mut Block,
        mut visit: impl FnMut(usize, &Block),
    ) {
        let keys = &self.cell_keys;
        let Some(&first) = cells.first() else {
            return;
        };
        let (sx, sy) = (self.stride[0] as i64, self.stride[1] as i64);
        let side = 2 * r + 1;
        let offsets: Vec<i64> = (0..side * side)
            .map(|o| (o % side - r) * sx + (o / side - r) * sy - r)
            .collect();
        // Per row of the block, a cursor into `keys` that only moves forward, since the
        // cells come in ascending key order.
        let first = keys[first] as i64;
        let mut cursor: Vec<usize> = offsets
            .iter()
            .map(|off| keys.partition_point(|&c| (c as i64) < first + off))
            .collect();
        let mut ranges: Vec<(usize, usize)> = Vec::with_capacity(offsets.len());
        for &c in cells {
            let key = keys[c] as i64;
            ranges.clear();
            for (cur, off) in cursor.iter_mut().zip(&offsets) {
                let lower = key + off;
                let mut j = *cur;
                while j < keys.len() && (keys[j] as i64) < lower {
                    j += 1;
                }
                *cur = j;
                let start = j;
                while j < keys.len() && (keys[j] as i64) <= lower + 2 * r {
                    j += 1;
                }
                if j > start {
                    ranges.push((start, j));
                }
            }
            // Wrapped rows of a narrow grid can overlap: merge the cell ranges so no
            // point is a candidate twice.
            ranges.sort_unstable();
            blk.clear();
            let mut done = 0;
            for &(a, b) in &ranges {
                let a = a.max(done);
                if a < b {
                    let pts = self.cell_start[a] as usize..self.cell_start[b] as usize;
                    blk.x.extend_from_slice(&self.coords[0][pts.clone()]);
                    blk.y.extend_from_slice(&self.coords[1][pts.clone()]);
                    blk.z.extend_from_slice(&self.coords[2][pts.clone()]);
                    blk.id.extend_from_slice(&self.sorted[pts]);
                    done = b;
                }
            }
            visit(c, blk);
        }
    }

    /// The point indices of cell `c`.
    fn cell(&self, c: usize) -> &[u32] {
        &self.sorted[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// Offers every point of cells `cells` to `try_point(i, block, margin)` with the
    /// block of radius 1 around its cell, then the points it refused with radius 2, 3,
    /// ... [`RINGS`]; returns the points refused by all.
    fn rings(
        &self,
        positions: &[[f32; 3]],
        cells: std::ops::Range<usize>,
        mut try_point: impl FnMut(u32, &Block, f64) -> bool,
    ) -> Vec<u32> {
        let mut blk = Block::new();
        let mut todo: Vec<usize> = cells.collect();
        // Points refused so far (ascending cell order), and their cells.
        let mut pending: Vec<u32> = Vec::new();
        for r in 1..=RINGS {
            let mut next: Vec<u32> = Vec::new();
            let mut next_cells: Vec<usize> = Vec::new();
            let mut from = 0;
            self.blocks(r as i64, &todo, &mut blk, |c, blk| {
                let members: &[u32] = if r == 1 {
                    self.cell(c)
                } else {
                    let n = pending[from..]
                        .iter()
                        .take_while(|&&i| self.cell(c).contains(&i))
                        .count();
                    from += n;
                    &pending[from - n..from]
                };
                for &i in members {
                    let margin = self.margin_r(&positions[i as usize], r as f64);
                    if !try_point(i, blk, margin) {
                        if next_cells.last() != Some(&c) {
                            next_cells.push(c);
                        }
                        next.push(i);
                    }
                }
            });
            pending = next;
            todo = next_cells;
            if pending.is_empty() {
                break;
            }
        }
        pending
    }

    /// Distance from `q` to the boundary of the block of cells within `r` of its cell
    /// (shrunk by a hair for the rounding of the cell computation).
    fn margin_r(&self, q: &[f32; 3], r: f64) -> f64 {
        let c = cell_of(q, self.origin, self.h);
        let mut m = f64::INFINITY;
        for a in 0..3 {
            let low = self.origin[a] + (c[a] as f64 - r) * self.h;
            let high = self.origin[a] + (c[a] as f64 + 1.0 + r) * self.h;
            let v = q[a] as f64;
            m = m.min(v - low).min(high - v);
        }
        m - self.h * 1e-9
    }
}

/// Cell coordinates of a finite point (`≥ 1` thanks to the padding).
fn cell_of(p: &[f32; 3], origin: [f64; 3], h: f64) -> [u64; 3] {
    std::array::from_fn(|a| ((p[a] as f64 - origin[a]) / h) as u64)
}

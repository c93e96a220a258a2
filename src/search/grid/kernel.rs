//! The k-NN kernel of the grid search: the k nearest of a query among a block's points,
//! when the block proves them the nearest of the whole cloud (portable and AVX2 code).

use super::{pack, word_d2, Block, MARGIN};
use crate::search::squared_distance;
use std::sync::atomic::{AtomicBool, Ordering};

/// Per-chunk scratch of the k-NN kernel.
pub(super) struct Scratch {
    d2: Vec<f32>,
    /// Packed neighbour words; [`block_knn`] leaves its answer at the front.
    pub(super) words: Vec<u64>,
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
pub(super) fn block_knn(
    q: &[f32; 3],
    blk: &Block,
    k: usize,
    margin: f64,
    sc: &mut Scratch,
) -> Option<usize> {
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
    unsafe {
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

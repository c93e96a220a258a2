//! A stable LSD radix sort of packed `(key << 32) | index` words, used to group points
//! by voxel or grid cell.
//!
//! Keys up to 32 bits are packed above a 32-bit index; the sort orders by key only and is
//! stable, so equal keys keep their input order (ascending index when the input was built
//! in index order). The result equals a comparison sort by `(key, index)`, whatever the
//! thread count. Digits of at most 12 bits keep the scatter's output streams in cache;
//! digits in which all keys agree are skipped.

/// Sorts `words` by bits `32..32 + key_bits` (the key), stably, with `buf` as the
/// scatter's second buffer (its contents are overwritten). `key_bits ≤ 32`.
///
/// PERF: digits of up to 12 bits (4096 buckets, whose counters and write cursors stay in
/// L1/L2), as few passes as that allows: a 24-bit voxel key takes 2 passes instead of 3.
pub(crate) fn radix_sort_packed(words: &mut Vec<u64>, buf: &mut Vec<u64>, key_bits: u32) {
    debug_assert!(key_bits <= 32);
    let n = words.len();
    if n < 2 || key_bits == 0 {
        return;
    }
    let passes = key_bits.div_ceil(MAX_DIGIT_BITS);
    let digit = key_bits.div_ceil(passes);
    let radix = 1usize << digit;
    let mask = (radix - 1) as u64;
    // All histograms in one read of the input.
    let mut hist = vec![0usize; radix * passes as usize];
    for &w in words.iter() {
        let key = w >> 32;
        for (d, h) in hist.chunks_exact_mut(radix).enumerate() {
            h[((key >> (digit * d as u32)) & mask) as usize] += 1;
        }
    }
    set_len(buf, n);
    let mut start = vec![0usize; radix];
    for (d, h) in hist.chunks_exact(radix).enumerate() {
        if h.contains(&n) {
            continue; // every key has the same digit: the pass would not move anything
        }
        let mut acc = 0;
        for (s, &c) in start.iter_mut().zip(h.iter()) {
            *s = acc;
            acc += c;
        }
        let shift = 32 + digit * d as u32;
        for &w in words.iter() {
            let b = ((w >> shift) & mask) as usize;
            buf[start[b]] = w;
            start[b] += 1;
        }
        std::mem::swap(words, buf);
    }
}

/// Sets `v`'s length to `n`; only a part beyond its old length is written (zeroed), so a
/// reused buffer is not cleared and refilled before being overwritten.
pub(crate) fn set_len(v: &mut Vec<u64>, n: usize) {
    if v.len() < n {
        v.resize(n, 0);
    }
    v.truncate(n);
}

/// Words a thread's reusable buffers may keep between calls (32 MiB each).
const RETAIN_WORDS: usize = 1 << 22;

thread_local! {
    static WORD_BUFFERS: std::cell::RefCell<(Vec<u64>, Vec<u64>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// Runs `f` with two word buffers (contents unspecified) that this thread keeps between calls, so that a
/// stream of frames does not fault its sort buffers into memory again on every frame
/// (a 640x480 frame's two buffers are 4.9 MB, about 1200 fresh pages). A nested call
/// (rayon may run another job on this thread meanwhile) gets fresh buffers; buffers
/// that grew beyond [`RETAIN_WORDS`] are freed afterwards.
pub(crate) fn with_word_buffers<R>(f: impl FnOnce(&mut Vec<u64>, &mut Vec<u64>) -> R) -> R {
    WORD_BUFFERS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut bufs) => {
            let (a, b) = &mut *bufs;
            let r = f(a, b);
            for v in [a, b] {
                if v.capacity() > RETAIN_WORDS {
                    *v = Vec::new();
                }
            }
            r
        }
        Err(_) => f(&mut Vec::new(), &mut Vec::new()),
    })
}

/// Widest digit of [`radix_sort_packed`], bits.
const MAX_DIGIT_BITS: u32 = 12;

/// Number of bits needed to hold every value below `count` (`0` for `count ≤ 1`).
pub(crate) fn bits_for(count: u64) -> u32 {
    if count <= 1 {
        0
    } else {
        64 - (count - 1).leading_zeros()
    }
}

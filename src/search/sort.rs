//! A stable LSD radix sort of packed `(key << 32) | index` words, used to group points
//! by voxel or grid cell.
//!
//! Keys up to 32 bits are packed above a 32-bit index; the sort orders by key only and is
//! stable, so equal keys keep their input order (ascending index when the input was built
//! in index order). The result equals a comparison sort by `(key, index)`, whatever the
//! thread count. Digits of at most 12 bits keep the scatter's output streams in cache;
//! digits in which all keys agree are skipped.

/// Sorts `words` by bits `32..32 + key_bits` (the key), stably. `key_bits ≤ 32`.
///
/// PERF: digits of up to 12 bits (4096 buckets, whose counters and write cursors stay in
/// L1/L2), as few passes as that allows: a 24-bit voxel key takes 2 passes instead of 3.
pub(crate) fn radix_sort_packed(words: &mut Vec<u64>, key_bits: u32) {
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
    let mut buf = vec![0u64; n];
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
        std::mem::swap(words, &mut buf);
    }
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

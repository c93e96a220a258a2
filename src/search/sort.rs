//! A stable LSD radix sort of packed `(key << 32) | index` words, used to group points
//! by voxel or grid cell.
//!
//! Keys up to 32 bits are packed above a 32-bit index; the sort orders by key only and is
//! stable, so equal keys keep their input order (ascending index when the input was built
//! in index order). The result equals a comparison sort by `(key, index)`, whatever the
//! thread count. 8-bit digits keep the scatter's 256 output streams in cache; digits in
//! which all keys agree are skipped.

/// Sorts `words` by bits `32..32 + key_bits` (the key), stably. `key_bits ≤ 32`.
pub(crate) fn radix_sort_packed(words: &mut Vec<u64>, key_bits: u32) {
    debug_assert!(key_bits <= 32);
    let n = words.len();
    if n < 2 || key_bits == 0 {
        return;
    }
    let passes = key_bits.div_ceil(8) as usize;
    // All histograms in one read of the input.
    let mut hist = vec![[0usize; 256]; passes];
    for &w in words.iter() {
        let key = w >> 32;
        for (d, h) in hist.iter_mut().enumerate() {
            h[((key >> (8 * d)) & 0xff) as usize] += 1;
        }
    }
    let mut buf = vec![0u64; n];
    for (d, h) in hist.iter().enumerate() {
        if h.contains(&n) {
            continue; // every key has the same digit: the pass would not move anything
        }
        let mut start = [0usize; 256];
        let mut acc = 0;
        for (s, &c) in start.iter_mut().zip(h.iter()) {
            *s = acc;
            acc += c;
        }
        let shift = 32 + 8 * d as u32;
        for &w in words.iter() {
            let b = ((w >> shift) & 0xff) as usize;
            buf[start[b]] = w;
            start[b] += 1;
        }
        std::mem::swap(words, &mut buf);
    }
}

/// Number of bits needed to hold every value below `count` (`0` for `count ≤ 1`).
pub(crate) fn bits_for(count: u64) -> u32 {
    if count <= 1 {
        0
    } else {
        64 - (count - 1).leading_zeros()
    }
}

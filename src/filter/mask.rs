//! Selection by bit mask, the engine of the selecting filters ([`super::pass_through`],
//! [`super::crop_box`]): the test is evaluated into one bit per point (bit `k` of word `w`
//! is point `64 w + k`), then the kept indices and each kept column are written out from
//! the mask, one column at a time.
//!
//! PERF: a mask word is 64 points tested without branches or stores; the write-out skips
//! empty words and copies full words (runs of 64 kept points, common in organized depth
//! frames) with `copy_from_slice`, so only the ragged edges of the valid regions pay the
//! bit-by-bit loop. With the `parallel` feature, large inputs are tested and written in
//! chunks of [`CHUNK`] points on rayon, each chunk at its own, precomputed output offset:
//! the result does not depend on the thread count.

use crate::cloud::PointCloud;

/// Points per parallel chunk (a multiple of 64); smaller inputs run on one thread.
const CHUNK: usize = 1 << 14;

/// A tested cloud: one bit per point, and how many bits are set per chunk of [`CHUNK`].
#[derive(Debug, Default)]
pub(crate) struct Mask {
    /// Bit `k` of word `w` is set when point `64 w + k` is kept; bits past the end are 0.
    words: Vec<u64>,
    /// Kept points per chunk of [`CHUNK`] points.
    counts: Vec<usize>,
}

impl Mask {
    /// The number of kept points.
    pub(crate) fn count(&self) -> usize {
        self.counts.iter().sum()
    }

    /// The mask of `keep(item)` over `items`.
    pub(crate) fn from_fn<T: Sync>(items: &[T], keep: impl Fn(&T) -> bool + Sync) -> Mask {
        Mask::build(items.len(), |start, words| {
            let chunk = &items[start..items.len().min(start + 64 * words.len())];
            for (w, block) in words.iter_mut().zip(chunk.chunks(64)) {
                let mut m = 0u64;
                for (k, item) in block.iter().enumerate() {
                    m |= u64::from(keep(item)) << k;
                }
                *w = m;
            }
        })
    }

    /// The mask of `lo[a] ≤ p[a] ≤ hi[a]` for all three axes (compared in `f32`, so a NaN
    /// coordinate fails), negated when `invert`.
    ///
    /// PERF: the coordinates are tested as one flat run of floats against bounds that
    /// cycle x, y, z (a loop the compiler vectorises without shuffles); the three bits of
    /// each point are then folded into one ([`fold_triples`]).
    pub(crate) fn in_box(positions: &[[f32; 3]], lo: [f32; 3], hi: [f32; 3], invert: bool) -> Mask {
        let lanes = |b: [f32; 3]| -> [f32; 48] { std::array::from_fn(|j| b[j % 3]) };
        let (lo48, hi48) = (lanes(lo), lanes(hi));
        let flip = if invert { u64::MAX } else { 0 };
        let inside = |p: &[f32; 3]| {
            (lo[0] <= p[0])
                & (p[0] <= hi[0])
                & (lo[1] <= p[1])
                & (p[1] <= hi[1])
                & (lo[2] <= p[2])
                & (p[2] <= hi[2])
        };
        Mask::build(positions.len(), |start, words| {
            let chunk = &positions[start..positions.len().min(start + 64 * words.len())];
            let full = chunk.len() / 64;
            let flat = chunk[..64 * full].as_flattened();
            for (w, block) in words.iter_mut().zip(flat.chunks_exact(192)) {
                let mut m = 0u64;
                for (s, sixteen) in block.chunks_exact(48).enumerate() {
                    // chunks_exact(48) yields 48-element slices only.
                    let sixteen: &[f32; 48] = sixteen.try_into().expect("chunks of 48");
                    m |= fold_triples(within_48(sixteen, &lo48, &hi48)) << (16 * s);
                }
                *w = m ^ flip;
            }
            if let Some(w) = words.get_mut(full) {
                let mut m = 0u64;
                for (k, p) in chunk[64 * full..].iter().enumerate() {
                    m |= u64::from(inside(p) != invert) << k;
                }
                *w = m;
            }
        })
    }

    /// Fills the words chunk by chunk with `fill(first_point, words)` (which must leave the
    /// bits past the end 0) and counts them.
    fn build(n: usize, fill: impl Fn(usize, &mut [u64]) + Sync) -> Mask {
        let mut words = vec![0u64; n.div_ceil(64)];
        let per_chunk = CHUNK / 64;
        let run = |(c, w): (usize, &mut [u64])| -> usize {
            fill(c * CHUNK, w);
            w.iter().map(|m| m.count_ones() as usize).sum()
        };
        #[cfg(feature = "parallel")]
        let counts = if n > CHUNK {
            use rayon::prelude::*;
            words
                .par_chunks_mut(per_chunk)
                .enumerate()
                .map(run)
                .collect()
        } else {
            words.chunks_mut(per_chunk).enumerate().map(run).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let counts = words.chunks_mut(per_chunk).enumerate().map(run).collect();
        Mask { words, counts }
    }

    /// The kept indices, ascending, into `out` (its allocation reused).
    pub(crate) fn indices_into(&self, out: &mut Vec<usize>) {
        self.write(out, |first, dst| {
            for (k, d) in dst.iter_mut().enumerate() {
                *d = first + k;
            }
        });
    }

    /// The kept elements of `column` (one per point), in order, into `out`.
    pub(crate) fn gather_into<T: Copy + Default + Send + Sync>(
        &self,
        column: &[T],
        out: &mut Vec<T>,
    ) {
        self.write(out, |first, dst| {
            dst.copy_from_slice(&column[first..first + dst.len()]);
        });
    }

    /// The kept points of `cloud` with every attribute into `out` (unorganized, its
    /// buffers reused); `self` must be a mask over `cloud`.
    pub(crate) fn select_into(&self, cloud: &PointCloud, out: &mut PointCloud) {
        fn column<T: Copy + Default + Send + Sync>(
            mask: &Mask,
            col: &Option<Vec<T>>,
            dst: &mut Option<Vec<T>>,
        ) {
            match col {
                None => *dst = None,
                Some(c) => mask.gather_into(c, dst.get_or_insert_with(Vec::new)),
            }
        }
        self.gather_into(&cloud.positions, &mut out.positions);
        column(self, &cloud.colors, &mut out.colors);
        column(self, &cloud.alpha, &mut out.alpha);
        column(self, &cloud.normals, &mut out.normals);
        column(self, &cloud.curvature, &mut out.curvature);
        column(self, &cloud.labels, &mut out.labels);
        out.width = u32::try_from(self.count()).unwrap_or(u32::MAX);
        out.height = 1;
        out.viewpoint = cloud.viewpoint;
    }

    /// Sizes `out` to the kept count (without rewriting slots it already has) and calls
    /// `run(first, dst)` for every run of consecutive kept points within a mask word,
    /// `first` being the run's first point and `dst` its output slots; chunks in parallel
    /// for large inputs.
    ///
    /// PERF: kept points come in long runs in organized frames (a row of valid depth), so
    /// a run is one slice copy rather than one element per set bit.
    fn write<T: Copy + Default + Send>(
        &self,
        out: &mut Vec<T>,
        run: impl Fn(usize, &mut [T]) + Sync,
    ) {
        let total = self.count();
        if out.len() < total {
            out.resize(total, T::default());
        } else {
            out.truncate(total);
        }
        let per_chunk = CHUNK / 64;
        let chunk = |(c, (words, dst)): (usize, (&[u64], &mut [T]))| {
            let mut at = 0;
            for (i, &m) in words.iter().enumerate() {
                let base = 64 * (c * per_chunk + i);
                let mut bits = m;
                while bits != 0 {
                    let start = bits.trailing_zeros();
                    let len = (!(bits >> start)).trailing_zeros(); // 1 ..= 64 - start
                    let end = start + len;
                    run(base + start as usize, &mut dst[at..at + len as usize]);
                    at += len as usize;
                    bits = if end == 64 {
                        0
                    } else {
                        bits & (u64::MAX << end)
                    };
                }
            }
        };
        let mut parts = Vec::with_capacity(self.counts.len());
        let mut rest = out.as_mut_slice();
        for &k in &self.counts {
            let (head, tail) = rest.split_at_mut(k);
            parts.push(head);
            rest = tail;
        }
        let chunks = self.words.chunks(per_chunk).zip(parts).enumerate();
        #[cfg(feature = "parallel")]
        if self.counts.len() > 1 {
            use rayon::prelude::*;
            chunks.collect::<Vec<_>>().into_par_iter().for_each(chunk);
            return;
        }
        chunks.for_each(chunk);
    }
}

/// Bit `j` set when `lo[j] ≤ v[j] ≤ hi[j]` (false for NaN).
#[cfg(target_arch = "x86_64")]
#[inline]
fn within_48(v: &[f32; 48], lo: &[f32; 48], hi: &[f32; 48]) -> u64 {
    // PERF: SSE2 (part of x86-64): compare four floats at once and take the sign bits.
    use std::arch::x86_64::{_mm_and_ps, _mm_cmple_ps, _mm_loadu_ps, _mm_movemask_ps};
    let mut bits = 0u64;
    for q in 0..12 {
        // SAFETY: SSE and SSE2 are part of the x86-64 baseline, so the intrinsics exist on
        // every x86-64 CPU; `4 q + 3 < 48`, so each load reads four floats inside its
        // array, and `loadu` has no alignment requirement.
        let ok = unsafe {
            let x = _mm_loadu_ps(v.as_ptr().add(4 * q));
            let l = _mm_loadu_ps(lo.as_ptr().add(4 * q));
            let h = _mm_loadu_ps(hi.as_ptr().add(4 * q));
            _mm_movemask_ps(_mm_and_ps(_mm_cmple_ps(l, x), _mm_cmple_ps(x, h)))
        };
        bits |= u64::from(ok as u32) << (4 * q);
    }
    bits
}

/// Bit `j` set when `lo[j] ≤ v[j] ≤ hi[j]` (false for NaN).
#[cfg(not(target_arch = "x86_64"))]
#[inline]
fn within_48(v: &[f32; 48], lo: &[f32; 48], hi: &[f32; 48]) -> u64 {
    // PERF: 0/1 bytes, packed eight at a time by one multiplication that moves byte
    // `i`'s bit to bit `56 + i` without carries.
    let mut bits = 0u64;
    for (i, ((v, lo), hi)) in v
        .chunks_exact(8)
        .zip(lo.chunks_exact(8))
        .zip(hi.chunks_exact(8))
        .enumerate()
    {
        let ok: [u8; 8] = std::array::from_fn(|j| u8::from((lo[j] <= v[j]) & (v[j] <= hi[j])));
        bits |= (u64::from_le_bytes(ok).wrapping_mul(0x0102_0408_1020_4080) >> 56) << (8 * i);
    }
    bits
}

/// Bits `0, 3, 6, …, 45`.
const EVERY_THIRD: u64 = {
    let mut m = 0u64;
    let mut k = 0;
    while k < 16 {
        m |= 1 << (3 * k);
        k += 1;
    }
    m
};

/// `bits` holds 16 points' three test bits (point `k` at bits `3k..3k+3`); returns one
/// bit per point, set when all three are.
///
/// PERF: instead of a bit-extract instruction (not in baseline x86-64), the surviving bits
/// at `3k` are packed by four shift-or-mask rounds, each halving the number of groups.
#[inline]
fn fold_triples(bits: u64) -> u64 {
    /// `width`-bit groups every `period` bits, `groups` of them.
    const fn groups(width: u32, period: u32, groups: u32) -> u64 {
        let mut m = 0u64;
        let mut g = 0;
        while g < groups {
            m |= ((1u64 << width) - 1) << (period * g);
            g += 1;
        }
        m
    }
    let a = bits & (bits >> 1) & (bits >> 2) & EVERY_THIRD; // point k at bit 3k
    let a = (a | (a >> 2)) & groups(2, 6, 8); // points 2i, 2i+1 at bits 6i, 6i+1
    let a = (a | (a >> 4)) & groups(4, 12, 4); // 4 points at 12j
    let a = (a | (a >> 8)) & groups(8, 24, 2); // 8 points at 24l
    (a | (a >> 16)) & 0xffff
}

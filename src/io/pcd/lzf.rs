//! LZF, the byte-oriented LZ77 variant PCL uses for `binary_compressed` bodies.
//!
//! The stream is a sequence of chunks, each starting with a control byte `c`:
//! - `c < 32`: a literal run of `c + 1` bytes follows;
//! - otherwise a back-reference: length `(c >> 5) + 2` (when `c >> 5 == 7` an extra byte is
//!   added to the length), distance `((c & 0x1f) << 8) + next_byte + 1` back from the
//!   current output position. Copies may overlap (run-length style).
//!
//! Our compressor is a simple greedy hash-chain-free matcher (one candidate per hash
//! bucket, like liblzf); its bytes differ from PCL's but any LZF decoder reads them.
//!
//! ```
//! use softsense::io::pcd::lzf;
//! let data = b"abcabcabcabcabcabc-xyz".repeat(10);
//! let packed = lzf::compress(&data);
//! assert!(packed.len() < data.len());
//! assert_eq!(lzf::decompress(&packed, data.len()).unwrap(), data);
//! ```

use thiserror::Error;

/// Largest expansion an LZF stream can encode: a 3-byte back-reference yields at most
/// 264 bytes. A declared uncompressed size above `compressed * MAX_RATIO` is a lie.
pub const MAX_RATIO: u64 = 88;

const HASH_LOG: u32 = 14;
const MAX_LITERAL: usize = 32;
const MAX_OFFSET: usize = 1 << 13;
const MAX_MATCH: usize = 264;
const SHORT_COPY: usize = 16;

/// What is wrong with an LZF stream.
#[derive(Debug, Error, PartialEq, Eq, Clone)]
pub enum LzfError {
    /// The stream ends inside a chunk.
    #[error("LZF stream truncated at byte {at}")]
    Truncated {
        /// Offset in the compressed stream.
        at: usize,
    },
    /// A back-reference points before the start of the output.
    #[error("LZF back-reference at byte {at} reaches {distance} bytes back but only {available} are decoded")]
    BadBackReference {
        /// Offset in the compressed stream.
        at: usize,
        /// How far back it points.
        distance: usize,
        /// Bytes decoded so far.
        available: usize,
    },
    /// The stream decodes to more bytes than declared.
    #[error("LZF stream decodes past the declared {expected} bytes (at byte {at})")]
    Overflow {
        /// Offset in the compressed stream.
        at: usize,
        /// The declared uncompressed size.
        expected: usize,
    },
    /// The stream decodes to fewer bytes than declared.
    #[error("LZF stream decodes to {got} bytes, {expected} declared")]
    Short {
        /// Bytes decoded.
        got: usize,
        /// The declared uncompressed size.
        expected: usize,
    },
}

/// Decompresses `input`, which must decode to exactly `expected` bytes. The output is
/// allocated once; callers bound `expected` (see [`MAX_RATIO`]) before calling.
pub fn decompress(input: &[u8], expected: usize) -> Result<Vec<u8>, LzfError> {
    let mut out = Vec::new();
    decompress_into(input, expected, &mut out)?;
    Ok(out)
}

/// Like [`decompress`], but into `out` (resized to `expected`), so that a caller
/// decoding frame after frame reuses one buffer instead of faulting in fresh pages.
pub fn decompress_into(input: &[u8], expected: usize, out: &mut Vec<u8>) -> Result<(), LzfError> {
    // PERF: writing a pre-sized buffer by index is several times faster than pushing,
    // and the overlapping copies below move whole periods at a time.
    out.clear();
    out.resize(expected, 0);
    let out = &mut out[..];
    let mut op = 0;
    let mut ip = 0;
    while ip < input.len() {
        let at = ip;
        let ctrl = input[ip] as usize;
        ip += 1;
        if ctrl < 32 {
            let len = ctrl + 1;
            if ip + len > input.len() {
                return Err(LzfError::Truncated { at });
            }
            if op + len > expected {
                return Err(LzfError::Overflow { at, expected });
            }
            if ip + MAX_LITERAL <= input.len() && op + MAX_LITERAL <= expected {
                // PERF: a fixed-size copy compiles to a few vector moves; the bytes past
                // `len` are overwritten by the chunks that follow.
                out[op..op + MAX_LITERAL].copy_from_slice(&input[ip..ip + MAX_LITERAL]);
            } else {
                out[op..op + len].copy_from_slice(&input[ip..ip + len]);
            }
            op += len;
            ip += len;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += *input.get(ip).ok_or(LzfError::Truncated { at })? as usize;
                ip += 1;
            }
            len += 2;
            let low = *input.get(ip).ok_or(LzfError::Truncated { at })? as usize;
            ip += 1;
            let distance = ((ctrl & 0x1f) << 8) + low + 1;
            if distance > op {
                return Err(LzfError::BadBackReference {
                    at,
                    distance,
                    available: op,
                });
            }
            if op + len > expected {
                return Err(LzfError::Overflow { at, expected });
            }
            let start = op - distance;
            if distance >= SHORT_COPY && len <= SHORT_COPY && op + SHORT_COPY <= expected {
                // PERF: fixed-size copy; the source lies wholly before `op`.
                out.copy_within(start..start + SHORT_COPY, op);
            } else if distance >= len {
                out.copy_within(start..start + len, op);
            } else {
                // Overlapping (run-length) copy. The bytes from `start` to the write
                // position repeat with period `distance`, so each piece can copy all of
                // them: pieces double in size.
                let mut copied = 0;
                while copied < len {
                    let c = (copied + distance).min(len - copied);
                    out.copy_within(start..start + c, op + copied);
                    copied += c;
                }
            }
            op += len;
        }
    }
    if op != expected {
        return Err(LzfError::Short { got: op, expected });
    }
    Ok(())
}

fn hash(b: &[u8]) -> usize {
    let v = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
    (v.wrapping_mul(2_654_435_761) >> (32 - HASH_LOG)) as usize
}

fn flush_literals(out: &mut Vec<u8>, lit: &[u8]) {
    for chunk in lit.chunks(MAX_LITERAL) {
        out.push((chunk.len() - 1) as u8);
        out.extend_from_slice(chunk);
    }
}

/// Compresses `input` into an LZF stream that [`decompress`] (and PCL) reads back.
pub fn compress(input: &[u8]) -> Vec<u8> {
    let n = input.len();
    let mut out = Vec::with_capacity(n / 2 + 16);
    // Position + 1 of the last occurrence of each 3-byte hash (0 = none).
    let mut table = vec![0usize; 1 << HASH_LOG];
    let mut lit_start = 0;
    let mut i = 0;
    while i + 2 < n {
        let h = hash(&input[i..i + 3]);
        let candidate = table[h];
        table[h] = i + 1;
        if candidate > 0 {
            let r = candidate - 1;
            let distance = i - r;
            if distance <= MAX_OFFSET && input[r..r + 3] == input[i..i + 3] {
                let max = MAX_MATCH.min(n - i);
                let mut len = 3;
                while len < max && input[r + len] == input[i + len] {
                    len += 1;
                }
                flush_literals(&mut out, &input[lit_start..i]);
                let l = len - 2;
                let off = distance - 1;
                if l < 7 {
                    out.push(((l << 5) | (off >> 8)) as u8);
                } else {
                    out.push(((7 << 5) | (off >> 8)) as u8);
                    out.push((l - 7) as u8);
                }
                out.push((off & 0xff) as u8);
                // Index the positions inside the match sparsely: enough for good ratios on
                // point data without hashing every byte.
                let end = i + len;
                let mut k = i + 1;
                while k + 2 < n && k < end {
                    table[hash(&input[k..k + 3])] = k + 1;
                    k += 2;
                }
                i = end;
                lit_start = i;
                continue;
            }
        }
        i += 1;
    }
    flush_literals(&mut out, &input[lit_start..]);
    out
}

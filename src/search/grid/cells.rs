//! The uniform grid of the k-NN and radius searches: points sorted by cell, and the
//! blocks of cells around each cell gathered as structures of arrays.

use crate::search::sort::{bits_for, radix_sort_packed, with_word_buffers};
use crate::search::squared_distance;

/// About how many points [`Grid::build`] samples to choose a large cloud's cell size.
const SAMPLE: usize = 32_768;

/// Largest block radius (in cells) tried before asking the tree. PERF: the tree costs
/// a build over the whole cloud (about 8 ms for a 640x480 frame); the dozen isolated
/// points of such a frame that blocks up to 9x9x9 cells could not answer are answered
/// by blocks up to 17x17x17 for far less.
pub(super) const RINGS: u64 = 8;

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
    pub(super) fn new() -> Block {
        Block {
            x: Vec::new(),
            y: Vec::new(),
            z: Vec::new(),
            id: Vec::new(),
        }
    }

    pub(super) fn clear(&mut self) {
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

/// Points sorted by cell, with the occupied cells' keys and start offsets.
pub(super) struct Grid {
    /// Cell edge, metres.
    h: f64,
    /// Grid origin (the low corner of cell 0, one padding cell below the bounds).
    origin: [f64; 3],
    /// Key strides of y and z (x stride 1).
    stride: [u64; 2],
    /// Sorted occupied cell keys.
    pub(super) cell_keys: Vec<u64>,
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
    pub(super) fn build(positions: &[[f32; 3]], finite: &[u32], k: usize) -> Option<Grid> {
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
    pub(super) fn bounds(positions: &[[f32; 3]], finite: &[u32]) -> Option<([f64; 3], [f64; 3])> {
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

    pub(super) fn with_cell(
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
    pub(super) fn blocks(
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
    pub(super) fn cell(&self, c: usize) -> &[u32] {
        &self.sorted[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// Offers every point of cells `cells` to `try_point(i, block, margin)` with the
    /// block of radius 1 around its cell, then the points it refused with radius 2, 3,
    /// ... [`RINGS`]; returns the points refused by all.
    pub(super) fn rings(
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
    pub(super) fn margin_r(&self, q: &[f32; 3], r: f64) -> f64 {
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

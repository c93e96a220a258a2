//! Radius passes over the grid: every point with the candidates for its neighbours
//! within a radius, and the count-based test of radius outlier removal built on it.

use super::{Block, Grid, MARGIN};
use crate::cloud::PointCloud;
use crate::search::{KdTree, Parallelism};
use std::sync::OnceLock;

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
        return crate::search::map_indices(n, par, |i| by_tree(&positions[i]));
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
    Some(crate::search::map_range(n_chunks, par, 1, |c| {
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

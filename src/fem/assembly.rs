//! Sparse assembly on the free degrees of freedom: the upper-triangular CSC pattern of K,
//! the per-element scatter slots, and the bitwise-deterministic assembly (element kernels in
//! parallel, scatter serial in element order).

use super::mesh::TetMesh;
use super::tet4::{ElementState, TetRest};
use super::FemResult;

/// Marks a local entry that is not stored (fixed DOF or lower triangle).
const SKIP: u32 = u32::MAX;

/// Free-DOF numbering: fixed nodes are removed from the system.
#[derive(Debug, Clone)]
pub struct DofMap {
    /// First free DOF of each node (3 consecutive), or `None` for a fixed node.
    pub node_dof: Vec<Option<usize>>,
    /// Number of free DOFs.
    pub ndof: usize,
}

impl DofMap {
    /// Numbers the free nodes in order, skipping `fixed`.
    pub fn new(num_nodes: usize, fixed: &[usize]) -> Self {
        let mut is_fixed = vec![false; num_nodes];
        for &v in fixed {
            if v < num_nodes {
                is_fixed[v] = true;
            }
        }
        let mut ndof = 0;
        let node_dof = is_fixed
            .iter()
            .map(|&f| {
                if f {
                    None
                } else {
                    ndof += 3;
                    Some(ndof - 3)
                }
            })
            .collect();
        Self { node_dof, ndof }
    }

    /// The free DOF of (node, component), if free.
    pub fn dof(&self, node: usize, k: usize) -> Option<usize> {
        self.node_dof.get(node).copied().flatten().map(|d| d + k)
    }

    /// Gathers a node-major 3n vector into free-DOF space.
    pub fn gather(&self, full: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.ndof];
        for (v, d) in self.node_dof.iter().enumerate() {
            if let Some(d) = d {
                out[*d..*d + 3].copy_from_slice(&full[3 * v..3 * v + 3]);
            }
        }
        out
    }
}

/// The sparsity pattern (upper triangle, CSC) and scatter slots of one mesh and DOF map.
#[derive(Debug, Clone)]
pub struct Pattern {
    /// Column pointers (ndof + 1).
    pub col_ptr: Vec<usize>,
    /// Row indices, ascending within each column.
    pub row_idx: Vec<usize>,
    /// For each element, its stored local entries as (value slot, local index 12 row + col
    /// of the row-major 12x12), from `entry_ptr[e]` to `entry_ptr[e + 1]`, in local order.
    entries: Vec<(u32, u8)>,
    entry_ptr: Vec<usize>,
    /// For each element, bit 4a + b set when its 3x3 block (a, b) has a stored entry.
    blocks: Vec<u16>,
}

impl Pattern {
    /// Builds the pattern for `mesh` with free DOFs `dofs`; each of `groups` (e.g. the
    /// nodes along one cable) is coupled fully as well.
    pub fn new(mesh: &TetMesh, dofs: &DofMap, groups: &[Vec<usize>]) -> FemResult<Self> {
        let n = mesh.num_nodes();
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
        for t in mesh
            .tets
            .iter()
            .map(|t| t.as_slice())
            .chain(groups.iter().map(|g| g.as_slice()))
        {
            for &a in t {
                for &b in t {
                    if a < n && b < n {
                        adj[b].push(a);
                    }
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(dofs.ndof + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        for (b, list) in adj.iter_mut().enumerate() {
            let Some(db) = dofs.node_dof[b] else { continue };
            list.sort_unstable();
            list.dedup();
            // Free neighbours' first DOFs, ascending (node order = DOF order).
            let rows: Vec<usize> = list
                .iter()
                .filter_map(|&a| dofs.node_dof[a])
                .filter(|&da| da <= db)
                .collect();
            for j in 0..3 {
                for &da in &rows {
                    for i in 0..3 {
                        if da + i <= db + j {
                            row_idx.push(da + i);
                        }
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        if row_idx.len() >= SKIP as usize {
            return Err(super::FemError::TooLarge {
                entries: row_idx.len(),
            });
        }
        let mut entries = Vec::new();
        let mut entry_ptr = Vec::with_capacity(mesh.tets.len() + 1);
        entry_ptr.push(0);
        let mut blocks = Vec::with_capacity(mesh.tets.len());
        for t in &mesh.tets {
            let mut s = [SKIP; 144];
            for a in 0..4 {
                for i in 0..3 {
                    let Some(r) = dofs.dof(t[a], i) else { continue };
                    for b in 0..4 {
                        for j in 0..3 {
                            let Some(c) = dofs.dof(t[b], j) else { continue };
                            if r > c {
                                continue;
                            }
                            let col = &row_idx[col_ptr[c]..col_ptr[c + 1]];
                            if let Ok(k) = col.binary_search(&r) {
                                s[(3 * a + i) * 12 + 3 * b + j] = (col_ptr[c] + k) as u32;
                            }
                        }
                    }
                }
            }
            let mut mask = 0u16;
            for (local, &slot) in s.iter().enumerate() {
                if slot != SKIP {
                    entries.push((slot, local as u8));
                    let (row, col) = (local / 12, local % 12);
                    mask |= 1 << (4 * (row / 3) + col / 3);
                }
            }
            entry_ptr.push(entries.len());
            blocks.push(mask);
        }
        Ok(Self {
            col_ptr,
            row_idx,
            entries,
            entry_ptr,
            blocks,
        })
    }

    /// The 3x3 blocks of element `e` that hold stored entries: bit 4a + b for block
    /// (a, b) (the upper triangle in DOF order, free nodes only).
    pub fn block_mask(&self, e: usize) -> u16 {
        self.blocks[e]
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Adds the 3x3 block `k` at (node rows `a`, node columns `b`) into `values`
    /// (upper-triangle entries only; pairs outside the pattern are ignored).
    pub fn add_block(
        &self,
        dofs: &DofMap,
        a: usize,
        b: usize,
        k: &[[f64; 3]; 3],
        values: &mut [f64],
    ) {
        for (i, krow) in k.iter().enumerate() {
            let Some(r) = dofs.dof(a, i) else { continue };
            for (j, kij) in krow.iter().enumerate() {
                let Some(c) = dofs.dof(b, j) else { continue };
                if r > c {
                    continue;
                }
                let col = &self.row_idx[self.col_ptr[c]..self.col_ptr[c + 1]];
                if let Ok(s) = col.binary_search(&r) {
                    values[self.col_ptr[c] + s] += kij;
                }
            }
        }
    }

    /// Adds element `e`'s tangent into `values` (only the entries in the blocks of
    /// [`Pattern::block_mask`] are read).
    pub fn scatter(&self, e: usize, k: &super::tet4::Mat12, values: &mut [f64]) {
        let flat = k.as_flattened();
        for &(slot, local) in &self.entries[self.entry_ptr[e]..self.entry_ptr[e + 1]] {
            values[slot as usize] += flat[local as usize];
        }
    }
}

/// Evaluates `kernel` on every element (in parallel with the `parallel` feature) into
/// `out` (reused between calls, resized to the element count; the kernel writes each state
/// in place); an error if any element fails. The scatter that follows is serial in element
/// order, so assembled values do not depend on the thread count.
pub fn eval_elements<F>(rest: &[TetRest], out: &mut Vec<ElementState>, kernel: F) -> FemResult<()>
where
    F: Fn(usize, &TetRest, &mut ElementState) -> FemResult<()> + Sync + Send,
{
    if out.len() != rest.len() {
        out.clear();
        out.resize(rest.len(), ElementState::default());
    }
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        out.par_iter_mut()
            .zip(rest.par_iter())
            .enumerate()
            .try_for_each(|(e, (o, r))| kernel(e, r, o))
    }
    #[cfg(not(feature = "parallel"))]
    {
        for (e, (o, r)) in out.iter_mut().zip(rest).enumerate() {
            kernel(e, r, o)?;
        }
        Ok(())
    }
}

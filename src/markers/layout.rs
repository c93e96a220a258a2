//! Marker layouts that minimise I_w (thesis 4.6.1, Table 4.1): where to put N markers so
//! the least squares amplifies the marker noise least.
//!
//! W_ef is computed once, at the free equilibrium, for every node of the pool (3 rows each;
//! its cost is one solve per force unknown, not per node). A layout's I_w = 1/σ_min(W_ef) of
//! its rows is then 1/sqrt(λ_min(Σ G_i)), G_i = W_iᵀW_i the n × n block of pool node i, so
//! no layout re-solves the FE model. Greedy forward selection adds the node that lowers I_w
//! most; an exchange pass then swaps a chosen node for an unchosen one while I_w drops.

use super::bind::{BoundMarker, CandidateLocation};
use super::{MarkerSensor, MarkersError, MarkersParams, MarkersResult};
use crate::fem::solve::{MappedPoint, NewtonParams, Problem};
use crate::inverse::lsq;
use crate::math::{norm, sub};
use nalgebra::DMatrix;
use serde::Serialize;

/// Options of [`propose_layout`].
#[derive(Debug, Clone, PartialEq)]
pub struct LayoutParams {
    /// Markers to place (default 8).
    pub markers: usize,
    /// Most exchange passes over the chosen markers (default 5).
    pub max_exchange_passes: usize,
    /// Keep every `pool_stride`-th node of the default pool (default 1: all).
    pub pool_stride: usize,
    /// At most this many pool nodes after the stride (default 4000).
    pub pool_limit: usize,
    /// Default-pool nodes nearer than this to a candidate are left out (m; default 0.005):
    /// a marker under the contact would be covered by it.
    pub clearance: f64,
}

impl Default for LayoutParams {
    fn default() -> Self {
        Self {
            markers: 8,
            max_exchange_passes: 5,
            pool_stride: 1,
            pool_limit: 4000,
            clearance: 0.005,
        }
    }
}

/// A proposed layout.
#[derive(Debug, Clone, Serialize)]
pub struct Layout {
    /// The chosen mesh nodes, in the order chosen (exchanges replace in place).
    pub nodes: Vec<usize>,
    /// Their positions at the free equilibrium (m, model frame), where the markers are bound.
    pub positions: Vec<[f64; 3]>,
    /// I_w of the layout (N/m).
    pub i_w: f64,
    /// I_w after the greedy phase, before the exchanges (N/m).
    pub i_w_greedy: f64,
    /// I_w after each greedy addition (infinite until the rows identify the unknowns).
    pub greedy_trace: Vec<f64>,
    /// I_w after each accepted exchange.
    pub exchange_trace: Vec<f64>,
    /// Pool size used.
    pub pool: usize,
}

/// The compliance of every pool node: its 3 × n rows of W_ef as the n × n block G_i = W_iᵀW_i.
#[derive(Debug, Clone)]
pub struct PoolCompliance {
    /// The pool's mesh nodes.
    pub nodes: Vec<usize>,
    /// G_i of each pool node.
    pub blocks: Vec<DMatrix<f64>>,
    /// The free-equilibrium node positions (m).
    pub positions: Vec<[f64; 3]>,
}

impl PoolCompliance {
    /// W_ef at the free equilibrium of `problem` (point loads dropped, cable inputs held as in
    /// [`MarkerSensor::linearise`]) for each of `pool`'s nodes.
    pub fn new(
        problem: &Problem,
        newton: &NewtonParams,
        candidates: &[CandidateLocation],
        pool: &[usize],
    ) -> MarkersResult<Self> {
        let markers = (pool.iter())
            .map(|&v| BoundMarker {
                name: format!("n{v}"),
                at: MappedPoint::node(v),
                distance: 0.0,
            })
            .collect();
        let sensor = MarkerSensor::new(
            problem,
            newton.clone(),
            markers,
            candidates.to_vec(),
            MarkersParams::default(),
        )?;
        let n = sensor.unknowns();
        let all: Vec<usize> = (0..pool.len()).collect();
        let (sol, w) = sensor.linearise(&vec![0.0; n], &all, None)?;
        let blocks = (0..pool.len())
            .map(|i| {
                let wi = w.rows(3 * i, 3);
                wi.tr_mul(&wi)
            })
            .collect();
        let positions = pool.iter().map(|&v| sol.positions[v]).collect();
        Ok(Self {
            nodes: pool.to_vec(),
            blocks,
            positions,
        })
    }
}

/// The default pool: surface nodes of `problem`'s mesh that are not fixed and at least
/// `clearance` from every candidate, every `pool_stride`-th, at most `pool_limit`.
pub fn default_pool(
    problem: &Problem,
    candidates: &[CandidateLocation],
    params: &LayoutParams,
) -> Vec<usize> {
    let x = &problem.mesh.nodes_in_rest;
    (problem.mesh.surface().nodes.into_iter())
        .filter(|v| !problem.fixed.contains(v))
        .filter(|&v| (candidates.iter()).all(|c| norm(sub(x[v], c.position)) >= params.clearance))
        .step_by(params.pool_stride.max(1))
        .take(params.pool_limit)
        .collect()
}

/// A marker layout minimising I_w for `candidates` on `problem` (see the module docs); the
/// pool defaults to [`default_pool`].
pub fn propose_layout(
    problem: &Problem,
    newton: &NewtonParams,
    candidates: &[CandidateLocation],
    pool: Option<&[usize]>,
    params: &LayoutParams,
) -> MarkersResult<Layout> {
    let unknowns: usize = candidates.iter().map(|c| c.unknowns()).sum();
    check_counts(params.markers, unknowns)?;
    let pool = match pool {
        Some(p) => p.to_vec(),
        None => default_pool(problem, candidates, params),
    };
    if pool.len() < params.markers {
        return Err(MarkersError::PoolTooSmall {
            pool: pool.len(),
            markers: params.markers,
        });
    }
    let pc = PoolCompliance::new(problem, newton, candidates, &pool)?;
    Ok(layout_from_pool(&pc, params))
}

/// The layout of `params.markers` markers from a pool's compliance (greedy, then exchanges).
pub fn layout_from_pool(pc: &PoolCompliance, params: &LayoutParams) -> Layout {
    let (chosen, greedy_trace) = greedy(&pc.blocks, params.markers);
    let i_w_greedy = greedy_trace.last().copied().unwrap_or(f64::INFINITY);
    let (chosen, exchange_trace) = exchange(&pc.blocks, chosen, params.max_exchange_passes);
    Layout {
        nodes: chosen.iter().map(|&i| pc.nodes[i]).collect(),
        positions: chosen.iter().map(|&i| pc.positions[i]).collect(),
        i_w: exchange_trace.last().copied().unwrap_or(i_w_greedy),
        i_w_greedy,
        greedy_trace,
        exchange_trace,
        pool: pc.nodes.len(),
    }
}

/// Corollary 1: `markers` markers give 3 rows each, which must be at least the unknowns.
pub fn check_counts(markers: usize, unknowns: usize) -> MarkersResult<()> {
    if markers * 3 < unknowns || unknowns == 0 {
        return Err(MarkersError::TooFewMarkers { markers, unknowns });
    }
    Ok(())
}

/// I_w (N/m) of the sum of blocks `gram` = W_efᵀW_ef, and log det(gram + εI) to rank
/// layouts that do not identify the unknowns yet ([`lsq::gram_i_w`]).
fn score(gram: &DMatrix<f64>) -> (f64, f64) {
    lsq::gram_i_w(gram)
}

/// I_w of the layout `chosen` (indices into `blocks`).
pub fn layout_i_w(blocks: &[DMatrix<f64>], chosen: &[usize]) -> f64 {
    score(&sum_blocks(blocks, chosen)).0
}

fn sum_blocks(blocks: &[DMatrix<f64>], chosen: &[usize]) -> DMatrix<f64> {
    let n = blocks.first().map_or(0, |b| b.nrows());
    chosen
        .iter()
        .fold(DMatrix::zeros(n, n), |s, &i| s + &blocks[i])
}

/// `a` is better than `b`: a lower I_w, or an equal (infinite) one and a larger log det.
fn better(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 > b.1)
}

/// Greedy forward selection of `count` of `blocks`: the chosen indices and I_w after each
/// addition. Adding a positive semidefinite block never lowers λ_min, so the trace never
/// rises.
pub fn greedy(blocks: &[DMatrix<f64>], count: usize) -> (Vec<usize>, Vec<f64>) {
    let mut chosen: Vec<usize> = Vec::with_capacity(count);
    let mut trace = Vec::with_capacity(count);
    let mut gram = sum_blocks(blocks, &[]);
    while chosen.len() < count.min(blocks.len()) {
        let mut best: Option<(usize, (f64, f64))> = None;
        for (i, b) in blocks.iter().enumerate() {
            if chosen.contains(&i) {
                continue;
            }
            let s = score(&(&gram + b));
            if best.is_none_or(|(_, bs)| better(s, bs)) {
                best = Some((i, s));
            }
        }
        let (i, s) = best.expect("an unchosen block remains");
        gram += &blocks[i];
        chosen.push(i);
        trace.push(s.0);
    }
    (chosen, trace)
}

/// Exchange passes: for each chosen index, the unchosen one that lowers I_w most replaces
/// it when it does lower it; stops after a pass without a swap or `max_passes`. Returns the
/// layout and I_w after each accepted swap (strictly falling).
pub fn exchange(
    blocks: &[DMatrix<f64>],
    mut chosen: Vec<usize>,
    max_passes: usize,
) -> (Vec<usize>, Vec<f64>) {
    let mut trace = Vec::new();
    let mut current = score(&sum_blocks(blocks, &chosen));
    for _ in 0..max_passes {
        let mut swapped = false;
        for slot in 0..chosen.len() {
            let without = sum_blocks(blocks, &chosen) - &blocks[chosen[slot]];
            let mut best: Option<(usize, (f64, f64))> = None;
            for (j, b) in blocks.iter().enumerate() {
                if chosen.contains(&j) {
                    continue;
                }
                let s = score(&(&without + b));
                if better(s, current) && best.is_none_or(|(_, bs)| better(s, bs)) {
                    best = Some((j, s));
                }
            }
            if let Some((j, s)) = best {
                chosen[slot] = j;
                current = s;
                trace.push(s.0);
                swapped = true;
            }
        }
        if !swapped {
            break;
        }
    }
    (chosen, trace)
}

/// Spearman's rank correlation of `a` and `b` (ties take their mean rank); NaN when either
/// is constant or they are shorter than 2.
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "paired samples");
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let mean = (n + 1.0) / 2.0;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        sab += (x - mean) * (y - mean);
        saa += (x - mean).powi(2);
        sbb += (y - mean).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

/// 1-based ranks, ties at their mean rank.
fn ranks(v: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
    let mut out = vec![0.0; v.len()];
    let mut k = 0;
    while k < order.len() {
        let mut e = k;
        while e + 1 < order.len() && v[order[e + 1]] == v[order[k]] {
            e += 1;
        }
        let r = (k + e) as f64 / 2.0 + 1.0;
        order[k..=e].iter().for_each(|&i| out[i] = r);
        k = e + 1;
    }
    out
}

//! Force locations among candidates (thesis 4.4.2, equations 4.11-4.13, Corollary 2,
//! Remark 2): all candidates are solved together; the candidates that carry no force come
//! out near zero, so a threshold picks the others.
//!
//! The rule: a candidate is found when its force magnitude exceeds `found_sigmas` times its
//! σ (the largest σ of its unknowns) and `found_fraction` of the largest magnitude. Found
//! candidates within `group_radius` of a group's strongest one join that group; a group is
//! one located force, at the magnitude-weighted centre of its candidates (a true location
//! between candidates spreads its force over its neighbours), carrying their summed force.

use super::solve::MarkerFrame;
use super::{CandidateLocation, MarkersParams};
use crate::math::{norm, sub};
use serde::Serialize;

/// One located force.
#[derive(Debug, Clone, Serialize)]
pub struct LocatedForce {
    /// The found candidate locations it gathers (indices into the sensor's `locations`),
    /// strongest first.
    pub candidates: Vec<usize>,
    /// Magnitude-weighted centre of their rest positions (m).
    pub centre: [f64; 3],
    /// Their summed force (N).
    pub force: [f64; 3],
}

/// The candidates found in `frame` (see the module docs), grouped into located forces.
pub fn locate_forces(
    frame: &MarkerFrame,
    candidates: &[CandidateLocation],
    params: &MarkersParams,
) -> Vec<LocatedForce> {
    if frame.forces.len() != candidates.len() {
        return Vec::new();
    }
    let mags: Vec<f64> = frame.forces.iter().map(|f| norm(*f)).collect();
    let largest = mags.iter().copied().fold(0.0, f64::max);
    let mut k = 0;
    let mut found = Vec::new();
    for (i, c) in candidates.iter().enumerate() {
        let n = c.unknowns();
        let sigma = (frame.sigma.get(k..k + n).unwrap_or(&[]).iter().copied()).fold(0.0, f64::max);
        k += n;
        if mags[i] > params.found_sigmas * sigma
            && mags[i] >= params.found_fraction * largest
            && mags[i] > 0.0
        {
            found.push(i);
        }
    }
    found.sort_by(|a, b| mags[*b].total_cmp(&mags[*a]));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in found {
        let p = candidates[i].position;
        match (groups.iter_mut())
            .find(|g| norm(sub(candidates[g[0]].position, p)) <= params.group_radius)
        {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    groups
        .into_iter()
        .map(|g| {
            let total: f64 = g.iter().map(|&i| mags[i]).sum();
            let mut centre = [0.0; 3];
            let mut force = [0.0; 3];
            for &i in &g {
                for a in 0..3 {
                    centre[a] += mags[i] / total * candidates[i].position[a];
                    force[a] += frame.forces[i][a];
                }
            }
            LocatedForce {
                candidates: g,
                centre,
                force,
            }
        })
        .collect()
}

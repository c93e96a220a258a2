//! A located force moved off the candidate grid (issue 36): a force between candidates
//! spreads over its neighbours, and their magnitude-weighted centre is a poor interpolant
//! when the candidates are far apart. Instead, each located force is placed on the surface
//! node near its candidates where one force alone explains the markers best.
//!
//! The search is linear about the frame's FE state: one FE solve and one compliance column
//! per searched node, no solve per node. With the residual r of the markers at that state,
//! W_C the compliance of all candidates and λ_C their intensities, d = r + W_C λ_C is the
//! markers' displacement the forces explain. A node v with compliance W_v explains it with
//! the residual min ‖d − W_R λ_R − W_v λ_v‖ over λ_R and λ_v, R the candidates outside the
//! group: the group's forces replaced by one at v, and the other candidates re-fitted with
//! it (a share of the force left on a candidate just outside the group, below the found
//! rule, would otherwise stay there and pull v off). The node of the smallest residual
//! wins.

use super::locate::LocatedForce;
use super::solve::{MarkerFrame, MarkerSensor};
use super::{CandidateLocation, MarkersResult};
use crate::fem::solve::MappedPoint;
use crate::inverse::{loads_of, total_force};
use crate::math::{dot, norm, sub};
use nalgebra::{DMatrix, DVector};

/// The search nodes of one located force: unheld surface nodes within `radius` of one of
/// its locations, facing the same way (normal candidates), with its directions.
fn search_nodes(
    sensor: &MarkerSensor,
    located: &LocatedForce,
    radius: f64,
) -> Vec<CandidateLocation> {
    let mesh = &sensor.problem.mesh;
    let surface = mesh.surface();
    let held = sensor.problem.held_nodes();
    let x = &mesh.nodes_in_rest;
    let first = &sensor.locations[located.candidates[0]];
    let first_directions: Vec<[f64; 3]> = first.candidates.iter().map(|c| c.direction).collect();
    let normal_only = first_directions.len() == 1;
    (surface.nodes.iter().copied())
        .filter(|v| held.binary_search(v).is_err())
        .filter(|&v| {
            (located.candidates.iter())
                .any(|&i| norm(sub(x[v], sensor.locations[i].position)) <= radius)
        })
        .filter(|&v| !normal_only || dot(surface.vertex_normals[v], first_directions[0]) > 0.5)
        .map(|v| {
            let directions = if normal_only {
                vec![surface.vertex_normals[v]]
            } else {
                first_directions.clone()
            };
            CandidateLocation::new(&format!("n{v}"), MappedPoint::node(v), &directions, x[v])
        })
        .collect()
}

/// The frame's linearisation with every search node added as a location with no force:
/// the compliance columns of all unknowns (the sensor's first), the markers' displacement
/// the sensor's forces explain (see the module docs), and the first unknown of each
/// location of the extended list.
struct Extended {
    /// Compliance of the visible markers' rows and every unknown (m/N).
    w: DMatrix<f64>,
    /// d = r + W_C λ_C (m).
    explained: DVector<f64>,
    /// The first unknown of each location: the sensor's, then the search nodes'.
    offset: Vec<usize>,
}

impl Extended {
    fn new(
        sensor: &MarkerSensor,
        frame: &MarkerFrame,
        measured: &[Option<[f64; 3]>],
        groups: &[Vec<CandidateLocation>],
    ) -> MarkersResult<Self> {
        let mut all = sensor.locations.clone();
        all.extend(groups.iter().flatten().cloned());
        let mut offset = Vec::with_capacity(all.len());
        let mut k = 0;
        for l in &all {
            offset.push(k);
            k += l.unknowns();
        }
        let ext = sensor.with_locations(all)?;
        let mut lambda = frame.intensities.clone();
        lambda.resize(ext.unknowns(), 0.0);
        let visible: Vec<usize> = (0..measured.len())
            .filter(|&m| measured[m].is_some())
            .collect();
        let (sol, w) = ext.linearise(&lambda, &visible, frame.solution.as_ref())?;
        let r0 = DVector::from_iterator(
            w.nrows(),
            (visible.iter()).flat_map(|&m| {
                let (t, p) = (
                    measured[m].expect("visible"),
                    ext.markers[m].at.position(&sol.positions),
                );
                [0, 1, 2].map(|a| t[a] - p[a])
            }),
        );
        // The markers' displacement from the unloaded linearised state: every candidate's
        // share put back.
        let mut explained = r0.clone();
        for (j, l) in lambda.iter().enumerate().take(sensor.unknowns()) {
            explained += w.column(j) * *l;
        }
        Ok(Self {
            w,
            explained,
            offset,
        })
    }

    /// The best of `nodes` (the search nodes of `located`, locations from `first` on in the
    /// extended list) for one force there, the other locations re-fitted with it: its index
    /// and its intensities. `None` when no node gives a full-rank fit.
    fn best_node(
        &self,
        sensor: &MarkerSensor,
        located: &LocatedForce,
        nodes: &[CandidateLocation],
        first: usize,
    ) -> Option<(usize, DVector<f64>)> {
        let offset = &self.offset;
        // The group replaced by one force at a node; the other candidates re-fitted with it,
        // so a share of the force left on a candidate outside the group is not fixed there.
        let rest: Vec<usize> = (0..sensor.locations.len())
            .filter(|i| !located.candidates.contains(i))
            .flat_map(|i| offset[i]..offset[i] + sensor.locations[i].unknowns())
            .collect();
        let mut best: Option<(f64, usize, DVector<f64>)> = None;
        for (e, c) in nodes.iter().enumerate() {
            let d = c.unknowns();
            let mut idx = rest.clone();
            idx.extend(offset[first + e]..offset[first + e] + d);
            let a = self.w.select_columns(&idx);
            let Some(chol) = a.tr_mul(&a).cholesky() else {
                continue;
            };
            let sol_e = chol.solve(&a.tr_mul(&self.explained));
            let res = (&self.explained - &a * &sol_e).norm();
            if best.as_ref().is_none_or(|b| res < b.0) {
                best = Some((res, e, sol_e.rows(rest.len(), d).clone_owned()));
            }
        }
        best.map(|(_, e, lam)| (e, lam))
    }
}

/// Each of `located` (from [`super::locate_forces`] on `frame`) moved to the surface node
/// within `params.refine_radius` of its candidates where one force explains the markers
/// `measured` best (see the module docs), with that force. Unchanged when the radius is 0
/// or the frame has no forces.
pub fn refine_located(
    sensor: &MarkerSensor,
    frame: &MarkerFrame,
    measured: &[Option<[f64; 3]>],
    located: &[LocatedForce],
) -> MarkersResult<Vec<LocatedForce>> {
    let radius = sensor.params.refine_radius;
    if located.is_empty() || radius <= 0.0 || frame.intensities.len() != sensor.unknowns() {
        return Ok(located.to_vec());
    }
    let groups: Vec<Vec<CandidateLocation>> = (located.iter())
        .map(|l| search_nodes(sensor, l, radius))
        .collect();
    let ext = Extended::new(sensor, frame, measured, &groups)?;
    let mut out = Vec::with_capacity(located.len());
    let mut first = sensor.locations.len();
    for (l, nodes) in located.iter().zip(&groups) {
        out.push(match ext.best_node(sensor, l, nodes, first) {
            Some((e, lam)) => LocatedForce {
                candidates: l.candidates.clone(),
                centre: nodes[e].position,
                force: total_force(&loads_of(&nodes[e].candidates, lam.as_slice())),
            },
            None => l.clone(),
        });
        first += nodes.len();
    }
    Ok(out)
}

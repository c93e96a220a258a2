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
use super::{ForceCandidate, MarkersResult};
use crate::fem::solve::MappedPoint;
use crate::math::{dot, norm, sub};
use nalgebra::DVector;

/// The search nodes of one located force: unheld surface nodes within `radius` of one of
/// its candidates, facing the same way (normal candidates), with its directions.
fn search_nodes(sensor: &MarkerSensor, located: &LocatedForce, radius: f64) -> Vec<ForceCandidate> {
    let mesh = &sensor.problem.mesh;
    let surface = mesh.surface();
    let held = sensor.problem.held_nodes();
    let x = &mesh.nodes_in_rest;
    let first = &sensor.candidates[located.candidates[0]];
    let normal_only = first.directions.len() == 1;
    (surface.nodes.iter().copied())
        .filter(|v| held.binary_search(v).is_err())
        .filter(|&v| {
            (located.candidates.iter())
                .any(|&i| norm(sub(x[v], sensor.candidates[i].position)) <= radius)
        })
        .filter(|&v| !normal_only || dot(surface.vertex_normals[v], first.directions[0]) > 0.5)
        .map(|v| ForceCandidate {
            name: format!("n{v}"),
            at: MappedPoint::node(v),
            directions: if normal_only {
                vec![surface.vertex_normals[v]]
            } else {
                first.directions.clone()
            },
            position: x[v],
        })
        .collect()
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
    let groups: Vec<Vec<ForceCandidate>> = (located.iter())
        .map(|l| search_nodes(sensor, l, radius))
        .collect();
    let mut all = sensor.candidates.clone();
    all.extend(groups.iter().flatten().cloned());
    // The first unknown of each candidate of the extended list.
    let mut offset = Vec::with_capacity(all.len());
    let mut k = 0;
    for c in &all {
        offset.push(k);
        k += c.directions.len();
    }
    let ext = sensor.with_candidates(all)?;
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
    let mut out = Vec::with_capacity(located.len());
    let mut first = sensor.candidates.len();
    // The markers' displacement from the unloaded linearised state: every candidate's
    // share put back.
    let n0 = sensor.unknowns();
    let mut r_all = r0.clone();
    for (j, l) in lambda.iter().enumerate().take(n0) {
        r_all += w.column(j) * *l;
    }
    for (l, nodes) in located.iter().zip(&groups) {
        // The group replaced by one force at a node; the other candidates re-fitted with it,
        // so a share of the force left on a candidate outside the group is not fixed there.
        let rest: Vec<usize> = (0..sensor.candidates.len())
            .filter(|i| !l.candidates.contains(i))
            .flat_map(|i| offset[i]..offset[i] + sensor.candidates[i].directions.len())
            .collect();
        let mut best: Option<(f64, usize, DVector<f64>)> = None;
        for (e, c) in nodes.iter().enumerate() {
            let d = c.directions.len();
            let mut idx = rest.clone();
            idx.extend(offset[first + e]..offset[first + e] + d);
            let a = w.select_columns(&idx);
            let Some(chol) = a.tr_mul(&a).cholesky() else {
                continue;
            };
            let sol_e = chol.solve(&a.tr_mul(&r_all));
            let res = (&r_all - &a * &sol_e).norm();
            if best.as_ref().is_none_or(|b| res < b.0) {
                best = Some((res, e, sol_e.rows(rest.len(), d).clone_owned()));
            }
        }
        first += nodes.len();
        out.push(match best {
            Some((_, e, lam)) => {
                let c = &nodes[e];
                let mut force = [0.0; 3];
                for (d, s) in c.directions.iter().zip(lam.iter()) {
                    (0..3).for_each(|a| force[a] += s * d[a]);
                }
                LocatedForce {
                    candidates: l.candidates.clone(),
                    centre: c.position,
                    force,
                }
            }
            None => l.clone(),
        });
    }
    Ok(out)
}

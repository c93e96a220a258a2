//! The catheter in its tube: the beam model with its cables, and its quasi-static
//! equilibrium with the tube's unilateral contacts (5.1-5.4) for cables driven either by
//! tension (the FE model's inputs) or by displacement (the robot's motors).
//!
//! Each settle repeats: solve the beam under the cables and the contact forces so far;
//! detect the nodes within the alarm distance of the wall; linearise W = H K⁻¹ Hᵀ on the
//! contact rows (and, for displacement-driven cables, the cable rows); solve the LCP for
//! the forces that close every gap from the current one; stop when the forces no longer
//! change. A displacement-driven cable is itself a unilateral constraint: its routing may
//! not be longer than the cable the motor lets out, g_a = s(x) + c T − u ≥ 0 with the
//! cable's own compliance c, complementary to its tension T ≥ 0 (a slack cable carries
//! nothing), so the plant's cables and contacts are one LCP.

use super::tube::{NodeContact, Surface, Tube};
use super::{CatheterError, CatheterResult};
use crate::fem::beam::{
    BeamCable, BeamLoads, BeamModel, BeamParams, BeamRow, BeamState, BeamStatus, NodeLoad,
    NodeSpring,
};
use crate::inverse::qp::QpParams;
use crate::inverse::qpcc::{solve_contact_lcp, LcpStatus};
use nalgebra::DMatrix;
use serde::Serialize;

/// The catheter: its beam, its cables and what the contact needs of its section.
#[derive(Clone, Debug)]
pub struct Catheter {
    /// The FE model; node 0 is the base on the insertion stage.
    pub beam: BeamModel,
    /// The cables, anchored at the tip.
    pub cables: Vec<BeamCable>,
    /// Outer radius of the catheter's section (m): a node touches the wall at this gap.
    pub radius: f64,
    /// Each cable's own axial compliance L / (E A) (m/N; > 0 keeps W_aa invertible for
    /// four cables, whose bending and stretch span only three directions).
    pub cable_compliance: f64,
}

/// The smallest fraction of a round's force change that is applied.
const MIN_RELAXATION: f64 = 1.0 / 64.0;

/// How the cables are driven.
#[derive(Clone, Copy, Debug)]
pub enum Drive<'a> {
    /// Tensions (N, ≥ 0), one per cable: the FE model's inputs.
    Tensions(&'a [f64]),
    /// Cable pulled in by the motors (m; negative lets cable out), one per cable: the
    /// robot's inputs.
    Pulls(&'a [f64]),
}

/// Options of a settle.
#[derive(Clone, Debug)]
pub struct SettleParams {
    /// A node whose gap to the wall is below this becomes a contact row (m; 1e-3).
    pub alarm: f64,
    /// Rounds of beam solve and LCP at most; 200.
    pub max_rounds: usize,
    /// Settled when no force changes by more than this between rounds (N; 1e-7).
    pub force_tolerance: f64,
    /// Stiffness of the wall behind each pushed node inside the beam's Newton solve (N/m;
    /// 1e3). It vanishes at the settled state (the gap is then zero) but keeps a rod
    /// compressed by its contacts from jumping through the wall between rounds.
    pub wall_stiffness: f64,
    /// The beam's Newton options.
    pub beam: BeamParams,
    /// The LCP's QP options.
    pub qp: QpParams,
}

impl Default for SettleParams {
    fn default() -> Self {
        Self {
            alarm: 1e-3,
            max_rounds: 200,
            force_tolerance: 1e-7,
            wall_stiffness: 1e3,
            beam: BeamParams {
                tolerance: 1e-9,
                ..BeamParams::default()
            },
            qp: QpParams::default(),
        }
    }
}

/// A node pushed by the wall or an obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ContactForce {
    /// The catheter node.
    pub node: usize,
    /// What pushes it.
    pub surface: Surface,
    /// Arc length of the nearest path point (m).
    pub s: f64,
    /// Unit direction of the push (towards the tube's axis, or away from an obstacle).
    pub normal: [f64; 3],
    /// The push (N, ≥ 0).
    pub force: f64,
    /// The node's gap to the surface (m).
    pub gap: f64,
}

/// How a settle ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum SettleStatus {
    /// The forces stopped changing.
    Settled,
    /// `max_rounds` came first; the last round's state is kept.
    MaxRounds,
    /// The beam's Newton did not converge.
    Beam(BeamStatus),
    /// The LCP had no solution (the wall and the cables cannot both be met).
    Lcp(LcpStatus),
}

/// The catheter at equilibrium.
#[derive(Clone, Debug)]
pub struct Settled {
    /// The configuration.
    pub state: BeamState,
    /// The cables' tensions (N).
    pub tensions: Vec<f64>,
    /// Nodes the wall or an obstacle pushes, by node; zero forces left out.
    pub contacts: Vec<ContactForce>,
    /// How the settle ended.
    pub status: SettleStatus,
    /// Rounds used.
    pub rounds: usize,
}

impl Settled {
    /// The tip's position (m).
    pub fn tip(&self) -> [f64; 3] {
        let p = self.state.nodes_in_world.last().expect("a beam has nodes");
        [p.x, p.y, p.z]
    }
}

impl Catheter {
    /// Index of the tip node.
    pub fn tip_node(&self) -> usize {
        self.beam.node_count() - 1
    }

    /// The nodes' positions at `state`.
    pub fn positions(state: &BeamState) -> Vec<[f64; 3]> {
        state
            .nodes_in_world
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect()
    }

    /// Every node within the alarm distance of a surface, plus the (node, surface) pairs
    /// in `keep` (which carry a force and must be able to let go), sorted by node.
    pub fn contact_rows(
        &self,
        tube: &Tube,
        state: &BeamState,
        alarm: f64,
        keep: &[(usize, Surface)],
    ) -> Vec<NodeContact> {
        let x = Self::positions(state);
        let mut rows = tube.contacts(&x, self.radius, alarm);
        for &(node, surface) in keep {
            if !rows.iter().any(|c| (c.node, c.surface) == (node, surface)) {
                rows.push(NodeContact {
                    node,
                    ..tube.gap_to(surface, x[node], self.radius)
                });
            }
        }
        rows.sort_by_key(|c| c.node);
        rows
    }

    /// Cable shortenings s(x) (m).
    pub fn shortenings(&self, state: &BeamState) -> Vec<f64> {
        (self.cables.iter())
            .map(|c| c.shortening(&self.beam, state))
            .collect()
    }

    /// Equilibrium at `insertion` m of the base, from `start` with the contact forces of
    /// `warm` (the last step's) as the first guess.
    pub fn settle(
        &self,
        tube: &Tube,
        start: &BeamState,
        insertion: f64,
        drive: Drive<'_>,
        warm: &Settled,
        params: &SettleParams,
    ) -> CatheterResult<Settled> {
        let n_a = self.cables.len();
        let mut tensions = match drive {
            Drive::Tensions(t) => {
                self.check_inputs(t, "tensions")?;
                if t.iter().any(|&v| v < 0.0) {
                    return Err(CatheterError::Shape(
                        "a cable tension is negative: cables only pull".into(),
                    ));
                }
                t.to_vec()
            }
            Drive::Pulls(u) => {
                self.check_inputs(u, "pulls")?;
                let mut t = warm.tensions.clone();
                t.resize(n_a, 0.0);
                t
            }
        };
        let mut forces: Vec<Push> = warm.contacts.iter().map(Push::from).collect();
        let mut state = start.clone();
        let base_from_rest = self.beam.insertion(insertion);
        let (mut relax, mut last_change) = (1.0_f64, f64::INFINITY);
        for round in 1..=params.max_rounds {
            let loads = BeamLoads {
                nodes: (forces.iter())
                    .map(|p| NodeLoad::force(p.node, p.normal.map(|v| p.force * v)))
                    .collect(),
                springs: self.walls(tube, &state, &forces, params.wall_stiffness),
                cables: self.cables.iter().copied().zip(tensions.clone()).collect(),
                base_from_rest,
            };
            let sol = self.beam.solve_static(&state, &loads, &params.beam)?;
            state = sol.state;
            // What each node was pushed with: the force and its wall's spring.
            for (f, spring) in forces.iter_mut().zip(&loads.springs) {
                let x = &state.nodes_in_world[spring.node];
                f.force += spring.force(x).dot(&spring.direction);
            }
            if !sol.status.is_converged() {
                return Ok(self.finish(
                    state,
                    tensions,
                    &forces,
                    tube,
                    SettleStatus::Beam(sol.status),
                    round,
                ));
            }
            let keep: Vec<(usize, Surface)> = forces.iter().map(|f| (f.node, f.surface)).collect();
            let rows = self.contact_rows(tube, &state, params.alarm, &keep);
            let pulls = match drive {
                Drive::Pulls(u) => Some(u),
                Drive::Tensions(_) => None,
            };
            if rows.is_empty() && pulls.is_none() {
                return Ok(self.finish(state, tensions, &[], tube, SettleStatus::Settled, round));
            }
            // The forces applied this round, measured along each row's current normal.
            let mut applied: Vec<f64> = rows.iter().map(|c| along(&forces, c)).collect();
            let mut gaps: Vec<f64> = rows.iter().map(|c| c.gap).collect();
            let mut beam_rows: Vec<BeamRow> = rows
                .iter()
                .map(|c| BeamRow::translation(c.node, c.normal))
                .collect();
            if let Some(u) = pulls {
                let s = self.shortenings(&state);
                for (i, cable) in self.cables.iter().enumerate() {
                    beam_rows.push(cable.row(&state));
                    applied.push(tensions[i]);
                    gaps.push(s[i] + self.cable_compliance * tensions[i] - u[i]);
                }
            }
            let mut w = (self.beam.linearise_loaded(&state, &loads.cables)?).compliance(&beam_rows);
            if pulls.is_some() {
                for i in rows.len()..beam_rows.len() {
                    w[(i, i)] += self.cable_compliance;
                }
            }
            let n_c = rows.len();
            soften(
                tube,
                &rows,
                &state,
                self.radius,
                &mut w,
                0,
                &mut gaps[..n_c],
                &applied,
            );
            let free = free_gaps(&w, &gaps, &applied);
            let lcp = solve_contact_lcp(&w, &free, &params.qp)?;
            if lcp.status != LcpStatus::Solved {
                return Ok(self.finish(
                    state,
                    tensions,
                    &forces,
                    tube,
                    SettleStatus::Lcp(lcp.status),
                    round,
                ));
            }
            let change = (lcp.lambda.iter().zip(&applied))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let unmatched = forces.iter().any(|f| {
                f.force > 0.0
                    && !rows
                        .iter()
                        .any(|c| (c.node, c.surface) == (f.node, f.surface))
            });
            if change <= params.force_tolerance && !unmatched {
                return Ok(self.finish(
                    state,
                    tensions,
                    &forces,
                    tube,
                    SettleStatus::Settled,
                    round,
                ));
            }
            // Far from contact the linearisation overshoots and the rounds can cycle; each
            // round that barely shrinks the change halves the step towards the LCP's forces,
            // and each that halves it lengthens the step again.
            if change >= 0.9 * last_change {
                relax = (0.5 * relax).max(MIN_RELAXATION);
            } else if change < 0.5 * last_change {
                relax = (1.5 * relax).min(1.0);
            }
            last_change = change;
            let next: Vec<f64> = (lcp.lambda.iter().zip(&applied))
                .map(|(l, a)| (a.max(0.0) + relax * (l - a.max(0.0))).max(0.0))
                .collect();
            forces = (rows.iter().zip(&next))
                .filter(|(_, f)| **f > 0.0)
                .map(|(c, &force)| Push {
                    node: c.node,
                    surface: c.surface,
                    normal: c.normal,
                    force,
                })
                .collect();
            if pulls.is_some() {
                tensions.copy_from_slice(&next[rows.len()..]);
            }
        }
        Ok(self.finish(
            state,
            tensions,
            &forces,
            tube,
            SettleStatus::MaxRounds,
            params.max_rounds,
        ))
    }

    /// A spring along each push's normal, relaxed where the node would meet its surface
    /// (a soft wall's as the pushes dent it).
    fn walls(
        &self,
        tube: &Tube,
        state: &BeamState,
        forces: &[Push],
        stiffness: f64,
    ) -> Vec<NodeSpring> {
        (forces.iter().zip(self.pushed_gaps(tube, state, forces)))
            .map(|(p, c)| {
                let x = state.nodes_in_world[p.node];
                let to_wall = crate::math::Vec3::from(c.normal) * c.gap;
                NodeSpring {
                    node: p.node,
                    direction: p.normal.into(),
                    anchor: x - to_wall,
                    stiffness,
                }
            })
            .collect()
    }

    /// Each push's gap to its surface, a soft wall's dented by all the pushes.
    fn pushed_gaps(&self, tube: &Tube, state: &BeamState, forces: &[Push]) -> Vec<NodeContact> {
        let x = Self::positions(state);
        let mut rows: Vec<NodeContact> = (forces.iter())
            .map(|p| NodeContact {
                node: p.node,
                ..tube.gap_to(p.surface, x[p.node], self.radius)
            })
            .collect();
        if let Some(c) = tube.wall_compliance(&rows, &x, self.radius) {
            let applied: Vec<f64> = rows.iter().map(|r| along(forces, r)).collect();
            let dent = c * nalgebra::DVector::from_column_slice(&applied);
            for (r, d) in rows.iter_mut().zip(dent.iter()) {
                r.gap += d;
            }
        }
        rows
    }

    fn check_inputs(&self, v: &[f64], what: &str) -> CatheterResult<()> {
        if v.len() != self.cables.len() || v.iter().any(|x| !x.is_finite()) {
            return Err(CatheterError::Shape(format!(
                "{} finite {what} wanted, one per cable; got {}",
                self.cables.len(),
                v.len()
            )));
        }
        Ok(())
    }

    fn finish(
        &self,
        state: BeamState,
        tensions: Vec<f64>,
        forces: &[Push],
        tube: &Tube,
        status: SettleStatus,
        rounds: usize,
    ) -> Settled {
        let pushed: Vec<Push> = forces.iter().filter(|f| f.force > 0.0).copied().collect();
        let contacts = (pushed.iter().zip(self.pushed_gaps(tube, &state, &pushed)))
            .map(|(p, c)| ContactForce {
                node: p.node,
                surface: p.surface,
                s: c.s,
                normal: p.normal,
                force: p.force,
                gap: c.gap,
            })
            .collect();
        Settled {
            state,
            tensions,
            contacts,
            status,
            rounds,
        }
    }

    /// The catheter at rest with slack cables and no contact, for the first step's warm start.
    pub fn unloaded(&self) -> Settled {
        Settled {
            state: self.beam.rest_state(),
            tensions: vec![0.0; self.cables.len()],
            contacts: Vec::new(),
            status: SettleStatus::Settled,
            rounds: 0,
        }
    }
}

/// A soft wall's part of the contact rows `rows`, which start at row `offset` of `w`: its
/// compliance added to their block (W_cc = H1 K1⁻¹ H1ᵀ + H2 K2⁻¹ H2ᵀ), and the dent of
/// the forces `applied` to them (indexed as `w`'s rows) added to their `gaps` (one per row,
/// from the undeformed wall). Nothing for a rigid tube.
#[allow(clippy::too_many_arguments)]
pub(super) fn soften(
    tube: &Tube,
    rows: &[NodeContact],
    state: &BeamState,
    catheter_radius: f64,
    w: &mut DMatrix<f64>,
    offset: usize,
    gaps: &mut [f64],
    applied: &[f64],
) {
    if tube.soft.is_none() {
        return;
    }
    let x = Catheter::positions(state);
    let Some(c) = tube.wall_compliance(rows, &x, catheter_radius) else {
        return;
    };
    let n = rows.len();
    let dent = &c * nalgebra::DVector::from_column_slice(&applied[offset..offset + n]);
    for (g, d) in gaps.iter_mut().zip(dent.iter()) {
        *g += d;
    }
    let mut block = w.view_mut((offset, offset), (n, n));
    block += c;
}

/// The gaps with the applied forces taken away, g − W λ: the LCP's free gaps.
fn free_gaps(w: &DMatrix<f64>, gaps: &[f64], applied: &[f64]) -> Vec<f64> {
    let wl = w * nalgebra::DVector::from_column_slice(applied);
    gaps.iter().zip(wl.iter()).map(|(g, v)| g - v).collect()
}

/// A push being settled: a node, what pushes it, the push's direction and size (N).
#[derive(Clone, Copy, Debug)]
struct Push {
    node: usize,
    surface: Surface,
    normal: [f64; 3],
    force: f64,
}

impl From<&ContactForce> for Push {
    fn from(c: &ContactForce) -> Self {
        Self {
            node: c.node,
            surface: c.surface,
            normal: c.normal,
            force: c.force,
        }
    }
}

/// The push on `row`'s node by `row`'s surface among `forces`, measured along the row's
/// normal (the surface's direction moves with the node between rounds and steps); 0
/// without.
fn along(forces: &[Push], row: &NodeContact) -> f64 {
    (forces
        .iter()
        .find(|f| (f.node, f.surface) == (row.node, row.surface)))
    .map_or(0.0, |f| f.force * crate::math::dot(f.normal, row.normal))
}

impl Settled {
    /// The push this equilibrium puts on `row`'s node by `row`'s surface, along the row's
    /// normal (N).
    pub fn force_along(&self, row: &NodeContact) -> f64 {
        let forces: Vec<Push> = self.contacts.iter().map(Push::from).collect();
        along(&forces, row)
    }
}

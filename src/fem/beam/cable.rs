//! A cable routed at a fixed offset in every node's section, anchored at the tip.
//!
//! Routing point of node i: p_i = x_i + R_i r (0, cos θ, sin θ) (node frame: x along the
//! rod). The cable runs straight from routing point to routing point, from the base (node
//! 0) to the tip, where it is anchored. Its length is Σ |p_{i+1} − p_i|; its shortening
//! s = length at rest − length now. Under tension T it pulls each routing point by
//! T ∂s/∂p_i: at the tip T toward the previous point, at an intermediate point T times the
//! sum of the unit vectors toward both neighbours; each force acts at p_i, so the node also
//! takes the moment (p_i − x_i) × F. That generalised force T ∂s/∂(x, w) is the cable's
//! constraint row: the actuator row of W is its H, W_aa = ∂s/∂T = gᵀ K⁻¹ g.

use super::{BeamModel, BeamRow, BeamState};
use crate::math::Vec3;

/// A cable at `offset` from the centreline, at `angle` in the section plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamCable {
    /// Distance from the centreline (m).
    pub offset: f64,
    /// Angle in the section plane from the node frame's y axis toward its z axis (rad).
    pub angle: f64,
}

impl BeamCable {
    /// The routing points p_i at `state` (m, world frame), base to tip.
    pub fn routing_points(&self, state: &BeamState) -> Vec<Vec3> {
        let local = Vec3::new(0.0, self.angle.cos(), self.angle.sin()) * self.offset;
        state
            .nodes_in_world
            .iter()
            .zip(&state.world_from_node)
            .map(|(x, q)| x + q * local)
            .collect()
    }

    /// The cable's length from the base to the tip (m).
    pub fn length(&self, state: &BeamState) -> f64 {
        self.routing_points(state)
            .windows(2)
            .map(|w| (w[1] - w[0]).norm())
            .sum()
    }

    /// How much the cable has shortened from the model's rest configuration (m).
    pub fn shortening(&self, model: &BeamModel, state: &BeamState) -> f64 {
        self.length(&model.rest) - self.length(state)
    }

    /// The cable's constraint row at `state`: ∂s/∂(x_i, w_i) per node (its loads under
    /// tension T are T times it).
    pub fn row(&self, state: &BeamState) -> BeamRow {
        let p = self.routing_points(state);
        let n = p.len();
        let unit_to = |from: usize, to: usize| {
            let d = p[to] - p[from];
            let l = d.norm();
            if l > 0.0 {
                d / l
            } else {
                Vec3::zeros()
            }
        };
        let entries = (1..n)
            .map(|i| {
                let mut force = unit_to(i, i - 1);
                if i + 1 < n {
                    force += unit_to(i, i + 1);
                }
                let moment = (p[i] - state.nodes_in_world[i]).cross(&force);
                (i, [force.x, force.y, force.z, moment.x, moment.y, moment.z])
            })
            .collect();
        BeamRow { entries }
    }
}

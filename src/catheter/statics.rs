//! Static insertions (thesis 5.5.6, Fig. 5.9 c-d and 5.10): the catheter pushed passively,
//! cables slack, through the scenario's tube to several insertions, the FE model and the
//! robot settled at each, and the model's tip compared with the robot's. The thesis's rod
//! gave 3.35 mm on average over ten positions in a 3-D tube.
//!
//! With rigid walls and no other load, the shape of a passive rod does not depend on its
//! modulus; what differs between model and robot is how each discretisation meets the
//! wall (node-based contact: a coarse model's segments may cut the wall between nodes).

use super::rig::{Catheter, ContactForce, Drive, SettleStatus, Settled};
use super::run::failure;
use super::scenario::Scenario;
use super::{CatheterError, CatheterResult};
use crate::math::dist;
use serde::Serialize;

/// The insertion advanced between settles on the way to each position (m): small enough
/// that a node never jumps through the wall's alarm band in one move.
const INSERTION_STEP: f64 = 1e-3;

/// One static position.
#[derive(Clone, Debug, Serialize)]
pub struct StaticPosition {
    /// Inserted length (m).
    pub insertion: f64,
    /// The robot's tip (m).
    pub robot: [f64; 3],
    /// The model's tip (m).
    pub model: [f64; 3],
    /// Their distance: the model's tip error (m).
    pub error: f64,
    /// The model's contact forces.
    pub model_contacts: Vec<ContactForce>,
    /// The robot's contact forces.
    pub robot_contacts: Vec<ContactForce>,
    /// Whether every settle of both on the way here converged; when not, the shapes (and
    /// the error) are those of the round limit, not of an equilibrium.
    pub settled: bool,
}

/// The static positions and their summary.
#[derive(Clone, Debug, Serialize)]
pub struct Statics {
    /// The positions, in order of insertion.
    pub positions: Vec<StaticPosition>,
    /// Mean tip error (mm), the thesis's 3.35 mm line.
    pub mean_mm: f64,
    /// Largest tip error (mm).
    pub max_mm: f64,
    /// Settles, of model or robot, that stopped at their round limit on the way.
    pub unsettled: usize,
}

/// Pushes model and robot passively through the tube and records them at `count` evenly
/// spaced insertions up to the scenario's `insertion.end_mm`; `progress(done, count)`
/// after each position.
pub fn static_insertions(
    scenario: &Scenario,
    count: usize,
    progress: &mut dyn FnMut(usize, usize),
) -> CatheterResult<Statics> {
    if count == 0 {
        return Err(CatheterError::Shape(
            "static insertions: count must be > 0".into(),
        ));
    }
    let tube = scenario.tube()?;
    let catheters = [scenario.catheter(false)?, scenario.catheter(true)?];
    let params = scenario.settle_params();
    let end = 1e-3 * scenario.insertion.end_mm;
    let mut now: Vec<Settled> = catheters.iter().map(Catheter::unloaded).collect();
    let slack = vec![0.0; catheters[0].cables.len()];
    let (mut positions, mut d, mut unsettled) = (Vec::with_capacity(count), 0.0, 0);
    let mut settled = true;
    for i in 1..=count {
        let target = end * i as f64 / count as f64;
        while d < target {
            d = (d + INSERTION_STEP).min(target);
            for (who, (c, s)) in ["model", "robot"]
                .iter()
                .zip(catheters.iter().zip(&mut now))
            {
                let next = c.settle(&tube, &s.state, d, Drive::Tensions(&slack), s, &params)?;
                if let Some(reason) = failure(who, next.status) {
                    return Err(CatheterError::Shape(format!(
                        "static insertion at {:.1} mm: {reason}",
                        1e3 * d
                    )));
                }
                let stuck = next.status == SettleStatus::MaxRounds;
                unsettled += usize::from(stuck);
                settled &= !stuck;
                *s = next;
            }
        }
        let (m, r) = (&now[0], &now[1]);
        positions.push(StaticPosition {
            insertion: d,
            robot: r.tip(),
            model: m.tip(),
            error: dist(r.tip(), m.tip()),
            model_contacts: m.contacts.clone(),
            robot_contacts: r.contacts.clone(),
            settled,
        });
        settled = true;
        progress(i, count);
    }
    let errors: Vec<f64> = positions.iter().map(|p| p.error).collect();
    Ok(Statics {
        mean_mm: 1e3 * errors.iter().sum::<f64>() / errors.len() as f64,
        max_mm: 1e3 * errors.iter().copied().fold(0.0, f64::max),
        positions,
        unsettled,
    })
}

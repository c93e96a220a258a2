//! The control laws of thesis 3.4-3.7 as one step each, and Theorem 2's robust-stability
//! bound (3.30-3.42).

use super::predictor::Kinematics;
use super::scenario::LawKind;
use super::ControlResult;
use nalgebra::DMatrix;

/// Which loop drove the robot at a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SwitchState {
    /// Feedback from the measured effector.
    Closed,
    /// No feedback: the model's inputs, reached progressively (3.43) by the switched law.
    Open,
    /// No feedback and the law has no open-loop fallback: inputs held.
    Hold,
}

/// Inputs of the robot and of the model, and what they need to step.
#[derive(Debug, Clone)]
pub struct LawState {
    /// The robot's inputs (SI).
    pub robot: Vec<f64>,
    /// The model's inputs (SI).
    pub model: Vec<f64>,
    /// Robot minus model inputs at the last step with a measurement.
    pub offset: Vec<f64>,
}

/// Everything a law sees at step k.
#[derive(Debug, Clone, Copy)]
pub struct StepInput<'a> {
    /// The model's kinematics at its current state.
    pub kin: &'a Kinematics,
    /// The target now and at the next step (the same when it is not known ahead).
    pub target: [f64; 3],
    /// The target at the next step.
    pub next_target: [f64; 3],
    /// The measured robot error e = δ_e − δ_d at the measurement's step, if seen.
    pub error: Option<[f64; 3]>,
    /// The model's effector minus the measured robot effector, at the measurement's step.
    pub model_error: Option<[f64; 3]>,
}

/// Gains of a law.
#[derive(Debug, Clone, Copy)]
pub struct Gains {
    /// μ (3.19) or k_p (3.28); k_p^s of the open loop.
    pub gain: f64,
    /// k_p^s (3.29).
    pub model_gain: f64,
    /// p (3.43).
    pub switch_rate: f64,
    /// Input limits (SI).
    pub limits: [f64; 2],
    /// Keep the robot-model input offset of the last seen step while features are lost.
    pub keep_input_offset: bool,
    /// Controller 2 moves the model by the robot's predicted motion as well (3.29's
    /// feed-forward), not only by k_p^s times the gap (3.8.4's simplification).
    pub model_feed_forward: bool,
}

/// What one step did.
#[derive(Debug, Clone, Copy)]
pub struct StepOutcome {
    /// Which loop drove the robot.
    pub switch: SwitchState,
    /// An allocation needed the bounded QP.
    pub bounded: bool,
}

fn add(a: &mut [f64], d: &[f64]) {
    for (x, y) in a.iter_mut().zip(d) {
        *x += y;
    }
}

fn lin(a: f64, x: [f64; 3], b: f64, y: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a * x[i] + b * y[i])
}

/// One step of `law`: updates `state`'s robot and model inputs.
pub fn step(
    law: LawKind,
    g: &Gains,
    s: &StepInput,
    state: &mut LawState,
) -> ControlResult<StepOutcome> {
    let kin = s.kin;
    // d_k - d_{k+1}: the feed-forward of (3.26).
    let ff = lin(1.0, s.target, -1.0, s.next_target);
    // The model servoed on its own effector to the target (Fig. 3.1); gain k_p^s.
    let model_open = |kp: f64, inputs: &[f64]| {
        let e = lin(1.0, kin.position, -1.0, s.target);
        kin.allocate(lin(-kp, e, -1.0, ff), inputs, g.limits)
    };
    let mut bounded = false;
    let switch = match (law, s.error) {
        (LawKind::Open, _) => {
            let a = model_open(g.gain, &state.model)?;
            add(&mut state.model, &a.delta);
            state.robot = state.model.clone();
            bounded = a.bounded;
            SwitchState::Open
        }
        (LawKind::Closed1, Some(e)) => {
            // (3.19): the effector moves by -μ e through the model's J.
            let a = kin.allocate(e.map(|v| -g.gain * v), &state.robot, g.limits)?;
            add(&mut state.robot, &a.delta);
            state.model = state.robot.clone();
            bounded = a.bounded;
            SwitchState::Closed
        }
        (LawKind::Closed2 | LawKind::Switched, Some(e)) => {
            // (3.28) on the robot. On the model (3.29): the robot's next position is its
            // desired one, which the model predicts as J times the robot's input change;
            // without it (3.8.4's simplification) the model lags a moving robot by
            // speed / k_p^s.
            let a = kin.allocate(lin(-g.gain, e, -1.0, ff), &state.robot, g.limits)?;
            add(&mut state.robot, &a.delta);
            bounded = a.bounded;
            if let Some(es) = s.model_error {
                let robot_motion = match g.model_feed_forward {
                    true => &kin.j * nalgebra::DVector::from_column_slice(&a.delta),
                    false => nalgebra::DVector::zeros(3),
                };
                let us = [0, 1, 2].map(|i| -g.model_gain * es[i] + robot_motion[i]);
                let m = kin.allocate(us, &state.model, g.limits)?;
                add(&mut state.model, &m.delta);
                bounded |= m.bounded;
            }
            state.offset = (state.robot.iter().zip(&state.model))
                .map(|(r, m)| r - m)
                .collect();
            SwitchState::Closed
        }
        (LawKind::Switched, None) => {
            // Open loop on the model along the preassigned path; the robot's inputs move
            // a fraction p of the way to the model's (3.43).
            let m = model_open(g.model_gain, &state.model)?;
            add(&mut state.model, &m.delta);
            if g.keep_input_offset {
                // The model's input changes pass straight through; the robot keeps the
                // offset to the model's inputs that the closed loop had found (at the
                // switch the robot's inputs are exactly model + offset: no jump).
                for ((r, ms), o) in state.robot.iter_mut().zip(&state.model).zip(&state.offset) {
                    *r = ms + o;
                }
            } else {
                for (r, ms) in state.robot.iter_mut().zip(&state.model) {
                    *r += g.switch_rate * (ms - *r);
                }
            }
            bounded = m.bounded;
            SwitchState::Open
        }
        (LawKind::Closed1 | LawKind::Closed2, None) => SwitchState::Hold,
    };
    Ok(StepOutcome { switch, bounded })
}

/// γ of (3.32): the spectral norm of I − J Ĵ⁺, how far the model's Jacobian Ĵ is from the
/// robot's J as seen by the pseudo-inverse allocation.
pub fn mismatch(j_robot: &DMatrix<f64>, j_model: &DMatrix<f64>) -> f64 {
    let n = j_robot.nrows();
    let pinv = j_model
        .clone()
        .pseudo_inverse(1e-12 * j_model.norm().max(f64::MIN_POSITIVE))
        .unwrap_or_else(|_| DMatrix::zeros(j_model.ncols(), n));
    let m = DMatrix::<f64>::identity(n, n) - j_robot * pinv;
    m.singular_values().iter().fold(0.0, |a, &b| a.max(b))
}

/// Theorem 2: the loop (3.30) is robustly stable for 0 < k_p < 2 / (1 + γ) when γ < 1;
/// `None` when γ ≥ 1 (no gain is guaranteed).
pub fn gain_bound(gamma: f64) -> Option<f64> {
    (gamma < 1.0).then(|| 2.0 / (1.0 + gamma))
}

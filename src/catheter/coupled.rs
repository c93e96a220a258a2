//! The coupled baseline (thesis 5.3.1, Fig. 5.1): one PD law moves the insertion and the
//! cables together to bring the tip to a desired point that travels along the path at the
//! insertion speed, with the Jacobian Ĵ of a model that ignores the tube (the control
//! design "without considering contact"). Once the tube has turned the catheter far
//! enough, Ĵ sends some direction the wrong way through the true robot: the smallest
//! eigenvalue of sym(J_true Ĵ⁺) (`law::rotation_margin`) goes negative, and the loop pushes
//! the error up along it. The decoupled loop ([`super::run`]) avoids this by leaving the
//! insertion to the physician and taking J from the model with its contacts (5.5.7.1).
//!
//! Inputs: the insertion and, for each antagonistic pair of cables (cable i and the one
//! opposite), a differential pull p about a common pretension (cable i pulled in by p
//! more, its opposite by p less).
//! Both Jacobians are central differences of a settle in those inputs: Ĵ of the model
//! settled in free space, J_true of the robot in the tube (the linear 5.18 cannot tell
//! which cable of a pair is slack).

use super::law::{rotation_margin, PdGains, PdLaw};
use super::rig::{Catheter, Drive, SettleParams, SettleStatus, Settled};
use super::run::{failure, summarise, Run, RunStatus, StepRecord};
use super::scenario::Scenario;
use super::tube::Tube;
use super::CatheterResult;
use crate::math::{dist, sub};
use nalgebra::DMatrix;

/// Central-difference step of the insertion (m).
const INSERTION_STEP: f64 = 1e-4;
/// Central-difference step of a pair's differential pull (m).
const PULL_STEP: f64 = 5e-5;
/// Radius of the model's free space (m): no node comes near its wall.
const FREE_SPACE: f64 = 1e3;
/// Every cable's pull at rest (m): 0.5 mm, about 1.3 N each on the default catheter (its
/// axial compliance takes most of it). Without it both cables of a pair go slack once the
/// other pair's tension shortens the catheter, the pair's input has a dead zone, Ĵ loses
/// rank and the law's step blows up.
pub const PRETENSION: f64 = 5e-4;

/// The cables' pulls for the coupled `inputs` [insertion, p_0, …]: every cable pulled in by
/// [`PRETENSION`], cable i by p_i more and cable i + n/2 by p_i less.
pub fn pulls_of(inputs: &[f64], cables: usize) -> Vec<f64> {
    let pairs = cables / 2;
    (0..cables)
        .map(|c| match c < pairs {
            true => PRETENSION + inputs[1 + c],
            false => PRETENSION - inputs[1 + c - pairs],
        })
        .collect()
}

/// The coupled loop's fixed parts.
struct Coupled {
    tube: Tube,
    free: Tube,
    model: Catheter,
    robot: Catheter,
    settle: SettleParams,
    straight: Vec<[f64; 2]>,
}

impl Coupled {
    /// `cat` settled in `tube` at the coupled `inputs`, from `from`.
    fn settle_at(
        &self,
        cat: &Catheter,
        tube: &Tube,
        from: &Settled,
        inputs: &[f64],
    ) -> CatheterResult<Settled> {
        let pulls = pulls_of(inputs, cat.cables.len());
        let d = inputs[0];
        cat.settle(
            tube,
            &from.state,
            d,
            Drive::Pulls(&pulls),
            from,
            &self.settle,
        )
    }

    /// The tip's Jacobian in the coupled inputs by central differences of `cat`'s settle
    /// in `tube` about `at` (settled at `inputs`); `None` when a settle fails.
    fn jacobian(
        &self,
        cat: &Catheter,
        tube: &Tube,
        at: &Settled,
        inputs: &[f64],
    ) -> CatheterResult<Option<DMatrix<f64>>> {
        let mut j = DMatrix::zeros(3, inputs.len());
        for i in 0..inputs.len() {
            let h = if i == 0 { INSERTION_STEP } else { PULL_STEP };
            let mut tips = [[0.0; 3]; 2];
            for (tip, sign) in tips.iter_mut().zip([1.0, -1.0]) {
                let mut x = inputs.to_vec();
                x[i] += sign * h;
                let s = self.settle_at(cat, tube, at, &x)?;
                if failure("", s.status).is_some() {
                    return Ok(None);
                }
                *tip = s.tip();
            }
            let column = sub(tips[0], tips[1]);
            for r in 0..3 {
                j[(r, i)] = column[r] / (2.0 * h);
            }
        }
        Ok(Some(j))
    }
}

/// Runs the scenario with the coupled scheme; `progress(k, n)` after each step. The run
/// ends `Diverged` once the robot's tip is farther from its desired point than the tube's
/// radius.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(usize, usize)) -> CatheterResult<Run> {
    let tube = scenario.tube()?;
    let l = Coupled {
        free: Tube::new(tube.centreline.clone(), FREE_SPACE)?,
        model: scenario.catheter(false)?,
        robot: scenario.catheter(true)?,
        settle: scenario.settle_params(),
        straight: scenario.straight_parts(),
        tube,
    };
    let tracker = scenario.tracker(&l.tube)?;
    let mut law = PdLaw::new(PdGains {
        kp: scenario.controller.kp,
        kd: scenario.controller.kd,
    });
    let n_a = l.robot.cables.len();
    let mut inputs = vec![0.0; 1 + n_a / 2];
    let (mut robot, mut model) = (l.robot.unloaded(), l.model.unloaded());
    let n = scenario.steps();
    let every = scenario.controller.rotation_check_every;
    let mut steps: Vec<StepRecord> = Vec::with_capacity(n);
    let (mut status, mut unsettled) = (RunStatus::Completed, 0);
    let length = 1e-3 * scenario.catheter.length_mm;
    for k in 0..n {
        let r = l.settle_at(&l.robot, &l.tube, &robot, &inputs)?;
        let m = l.settle_at(&l.model, &l.free, &model, &inputs)?;
        if let Some(reason) = failure("robot", r.status).or(failure("model", m.status)) {
            status = RunStatus::Failed { step: k, reason };
            break;
        }
        unsettled +=
            usize::from(r.status == SettleStatus::MaxRounds || m.status == SettleStatus::MaxRounds);
        let Some(j_model) = l.jacobian(&l.model, &l.free, &m, &inputs)? else {
            let reason = "a settle of the free model's Jacobian failed".to_string();
            status = RunStatus::Failed { step: k, reason };
            break;
        };
        let margin = match every > 0 && k % every == 0 {
            true => match l.jacobian(&l.robot, &l.tube, &r, &inputs)? {
                Some(j_true) => Some(rotation_margin(&j_true, &j_model)?),
                None => None,
            },
            false => None,
        };
        let s_d = scenario.insertion_at(k);
        let desired = l.tube.centreline.at(s_d).point;
        let measured = tracker.measure(r.tip(), k);
        let error = dist(r.tip(), desired);
        steps.push(StepRecord {
            step: k,
            insertion: inputs[0],
            robot: r.tip(),
            measured,
            model: m.tip(),
            desired,
            s: s_d,
            straight: (l.straight.iter()).any(|p| s_d >= p[0] && s_d <= p[1]),
            error,
            model_error: dist(m.tip(), desired),
            pulls: pulls_of(&inputs, n_a),
            robot_tensions: r.tensions.clone(),
            model_tensions: m.tensions.clone(),
            model_contacts: Vec::new(),
            robot_contacts: r.contacts.clone(),
            qpcc_nodes: 0,
            rotation_margin: margin,
        });
        progress(k + 1, n);
        (robot, model) = (r, m);
        if error > l.tube.radius {
            status = RunStatus::Diverged {
                step: k,
                error_mm: 1e3 * error,
            };
            break;
        }
        let u = law.step(&j_model, &sub(measured, desired))?;
        (inputs.iter_mut().zip(&u)).for_each(|(x, du)| *x += du);
        inputs[0] = inputs[0].clamp(0.0, length);
    }
    let summary = summarise(&steps, scenario.rate_hz, unsettled, 0, tracker.calibration);
    Ok(Run {
        name: scenario.name.clone(),
        scenario: scenario.clone(),
        status,
        robot_nodes: Catheter::positions(&robot.state),
        model_nodes: Catheter::positions(&model.state),
        steps,
        summary,
    })
}

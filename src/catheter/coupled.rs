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
//! J_true is the central difference of the robot's settle in the tube in those inputs (the
//! linear 5.18 cannot tell which cable of a pair is slack). Ĵ is the model's in free space:
//! its pull columns by central differences, its insertion column the insertion axis, as
//! inserting only translates a free catheter.

use super::law::{rotation_margin, PdGains, PdLaw};
use super::rig::{Catheter, Drive, SettleStatus, Settled};
use super::run::{failure, summarise, Parts, Run, RunStatus, StepRecord};
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

/// The coupled loop's fixed parts: the decoupled loop's, and the model's free space.
pub struct Coupled {
    parts: Parts,
    free: Tube,
}

impl Coupled {
    /// The scenario's parts and a free space along its path.
    pub fn new(scenario: &Scenario) -> CatheterResult<Self> {
        let parts = Parts::new(scenario)?;
        let free = Tube::new(parts.tube.centreline.clone(), FREE_SPACE)?;
        Ok(Self { parts, free })
    }

    /// The model settled in free space at the coupled `inputs`, from `from`.
    pub fn settle_free(&self, from: &Settled, inputs: &[f64]) -> CatheterResult<Settled> {
        self.settle_at(&self.parts.model, &self.free, from, inputs)
    }

    /// The free model's Ĵ about `at` (settled at `inputs`) with every column, the insertion's
    /// too, by central differences: the check of [`Self::model_jacobian`]'s derived column.
    pub fn model_jacobian_by_differences(
        &self,
        at: &Settled,
        inputs: &[f64],
    ) -> CatheterResult<Option<DMatrix<f64>>> {
        self.jacobian_by_differences(&self.parts.model, &self.free, at, inputs)
    }

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
        let settle = &self.parts.settle;
        cat.settle(tube, &from.state, d, Drive::Pulls(&pulls), from, settle)
    }

    /// `cat`'s Jacobian in the coupled inputs, every column by central differences of its
    /// settle in `tube` about `at` (settled at `inputs`); `None` when a settle fails.
    fn jacobian_by_differences(
        &self,
        cat: &Catheter,
        tube: &Tube,
        at: &Settled,
        inputs: &[f64],
    ) -> CatheterResult<Option<DMatrix<f64>>> {
        let mut j = DMatrix::zeros(3, inputs.len());
        let ok = self.differences(cat, tube, at, inputs, &mut j, 0)?;
        Ok(ok.then_some(j))
    }

    /// The free model's Ĵ about `at` (settled at `inputs`): the insertion column is the
    /// insertion axis, since inserting translates a catheter that touches nothing rigidly;
    /// the pulls' columns by central differences. `None` when a settle fails.
    pub fn model_jacobian(
        &self,
        at: &Settled,
        inputs: &[f64],
    ) -> CatheterResult<Option<DMatrix<f64>>> {
        let model = &self.parts.model;
        let mut j = DMatrix::zeros(3, inputs.len());
        let axis = model.beam.insertion(1.0).translation.vector;
        j.set_column(0, &axis);
        let ok = self.differences(model, &self.free, at, inputs, &mut j, 1)?;
        Ok(ok.then_some(j))
    }

    /// Fills `j`'s columns from `first` on with central differences of `cat`'s settle in
    /// `tube` about `at` (settled at `inputs`); false when a settle fails.
    fn differences(
        &self,
        cat: &Catheter,
        tube: &Tube,
        at: &Settled,
        inputs: &[f64],
        j: &mut DMatrix<f64>,
        first: usize,
    ) -> CatheterResult<bool> {
        for i in first..inputs.len() {
            let h = if i == 0 { INSERTION_STEP } else { PULL_STEP };
            let mut tips = [[0.0; 3]; 2];
            for (tip, sign) in tips.iter_mut().zip([1.0, -1.0]) {
                let mut x = inputs.to_vec();
                x[i] += sign * h;
                let s = self.settle_at(cat, tube, at, &x)?;
                if failure("", s.status).is_some() {
                    return Ok(false);
                }
                *tip = s.tip();
            }
            let column = sub(tips[0], tips[1]);
            for r in 0..3 {
                j[(r, i)] = column[r] / (2.0 * h);
            }
        }
        Ok(true)
    }
}

/// Runs the scenario with the coupled scheme; `progress(k, n)` after each step. The run
/// ends `Diverged` once the robot's tip is farther from its desired point than the tube's
/// radius.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(usize, usize)) -> CatheterResult<Run> {
    let l = Coupled::new(scenario)?;
    let p = &l.parts;
    let tracker = scenario.tracker(&p.tube)?;
    let mut law = PdLaw::new(PdGains {
        kp: scenario.controller.kp,
        kd: scenario.controller.kd,
    });
    let n_a = p.robot.cables.len();
    let mut inputs = vec![0.0; 1 + n_a / 2];
    let (mut robot, mut model) = (p.robot.unloaded(), p.model.unloaded());
    let n = scenario.steps();
    let every = scenario.controller.rotation_check_every;
    let mut steps: Vec<StepRecord> = Vec::with_capacity(n);
    let (mut status, mut unsettled) = (RunStatus::Completed, 0);
    let length = 1e-3 * scenario.catheter.length_mm;
    for k in 0..n {
        let r = l.settle_at(&p.robot, &p.tube, &robot, &inputs)?;
        let m = l.settle_free(&model, &inputs)?;
        if let Some(reason) = failure("robot", r.status).or(failure("model", m.status)) {
            status = RunStatus::Failed { step: k, reason };
            break;
        }
        unsettled +=
            usize::from(r.status == SettleStatus::MaxRounds || m.status == SettleStatus::MaxRounds);
        let Some(j_model) = l.model_jacobian(&m, &inputs)? else {
            let reason = "a settle of the free model's Jacobian failed".to_string();
            status = RunStatus::Failed { step: k, reason };
            break;
        };
        let margin = match every > 0 && k % every == 0 {
            true => match l.jacobian_by_differences(&p.robot, &p.tube, &r, &inputs)? {
                Some(j_true) => Some(rotation_margin(&j_true, &j_model)?),
                None => None,
            },
            false => None,
        };
        // The desired point travels along the path at the insertion speed.
        let desired = p.tube.centreline.at(scenario.insertion_at(k));
        let measured = tracker.measure(r.tip(), k);
        let record = StepRecord {
            // Both tips' errors are to the moving desired point, which the loop chases.
            model_error: dist(m.tip(), desired.point),
            pulls: pulls_of(&inputs, n_a),
            model_tensions: m.tensions.clone(),
            rotation_margin: margin,
            ..p.record(k, inputs[0], &r, &m, measured, desired)
        };
        let error = record.error;
        steps.push(record);
        progress(k + 1, n);
        (robot, model) = (r, m);
        if error > p.tube.radius {
            status = RunStatus::Diverged {
                step: k,
                error_mm: 1e3 * error,
            };
            break;
        }
        let u = law.step(&j_model, &sub(measured, desired.point))?;
        (inputs.iter_mut().zip(&u)).for_each(|(x, du)| *x += du);
        inputs[0] = inputs[0].clamp(0.0, length);
    }
    let summary = summarise(&steps, scenario.rate_hz, unsettled, 0, tracker.calibration);
    Ok(Run::new(scenario, status, steps, summary, [&robot, &model]))
}

//! A control run: the plant, the sensor, the model and the law stepped together, the
//! trajectory recorded and summarised.

use super::law::{self, Gains, LawState, StepInput, SwitchState};
use super::plant::{Plant, Sensor};
use super::predictor::{Kinematics, Predictor};
use super::scenario::{LawKind, Scenario};
use super::task::Task;
use super::{ControlError, ControlResult};
use crate::fem::model::Model;
use crate::io::InFile;
use crate::math::{dist, sub};
use serde::Serialize;

/// One step of a run. Positions in m, inputs in SI.
#[derive(Debug, Clone, Serialize)]
pub struct StepRecord {
    /// Step index.
    pub step: usize,
    /// The target.
    pub target: [f64; 3],
    /// What the controller measured (with noise and latency), if anything.
    pub measured: Option<[f64; 3]>,
    /// The robot's true effector.
    pub robot: [f64; 3],
    /// The model's effector.
    pub model: [f64; 3],
    /// |robot − target| (m).
    pub error: f64,
    /// The robot's inputs in force at this step.
    pub inputs: Vec<f64>,
    /// The model's inputs at this step.
    pub model_inputs: Vec<f64>,
    /// Which loop drove the robot into this step.
    pub switch: SwitchState,
    /// The bounded QP replaced the pseudo-inverse.
    pub bounded: bool,
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum RunStatus {
    /// Every step was done.
    Completed,
    /// The error passed [`DIVERGED`]: the loop ran away.
    Diverged {
        /// The step.
        step: usize,
    },
    /// An FE solve of the plant or the model failed.
    Failed {
        /// The step.
        step: usize,
        /// Why.
        reason: String,
    },
}

/// An error beyond this (m) ends a run as diverged.
pub const DIVERGED: f64 = 0.1;

/// A run's numbers. Errors in mm, input jumps in the scenario's input unit.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Mean |robot − target| over all steps (Table 3.5's "average error").
    pub average_error_mm: f64,
    /// Mean error over the last quarter of the steps.
    pub settled_error_mm: f64,
    /// Largest error over the last quarter of the steps.
    pub settled_max_mm: f64,
    /// Mean error over the steps with a measurement.
    pub seen_error_mm: Option<f64>,
    /// Mean error over the steps without one.
    pub lost_error_mm: Option<f64>,
    /// Mean |model − robot|.
    pub model_gap_mm: f64,
    /// Largest change of one input between two steps.
    pub max_input_jump: f64,
    /// Steps where an allocation hit a limit or a tension bound.
    pub bounded_steps: usize,
    /// Theorem 2's mismatch γ (3.32), the robot's J against the model's: the larger of
    /// the start's and (for a completed run) the end's.
    pub gamma: f64,
    /// 2 / (1 + γ) when γ < 1: the largest k_p Theorem 2 guarantees.
    pub gain_bound: Option<f64>,
}

/// A finished run.
#[derive(Debug, Clone, Serialize)]
pub struct Run {
    /// The scenario's name.
    pub name: String,
    /// The law.
    pub law: LawKind,
    /// How it ended.
    pub status: RunStatus,
    /// Its numbers.
    pub summary: Summary,
    /// Every step.
    pub steps: Vec<StepRecord>,
    /// The scenario, as read.
    pub scenario: Scenario,
}

/// What a run starts from: both models, the law's gains and state, the task, and the
/// first positions.
struct Start {
    predictor: Predictor,
    plant: Plant,
    gains: Gains,
    state: LawState,
    kin: Kinematics,
    task: Task,
    robot_pos: [f64; 3],
    /// Theorem 2's γ between the plant's J and the model's at the start.
    gamma: f64,
}

/// Loads both models and solves them at the initial inputs.
fn start(scenario: &Scenario) -> ControlResult<Start> {
    let c = &scenario.controller;
    let scale = scenario.input_scale();
    let load =
        |p: std::path::PathBuf| Model::load(&p, None).map_err(|e| ControlError::Fem(e.in_file(&p)));
    let model = load(scenario.controller_model())?;
    let plant_model = load(scenario.plant_model())?;
    let mut predictor = Predictor::new(model, c.effector.as_deref(), c.actuation)?;
    let mut plant = Plant::new(
        plant_model,
        c.effector.as_deref(),
        c.actuation,
        &scenario.plant,
        scale,
    )?;
    let initial = vec![c.initial * scale; predictor.actuators()];
    let gains = Gains {
        gain: c.gain,
        model_gain: c.model_gain,
        switch_rate: c.switch_rate,
        limits: c.limits.map(|v| v * scale),
        keep_input_offset: c.keep_input_offset,
        model_feed_forward: c.model_feed_forward,
    };
    let kin = predictor.update(&initial)?;
    let task = Task::new(scenario.task.clone(), kin.position, scenario.rate_hz);
    let robot_pos = plant
        .apply(0, &initial)
        .map_err(|e| plant_error(scenario, e))?;
    let gamma = match plant.kinematics().map_err(|e| plant_error(scenario, e))? {
        Some(k) => law::mismatch(&k.j, &kin.j),
        None => f64::NAN,
    };
    let state = LawState {
        robot: initial.clone(),
        offset: vec![0.0; initial.len()],
        model: initial,
    };
    Ok(Start {
        predictor,
        plant,
        gains,
        state,
        kin,
        task,
        robot_pos,
        gamma,
    })
}

/// An FE failure of the plant, naming `plant.young_factor` when it is not 1: a plant far
/// softer or stiffer than its model is the likely cause of an inverted element.
fn plant_error(scenario: &Scenario, e: ControlError) -> ControlError {
    match e {
        ControlError::Fem(source) if scenario.plant.young_factor != 1.0 => ControlError::Plant {
            file: scenario.file.clone(),
            young_factor: scenario.plant.young_factor,
            source,
        },
        e => e,
    }
}

/// Theorem 2's γ at the end of a completed run (NaN otherwise): the robot's J moves away
/// from the model's on the way, so the start alone can understate it.
fn gamma_at_end(status: &RunStatus, plant: &mut Plant, kin: &Kinematics) -> f64 {
    match (status, plant.kinematics()) {
        (RunStatus::Completed, Ok(Some(k))) => law::mismatch(&k.j, &kin.j),
        _ => f64::NAN,
    }
}

/// Runs `scenario`, calling `progress(step, steps)` after each step.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(usize, usize)) -> ControlResult<Run> {
    let Start {
        mut predictor,
        mut plant,
        gains,
        mut state,
        mut kin,
        task,
        mut robot_pos,
        gamma,
    } = start(scenario)?;
    let mut sensor = Sensor::new(&scenario.sensor);
    let mut model_history = vec![kin.position];
    let mut records: Vec<StepRecord> = Vec::with_capacity(scenario.steps);
    let mut status = RunStatus::Completed;
    let mut outcome = law::StepOutcome {
        switch: SwitchState::Closed,
        bounded: false,
    };
    for k in 0..scenario.steps {
        sensor.record(robot_pos);
        let target = task.target(k);
        let measured = sensor.measure(k);
        records.push(StepRecord {
            step: k,
            target,
            measured: measured.map(|m| m.position),
            robot: robot_pos,
            model: kin.position,
            error: dist(robot_pos, target),
            inputs: state.robot.clone(),
            model_inputs: state.model.clone(),
            switch: outcome.switch,
            bounded: outcome.bounded,
        });
        if dist(robot_pos, target) > DIVERGED {
            status = RunStatus::Diverged { step: k };
            break;
        }
        let next_target = match task.preassigned() {
            true => task.target(k + 1),
            false => target,
        };
        let input = StepInput {
            kin: &kin,
            target,
            next_target,
            error: measured.map(|m| sub(m.position, task.target(m.of_step))),
            model_error: measured.map(|m| sub(model_history[m.of_step], m.position)),
        };
        let stepped =
            law::step(scenario.controller.law, &gains, &input, &mut state).and_then(|o| {
                outcome = o;
                robot_pos =
                    (plant.apply(k + 1, &state.robot)).map_err(|e| plant_error(scenario, e))?;
                kin = predictor.update(&state.model)?;
                Ok(())
            });
        if let Err(e) = stepped {
            let reason = e.to_string();
            status = RunStatus::Failed { step: k, reason };
            break;
        }
        model_history.push(kin.position);
        progress(k + 1, scenario.steps);
    }
    let gamma = gamma.max(gamma_at_end(&status, &mut plant, &kin));
    let summary = summarise(&records, &sensor, gamma, scenario.input_scale());
    Ok(Run {
        name: scenario.name.clone(),
        law: scenario.controller.law,
        status,
        summary,
        steps: records,
        scenario: scenario.clone(),
    })
}

fn mean_mm(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| 1e3 * s / n as f64)
}

fn summarise(records: &[StepRecord], sensor: &Sensor, gamma: f64, scale: f64) -> Summary {
    let last = &records[records.len() - records.len().div_ceil(4).max(1).min(records.len())..];
    let jumps = records
        .windows(2)
        .flat_map(|w| (w[0].inputs.iter().zip(&w[1].inputs)).map(|(a, b)| (b - a).abs() / scale));
    Summary {
        average_error_mm: mean_mm(records.iter().map(|r| r.error)).unwrap_or(f64::NAN),
        settled_error_mm: mean_mm(last.iter().map(|r| r.error)).unwrap_or(f64::NAN),
        settled_max_mm: 1e3 * last.iter().map(|r| r.error).fold(0.0, f64::max),
        seen_error_mm: mean_mm(
            (records.iter())
                .filter(|r| !sensor.lost(r.step))
                .map(|r| r.error),
        ),
        lost_error_mm: mean_mm(
            (records.iter())
                .filter(|r| sensor.lost(r.step))
                .map(|r| r.error),
        ),
        model_gap_mm: mean_mm(records.iter().map(|r| dist(r.model, r.robot))).unwrap_or(f64::NAN),
        max_input_jump: jumps.fold(0.0, f64::max),
        bounded_steps: records.iter().filter(|r| r.bounded).count(),
        gamma,
        gain_bound: law::gain_bound(gamma),
    }
}

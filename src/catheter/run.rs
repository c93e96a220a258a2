//! The closed loop of thesis Fig. 5.2: per step, the physician's insertion moves both the
//! robot and the FE model; the FEM controller (the QPCC 5.5-5.8 on the rows mapped onto
//! Pyz) drives the model's tip to the path and gives the contact forces; the robot
//! controller (5.22) moves the robot's cables by the model's J, contacts included, from the
//! tracker's measured tip.

use super::law::{jacobian, PdGains, PdLaw};
use super::mapping::{LocalFrame, Mapping};
use super::rig::{Catheter, ContactForce, Drive, SettleParams, SettleStatus, Settled};
use super::scenario::{Scenario, Scheme};
use super::tracker::{Calibration, Tracker};
use super::tube::{CurvePoint, Tube};
use super::{CatheterError, CatheterResult};
use crate::fem::beam::BeamRow;
use crate::inverse::qpcc::{QpccParams, QpccProblem, QpccStatus};
use crate::math::dist;
use nalgebra::DMatrix;
use serde::Serialize;

/// One control step.
#[derive(Clone, Debug, Serialize)]
pub struct StepRecord {
    /// Step index (at `rate_hz`).
    pub step: usize,
    /// Inserted length (m).
    pub insertion: f64,
    /// The robot's tip, true (m, robot frame).
    pub robot: [f64; 3],
    /// The tip as tracked and calibrated (m, robot frame).
    pub measured: [f64; 3],
    /// The model's tip (m).
    pub model: [f64; 3],
    /// The path point nearest the robot's true tip (m).
    pub desired: [f64; 3],
    /// Its arc length (m).
    pub s: f64,
    /// Whether it lies on a straight piece of the path.
    pub straight: bool,
    /// The robot's true tip to the path (m): the tracking error of 5.5.3.
    pub error: f64,
    /// The model's tip to the path (m).
    pub model_error: f64,
    /// Cable pulled in by each motor (m).
    pub pulls: Vec<f64>,
    /// The robot's cable tensions (N).
    pub robot_tensions: Vec<f64>,
    /// The model's cable tensions (N), the FEM controller's inputs.
    pub model_tensions: Vec<f64>,
    /// The model's contact forces: the estimate along the whole catheter.
    pub model_contacts: Vec<ContactForce>,
    /// The robot's contact forces: the truth.
    pub robot_contacts: Vec<ContactForce>,
    /// Branch-and-bound QPs of the FEM controller's QPCC.
    pub qpcc_nodes: usize,
    /// The smallest eigenvalue of sym(J_true Ĵ⁺) at this step, where the coupled scheme
    /// checked it (`controller.rotation_check_every`); negative: Ĵ is rotated (5.5.7.1).
    pub rotation_margin: Option<f64>,
}

/// A run's numbers (mm and N), as the thesis reports them.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Mean tracking error while the desired point is on a straight piece (mm).
    pub straight_mean_mm: f64,
    /// Largest tracking error of the run (mm).
    pub max_mm: f64,
    /// Mean tracking error of the whole run (mm).
    pub mean_mm: f64,
    /// Mean tracking error over the last second (mm): the positioning error.
    pub final_mm: f64,
    /// Largest contact force on the robot (N).
    pub max_contact_n: f64,
    /// Largest number of simultaneous contact nodes on the robot.
    pub max_contacts: usize,
    /// Steps where a settle stopped at its round limit.
    pub unsettled_steps: usize,
    /// Steps where the QPCC found no solution and the model kept its tensions.
    pub qpcc_failures: usize,
    /// The tracker calibration.
    pub calibration: Calibration,
    /// The smallest rotation margin of the run, where one was checked.
    pub min_rotation_margin: Option<f64>,
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum RunStatus {
    /// Every step ran.
    Completed,
    /// A settle failed: the beam or its LCP had no solution.
    Failed {
        /// The step.
        step: usize,
        /// Why.
        reason: String,
    },
    /// The coupled loop ran away: the tip farther from its desired point than the tube's
    /// radius.
    Diverged {
        /// The step.
        step: usize,
        /// The tracking error there (mm).
        error_mm: f64,
    },
}

/// A run: the scenario, every step and the summary.
#[derive(Clone, Debug, Serialize)]
pub struct Run {
    /// The scenario's name.
    pub name: String,
    /// The scenario.
    pub scenario: Scenario,
    /// How it ended.
    pub status: RunStatus,
    /// The steps.
    pub steps: Vec<StepRecord>,
    /// The numbers.
    pub summary: Summary,
    /// The robot's nodes at the last step (m).
    pub robot_nodes: Vec<[f64; 3]>,
    /// The model's nodes at the last step (m).
    pub model_nodes: Vec<[f64; 3]>,
}

/// What the FEM controller hands on: the model's next tensions and its J (3 rows, global).
#[derive(Clone, Debug)]
struct FemStep {
    tensions: Vec<f64>,
    jacobian: DMatrix<f64>,
    nodes: usize,
    solved: bool,
}

/// Weight of the tensions' ridge in the FEM controller's objective, relative to the
/// largest effector compliance: the tip error it leaves is 1e-6 of that compliance times
/// the tension (about 7 nm per newton for the default catheter).
const TENSION_RIDGE: f64 = 1e-3;

/// What both schemes run on: the tube, the controller's catheter and the robot, and how
/// they settle.
#[derive(Clone, Debug)]
pub(super) struct Parts {
    pub tube: Tube,
    pub model: Catheter,
    pub robot: Catheter,
    pub settle: SettleParams,
    /// The path's straight parts (m of arc length), for the records.
    pub straight: Vec<[f64; 2]>,
}

impl Parts {
    /// The scenario's parts.
    pub fn new(scenario: &Scenario) -> CatheterResult<Self> {
        Ok(Self {
            tube: scenario.tube()?,
            model: scenario.catheter(false)?,
            robot: scenario.catheter(true)?,
            settle: scenario.settle_params(),
            straight: scenario.straight_parts(),
        })
    }

    /// The record of step `k` at `insertion`, with the robot `r` and the model `m` settled,
    /// the `measured` tip and the robot's `desired` point; the model's error is to the path
    /// point nearest its tip. The scheme's own parts (pulls, the model's tensions, the QPCC's
    /// nodes, the margin) start empty, for the scheme to fill.
    pub fn record(
        &self,
        k: usize,
        insertion: f64,
        r: &Settled,
        m: &Settled,
        measured: [f64; 3],
        desired: CurvePoint,
    ) -> StepRecord {
        let path = &self.tube.centreline;
        StepRecord {
            step: k,
            insertion,
            robot: r.tip(),
            measured,
            model: m.tip(),
            desired: desired.point,
            s: desired.s,
            straight: (self.straight.iter()).any(|p| desired.s >= p[0] && desired.s <= p[1]),
            error: dist(r.tip(), desired.point),
            model_error: dist(m.tip(), path.nearest(m.tip()).point),
            pulls: Vec::new(),
            robot_tensions: r.tensions.clone(),
            model_tensions: Vec::new(),
            model_contacts: m.contacts.clone(),
            robot_contacts: r.contacts.clone(),
            qpcc_nodes: 0,
            rotation_margin: None,
        }
    }
}

/// The decoupled loop's fixed parts.
#[derive(Clone, Debug)]
struct Loop<'a> {
    scenario: &'a Scenario,
    parts: Parts,
    qpcc: QpccParams,
}

/// What the controllers decide in one step (5.2): the model at the insertion, the FEM
/// controller's answer and the robot's cable increments.
#[derive(Clone, Debug)]
pub struct Control {
    /// The FE model settled at the step's insertion under the current tensions.
    pub model: Settled,
    /// The model's tensions for the next step (N).
    pub next_tensions: Vec<f64>,
    /// The increments of the robot's pulls (m), from the PD law (5.22).
    pub pull_increments: Vec<f64>,
    /// Branch-and-bound QPs of the FEM controller's QPCC.
    pub qpcc_nodes: usize,
    /// Whether the QPCC found its optimum (otherwise the tensions are kept).
    pub qpcc_solved: bool,
}

/// What one step of a [`Session`] ended with.
#[derive(Clone, Debug)]
pub enum Step {
    /// The step ran.
    Done(Box<StepRecord>),
    /// The step failed (a settle or a controller); the run ends here.
    Failed(String),
}

/// A run in progress: the loop's fixed parts, the tracker, the controllers' memories and
/// both catheters' last equilibria. [`run`] steps one to the end; a bench or a caller
/// can step it one at a time.
#[derive(Clone, Debug)]
pub struct Session<'a> {
    l: Loop<'a>,
    tracker: Tracker,
    law: PdLaw,
    robot_map: Mapping,
    model_map: Mapping,
    model: Settled,
    robot: Settled,
    tensions: Vec<f64>,
    pulls: Vec<f64>,
    k: usize,
    unsettled: usize,
    qpcc_failures: usize,
}

/// Runs the scenario with its scheme; `progress(k, n)` after each step.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(usize, usize)) -> CatheterResult<Run> {
    if scenario.controller.scheme == Scheme::Coupled {
        return super::coupled::run(scenario, progress);
    }
    let mut session = Session::new(scenario)?;
    let n = scenario.steps();
    let (mut steps, mut status) = (Vec::with_capacity(n), RunStatus::Completed);
    while session.k < n {
        let k = session.k;
        match session.step()? {
            Step::Done(record) => steps.push(*record),
            Step::Failed(reason) => {
                status = RunStatus::Failed { step: k, reason };
                break;
            }
        }
        progress(k + 1, n);
    }
    let summary = summarise(
        &steps,
        scenario.rate_hz,
        session.unsettled,
        session.qpcc_failures,
        session.tracker.calibration,
    );
    Ok(Run::new(
        scenario,
        status,
        steps,
        summary,
        [&session.robot, &session.model],
    ))
}

impl Run {
    /// The run of `scenario` that ended `status` after `steps`, with the [robot, model]
    /// `last` equilibria.
    pub(super) fn new(
        scenario: &Scenario,
        status: RunStatus,
        steps: Vec<StepRecord>,
        summary: Summary,
        last: [&Settled; 2],
    ) -> Self {
        Run {
            name: scenario.name.clone(),
            scenario: scenario.clone(),
            status,
            steps,
            summary,
            robot_nodes: Catheter::positions(&last[0].state),
            model_nodes: Catheter::positions(&last[1].state),
        }
    }
}

impl<'a> Session<'a> {
    /// The scenario's catheters at rest, the tracker calibrated, no step taken. The scheme
    /// is the decoupled one, whatever the scenario says.
    pub fn new(scenario: &'a Scenario) -> CatheterResult<Self> {
        let l = Loop {
            scenario,
            parts: Parts::new(scenario)?,
            qpcc: QpccParams::default(),
        };
        let tracker = scenario.tracker(&l.parts.tube)?;
        let gains = PdGains {
            kp: scenario.controller.kp,
            kd: scenario.controller.kd,
        };
        let n_a = l.parts.model.cables.len();
        Ok(Self {
            tracker,
            law: PdLaw::new(gains),
            robot_map: Mapping::default(),
            model_map: Mapping::default(),
            model: l.parts.model.unloaded(),
            robot: l.parts.robot.unloaded(),
            tensions: vec![0.0; n_a],
            pulls: vec![0.0; n_a],
            k: 0,
            unsettled: 0,
            qpcc_failures: 0,
            l,
        })
    }

    /// Steps taken so far.
    pub fn steps_taken(&self) -> usize {
        self.k
    }

    /// The robot's last equilibrium: its contacts are the truth.
    pub fn robot(&self) -> &Settled {
        &self.robot
    }

    /// The FE model's last equilibrium: its contacts are the estimate.
    pub fn model(&self) -> &Settled {
        &self.model
    }

    /// The tracker's measurement of the robot's tip at the current step (m, robot frame).
    pub fn measured_tip(&self) -> [f64; 3] {
        self.tracker.measure(self.robot.tip(), self.k)
    }

    /// One step of the loop: the robot (the plant) settles under its pulls at the step's
    /// insertion, the tracker measures its tip, the controllers decide, and both move on.
    pub fn step(&mut self) -> CatheterResult<Step> {
        let k = self.k;
        let d = self.l.scenario.insertion_at(k);
        let parts = &self.l.parts;
        let r = parts.robot.settle(
            &parts.tube,
            &self.robot.state,
            d,
            Drive::Pulls(&self.pulls),
            &self.robot,
            &parts.settle,
        )?;
        if let Some(reason) = failure("robot", r.status) {
            return Ok(Step::Failed(reason));
        }
        let measured = self.tracker.measure(r.tip(), k);
        let c = match self.control(d, measured) {
            Ok(c) => c,
            Err(reason) => return Ok(Step::Failed(reason)),
        };
        let m = &c.model;
        self.unsettled +=
            usize::from(m.status == SettleStatus::MaxRounds || r.status == SettleStatus::MaxRounds);
        self.qpcc_failures += usize::from(!c.qpcc_solved);
        let parts = &self.l.parts;
        let desired = parts.tube.centreline.nearest(r.tip());
        let record = StepRecord {
            pulls: self.pulls.clone(),
            model_tensions: self.tensions.clone(),
            qpcc_nodes: c.qpcc_nodes,
            ..parts.record(k, d, &r, m, measured, desired)
        };
        (self.pulls.iter_mut().zip(&c.pull_increments)).for_each(|(p, du)| *p += du);
        self.tensions = c.next_tensions;
        (self.model, self.robot) = (c.model, r);
        self.k += 1;
        Ok(Step::Done(Box::new(record)))
    }

    /// The controllers' part of a step (the work a real rig does per frame): the model
    /// settles at `insertion` under its tensions, the FEM controller solves its QPCC, and
    /// the PD law turns the `measured` tip's error into pull increments. The controllers'
    /// memories (the mappings' frames, the law's last error) move on; the catheters'
    /// states do not. A failure is the reason, in words.
    pub fn control(&mut self, insertion: f64, measured: [f64; 3]) -> Result<Control, String> {
        let l = &self.l;
        let p = &l.parts;
        let m = p
            .model
            .settle(
                &p.tube,
                &self.model.state,
                insertion,
                Drive::Tensions(&self.tensions),
                &self.model,
                &p.settle,
            )
            .map_err(|e| e.to_string())?;
        if let Some(reason) = failure("model", m.status) {
            return Err(reason);
        }
        let path = &p.tube.centreline;
        let model_frame = self.model_map.frame(path, m.tip());
        let robot_frame = self.robot_map.frame(path, measured);
        let fem = l
            .fem_step(&m, &model_frame, &self.tensions)
            .map_err(|e| e.to_string())?;
        let j = robot_frame.rows_2d(&fem.jacobian);
        let u = (self.law.step(&j, &robot_frame.error_2d(measured))).map_err(|e| e.to_string())?;
        Ok(Control {
            model: m,
            next_tensions: fem.tensions,
            pull_increments: u,
            qpcc_nodes: fem.nodes,
            qpcc_solved: fem.solved,
        })
    }
}

/// Why a settle's status ends a run, in words; `None` when it does not.
pub(super) fn failure(who: &str, status: SettleStatus) -> Option<String> {
    match status {
        SettleStatus::Beam(b) => Some(format!("the {who}'s beam Newton ended {b:?}")),
        SettleStatus::Lcp(s) => Some(format!("the {who}'s contact LCP ended {s:?}")),
        SettleStatus::Settled | SettleStatus::MaxRounds => None,
    }
}

impl Loop<'_> {
    /// The FEM controller at the model's settled state: the QPCC (5.6-5.8) for the tensions
    /// that bring its tip onto the path, and J = W_ea W_aa⁻¹ (5.18) with the contacts that
    /// carry force held closed.
    fn fem_step(
        &self,
        m: &Settled,
        frame: &LocalFrame,
        tensions: &[f64],
    ) -> CatheterResult<FemStep> {
        let p = &self.parts;
        let cat = &p.model;
        let n_a = cat.cables.len();
        let keep: Vec<_> = m.contacts.iter().map(|c| (c.node, c.surface)).collect();
        let contacts = cat.contact_rows(&p.tube, &m.state, p.settle.alarm, &keep);
        let tip = cat.tip_node();
        let mut rows: Vec<BeamRow> = (0..3)
            .map(|a| {
                BeamRow::translation(tip, std::array::from_fn(|k| f64::from(u8::from(k == a))))
            })
            .collect();
        rows.extend(cat.cables.iter().map(|c| c.row(&m.state)));
        rows.extend(
            contacts
                .iter()
                .map(|c| BeamRow::translation(c.node, c.normal)),
        );
        let loaded: Vec<_> = cat
            .cables
            .iter()
            .copied()
            .zip(tensions.iter().copied())
            .collect();
        let mut w = cat
            .beam
            .linearise_loaded(&m.state, &loaded)?
            .compliance(&rows);
        for i in 3..3 + n_a {
            w[(i, i)] += cat.cable_compliance;
        }
        let n = n_a + contacts.len();
        let applied: Vec<f64> = (tensions.iter().copied())
            .chain(contacts.iter().map(|c| m.force_along(c)))
            .collect();
        let mut gaps: Vec<f64> = contacts.iter().map(|c| c.gap).collect();
        let mut w_cc = w.view((3, 3), (n, n)).into_owned();
        super::rig::soften(
            &self.parts.tube,
            &contacts,
            &m.state,
            cat.radius,
            &mut w_cc,
            n_a,
            &mut gaps,
            &applied,
        );
        w.view_mut((3, 3), (n, n)).copy_from(&w_cc);
        // In units of the largest effector compliance, so that the QP sees numbers near 1
        // (m/N compliances and 0.1 mm errors would sit under its tolerances).
        let w_e2 = frame.rows_2d(&w.view((0, 3), (3, n)).into_owned());
        let unit = w_e2.amax().max(f64::MIN_POSITIVE);
        // Equal tensions in opposite cables only compress the catheter, so (5.5) leaves
        // them free; a ridge on the tensions picks the least-tension optimum.
        let mut w_e = DMatrix::zeros(2 + n_a, n);
        w_e.view_mut((0, 0), (2, n)).copy_from(&(w_e2 / unit));
        for i in 0..n_a {
            w_e[(2 + i, i)] = TENSION_RIDGE;
        }
        let w_c = w.view((3 + n_a, 3), (contacts.len(), n)).into_owned() / unit;
        let lambda = nalgebra::DVector::from_column_slice(&applied);
        let e = frame.error_2d(m.tip());
        let e_free: Vec<f64> = (0..2 + n_a)
            .map(|i| match i < 2 {
                true => e[i] / unit - (w_e.row(i) * &lambda)[0],
                false => 0.0,
            })
            .collect();
        let c_free: Vec<f64> = (gaps.iter().enumerate())
            .map(|(i, g)| g / unit - (w_c.row(i) * &lambda)[0])
            .collect();
        let mut problem = QpccProblem::new(w_e, w_c, e_free, c_free, vec![0.0; 2 + n_a], n_a);
        problem.lambda_a_max = vec![self.scenario.controller.max_tension_n; n_a];
        let sol = problem.solve(&self.qpcc)?;
        let solved = sol.status == QpccStatus::Solved;
        let next = match solved {
            true => sol.lambda[..n_a].iter().map(|&t| t.max(0.0)).collect(),
            false => tensions.to_vec(),
        };
        let active: Vec<usize> = (contacts.iter().enumerate())
            .filter(|(_, c)| keep.contains(&(c.node, c.surface)))
            .map(|(i, _)| 3 + n_a + i)
            .collect();
        let jacobian = condensed_jacobian(&w, n_a, &active)?;
        Ok(FemStep {
            tensions: next,
            jacobian,
            nodes: sol.nodes,
            solved,
        })
    }
}

/// J = W'_ea W'_aa⁻¹ with the `active` contact rows held closed: W' = W − W_·A W_AA⁻¹ W_A·
/// (the Schur complement), so the contacts' reactions are in the model's J.
fn condensed_jacobian(
    w: &DMatrix<f64>,
    n_a: usize,
    active: &[usize],
) -> CatheterResult<DMatrix<f64>> {
    let ea: Vec<usize> = (0..3 + n_a).collect();
    let mut w_ea = w.select_rows(&ea).select_columns(&ea);
    if !active.is_empty() {
        let w_aa = w.select_rows(active).select_columns(active);
        let w_xa = w.select_rows(&ea).select_columns(active);
        let inv = w_aa.clone().try_inverse().ok_or(CatheterError::Singular {
            what: "W of the closed contacts",
            rank: w_aa.rank(1e-12 * w_aa.norm()),
        })?;
        w_ea -= &w_xa * inv * w_xa.transpose();
    }
    let e = w_ea.view((0, 3), (3, n_a)).into_owned();
    let a = w_ea.view((3, 3), (n_a, n_a)).into_owned();
    jacobian(&e, &a)
}

/// The thesis's numbers of `steps`.
pub(super) fn summarise(
    steps: &[StepRecord],
    rate_hz: f64,
    unsettled: usize,
    qpcc_failures: usize,
    calibration: Calibration,
) -> Summary {
    let mean = |v: Vec<f64>| match v.is_empty() {
        true => f64::NAN,
        false => v.iter().sum::<f64>() / v.len() as f64,
    };
    let last = (rate_hz.round() as usize).max(1).min(steps.len());
    Summary {
        straight_mean_mm: 1e3
            * mean(
                steps
                    .iter()
                    .filter(|r| r.straight)
                    .map(|r| r.error)
                    .collect(),
            ),
        max_mm: 1e3 * steps.iter().map(|r| r.error).fold(0.0, f64::max),
        mean_mm: 1e3 * mean(steps.iter().map(|r| r.error).collect()),
        final_mm: 1e3
            * mean(
                steps[steps.len() - last..]
                    .iter()
                    .map(|r| r.error)
                    .collect(),
            ),
        max_contact_n: (steps.iter().flat_map(|r| &r.robot_contacts))
            .map(|c| c.force)
            .fold(0.0, f64::max),
        max_contacts: steps
            .iter()
            .map(|r| r.robot_contacts.len())
            .max()
            .unwrap_or(0),
        unsettled_steps: unsettled,
        qpcc_failures,
        calibration,
        min_rotation_margin: (steps.iter().filter_map(|r| r.rotation_margin)).reduce(f64::min),
    }
}

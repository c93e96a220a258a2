//! The closed loop of thesis Fig. 5.2: per step, the physician's insertion moves both the
//! robot and the FE model; the FEM controller (the QPCC 5.5-5.8 on the rows mapped onto
//! Pyz) drives the model's tip to the path and gives the contact forces; the robot
//! controller (5.22) moves the robot's cables by the model's J, contacts included, from the
//! tracker's measured tip.

use super::law::{jacobian, PdGains, PdLaw};
use super::mapping::{LocalFrame, Mapping};
use super::rig::{Catheter, ContactForce, Drive, SettleParams, SettleStatus, Settled};
use super::scenario::Scenario;
use super::tracker::{Calibration, Tracker};
use super::tube::Tube;
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

/// The loop's fixed parts.
struct Loop<'a> {
    scenario: &'a Scenario,
    tube: Tube,
    model: Catheter,
    robot: Catheter,
    settle: SettleParams,
    qpcc: QpccParams,
}

/// Runs the scenario; `progress(k, n)` after each step.
pub fn run(scenario: &Scenario, progress: &mut dyn FnMut(usize, usize)) -> CatheterResult<Run> {
    let settle = SettleParams {
        alarm: 1e-3 * scenario.controller.alarm_mm,
        ..SettleParams::default()
    };
    let l = Loop {
        scenario,
        tube: scenario.tube()?,
        model: scenario.catheter(false)?,
        robot: scenario.catheter(true)?,
        settle,
        qpcc: QpccParams::default(),
    };
    let t = &scenario.tracker;
    let tracker = Tracker::calibrated(
        scenario.tracker_from_robot(),
        1e-3 * t.noise_mm,
        1e-3 * t.calibration_noise_mm,
        &l.tube,
        t.calibration_points,
        t.seed,
    )?;
    let path = &l.tube.centreline;
    let straight = scenario.straight_parts();
    let n = scenario.steps();
    let gains = PdGains {
        kp: scenario.controller.kp,
        kd: scenario.controller.kd,
    };
    let (mut law, mut robot_map, mut model_map) =
        (PdLaw::new(gains), Mapping::default(), Mapping::default());
    let n_a = l.model.cables.len();
    let (mut model, mut robot) = (l.model.unloaded(), l.robot.unloaded());
    let (mut tensions, mut pulls) = (vec![0.0; n_a], vec![0.0; n_a]);
    let (mut steps, mut status) = (Vec::with_capacity(n), RunStatus::Completed);
    let (mut unsettled, mut qpcc_failures) = (0, 0);
    for k in 0..n {
        let d = scenario.insertion_at(k);
        let m = l.model.settle(
            &l.tube,
            &model.state,
            d,
            Drive::Tensions(&tensions),
            &model,
            &l.settle,
        )?;
        let r = l.robot.settle(
            &l.tube,
            &robot.state,
            d,
            Drive::Pulls(&pulls),
            &robot,
            &l.settle,
        )?;
        let failed = [("model", &m), ("robot", &r)]
            .iter()
            .find_map(|(who, s)| failure(who, s.status));
        if let Some(reason) = failed {
            status = RunStatus::Failed { step: k, reason };
            break;
        }
        unsettled +=
            usize::from(m.status == SettleStatus::MaxRounds || r.status == SettleStatus::MaxRounds);
        let model_frame = model_map.frame(path, m.tip());
        let measured = tracker.measure(r.tip(), k);
        let robot_frame = robot_map.frame(path, measured);
        let control = l.fem_step(&m, &model_frame, &tensions).and_then(|fem| {
            let j = robot_frame.rows_2d(&fem.jacobian);
            Ok((law.step(&j, &robot_frame.error_2d(measured))?, fem))
        });
        let (u, fem) = match control {
            Ok(c) => c,
            Err(e) => {
                status = RunStatus::Failed {
                    step: k,
                    reason: e.to_string(),
                };
                break;
            }
        };
        qpcc_failures += usize::from(!fem.solved);
        let desired = path.nearest(r.tip());
        steps.push(StepRecord {
            step: k,
            insertion: d,
            robot: r.tip(),
            measured,
            model: m.tip(),
            desired: desired.point,
            s: desired.s,
            straight: straight
                .iter()
                .any(|p| desired.s >= p[0] && desired.s <= p[1]),
            error: dist(r.tip(), desired.point),
            model_error: dist(m.tip(), path.nearest(m.tip()).point),
            pulls: pulls.clone(),
            robot_tensions: r.tensions.clone(),
            model_tensions: tensions.clone(),
            model_contacts: m.contacts.clone(),
            robot_contacts: r.contacts.clone(),
            qpcc_nodes: fem.nodes,
        });
        pulls.iter_mut().zip(&u).for_each(|(p, du)| *p += du);
        tensions = fem.tensions;
        (model, robot) = (m, r);
        progress(k + 1, n);
    }
    let summary = summarise(
        &steps,
        scenario.rate_hz,
        unsettled,
        qpcc_failures,
        tracker.calibration,
    );
    Ok(Run {
        name: scenario.name.clone(),
        scenario: scenario.clone(),
        status,
        steps,
        summary,
        robot_nodes: Catheter::positions(&robot.state),
        model_nodes: Catheter::positions(&model.state),
    })
}

fn failure(who: &str, status: SettleStatus) -> Option<String> {
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
        let cat = &self.model;
        let n_a = cat.cables.len();
        let keep: Vec<usize> = m.contacts.iter().map(|c| c.node).collect();
        let contacts = cat.contact_rows(&self.tube, &m.state, self.settle.alarm, &keep);
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
        let c_free: Vec<f64> = (contacts.iter().enumerate())
            .map(|(i, c)| c.gap / unit - (w_c.row(i) * &lambda)[0])
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
            .filter(|(_, c)| keep.contains(&c.node))
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

fn summarise(
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
    }
}

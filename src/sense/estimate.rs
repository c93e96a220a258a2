//! The per-frame worker ([`Sensor::sense`], [`Sensor::track`]): the frame's model, free
//! state, contacts and features, then the estimate (of the seen contacts' locations,
//! [`super::locate`], else of the model's declared force points), then the report.

use super::blend::Group;
use super::free::FreeState;
use super::timings::ms;
use super::track::{force_point_ends, leave, Track};
use super::{FrameReport, FrameStatus, ModelInputs, Observation, Sensor};
use crate::contact::Contact;
use crate::inverse::dense::subsample;
use crate::inverse::{
    estimate, par_map, Candidate, DenseInputs, DenseView, FrameEstimate, FrameInputs, FrameParams,
    InverseResult, Start,
};
use crate::math::{dot, sub};
use crate::recording::FrameInput;
use crate::register::{Registrar, SurfaceFeature};
use std::sync::Arc;

/// A frame failed: its status says how.
pub(super) fn fail(e: &dyn std::fmt::Display) -> FrameStatus {
    FrameStatus::NotSolved(e.to_string())
}

/// What a frame's estimates share.
pub(super) struct Frame<'a> {
    /// The sensor.
    pub sensor: &'a Sensor,
    /// The actuated model, the frame's points and features, and the loop's parameters.
    pub inputs: FrameInputs<'a>,
    /// The free equilibrium at the frame's actuator inputs.
    pub free: &'a FreeState,
    /// The seen contacts.
    pub contacts: &'a [Contact],
    /// The frame's actuator inputs.
    pub actuators: super::free::ActuatorInputs,
}

impl Frame<'_> {
    /// The estimate of `cands` from the unloaded (free) state, with the loop's `params`.
    pub fn solve_with(
        &self,
        cands: &[Candidate],
        params: &FrameParams,
    ) -> InverseResult<FrameEstimate> {
        let inputs = FrameInputs {
            params,
            ..self.inputs
        };
        let start = Start::Unloaded {
            near: Some(&self.free.solution),
            state: self.free.solver.clone(),
        };
        estimate(&inputs, cands, start)
    }

    /// The estimate of `cands` from the unloaded (free) state.
    pub fn solve(&self, cands: &[Candidate]) -> InverseResult<FrameEstimate> {
        self.solve_with(cands, self.inputs.params)
    }
}

/// A frame's final estimate, of `candidates` in report `groups`.
pub(super) struct Estimated {
    pub est: FrameEstimate,
    pub candidates: Vec<Candidate>,
    pub groups: Vec<Group>,
    /// Without seen contacts: every force point's estimate (the chosen one's taken out, to
    /// be `est`), and which was chosen.
    pub force_points: Option<(Vec<Option<FrameEstimate>>, usize)>,
}

impl Sensor {
    /// Senses one frame, starting from `prev` when tracking (`want_track`): the worker of
    /// [`Sensor::sense`] and [`Sensor::track`]. Never fails: problems are in the report's
    /// status.
    pub(super) fn sense_frame(
        &self,
        frame: usize,
        obs: &Observation,
        inputs: Option<&FrameInput>,
        prev: Option<&Track>,
        want_track: bool,
    ) -> (FrameReport, Option<Track>) {
        let t0 = std::time::Instant::now();
        let mut report = FrameReport::empty(frame, FrameStatus::Sensed);
        report.reference = self.reference_frames.contains(&frame);
        report.robot_points = obs.robot.len();
        report.object_points = obs.objects.len();
        report.cameras = obs.cameras.clone();
        for c in obs.cameras.iter().filter(|c| !c.is_seen()) {
            report
                .warnings
                .push(format!("camera {c}: sensed from the other cameras alone"));
        }
        report.features = self.features.len();
        if inputs.is_none() {
            report.warnings.push(match self.model_inputs {
                ModelInputs::ModelFile => {
                    "no recorded actuator inputs: the model file's are used".into()
                }
                ModelInputs::Calibration => {
                    "no recorded actuator inputs: the calibrated ones are used".into()
                }
            });
        }
        report.timings = obs.timings;
        let track = match self.estimate_frame(obs, inputs, prev, want_track, &mut report) {
            Ok(track) => {
                let reference = self
                    .tare
                    .as_ref()
                    .map_or(1.0, |t| 1.0 + 1.0 / t.frames as f64);
                for f in &mut report.forces {
                    f.add_model_error(reference, self.params.model_error);
                }
                track.filter(|_| report.reliable)
            }
            Err(status) => {
                report.status = status;
                None
            }
        };
        report.ms = ms(t0.elapsed());
        let t = &mut report.timings;
        t.total = t.read + t.crop + t.segment + report.ms;
        (report, track)
    }

    /// The stages of [`Sensor::sense_frame`] after reading: the estimate and its report,
    /// and with `want_track` what the frame leaves for the next.
    fn estimate_frame(
        &self,
        obs: &Observation,
        inputs: Option<&FrameInput>,
        prev: Option<&Track>,
        want_track: bool,
        report: &mut FrameReport,
    ) -> Result<Option<Track>, FrameStatus> {
        if obs.robot.len() < 50 {
            return Err(FrameStatus::NoRobot);
        }
        let model = self.actuated(inputs).map_err(|e| fail(&e))?;
        let (free, contacts) = self.free_and_contacts(obs, &model, report)?;
        let features = self.features_near(&free.solution.positions, &contacts);
        report.features = features.len();
        let clock = std::time::Instant::now();
        let robot = self.tared_points(obs, &free.solution.positions);
        let registrar = Registrar::new(&robot);
        let dense_on = (self.params.registration).is_dense(contacts.len(), self.tare.is_some());
        let views = if dense_on {
            self.dense_views(obs, &robot)
        } else {
            Vec::new()
        };
        let dense = DenseInputs {
            views: &views,
            triangles: &self.surface.triangles,
            surface: Default::default(),
            params: self.params.dense_rows,
        };
        report.timings.register += ms(clock.elapsed());
        let frame = Frame {
            sensor: self,
            inputs: FrameInputs {
                model: &model,
                registrar: &registrar,
                features: &features,
                params: &self.params.frame,
                dense: dense_on.then_some(&dense),
            },
            free: &free,
            contacts: &contacts,
            actuators: super::free::ActuatorInputs::of(&model),
        };
        let Estimated {
            mut est,
            candidates,
            groups,
            force_points,
        } = if contacts.is_empty() {
            force_points(&frame, prev, report)?
        } else {
            super::locate::locate(&frame, prev, want_track, report)?
        };
        if dense_on {
            est.use_independent_uncertainty();
        } else {
            est.use_shared_point_uncertainty();
        }
        report.describe(&est, &candidates, &groups, &model, &self.params);
        if est.visible == 0 {
            return Err(FrameStatus::NoFeatures);
        }
        if !want_track {
            return Ok(None);
        }
        Ok(leave(
            frame.actuators,
            est,
            candidates,
            &groups,
            force_points,
        ))
    }

    /// The free equilibrium of the actuated `model` (cached per input) and the contacts
    /// seen in `obs`, timed; a frame with more contacts than `max_contacts` stops here.
    fn free_and_contacts(
        &self,
        obs: &Observation,
        model: &crate::fem::model::Model,
        report: &mut FrameReport,
    ) -> Result<(Arc<FreeState>, Vec<Contact>), FrameStatus> {
        let clock = std::time::Instant::now();
        let free = self.free.solve(&self.model, model).map_err(|e| fail(&e))?;
        report.timings.free_solve = ms(clock.elapsed());
        let clock = std::time::Instant::now();
        let contacts = self.contacts(obs).map_err(|e| fail(&e))?;
        report.timings.contacts = ms(clock.elapsed());
        if contacts.len() > self.params.max_contacts {
            return Err(FrameStatus::TooManyContacts {
                seen: contacts.len(),
                max: self.params.max_contacts,
            });
        }
        Ok((free, contacts))
    }

    /// Each camera's robot points (`robot`, those of `obs` or moved by the reference),
    /// subsampled, with its eye and viewing axis: the rows of dense registration.
    fn dense_views(&self, obs: &Observation, robot: &[[f64; 3]]) -> Vec<DenseView> {
        (obs.views.iter())
            .map(|v| {
                let points = &robot[v.robot.clone()];
                let camera = &self.cameras[v.camera];
                DenseView {
                    points: subsample(points, self.params.dense_rows.max_points),
                    eye: camera.eye,
                    axis: camera.robot_from_camera.axis(2),
                }
            })
            .collect()
    }

    /// The frame's features: the sensor's, and the pool's within
    /// `local_features_radius` of a seen contact at node positions `x`.
    fn features_near(&self, x: &[[f64; 3]], contacts: &[Contact]) -> Vec<SurfaceFeature> {
        let mut features = self.features.clone();
        let r2 = self.params.local_features_radius.powi(2);
        features.extend(self.local_pool.iter().filter(|f| {
            let p = f.position(x);
            contacts.iter().any(|c| {
                let d = sub(p, c.centroid.map(|v| v as f64));
                dot(d, d) <= r2
            })
        }));
        features
    }
}

/// A frame without seen contacts: the model's declared force points are the candidates,
/// each estimated (in parallel; a tracked frame resumes each where the previous frame's
/// loop ended), and the one explaining the frame best (in model order) is reported.
fn force_points(
    frame: &Frame<'_>,
    prev: Option<&Track>,
    report: &mut FrameReport,
) -> Result<Estimated, FrameStatus> {
    let model = frame.inputs.model;
    if !model.force_points.is_empty() {
        report.warnings.push(format!(
            "no contact seen: the model's {} declared force point(s) are the candidates",
            model.force_points.len()
        ));
    }
    let sets = force_point_candidates(model);
    let ends = force_point_ends(prev, &frame.actuators, sets.len());
    let index: Vec<usize> = (0..sets.len()).collect();
    let results = par_map(&index, |&i| match ends.and_then(|e| e[i].as_ref()) {
        Some(e) => {
            let start = Start::Resume {
                solution: e.solution.as_ref(),
                state: e.solver.clone(),
                forces: &e.applied,
            };
            estimate(&frame.inputs, &sets[i], start)
        }
        None => frame.solve(&sets[i]),
    });
    report.tracked = ends.is_some_and(|e| e.iter().any(Option::is_some));
    let (mut point_ends, chosen) = best_force_point(model, results, report);
    if let Some(b) = chosen {
        if let Some(est) = point_ends[b].take() {
            let group = Group {
                source: format!("force point {}", model.force_points[b].name),
                seen_at: None,
                points: 0,
                node: None,
                range: 0..sets[b].len(),
                alternatives: Vec::new(),
            };
            return Ok(Estimated {
                est,
                candidates: sets[b].clone(),
                groups: vec![group],
                force_points: Some((point_ends, b)),
            });
        }
    }
    if !model.force_points.is_empty() {
        return Err(FrameStatus::NotSolved("every force point failed".into()));
    }
    report.warnings.push(
        "no contact seen and the model declares no force points: only the actuators are estimated"
            .into(),
    );
    let est = frame.solve(&[]).map_err(|e| fail(&e))?;
    report.account(&est);
    Ok(Estimated {
        est,
        candidates: Vec::new(),
        groups: Vec::new(),
        force_points: None,
    })
}

/// The candidate forces of each of `model`'s declared force points: one per row, along the
/// row's summed entries, pushing only.
fn force_point_candidates(model: &crate::fem::model::Model) -> Vec<Vec<Candidate>> {
    model
        .force_points
        .iter()
        .map(|fp| {
            fp.rows
                .iter()
                .map(|r| {
                    let direction = r.entries.iter().fold([0.0; 3], |a, e| {
                        [a[0] + e.1[0], a[1] + e.1[1], a[2] + e.1[2]]
                    });
                    Candidate::new(fp.point, direction, true)
                })
                .collect()
        })
        .collect()
}

/// Each force point's estimate (`None` where it failed, with a warning) and the one with
/// the smallest residual, the first on a tie.
fn best_force_point(
    model: &crate::fem::model::Model,
    results: Vec<InverseResult<FrameEstimate>>,
    report: &mut FrameReport,
) -> (Vec<Option<FrameEstimate>>, Option<usize>) {
    let mut point_ends: Vec<Option<FrameEstimate>> = Vec::new();
    let mut chosen: Option<usize> = None;
    for (fp, result) in model.force_points.iter().zip(results) {
        match result {
            Ok(e) => {
                report.account(&e);
                let residual = e.estimate.residual_rms;
                let better = chosen.is_none_or(|b| {
                    point_ends[b]
                        .as_ref()
                        .is_some_and(|c| residual < c.estimate.residual_rms)
                });
                if better {
                    chosen = Some(point_ends.len());
                }
                point_ends.push(Some(e));
            }
            Err(e) => {
                report
                    .warnings
                    .push(format!("force point {}: {e}", fp.name));
                point_ends.push(None);
            }
        }
    }
    (point_ends, chosen)
}

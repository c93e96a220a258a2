//! Where seen contacts touch the FE model: the data choose each contact's surface node
//! among those near it ([`crate::inverse::choose_locations`]), in rounds: at the free state
//! (its estimate a preview), at the preview's state, then at estimated states, each round
//! whose choice moves estimating the new locations. A tracked frame starts from the
//! previous frame's locations and forces, and checks them with one choice.

use super::blend::{force_of, Group, LocationAlternative};
use super::estimate::{fail, Estimated, Frame};
use super::timings::ms;
use super::track::{resume_contacts, Resumed, Track};
use super::FrameReport;
use super::FrameStatus;
use crate::fem::solve::{MappedPoint, SolverState};
use crate::inverse::{
    choose_locations, estimate, Alternative, Candidate, FrameEstimate, FrameInputs, FrameParams,
    InverseResult, LinearisationPoint, LocationChoice, Start,
};
use crate::math::{dot, sub, tangents};
use crate::register::vertex_normals;

/// Locations tried, per round of a frame's location choice, after the chosen one could not
/// be estimated (each next-best by the same choice without the failed ones).
const LOCATION_RETRIES: usize = 2;

/// The rounds of a frame's location choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Round {
    /// The first, at the free state: its estimate is a preview
    /// ([`SenseParams::preview_updates`](super::SenseParams::preview_updates)).
    Free,
    /// At a preview's state: if the locations stand the preview goes on, else the new ones
    /// are estimated.
    Preview,
    /// At an estimated state: if the locations stand the estimate is final, else the new
    /// ones are estimated.
    Check,
}

/// What a round does with the locations the data chose.
enum Action {
    /// They stand: the rounds are over.
    Keep,
    /// They stand: the preview goes on.
    GoOn(Box<Located>),
    /// Estimate them (as a preview, or fully).
    Estimate { preview: bool },
}

/// Whether the rounds go on.
enum Flow {
    Next,
    Stop,
}

/// An estimate of chosen locations.
struct Located {
    est: FrameEstimate,
    candidates: Vec<Candidate>,
    groups: Vec<Group>,
    /// The chosen surface node of each contact.
    nodes: Vec<usize>,
}

/// The estimate the rounds hold.
enum Held {
    /// None yet (or a preview whose going on failed).
    Nothing,
    /// A preview: stopped after `preview_updates` FE updates, before it settled.
    Preview(Located),
    /// An estimate.
    Estimate(Located),
}

/// Where the choice linearises: node positions, cable tensions and a solver state there
/// (the free equilibrium's, then the last estimate's).
struct Linearisation {
    x: Vec<[f64; 3]>,
    tensions: Vec<f64>,
    state: Option<SolverState>,
    /// Whether `x` is the free state.
    free: bool,
}

/// Each contact's options (surface nodes near it and their candidates), the data's choice
/// among them, and the chosen nodes.
type Chosen = (
    Vec<(Vec<usize>, Vec<Vec<Candidate>>)>,
    LocationChoice,
    Vec<usize>,
);

/// An estimate tried, of `candidates` in `groups` (a preview when `preview`).
type Attempt = (
    InverseResult<FrameEstimate>,
    Vec<Candidate>,
    Vec<Group>,
    bool,
);

/// The location rounds of one frame.
struct Rounds<'f, 'a> {
    frame: &'f Frame<'a>,
    report: &'f mut FrameReport,
    centroids: Vec<[f64; 3]>,
    at: Linearisation,
    held: Held,
    /// Whether a choice keeps the solver state (the last estimate's also starts the next
    /// frame); else it takes it.
    keep_state: bool,
    /// Whether the first estimate is a preview (the first update is at the free state
    /// itself: a preview needs two).
    previews: bool,
    /// The last choice that stood or was estimated: the frame's alternative locations
    /// come from it, if it picked the final estimate's nodes.
    last_choice: Option<Chosen>,
}

/// The seen contacts' locations and their estimate.
pub(super) fn locate(
    frame: &Frame<'_>,
    prev: Option<&Track>,
    want_track: bool,
    report: &mut FrameReport,
) -> Result<Estimated, FrameStatus> {
    let params = &frame.sensor.params;
    let free = frame.free;
    let mut rounds = Rounds {
        frame,
        report,
        centroids: frame
            .contacts
            .iter()
            .map(|c| c.centroid.map(|v| v as f64))
            .collect(),
        at: Linearisation {
            x: free.solution.positions.clone(),
            tensions: free.solution.actuator_forces(),
            state: free.solver.clone(),
            free: true,
        },
        held: Held::Nothing,
        keep_state: want_track,
        previews: params.preview_updates >= 2,
        last_choice: None,
    };
    let resumed = prev
        .and_then(|t| resume_contacts(t, params.track_radius, &frame.actuators, &rounds.centroids));
    let count = match resumed.map(|r| rounds.tracked(r)) {
        Some(Some(kept)) if kept => 0,
        Some(Some(_)) => params.location_checks,
        _ => 1 + usize::from(rounds.previews) + params.location_checks,
    };
    for _ in 0..count {
        let flow = match rounds.next_round() {
            Round::Free => rounds.free_round()?,
            Round::Preview => rounds.preview_round()?,
            Round::Check => rounds.check_round()?,
        };
        if let Flow::Stop = flow {
            break;
        }
    }
    rounds.finish()
}

impl Rounds<'_, '_> {
    /// A tracked frame: the loop starts from the previous frame's locations and forces
    /// while, at the same time, the data choose the locations linearised at the previous
    /// frame's state (nearer than the free one). Returns whether the choice kept the
    /// previous locations (`None`: the estimate failed, the frame is sensed untracked).
    fn tracked(&mut self, r: Resumed<'_>) -> Option<bool> {
        let t = r.estimate;
        let (tracked, choice) = crate::search::join(
            crate::search::Parallelism::Rayon,
            || {
                let start = Start::Resume {
                    solution: t.solution.as_ref(),
                    state: t.solver.clone(),
                    forces: &r.applied,
                };
                estimate(&self.frame.inputs, &r.candidates, start)
            },
            || {
                let clock = std::time::Instant::now();
                let c = choose(
                    self.frame,
                    &t.positions,
                    &tensions_of(t),
                    t.solver.clone(),
                    &[],
                );
                (c, ms(clock.elapsed()))
            },
        );
        self.report.timings.mapping += choice.1;
        match tracked {
            Ok(mut est) => {
                self.report.account(&est);
                self.report.tracked = true;
                let groups = (0..self.frame.contacts.len())
                    .map(|i| self.contact_group(i, r.nodes[i], r.ranges[i].clone()))
                    .collect();
                self.at = Linearisation {
                    x: est.positions.clone(),
                    tensions: tensions_of(&est),
                    state: est.solver.take(),
                    free: false,
                };
                let kept = matches!(&choice.0, Ok((_, _, picked)) if *picked == r.nodes);
                self.last_choice = choice.0.ok();
                self.held = Held::Estimate(Located {
                    est,
                    candidates: r.candidates,
                    groups,
                    nodes: r.nodes,
                });
                Some(kept)
            }
            Err(e) => {
                self.report.warnings.push(format!(
                    "not tracked: the estimate from the previous frame's failed ({e}); sensed from the unloaded state"
                ));
                None
            }
        }
    }

    /// The round the held estimate calls for.
    fn next_round(&self) -> Round {
        match self.held {
            Held::Nothing => Round::Free,
            Held::Preview(_) => Round::Preview,
            Held::Estimate(_) => Round::Check,
        }
    }

    /// The first round, at the free state: the chosen locations are estimated, as a preview.
    fn free_round(&mut self) -> Result<Flow, FrameStatus> {
        let preview = self.previews;
        self.attempts(|_, _| Action::Estimate { preview })
    }

    /// The round at a preview's state: if the locations stand, the preview goes on; else
    /// the new ones are estimated (as a preview again if going on failed).
    fn preview_round(&mut self) -> Result<Flow, FrameStatus> {
        self.attempts(
            |rounds, picked| match std::mem::replace(&mut rounds.held, Held::Nothing) {
                Held::Preview(p) if p.nodes == picked => Action::GoOn(Box::new(p)),
                Held::Nothing => Action::Estimate {
                    preview: rounds.previews,
                },
                other => {
                    rounds.held = other;
                    Action::Estimate { preview: false }
                }
            },
        )
    }

    /// A round at an estimated state: if the locations stand, the estimate is final; else
    /// the new ones are estimated.
    fn check_round(&mut self) -> Result<Flow, FrameStatus> {
        self.attempts(|rounds, picked| match &rounds.held {
            Held::Estimate(e) if e.nodes == picked => Action::Keep,
            _ => Action::Estimate { preview: false },
        })
    }

    /// One round: the data's choice, and `action` with it. Locations whose estimate fails
    /// (the FE model could not carry the estimated load there, e.g. an element inverted
    /// under a point load at a corner node) are excluded and the next-best estimated.
    fn attempts(
        &mut self,
        mut action: impl FnMut(&mut Self, &[usize]) -> Action,
    ) -> Result<Flow, FrameStatus> {
        let mut failed: Vec<Vec<usize>> = Vec::new();
        // Why the last of them failed.
        let mut last_failure = None;
        loop {
            let Some((options, choice, picked)) = self.choose_next(&failed, last_failure.take())?
            else {
                return Ok(Flow::Stop);
            };
            let attempt = match action(self, &picked) {
                Action::Keep => {
                    self.last_choice = Some((options, choice, picked));
                    return Ok(Flow::Stop);
                }
                Action::GoOn(p) => self.go_on(*p),
                Action::Estimate { preview } => self.estimate_new(&options, &choice, preview),
            };
            let (solved, candidates, groups, preview) = attempt;
            match solved {
                Ok(est) => {
                    self.hold(est, candidates, groups, picked.clone(), preview);
                    self.last_choice = Some((options, choice, picked));
                    return Ok(Flow::Next);
                }
                Err(e) if failed.len() < LOCATION_RETRIES => {
                    last_failure = Some(format!(
                        "contact location (nodes {picked:?}) could not be estimated ({e})"
                    ));
                    failed.push(choice.pick);
                }
                Err(e) if !matches!(self.held, Held::Nothing) => {
                    self.report.warnings.push(format!(
                        "contact location (nodes {picked:?}) could not be estimated ({e}); the last estimate's location is kept"
                    ));
                    return Ok(Flow::Stop);
                }
                Err(e) => return Err(fail(&e)),
            }
        }
    }

    /// The data's choice at the current linearisation point, without the `failed`
    /// combinations (`failure`: why the last one failed). `None`: nothing is left to try
    /// and the last estimate stands.
    fn choose_next(
        &mut self,
        failed: &[Vec<usize>],
        failure: Option<String>,
    ) -> Result<Option<Chosen>, FrameStatus> {
        let clock = std::time::Instant::now();
        // The last estimate's state also starts the next frame, and a preview's goes on if
        // its locations stand.
        let state = if self.keep_state || matches!(self.held, Held::Preview(_)) {
            self.at.state.clone()
        } else {
            self.at.state.take()
        };
        let choice = choose(self.frame, &self.at.x, &self.at.tensions, state, failed);
        self.report.timings.mapping += ms(clock.elapsed());
        match (choice, failure) {
            (Ok(c), failure) => {
                if let Some(e) = failure {
                    self.report
                        .warnings
                        .push(format!("{e}; the next-best location is estimated instead"));
                }
                Ok(Some(c))
            }
            // No location left to try (e.g. a contact with a single option).
            (Err(_), Some(e)) if !matches!(self.held, Held::Nothing) => {
                self.report.warnings.push(format!(
                    "{e}; no other location is left: the last estimate's location is kept"
                ));
                Ok(None)
            }
            (Err(_), Some(e)) => Err(FrameStatus::NotSolved(e)),
            (Err(e), None) => Err(fail(&e)),
        }
    }

    /// The preview `p`, whose locations stand, goes on from where it stopped.
    fn go_on(&mut self, p: Located) -> Attempt {
        let start = Start::Onwards {
            from: &p.est,
            state: self.at.state.take(),
        };
        let solved = estimate(&self.frame.inputs, &p.candidates, start);
        (solved, p.candidates, p.groups, false)
    }

    /// The estimate of the locations `choice` picked among `options` (a preview: stopped
    /// after `preview_updates` FE updates).
    fn estimate_new(
        &self,
        options: &[(Vec<usize>, Vec<Vec<Candidate>>)],
        choice: &LocationChoice,
        preview: bool,
    ) -> Attempt {
        let mut candidates = Vec::new();
        let mut groups = Vec::new();
        for (i, ((nodes, opts), &k)) in options.iter().zip(&choice.pick).enumerate() {
            let start = candidates.len();
            candidates.extend_from_slice(&opts[k]);
            groups.push(self.contact_group(i, nodes[k], start..candidates.len()));
        }
        let frame = self.frame;
        let solved = if !preview {
            frame.solve(&candidates)
        } else {
            let params = FrameParams {
                max_updates: frame.sensor.params.preview_updates,
                ..frame.inputs.params.clone()
            };
            if self.at.free {
                // The choice's QP at the free state is the loop's first update there.
                let inputs = FrameInputs {
                    params: &params,
                    ..frame.inputs
                };
                let start = Start::AfterChoice {
                    at: &frame.free.solution,
                    state: frame.free.solver.clone(),
                    choice,
                };
                estimate(&inputs, &candidates, start)
            } else {
                frame.solve_with(&candidates, &params)
            }
        };
        (solved, candidates, groups, preview)
    }

    /// Holds a new estimate `est` of the locations `nodes`, and linearises the next choice
    /// at its state.
    fn hold(
        &mut self,
        mut est: FrameEstimate,
        candidates: Vec<Candidate>,
        groups: Vec<Group>,
        nodes: Vec<usize>,
        preview: bool,
    ) {
        self.report.account(&est);
        let partial = preview && !est.settled;
        self.at = Linearisation {
            x: est.positions.clone(),
            tensions: tensions_of(&est),
            state: est.solver.take(),
            free: false,
        };
        let located = Located {
            est,
            candidates,
            groups,
            nodes,
        };
        self.held = if partial {
            Held::Preview(located)
        } else {
            Held::Estimate(located)
        };
    }

    /// The final estimate: a preview left standing (its locations' next-best could not be
    /// estimated) is finished first.
    fn finish(mut self) -> Result<Estimated, FrameStatus> {
        let held = std::mem::replace(&mut self.held, Held::Nothing);
        self.held = match held {
            Held::Preview(p) => {
                let start = Start::Onwards {
                    from: &p.est,
                    state: self.at.state.take(),
                };
                let mut est =
                    estimate(&self.frame.inputs, &p.candidates, start).map_err(|e| fail(&e))?;
                self.report.account(&est);
                self.at.state = est.solver.take();
                Held::Estimate(Located { est, ..p })
            }
            other => other,
        };
        let (Held::Preview(mut out) | Held::Estimate(mut out)) = self.held else {
            return Err(FrameStatus::NotSolved("no estimate".into()));
        };
        // The last choice's alternatives, where it picked the estimate's locations, moved
        // to the estimate's forces (solved once per frame, not per round).
        if let Some((options, choice, picked)) = self.last_choice.take() {
            if picked == out.nodes {
                let params = &self.frame.sensor.params;
                let window = 2.0 * params.location_ambiguity;
                let fits = choice.alternatives(self.frame.inputs.params, window);
                let alternatives = alternatives_of(&options, &choice, &fits, &out.est.positions);
                for (g, alts) in out.groups.iter_mut().zip(alternatives) {
                    let r = g.range.clone();
                    let f = force_of(&out.candidates[r.clone()], &out.est.estimate.forces[r]);
                    g.alternatives = alts
                        .into_iter()
                        .map(|a| LocationAlternative {
                            force: std::array::from_fn(|q| f[q] + a.force[q]),
                            ..a
                        })
                        .collect();
                }
            }
        }
        // `at.state` is the last estimate's solver state.
        out.est.solver = self.at.state;
        Ok(Estimated {
            est: out.est,
            candidates: out.candidates,
            groups: out.groups,
            force_points: None,
        })
    }

    /// The report group of contact `i` located at `node`, its candidates at `range`.
    fn contact_group(&self, i: usize, node: usize, range: std::ops::Range<usize>) -> Group {
        Group {
            source: "contact".into(),
            seen_at: Some(self.centroids[i]),
            points: self.frame.contacts[i].points,
            node: Some(node),
            range,
            alternatives: Vec::new(),
        }
    }
}

/// Per contact, `choice`'s alternatives `fits` among `options` at node positions `x`, each
/// with (as its `force`) the change of the contact's force in the choice's QP when it
/// moves there.
fn alternatives_of(
    options: &[(Vec<usize>, Vec<Vec<Candidate>>)],
    choice: &LocationChoice,
    fits: &[Vec<Alternative>],
    x: &[[f64; 3]],
) -> Vec<Vec<LocationAlternative>> {
    let mut start = 0;
    let mut out = Vec::new();
    for (k, ((nodes, opts), alts)) in options.iter().zip(fits).enumerate() {
        let chosen = &opts[choice.pick[k]];
        let range = start..start + chosen.len();
        start = range.end;
        let f = force_of(chosen, &choice.estimate.forces[range]);
        out.push(
            alts.iter()
                .map(|a| {
                    let g = force_of(&opts[a.option], &a.forces);
                    LocationAlternative {
                        node: nodes[a.option],
                        location: x[nodes[a.option]],
                        force: sub(g, f),
                        misfit: a.misfit,
                    }
                })
                .collect(),
        );
    }
    out
}

/// The options of each contact (surface nodes near its centroid at node positions `x`, and
/// their candidates) and the data's choice among them, linearised at `x` with `state` (a
/// solver state there, if any), without the `excluded` combinations.
fn choose(
    frame: &Frame<'_>,
    x: &[[f64; 3]],
    tensions: &[f64],
    state: Option<SolverState>,
    excluded: &[Vec<usize>],
) -> InverseResult<Chosen> {
    let sensor = frame.sensor;
    let surface = &sensor.surface;
    let params = &sensor.params;
    let normals = vertex_normals(x, &surface.triangles);
    let options: Vec<(Vec<usize>, Vec<Vec<Candidate>>)> = frame
        .contacts
        .iter()
        .map(|c| {
            let nodes = near_nodes(
                x,
                &surface.nodes,
                c.centroid.map(|v| v as f64),
                params.location_radius,
                params.location_options,
            );
            let opts = nodes
                .iter()
                .map(|&n| candidates_at(n, normals[n], params.three_d))
                .collect();
            (nodes, opts)
        })
        .collect();
    let all: Vec<Vec<Vec<Candidate>>> = options.iter().map(|o| o.1.clone()).collect();
    let at = LinearisationPoint {
        positions: x,
        tensions,
        state,
    };
    let choice = choose_locations(&frame.inputs, &all, at, params.max_combinations, excluded)?;
    let picked: Vec<usize> = choice
        .pick
        .iter()
        .zip(&options)
        .map(|(&k, (nodes, _))| nodes[k])
        .collect();
    Ok((options, choice, picked))
}

/// The actuator forces (cable tensions, cavity pressures) of an estimate's last FE state
/// (none if it has none: a choice linearised there then fails and says so).
fn tensions_of(est: &FrameEstimate) -> Vec<f64> {
    est.solution
        .as_ref()
        .map_or(Vec::new(), |s| s.actuator_forces())
}

/// The candidate forces at surface node `node` with outward normal `normal`: a pushing
/// force along the inward normal, and with `three_d` two free tangential ones.
fn candidates_at(node: usize, normal: [f64; 3], three_d: bool) -> Vec<Candidate> {
    let inward = normal.map(|v| -v);
    let mut c = vec![Candidate::at_node(node, inward)];
    if three_d {
        let (t1, t2) = tangents(inward);
        for t in [t1, t2] {
            c.push(Candidate::new(MappedPoint::node(node), t, false));
        }
    }
    c
}

/// Up to `max` of `nodes` within `radius` of `p` at positions `x`, nearest first (at least
/// the nearest one).
fn near_nodes(x: &[[f64; 3]], nodes: &[usize], p: [f64; 3], radius: f64, max: usize) -> Vec<usize> {
    let mut d: Vec<(f64, usize)> = nodes
        .iter()
        .map(|&n| {
            let v = sub(x[n], p);
            (dot(v, v), n)
        })
        .collect();
    d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let within = d
        .iter()
        .filter(|e| e.0 <= radius * radius)
        .count()
        .clamp(1, max.max(1));
    d.iter().take(within).map(|e| e.1).collect()
}

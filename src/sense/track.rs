//! Sensing a stream frame after frame ([`Sensor::track_frames`]): what a frame leaves for
//! the next ([`Track`]), and whether the next can start from it.

use super::blend::Group;
use super::free::{same_inputs, ActuatorInputs};
use super::{CameraFrames, FrameReport, FrameStatus, Observation, SenseResult, Sensor};
use crate::inverse::{Candidate, FrameEstimate};
use crate::math::{dot, sub};
use std::ops::Range;

/// What a sensed frame leaves for the next frame of a stream ([`Sensor::track`],
/// [`Sensor::track_frames`]): its cable inputs, and where its loops ended.
#[derive(Clone, Debug)]
pub struct Track {
    /// The actuator inputs of the frame.
    inputs: ActuatorInputs,
    /// What the next frame can start from.
    ends: Ends,
}

/// Where a frame's loops ended.
#[derive(Clone, Debug)]
enum Ends {
    /// Seen contacts: where they were seen, the locations chosen for them, and the final
    /// estimate (forces, FE state, solver state).
    Contacts {
        /// Centroids of the seen contacts (robot frame, m), in the frame's order.
        centroids: Vec<[f64; 3]>,
        /// The chosen surface node of each contact.
        nodes: Vec<usize>,
        /// The candidate forces of the estimate, contact after contact.
        candidates: Vec<Candidate>,
        /// The candidates of each contact (ranges into `candidates`).
        ranges: Vec<std::ops::Range<usize>>,
        /// The final estimate.
        estimate: Box<FrameEstimate>,
    },
    /// No contact seen: the estimate of each of the model's force points (`None` where it
    /// failed), in model order.
    ForcePoints(Vec<Option<FrameEstimate>>),
}

impl Track {
    /// The chosen surface node of each seen contact (none for a frame without contacts).
    pub fn nodes(&self) -> &[usize] {
        match &self.ends {
            Ends::Contacts { nodes, .. } => nodes,
            Ends::ForcePoints(_) => &[],
        }
    }
}

impl Sensor {
    /// Observes and senses `frames` of `rec` one after the other as a stream, each frame
    /// starting from what the one before left ([`Sensor::track`]) while the next is read
    /// beside it, and hands each observation and report to `emit` in frame order. An
    /// unreadable frame gets [`FrameStatus::Unreadable`] (and the next starts afresh).
    /// Stops at the first error of `emit`.
    ///
    /// ```no_run
    /// # use softsense::sense::{Recording, SenseParams, Sensor};
    /// # use softsense::fem::model::Model;
    /// let rec = Recording::open("clouds/scenes/probe_press".as_ref())?;
    /// let model = Model::load("meshes/models/robot.toml".as_ref(), None)?;
    /// let sensor = Sensor::new(model, rec.robot_from_camera.unwrap(), SenseParams::default());
    /// sensor.track_frames(&rec, &rec.frames, |_obs, report| {
    ///     let tracked = if report.tracked { "tracked" } else { "cold" };
    ///     println!("frame {} ({tracked}): {}", report.frame, report.status);
    ///     Ok::<(), std::io::Error>(())
    /// })?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn track_frames<E>(
        &self,
        rec: &impl CameraFrames,
        frames: &[usize],
        mut emit: impl FnMut(&SenseResult<Observation>, FrameReport) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut prev: Option<Track> = None;
        let mut next = frames.first().map(|&f| self.observe(rec, f));
        for (i, &frame) in frames.iter().enumerate() {
            let Some(obs) = next.take() else { break };
            let following = frames.get(i + 1).copied();
            let ((report, track), read) = crate::search::join(
                crate::search::Parallelism::Rayon,
                || match &obs {
                    Ok(o) => self.track(frame, o, rec.inputs_of(frame).as_ref(), prev.as_ref()),
                    Err(e) => (
                        FrameReport::empty(frame, FrameStatus::Unreadable(e.to_string())),
                        None,
                    ),
                },
                || following.map(|f| self.observe(rec, f)),
            );
            next = read;
            prev = track;
            emit(&obs, report)?;
        }
        Ok(())
    }
}

/// Whether a frame with cable inputs `inputs` and contacts seen at `centroids` can start
/// from `track`: the same inputs, and each contact within `radius`
/// ([`SenseParams::track_radius`](super::SenseParams::track_radius)) of exactly one of the
/// track's (contact detection does not keep an order from frame to frame). Returns, for
/// each contact, the track's.
fn track_order(
    track: &Track,
    radius: f64,
    inputs: &ActuatorInputs,
    centroids: &[[f64; 3]],
) -> Option<Vec<usize>> {
    let Ends::Contacts {
        centroids: seen,
        candidates,
        ..
    } = &track.ends
    else {
        return None;
    };
    if !same_inputs(&track.inputs, inputs) || candidates.is_empty() || seen.len() != centroids.len()
    {
        return None;
    }
    let r2 = radius.powi(2);
    let mut order = Vec::with_capacity(centroids.len());
    for c in centroids {
        let mut near = seen.iter().enumerate().filter(|(_, t)| {
            let d = sub(**t, *c);
            dot(d, d) <= r2
        });
        match (near.next(), near.next()) {
            (Some((j, _)), None) if !order.contains(&j) => order.push(j),
            _ => return None,
        }
    }
    Some(order)
}

/// What a tracked frame with seen contacts starts from: the previous frame's estimate, and
/// its locations, candidates and forces in this frame's contact order.
pub(super) struct Resumed<'t> {
    /// The previous frame's final estimate.
    pub estimate: &'t FrameEstimate,
    /// The chosen surface node of each contact.
    pub nodes: Vec<usize>,
    /// The candidate forces, contact after contact.
    pub candidates: Vec<Candidate>,
    /// Their forces in the previous frame's last FE state (N).
    pub applied: Vec<f64>,
    /// The candidates of each contact (ranges into `candidates`).
    pub ranges: Vec<Range<usize>>,
}

/// What a frame with cable inputs `inputs` and contacts seen at `centroids` resumes from
/// `track` (see `track_order`), if it can.
pub(super) fn resume_contacts<'t>(
    track: &'t Track,
    radius: f64,
    inputs: &ActuatorInputs,
    centroids: &[[f64; 3]],
) -> Option<Resumed<'t>> {
    let order = track_order(track, radius, inputs, centroids)?;
    let Ends::Contacts {
        nodes: t_nodes,
        candidates: t_candidates,
        ranges: t_ranges,
        estimate,
        ..
    } = &track.ends
    else {
        return None;
    };
    let mut candidates = Vec::new();
    let mut applied = Vec::new();
    let mut ranges = Vec::new();
    for &j in &order {
        let r = t_ranges[j].clone();
        let start = candidates.len();
        candidates.extend_from_slice(&t_candidates[r.clone()]);
        applied.extend_from_slice(estimate.applied.get(r)?);
        ranges.push(start..candidates.len());
    }
    let nodes: Vec<usize> = order.iter().map(|&j| t_nodes[j]).collect();
    Some(Resumed {
        estimate,
        nodes,
        candidates,
        applied,
        ranges,
    })
}

/// The previous frame's estimate of each of `count` force points, when a frame without
/// contacts and cable inputs `inputs` can resume them from `track`.
pub(super) fn force_point_ends<'t>(
    track: Option<&'t Track>,
    inputs: &ActuatorInputs,
    count: usize,
) -> Option<&'t [Option<FrameEstimate>]> {
    track
        .filter(|t| same_inputs(&t.inputs, inputs))
        .and_then(|t| match &t.ends {
            Ends::ForcePoints(e) if e.len() == count => Some(&e[..]),
            _ => None,
        })
}

/// What a sensed frame leaves for the next: with `force_points` (a frame without contacts:
/// each force point's estimate, and which was chosen, `est`) their ends; else the seen
/// contacts of `groups` with the final estimate `est` of `candidates` (`None` when a group
/// is not a seen contact, or there is none).
pub(super) fn leave(
    inputs: ActuatorInputs,
    est: FrameEstimate,
    candidates: Vec<Candidate>,
    groups: &[Group],
    force_points: Option<(Vec<Option<FrameEstimate>>, usize)>,
) -> Option<Track> {
    let ends = if let Some((mut point_ends, b)) = force_points {
        point_ends[b] = Some(est);
        Ends::ForcePoints(point_ends)
    } else {
        let mut centroids = Vec::new();
        let mut nodes = Vec::new();
        let mut ranges = Vec::new();
        for g in groups {
            // Only seen contacts are followed (not the actuators-only estimate).
            let (Some(at), Some(node)) = (g.seen_at, g.node) else {
                return None;
            };
            centroids.push(at);
            nodes.push(node);
            ranges.push(g.range.clone());
        }
        if centroids.is_empty() {
            return None;
        }
        Ends::Contacts {
            centroids,
            nodes,
            candidates,
            ranges,
            estimate: Box::new(est),
        }
    };
    Some(Track { inputs, ends })
}

//! The reference (tare) of a sensor: unloaded frames register the model to what the cameras
//! see before any contact, and later frames are sensed relative to it
//! ([`crate::inverse::tare`]).

use super::cameras::CameraFrames;
use super::observe::Observation;
use super::{SenseError, SenseResult, Sensor};
use crate::inverse::tare::{Tare, TareFit, TareParams};
use std::borrow::Cow;

impl Sensor {
    /// Takes `frames` of `source` as the reference: they must show the body unloaded (no
    /// contact seen; a hanging weight is not seen, so it is the caller's word). The model's
    /// unloaded state at each frame's inputs is matched to its robot points, and the normal
    /// offsets, averaged over the frames and smoothed over the surface, become the
    /// reference later frames are sensed relative to ([`Sensor::tare`]). Replaces an
    /// earlier reference.
    pub fn take_reference(
        &mut self,
        source: &impl CameraFrames,
        frames: &[usize],
        params: TareParams,
    ) -> SenseResult<&Tare> {
        self.tare = None;
        self.reference_frames.clear();
        let mut seen = Vec::with_capacity(frames.len());
        for &frame in frames {
            let obs = self.observe(source, frame)?;
            let contacts = self.contacts(&obs).map(|c| c.len()).unwrap_or(0);
            if contacts > 0 {
                return Err(SenseError::LoadedReference { frame, contacts });
            }
            let inputs = source.camera_recording(0).inputs_of(frame);
            let model = self.actuated(inputs.as_ref())?;
            let free = (self.free.solve(&self.model, &model))
                .map_err(|e| SenseError::Reference { frame, source: e })?;
            seen.push((obs, free));
        }
        let nodes = self.model.problem.mesh.nodes_in_rest.len();
        let mut fit = TareFit::new(nodes, &self.surface.triangles, params);
        for (obs, free) in &seen {
            for v in &obs.views {
                let eye = self.cameras[v.camera].eye;
                let points = &obs.robot[v.robot.clone()];
                fit.add_view(&free.solution.positions, eye, points);
            }
            fit.end_frame();
        }
        let tare = fit.finish().ok_or(SenseError::EmptyReference {
            frames: frames.to_vec(),
        })?;
        self.reference_frames = frames.to_vec();
        Ok(self.tare.insert(tare))
    }

    /// The reference later frames are sensed relative to, if one was taken
    /// ([`Sensor::take_reference`]).
    pub fn tare(&self) -> Option<&Tare> {
        self.tare.as_ref()
    }

    /// `obs`'s robot points as the reference sees them: each camera's moved back by the
    /// reference's offsets at the unloaded state `x` of the frame's inputs; as they are
    /// without a reference.
    pub(super) fn tared_points<'a>(
        &self,
        obs: &'a Observation,
        x: &[[f64; 3]],
    ) -> Cow<'a, [[f64; 3]]> {
        let Some(tare) = &self.tare else {
            return Cow::Borrowed(&obs.robot);
        };
        let mut robot = obs.robot.clone();
        for v in &obs.views {
            let eye = self.cameras[v.camera].eye;
            tare.apply(x, &self.surface.triangles, eye, &mut robot[v.robot.clone()]);
        }
        Cow::Owned(robot)
    }
}

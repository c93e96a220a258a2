//! The model's Young's modulus from the body's own weight: a body's sag under gravity
//! scales as density / modulus, so with the model's density taken as the body's, the
//! unloaded frames' offsets from the model's unloaded surface, projected on the model's
//! own sag, say how much stiffer or softer the body is ([`Sensor::fit_modulus_from_sag`]).
//! No known load is needed; a wrong density, or a shape the cables bend differently, is
//! read as modulus.

use super::cameras::CameraFrames;
use super::{SenseError, SenseResult, Sensor};
use crate::geometry::raycast::Bvh;
use crate::inverse::tare::{surface_hit, TareParams};
use crate::math::{dot, sub};
use serde::Serialize;

/// One round: the modulus tried, and the log-factor step the sag asked for.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SagRound {
    /// The modulus over the model file's.
    pub factor: f64,
    /// The step in log modulus the offsets asked for.
    pub step: f64,
    /// Points used.
    pub points: usize,
}

/// The modulus found from the sag; the sensor keeps it and its reference.
#[derive(Clone, Debug, Serialize)]
pub struct SagFit {
    /// The modulus over the model file's.
    pub factor: f64,
    /// The modulus (Pa).
    pub young: f64,
    /// Whether the last step was below 1e-3.
    pub converged: bool,
    /// Every round, in order.
    pub rounds: Vec<SagRound>,
}

impl Sensor {
    /// Finds the modulus whose sag under the model's own gravity and density matches the
    /// unloaded `reference` frames: d(position)/d(log modulus) is minus the gravity sag, so
    /// each round moves log modulus by −Σ r a / Σ a² (r a point's offset along the normal,
    /// a the model's sag there along it) and solves again, until the step is below 1e-3
    /// (8 rounds at most). Then takes the reference at that modulus. The sensor keeps both.
    pub fn fit_modulus_from_sag(
        &mut self,
        source: &impl CameraFrames,
        reference: &[usize],
        params: TareParams,
    ) -> SenseResult<SagFit> {
        let nominal = self.model.problem.material.young();
        let mut factor = 1.0;
        let mut rounds = Vec::new();
        let mut converged = false;
        for _ in 0..8 {
            self.set_young(nominal * factor)?;
            let (step, points) = self.sag_step(source, reference, params)?;
            rounds.push(SagRound {
                factor,
                step,
                points,
            });
            if !step.is_finite() {
                return Err(SenseError::EmptyReference {
                    frames: reference.to_vec(),
                });
            }
            factor *= step.clamp(-0.7, 0.7).exp();
            if step.abs() < 1e-3 {
                converged = true;
                break;
            }
        }
        self.set_young(nominal * factor)?;
        self.take_reference(source, reference, params)?;
        Ok(SagFit {
            factor,
            young: nominal * factor,
            converged,
            rounds,
        })
    }

    /// One round's step in log modulus, and the points it used.
    fn sag_step(
        &self,
        source: &impl CameraFrames,
        reference: &[usize],
        params: TareParams,
    ) -> SenseResult<(f64, usize)> {
        let (mut ra, mut aa, mut count) = (0.0, 0.0, 0);
        for &frame in reference {
            let obs = self.observe(source, frame)?;
            let inputs = source.camera_recording(0).inputs_of(frame);
            let model = self.actuated(inputs.as_ref())?;
            let free = (self.free.solve(&self.model, &model))
                .map_err(|e| SenseError::Reference { frame, source: e })?;
            let x = &free.solution.positions;
            let mut weightless = model.clone();
            weightless.problem.gravity = [0.0; 3];
            let x0 = (weightless
                .problem
                .solve_static_from(&weightless.newton, &free.solution))
            .map_err(|e| SenseError::Reference { frame, source: e })?
            .positions;
            let triangles = &self.surface.triangles;
            let bvh = Bvh::new(x, triangles);
            for v in &obs.views {
                let eye = self.cameras[v.camera].eye;
                for &q in &obs.robot[v.robot.clone()] {
                    let Some((k, w, n, r)) =
                        surface_hit(&bvh, triangles, x, eye, q, params.min_view_cos)
                    else {
                        continue;
                    };
                    if r.abs() > params.max_offset {
                        continue;
                    }
                    let t = triangles[k];
                    let sag: [f64; 3] =
                        [0, 1, 2].map(|c| (0..3).map(|a| w[a] * sub(x[t[a]], x0[t[a]])[c]).sum());
                    let a = dot(n, sag);
                    ra += r * a;
                    aa += a * a;
                    count += 1;
                }
            }
        }
        Ok((-ra / aa, count))
    }
}

//! Fusion over the frames a load is held ([`Hold`]): the RGB-D analogue of the markers'
//! accumulation (thesis Remark 2). While every force of a stream stays where it was and
//! within its noise of the fused estimate, the frames' forces are fused by their inverse
//! covariances, and the fused σ shrinks as 1/√n, down to what every frame shares (the
//! reference's noise and the model's stiffness, which fusion cannot average away). A force
//! that moves or changes beyond its noise starts a new hold once the next frame confirms
//! it; a single frame that disagrees is left out.

use super::blend::magnitude_sigma;
use super::params::CHI2_3DOF_95;
use super::{largest_sigma, FrameReport, FrameStatus};
use crate::math::{dist, norm};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Tunables of [`Hold`].
#[derive(Clone, Copy, Debug)]
pub struct HoldParams {
    /// A force whose change from the fused one, in units of their noise (squared
    /// Mahalanobis distance, 3 degrees of freedom), exceeds this starts a new hold
    /// ([`CHI2_3DOF_95`]).
    pub change: f64,
    /// A force that moved farther than this starts a new hold (m, 0.005).
    pub radius: f64,
}

impl Default for HoldParams {
    fn default() -> Self {
        Self {
            change: CHI2_3DOF_95,
            radius: 0.005,
        }
    }
}

/// One force fused over the frames its load was held.
#[derive(Clone, Debug, Serialize)]
pub struct HeldForce {
    /// The first frame of the hold.
    pub since: usize,
    /// Frames fused, this one included.
    pub frames: usize,
    /// The fused force (N, robot frame).
    pub force: [f64; 3],
    /// Its magnitude (N).
    pub magnitude: f64,
    /// One-sigma of the magnitude (N).
    pub sigma: f64,
    /// The largest one-sigma over all directions (N).
    pub sigma_max: f64,
    /// Covariance of `force` (N², robot frame; rows).
    pub covariance: [[f64; 3]; 3],
    /// The latest frame's location (robot frame, m).
    pub location: [f64; 3],
}

/// One force's running sums.
#[derive(Clone, Debug)]
struct Sums {
    /// Σ C0_i⁻¹ and Σ C0_i⁻¹ F_i over the frames, C0 the frame's own noise.
    information: Matrix3<f64>,
    weighted: Vector3<f64>,
    location: [f64; 3],
}

/// One hold's sums: its first frame, frames fused, and each force's sums.
#[derive(Clone, Debug, Default)]
struct Run {
    since: usize,
    frames: usize,
    forces: Vec<Sums>,
}

/// The running fusion of a stream's frames, in frame order ([`Hold::push`]).
#[derive(Clone, Debug)]
pub struct Hold {
    params: HoldParams,
    /// Each frame's covariance is (1 + 1/N) times its own noise plus ε² F Fᵀ: `reference`
    /// is 1 + 1/N (1 without a reference), `model_error` is ε.
    reference: f64,
    model_error: f64,
    /// The hold the latest frame belongs to.
    current: Run,
    /// The hold one frame before, when that frame disagreed with it or could not be used:
    /// it resumes if the next frame agrees with it again.
    interrupted: Option<Run>,
}

impl Hold {
    /// A hold for the reports of a sensor whose reference had `reference_frames` frames
    /// (0: none) and whose stiffness is known to the relative `model_error`
    /// ([`super::SenseParams::model_error`]).
    pub fn new(params: HoldParams, reference_frames: usize, model_error: f64) -> Self {
        Self {
            params,
            reference: match reference_frames {
                0 => 1.0,
                n => 1.0 + 1.0 / n as f64,
            },
            model_error,
            current: Run::default(),
            interrupted: None,
        }
    }

    /// Takes the next frame of the stream and sets its [`FrameReport::held`]: the fused
    /// forces when its load is the one held (or this frame starts a new hold). A hold
    /// outlasts one frame that disagrees with it or cannot be used (failed, unreliable, a
    /// reference frame: it gets none), and resumes if the frame after agrees with it
    /// again; two such frames in a row end it. The frame-to-frame scatter of a force's
    /// direction often exceeds its 3-D covariance, so a single frame is not taken as a
    /// change of load (with a restart on every disagreeing frame, 10-frame holds broke
    /// after 2-3 frames).
    pub fn push(&mut self, report: &mut FrameReport) {
        let usable = matches!(report.status, FrameStatus::Sensed)
            && report.reliable
            && !report.reference
            && !report.forces.is_empty();
        let Some(own) = usable.then(|| self.own_noise(report)).flatten() else {
            let run = std::mem::take(&mut self.current);
            self.interrupted = (run.frames > 0).then_some(run);
            return;
        };
        let resumes = (self.interrupted.as_ref()).is_some_and(|run| self.continues(run, report));
        if resumes {
            self.current = self.interrupted.take().unwrap_or_default();
        } else if !self.continues(&self.current, report) {
            let run = std::mem::take(&mut self.current);
            self.interrupted = (run.frames > 0).then_some(run);
            self.current.since = report.frame;
        } else {
            self.interrupted = None;
        }
        let run = &mut self.current;
        let first = run.forces.is_empty();
        for (k, (f, c0)) in report.forces.iter().zip(&own).enumerate() {
            let inv = c0.try_inverse().unwrap_or_else(Matrix3::zeros);
            let add = Sums {
                information: inv,
                weighted: inv * Vector3::from(f.force),
                location: f.location,
            };
            if first {
                run.forces.push(add);
            } else {
                let s = &mut run.forces[k];
                s.information += add.information;
                s.weighted += add.weighted;
                s.location = f.location;
            }
        }
        run.frames += 1;
        report.held = self.fused(&self.current);
    }

    /// Each force's own noise C0 = (C − ε² F Fᵀ) / reference, `None` if one is singular.
    fn own_noise(&self, report: &FrameReport) -> Option<Vec<Matrix3<f64>>> {
        let e2 = self.model_error * self.model_error;
        (report.forces.iter())
            .map(|f| {
                let c = Matrix3::from_fn(|r, q| f.covariance[r][q]);
                let v = Vector3::from(f.force);
                let c0 = (c - e2 * v * v.transpose()) / self.reference;
                c0.try_inverse().map(|_| c0)
            })
            .collect()
    }

    /// Whether `report`'s forces are the held ones: as many, each within the radius of
    /// where it was and within its noise of the fused force.
    fn continues(&self, run: &Run, report: &FrameReport) -> bool {
        if run.forces.is_empty() || run.forces.len() != report.forces.len() {
            return false;
        }
        let fused = self.fused(run);
        (report.forces.iter().zip(&fused)).all(|(f, h)| {
            let c = Matrix3::from_fn(|r, q| f.covariance[r][q] + h.covariance[r][q]);
            let d = Vector3::from(f.force) - Vector3::from(h.force);
            let m2 = c.try_inverse().map(|i| (d.transpose() * i * d)[0]);
            dist(f.location, h.location) <= self.params.radius
                && m2.is_some_and(|m2| m2 <= self.params.change)
        })
    }

    /// The fused forces: the frames' own noise fused, plus what every frame shares (the
    /// reference's share of a frame's own noise, and ε² F Fᵀ).
    fn fused(&self, run: &Run) -> Vec<HeldForce> {
        let n = run.frames.max(1) as f64;
        let e2 = self.model_error * self.model_error;
        (run.forces.iter())
            .filter_map(|s| {
                let fused_own = s.information.try_inverse()?;
                let f = fused_own * s.weighted;
                // The reference's share is of a frame's own noise: the fused one times n
                // (the frames' harmonic mean, which an ambiguous frame's wide σ does not
                // inflate).
                let shared = (self.reference - 1.0) * n * fused_own + e2 * f * f.transpose();
                let c = fused_own + shared;
                let covariance =
                    [0, 1, 2].map(|r| [0, 1, 2].map(|q| 0.5 * (c[(r, q)] + c[(q, r)])));
                let force = [f[0], f[1], f[2]];
                let magnitude = norm(force);
                let sigma_max = largest_sigma(&covariance);
                let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                let sigma = magnitude_sigma(force, &axes, &|r, q| covariance[r][q]);
                Some(HeldForce {
                    since: run.since,
                    frames: run.frames,
                    force,
                    magnitude,
                    sigma,
                    sigma_max,
                    covariance,
                    location: s.location,
                })
            })
            .collect()
    }
}

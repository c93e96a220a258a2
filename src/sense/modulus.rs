//! The model's Young's modulus from a frame with a known load, for users who have one (a
//! weight hung from the robot, a probe on a scale): after a reference
//! ([`Sensor::take_reference`]), the forces a model reads scale with its modulus, so the
//! modulus that makes the known frame read its load is found by a few fixed-point rounds,
//! each re-taking the reference with the new modulus (its sag changes with it).

use super::cameras::CameraFrames;
use super::{FrameStatus, SenseError, SenseResult, Sensor};
use crate::fem::material::Material;
use crate::inverse::tare::TareParams;
use crate::math::norm;
use serde::Serialize;

/// Tunables of [`Sensor::calibrate_modulus`].
#[derive(Clone, Copy, Debug)]
pub struct ModulusParams {
    /// At most this many rounds (8).
    pub max_rounds: usize,
    /// Stop when the known frame reads its load within this fraction (1e-3).
    pub tolerance: f64,
    /// The reference's fit, re-taken each round.
    pub tare: TareParams,
}

impl Default for ModulusParams {
    fn default() -> Self {
        Self {
            max_rounds: 8,
            tolerance: 1e-3,
            tare: TareParams::default(),
        }
    }
}

/// One round: the modulus tried and what the known frame read with it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ModulusRound {
    /// The modulus over the model file's.
    pub factor: f64,
    /// The known frame's total force (N).
    pub read: f64,
    /// Its one-sigma (N).
    pub sigma: f64,
}

/// Why a frame of known load could not calibrate the modulus
/// ([`SenseError::KnownLoad`]).
#[derive(Clone, Debug, PartialEq)]
pub enum KnownLoadProblem {
    /// The known load is not a positive number of newtons.
    NotPositive(f64),
    /// The frame could not be sensed.
    NotSensed(FrameStatus),
    /// The frame reads no force.
    NoForce,
}

impl std::fmt::Display for KnownLoadProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotPositive(load) => write!(
                f,
                "the known load must be a positive number of newtons, not {load}"
            ),
            Self::NotSensed(status) => write!(f, "{status:?}"),
            Self::NoForce => write!(f, "it reads no force: is the load on it?"),
        }
    }
}

/// The modulus found by [`Sensor::calibrate_modulus`]; the sensor keeps it.
#[derive(Clone, Debug, Serialize)]
pub struct ModulusFit {
    /// The modulus over the model file's.
    pub factor: f64,
    /// The modulus (Pa).
    pub young: f64,
    /// Relative one-sigma of the modulus: the known frame's relative σ and the last
    /// round's change, in quadrature. It becomes [`super::SenseParams::model_error`].
    pub relative_sigma: f64,
    /// Whether the known frame read its load within the tolerance.
    pub converged: bool,
    /// Every round, in order.
    pub rounds: Vec<ModulusRound>,
}

impl Sensor {
    /// Sets the model's Young's modulus to `young` (Pa), keeping its Poisson ratio. The
    /// cached free solves and the reference were of the old modulus: the reference is
    /// dropped (take it again).
    pub fn set_young(&mut self, young: f64) -> SenseResult<()> {
        let nu = self.model.problem.material.poisson();
        self.model.problem.material = Material::new(young, nu).map_err(SenseError::Modulus)?;
        self.free = Default::default();
        self.tare = None;
        self.reference_frames.clear();
        Ok(())
    }

    /// Finds the modulus that makes `frame` of `source`, which carries a known `load` (N,
    /// its total force's magnitude), read that load, with `reference` (unloaded frames)
    /// re-taken at each modulus tried. The sensor keeps the modulus, its reference, and the
    /// modulus's relative σ as [`super::SenseParams::model_error`]; its reports then mark
    /// `frame` as part of the reference.
    pub fn calibrate_modulus(
        &mut self,
        source: &impl CameraFrames,
        reference: &[usize],
        frame: usize,
        load: f64,
        params: &ModulusParams,
    ) -> SenseResult<ModulusFit> {
        if !(load.is_finite() && load > 0.0) {
            let why = KnownLoadProblem::NotPositive(load);
            return Err(SenseError::KnownLoad { frame, why });
        }
        let nominal = self.model.problem.material.young();
        let inputs = source.camera_recording(0).inputs_of(frame);
        let mut factor = 1.0;
        let mut rounds: Vec<ModulusRound> = Vec::new();
        let mut converged = false;
        for _ in 0..params.max_rounds.max(1) {
            self.set_young(nominal * factor)?;
            self.take_reference(source, reference, params.tare)?;
            let obs = self.observe(source, frame)?;
            let report = self.sense(frame, &obs, inputs.as_ref());
            let why = match &report.status {
                FrameStatus::Sensed if report.forces.is_empty() => Some(KnownLoadProblem::NoForce),
                FrameStatus::Sensed => None,
                other => Some(KnownLoadProblem::NotSensed(other.clone())),
            };
            if let Some(why) = why {
                return Err(SenseError::KnownLoad { frame, why });
            }
            let total =
                (report.forces.iter()).fold([0.0; 3], |s, f| [0, 1, 2].map(|k| s[k] + f.force[k]));
            let read = norm(total);
            let sigma = report
                .forces
                .iter()
                .map(|f| f.sigma * f.sigma)
                .sum::<f64>()
                .sqrt();
            rounds.push(ModulusRound {
                factor,
                read,
                sigma,
            });
            if read <= 0.0 {
                let why = KnownLoadProblem::NoForce;
                return Err(SenseError::KnownLoad { frame, why });
            }
            if (read / load - 1.0).abs() <= params.tolerance {
                converged = true;
                break;
            }
            factor = next_factor(&rounds, load);
        }
        let last = rounds[rounds.len() - 1];
        let change = match rounds.len() {
            1 => 0.0,
            n => (last.factor / rounds[n - 2].factor - 1.0).abs(),
        };
        let change = if converged { 0.0 } else { change };
        let relative_sigma = ((last.sigma / last.read).powi(2) + change * change).sqrt();
        self.params.model_error = relative_sigma;
        self.reference_frames.push(frame);
        Ok(ModulusFit {
            factor: last.factor,
            young: nominal * last.factor,
            relative_sigma,
            converged,
            rounds,
        })
    }
}

/// The next modulus to try: the forces a model reads scale with its modulus, so first
/// `load / read` times the last; then the secant of log(read / load) against log(factor)
/// through the last two rounds (the reference's sag moves with the modulus too), kept
/// within a factor of 2 of the last.
fn next_factor(rounds: &[ModulusRound], load: f64) -> f64 {
    let g = |r: &ModulusRound| (r.read / load).ln();
    let last = &rounds[rounds.len() - 1];
    let fixed = last.factor * load / last.read;
    let [.., before, _] = rounds else {
        return fixed;
    };
    let (dg, ds) = (g(last) - g(before), last.factor.ln() - before.factor.ln());
    if dg.abs() < 1e-12 || ds.abs() < 1e-12 {
        return fixed;
    }
    let step = (-g(last) * ds / dg).clamp(-std::f64::consts::LN_2, std::f64::consts::LN_2);
    last.factor * step.exp()
}

//! The membrane's calibration on frames with a known load: one scale on its stiffness
//! (the model's modulus and pre-tension together, so the linear compliance scales by its
//! inverse), and the two terms of the sigma.

use super::{MembraneError, MembraneResult, MembraneSensor, MembraneStatus};
use crate::inverse::pushes::nnls_gram;
use serde::Serialize;

/// A frame of the fit: its node motions, pressure (Pa) and known force magnitude (N).
#[derive(Clone, Debug)]
pub struct FitFrame {
    /// The frame number (for messages).
    pub frame: usize,
    /// Its node motions ([`MembraneSensor::observe`]).
    pub motions: Vec<Option<f64>>,
    /// Its pressure (Pa).
    pub pressure: f64,
    /// Its known force magnitude (N).
    pub known: f64,
}

/// One stiffness tried by the fit.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StiffnessRound {
    /// The factor on the model's stiffness.
    pub scale: f64,
    /// RMS of |F| − known over the fit's frames (N).
    pub rms: f64,
}

/// The stiffness fit's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct StiffnessFit {
    /// The best factor on the model's stiffness.
    pub scale: f64,
    /// Its RMS misfit (N).
    pub rms: f64,
    /// Every factor tried, in order.
    pub rounds: Vec<StiffnessRound>,
    /// The frames used.
    pub frames: Vec<usize>,
}

/// The sigma of a magnitude: `floor` in quadrature with `model_error` times it.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SigmaCalibration {
    /// The unloaded frames' scatter: the RMS magnitude sensed on still frames (N).
    pub floor: f64,
    /// The model error: the RMS relative misfit of the loaded fit frames.
    pub model_error: f64,
}

impl SigmaCalibration {
    /// One sigma of a magnitude `magnitude` (N).
    pub fn sigma(&self, magnitude: f64) -> f64 {
        self.floor.hypot(self.model_error * magnitude)
    }
}

/// A fit frame's push problem in Gram form ([`MembraneSensor::gram`]).
pub(super) struct Gram {
    pub g0: nalgebra::DMatrix<f64>,
    pub wo: nalgebra::DVector<f64>,
    pub wq: nalgebra::DVector<f64>,
}

/// The factors the fit's grid tries: 4 per factor of 2, from 1/16 to 16.
const GRID: std::ops::RangeInclusive<i32> = -16..=16;
/// Golden-section steps after the grid (the bracket shrinks to 0.618^n of a grid step).
const REFINE: usize = 12;

impl MembraneSensor {
    /// Fits the stiffness scale to `frames` (their known magnitudes; frames that cannot be
    /// sensed are left out): the RMS of |F| − known over a log grid, then refined by golden
    /// section around the best. Sets [`MembraneSensor::stiffness_scale`].
    pub fn fit_stiffness(&mut self, frames: &[FitFrame]) -> MembraneResult<StiffnessFit> {
        let usable: Vec<(&FitFrame, Gram)> = (frames.iter())
            .filter(|f| f.known.is_finite())
            .filter_map(|f| Some((f, self.gram(&f.motions, f.pressure)?)))
            .collect();
        if usable.is_empty() {
            return Err(MembraneError::Fit(format!(
                "none of the {} frames with a known load can be sensed",
                frames.len()
            )));
        }
        let max_iterations = self.params.push.max_iterations;
        let mut rounds = Vec::new();
        let mut rms_at = |scale: f64| {
            let sq: f64 = (usable.iter())
                .map(|(f, g)| {
                    let h = &g.wo * scale - &g.wq;
                    let (lambda, _) = nnls_gram(&g.g0, &h, max_iterations);
                    let force = self.net_force(&lambda);
                    let m = (force[0].powi(2) + force[1].powi(2) + force[2].powi(2)).sqrt();
                    (m - f.known).powi(2)
                })
                .sum();
            let rms = (sq / usable.len() as f64).sqrt();
            rounds.push(StiffnessRound { scale, rms });
            rms
        };
        let step = 2f64.ln() / 4.0;
        let grid: Vec<(f64, f64)> = GRID
            .map(|k| {
                let s = (f64::from(k) * step).exp();
                (s.ln(), rms_at(s))
            })
            .collect();
        let best = (0..grid.len())
            .min_by(|&a, &b| grid[a].1.total_cmp(&grid[b].1))
            .unwrap_or(0);
        let (mut lo, mut hi) = (grid[best].0 - step, grid[best].0 + step);
        let g = 0.5 * (5f64.sqrt() - 1.0);
        let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        let (mut fa, mut fb) = (rms_at(a.exp()), rms_at(b.exp()));
        for _ in 0..REFINE {
            if fa <= fb {
                hi = b;
                (b, fb) = (a, fa);
                a = hi - g * (hi - lo);
                fa = rms_at(a.exp());
            } else {
                lo = a;
                (a, fa) = (b, fb);
                b = lo + g * (hi - lo);
                fb = rms_at(b.exp());
            }
        }
        let best = (rounds.iter().copied())
            .min_by(|x, y| x.rms.total_cmp(&y.rms))
            .unwrap_or(StiffnessRound {
                scale: 1.0,
                rms: f64::NAN,
            });
        self.stiffness_scale = best.scale;
        Ok(StiffnessFit {
            scale: best.scale,
            rms: best.rms,
            rounds,
            frames: usable.iter().map(|(f, _)| f.frame).collect(),
        })
    }

    /// Sets the sigma's terms: the floor from `still` frames (node motions and pressures of
    /// unloaded frames), the model error from the `frames` whose known load is at least
    /// `loaded_share` of their largest (the loaded ones; none given: no model error). Call
    /// after the stiffness fit.
    pub fn calibrate_sigma(
        &mut self,
        still: &[(Vec<Option<f64>>, f64)],
        frames: &[FitFrame],
        loaded_share: f64,
    ) -> MembraneResult<SigmaCalibration> {
        let floor: Vec<f64> = (still.iter())
            .map(|(m, p)| self.estimate(m, *p))
            .filter(|e| e.status == MembraneStatus::Ok)
            .map(|e| e.magnitude * e.magnitude)
            .collect();
        if floor.is_empty() {
            return Err(MembraneError::Fit(
                "no still frame can be sensed for the sigma's floor".into(),
            ));
        }
        let largest = (frames.iter().map(|f| f.known))
            .filter(|k| k.is_finite())
            .fold(0.0f64, f64::max);
        let rel: Vec<f64> = (frames.iter())
            .filter(|f| f.known.is_finite() && f.known > 0.0 && f.known >= loaded_share * largest)
            .map(|f| (self.estimate(&f.motions, f.pressure), f.known))
            .filter(|(e, _)| e.status == MembraneStatus::Ok)
            .map(|(e, k)| (e.magnitude / k - 1.0).powi(2))
            .collect();
        if rel.is_empty() && !frames.is_empty() {
            return Err(MembraneError::Fit(
                "no loaded frame among the fit's frames for the model error".into(),
            ));
        }
        self.sigma = SigmaCalibration {
            floor: (floor.iter().sum::<f64>() / floor.len() as f64).sqrt(),
            model_error: (rel.iter().sum::<f64>() / rel.len().max(1) as f64).sqrt(),
        };
        Ok(self.sigma)
    }
}

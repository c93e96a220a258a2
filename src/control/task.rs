//! Targets along time: a fixed position, a circle, or a target moving on a path the
//! controller does not know in advance (thesis 3.8.3-3.8.5).

use super::scenario::TaskSpec;
use crate::math::{cross, dot, unit};

/// A task bound to the effector's start position, in SI (m).
#[derive(Debug, Clone)]
pub struct Task {
    spec: TaskSpec,
    start: [f64; 3],
    rate_hz: f64,
}

impl Task {
    /// The task of `spec` starting at `start` (m); `rate_hz` converts rad/s to rad/step.
    pub fn new(spec: TaskSpec, start: [f64; 3], rate_hz: f64) -> Self {
        Self {
            spec,
            start,
            rate_hz,
        }
    }

    /// Whether the controller may know the next target (feed-forward of 3.26): not for a
    /// target that moves on its own.
    pub fn preassigned(&self) -> bool {
        !matches!(self.spec, TaskSpec::Follow { .. })
    }

    /// The target at step `k` (m).
    pub fn target(&self, k: usize) -> [f64; 3] {
        let s = self.start;
        let k = k as f64;
        match &self.spec {
            TaskSpec::Position { offset_mm } => [0, 1, 2].map(|i| s[i] + 1e-3 * offset_mm[i]),
            TaskSpec::Circle {
                radius_mm,
                rad_per_s,
                rad_per_step,
                normal,
            } => {
                let w = rad_per_step.unwrap_or_else(|| rad_per_s.unwrap_or(0.0) / self.rate_hz);
                let (u, v) = plane_axes(*normal);
                let r = 1e-3 * radius_mm;
                // Centred at the start, reached by a straight lead-in at the circle's speed
                // (1/ω steps), so that the path has no jump.
                let lead = 1.0 / w.abs().max(f64::MIN_POSITIVE);
                if k < lead {
                    let f = r * k / lead;
                    return [0, 1, 2].map(|i| s[i] + f * u[i]);
                }
                let a = w * (k - lead);
                [0, 1, 2].map(|i| s[i] + r * a.cos() * u[i] + r * a.sin() * v[i])
            }
            TaskSpec::Follow {
                amplitude_mm,
                rad_per_step,
                seed,
            } => {
                let w = *rad_per_step;
                [0, 1, 2].map(|i| {
                    let (p1, p2) = (phase(*seed, 2 * i as u64), phase(*seed, 2 * i as u64 + 1));
                    let a = 1e-3 * amplitude_mm[i];
                    let wave = 0.6 * ((w * k + p1).sin() - p1.sin())
                        + 0.4 * ((1.7 * w * k + p2).sin() - p2.sin());
                    s[i] + a * wave
                })
            }
        }
    }
}

/// Two unit vectors spanning the plane normal to `n`, u as close to +x as possible.
fn plane_axes(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let n = unit(n);
    let seed = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    // Not `math::tangents`: u is the seed axis projected on the plane, so a circle starts
    // on the +x side of its centre.
    let d = dot(seed, n);
    let u = unit([0, 1, 2].map(|i| seed[i] - d * n[i]));
    (u, cross(n, u))
}

/// A phase in [0, 2π) from a seed and an index.
fn phase(seed: u64, i: u64) -> f64 {
    std::f64::consts::TAU * crate::math::rand::uniform(seed, 0, i, 0)
}

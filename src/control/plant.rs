//! The simulated robot: an FE model that differs from the controller's (Young's modulus,
//! an unmodelled hanging weight, actuator offsets and gain), and the sensor that sees its
//! effector (noise, latency, frames lost on a schedule).

use super::predictor::{drive, effector_index, equilibrium, kinematics_at, Kinematics};
use super::scenario::{Actuation, PlantSpec, SensorSpec};
use super::ControlResult;
use crate::fem::material::Material;
use crate::fem::model::Model;
use crate::fem::solve::{PointLoad, Solution, SolverState};

/// The "real" robot.
#[derive(Debug)]
pub struct Plant {
    model: Model,
    effector: usize,
    actuation: Actuation,
    spec: PlantSpec,
    /// Input unit to SI (the offset is in the file's unit).
    input_scale: f64,
    weight_on: bool,
    solution: Option<Solution>,
    state: Option<SolverState>,
}

impl Plant {
    /// The plant: `model` with the differences of `spec`.
    pub fn new(
        mut model: Model,
        effector: Option<&str>,
        actuation: Actuation,
        spec: &PlantSpec,
        input_scale: f64,
    ) -> ControlResult<Self> {
        let effector = effector_index(&model, effector)?;
        let m = model.problem.material;
        model.problem.material = Material::new(m.young() * spec.young_factor, m.poisson())?;
        Ok(Self {
            model,
            effector,
            actuation,
            spec: spec.clone(),
            input_scale,
            weight_on: false,
            solution: None,
            state: None,
        })
    }

    /// Applies the commanded `inputs` at step `step` (the plant's actuators turn them into
    /// gain × input + offset) and returns the effector's true position (m).
    pub fn apply(&mut self, step: usize, inputs: &[f64]) -> ControlResult<[f64; 3]> {
        let actual: Vec<f64> = inputs
            .iter()
            .map(|u| self.spec.input_gain * u + self.spec.input_offset * self.input_scale)
            .collect();
        drive(&mut self.model, self.actuation, &actual);
        let hang = self.spec.weight != 0.0 && step >= self.spec.weight_from_step;
        if hang != self.weight_on {
            self.hang_weight(hang);
        }
        let sol = equilibrium(&self.model, self.solution.as_ref(), &mut self.state)?;
        let p = self.model.effectors[self.effector]
            .point
            .position(&sol.positions);
        self.solution = Some(sol);
        Ok(p)
    }

    /// The plant's true kinematics at its last state, J scaled by the actuators' gain:
    /// what Theorem 2's mismatch (3.32) compares the model's J with. `None` before the
    /// first step.
    pub fn kinematics(&mut self) -> ControlResult<Option<Kinematics>> {
        let Some(sol) = &self.solution else {
            return Ok(None);
        };
        let mut k = kinematics_at(
            &self.model,
            self.effector,
            self.actuation,
            sol,
            &mut self.state,
        )?;
        k.j *= self.spec.input_gain;
        Ok(Some(k))
    }

    fn hang_weight(&mut self, on: bool) {
        let p = &mut self.model.problem;
        if on {
            let g = p.gravity;
            let lg = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
            // Along gravity; straight down when the model has none.
            let down = if lg > 0.0 {
                g.map(|c| c / lg)
            } else {
                [0.0, 0.0, -1.0]
            };
            p.loads.push(PointLoad {
                at: self.model.effectors[self.effector].point,
                force: down.map(|c| c * self.spec.weight),
            });
        } else {
            p.loads.pop();
        }
        self.weight_on = on;
    }
}

/// What the controller sees of the effector.
#[derive(Debug, Clone)]
pub struct Sensor {
    spec: SensorSpec,
    /// True positions by step.
    history: Vec<[f64; 3]>,
}

/// One measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Measured effector position (m).
    pub position: [f64; 3],
    /// The step whose state it shows (the current step minus the latency).
    pub of_step: usize,
}

impl Sensor {
    /// A sensor of `spec`.
    pub fn new(spec: &SensorSpec) -> Self {
        Self {
            spec: spec.clone(),
            history: Vec::new(),
        }
    }

    /// Records the true position at the next step.
    pub fn record(&mut self, position: [f64; 3]) {
        self.history.push(position);
    }

    /// Whether features are lost at `step`.
    pub fn lost(&self, step: usize) -> bool {
        self.spec.lost.iter().any(|r| (r[0]..=r[1]).contains(&step))
    }

    /// The measurement available at `step`: the position `latency` steps earlier with
    /// noise, none while features are lost or before the first state is old enough.
    pub fn measure(&self, step: usize) -> Option<Measurement> {
        if self.lost(step) {
            return None;
        }
        let of_step = step.checked_sub(self.spec.latency)?;
        let p = self.history.get(of_step)?;
        let s = 1e-3 * self.spec.noise_mm;
        let noise = |axis: u64| s * crate::math::rand::normal(self.spec.seed, step as u64, axis, 7);
        Some(Measurement {
            position: [p[0] + noise(0), p[1] + noise(1), p[2] + noise(2)],
            of_step,
        })
    }
}

//! The scenario file of `softsense control`: the controller's FE model and law, the plant
//! (a "real" FE model that differs from the controller's), the sensor and the task.
//!
//! Lengths in the file are in millimetres (fields end in `_mm`), angles in radians,
//! actuator inputs in the model's actuation unit (mm of cable shortening, N of tension
//! or kPa of cavity pressure); everything is converted to SI when the file is read.

use super::{ControlError, ControlResult, FieldProblem};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// How the actuators are driven, and so what an actuator input is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Actuation {
    /// Inputs are cable shortenings (file: mm); J = W_ea W_aa⁻¹ (3.8).
    Displacement,
    /// Inputs are cable tensions (N); J = W_ea (3.4).
    Force,
    /// Inputs are the pressures of the model's cavities, not its cables (file: kPa);
    /// J = W_ea, the pressure being the cavity row's multiplier as a tension is a cable's.
    Pressure,
}

/// The control law (thesis 3.4-3.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LawKind {
    /// Open loop (3.4, Fig. 3.1): the model is servoed to the target, the robot gets its inputs.
    Open,
    /// Closed-loop control 1 (3.19, Fig. 3.2): the robot's measured error, the model's J.
    Closed1,
    /// Closed-loop control 2 (3.28-3.29, Fig. 3.3): controller 1 on the robot, controller 2
    /// keeping the model on the robot.
    Closed2,
    /// Switched control (3.7): closed loop 2 while features are seen, the open loop with
    /// the progressive switch (3.43) while they are lost.
    Switched,
}

/// What the effector should do.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum TaskSpec {
    /// Reach the start position plus `offset_mm` and stay there.
    Position {
        /// Target relative to the effector's start (mm).
        offset_mm: [f64; 3],
    },
    /// A circle centred at the start position, in the plane normal to `normal`, entered
    /// by a straight lead-in from the centre at the circle's speed.
    Circle {
        /// Radius (mm).
        radius_mm: f64,
        /// Angular speed (rad/s, with the scenario's `rate_hz`).
        #[serde(default)]
        rad_per_s: Option<f64>,
        /// Angular step (rad/step); give this or `rad_per_s`.
        #[serde(default)]
        rad_per_step: Option<f64>,
        /// Normal of the circle's plane (default +z: a circle in xy).
        #[serde(default = "default_normal")]
        normal: [f64; 3],
    },
    /// A target moving on a smooth path the controller does not know in advance (a sum of
    /// two sinusoids per axis with phases drawn from `seed`): no feed-forward term.
    Follow {
        /// Amplitude per axis (mm).
        amplitude_mm: [f64; 3],
        /// Slowest angular speed (rad/step); the second sinusoid runs 1.7 times faster.
        rad_per_step: f64,
        /// Seed of the phases.
        #[serde(default)]
        seed: u64,
    },
}

fn default_normal() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

/// The controller side: its FE model, effector, law and limits.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// The controller's FE model file (relative to the scenario file).
    pub model: PathBuf,
    /// The effector to control, by name (default: the model's first).
    #[serde(default)]
    pub effector: Option<String>,
    /// Displacement or force inputs (default displacement).
    #[serde(default = "default_actuation")]
    pub actuation: Actuation,
    /// The law.
    pub law: LawKind,
    /// μ of (3.19) for closed1, k_p of (3.28) for closed2 and switched, k_p^s for open.
    pub gain: f64,
    /// k_p^s of controller 2 (3.29), for closed2 and switched (default 0.5).
    #[serde(default = "half")]
    pub model_gain: f64,
    /// p of the progressive switch (3.43), in (0, 1) (default 0.5).
    #[serde(default = "half")]
    pub switch_rate: f64,
    /// Controller 2's feed-forward (3.29): the model also moves by J times the robot's
    /// input change, its prediction of where the robot goes (default true; false is the
    /// thesis's simplification of 3.8.4, under which the model lags a moving robot).
    #[serde(default = "yes")]
    pub model_feed_forward: bool,
    /// Switched law: while features are lost, keep the offset between the robot's and the
    /// model's inputs learned at the last seen step (3.43 with that offset added; default
    /// false: the thesis's rule, which drives the robot to the model's inputs).
    #[serde(default)]
    pub keep_input_offset: bool,
    /// Initial input of every cable (mm or N), the same for all (default 5).
    #[serde(default = "five")]
    pub initial: f64,
    /// Input limits [min, max] (mm or N) (default [0, 40]).
    #[serde(default = "default_limits")]
    pub limits: [f64; 2],
}

fn yes() -> bool {
    true
}
fn default_actuation() -> Actuation {
    Actuation::Displacement
}
fn half() -> f64 {
    0.5
}
fn five() -> f64 {
    5.0
}
fn default_limits() -> [f64; 2] {
    [0.0, 40.0]
}

/// How the plant (the "real" robot) differs from the controller's model.
#[derive(Debug, Clone, Default, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlantSpec {
    /// The plant's FE model file (default: the controller's).
    #[serde(default)]
    pub model: Option<PathBuf>,
    /// The plant's Young's modulus over the model's (default 1).
    #[serde(default = "one")]
    pub young_factor: f64,
    /// An unmodelled weight hung at the effector (N, along gravity; default 0).
    #[serde(default)]
    pub weight: f64,
    /// The step the weight is hung at (default 0: from the start).
    #[serde(default)]
    pub weight_from_step: usize,
    /// Added to every input the plant receives (mm or N; default 0): actuator offsets.
    #[serde(default)]
    pub input_offset: f64,
    /// Multiplies every input the plant receives (default 1): e.g. a pulley radius error.
    #[serde(default = "one")]
    pub input_gain: f64,
}

fn one() -> f64 {
    1.0
}

/// The effector measurement.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Standard deviation of the noise per axis (mm; default 0.1, an optical tracker).
    #[serde(default = "tenth")]
    pub noise_mm: f64,
    /// Frames between the robot's state and the controller seeing it (default 1).
    #[serde(default = "one_frame")]
    pub latency: usize,
    /// Inclusive step ranges without a measurement (feature loss).
    #[serde(default)]
    pub lost: Vec<[usize; 2]>,
    /// Seed of the noise (default 0).
    #[serde(default)]
    pub seed: u64,
}

fn tenth() -> f64 {
    0.1
}
fn one_frame() -> usize {
    1
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            noise_mm: tenth(),
            latency: 1,
            lost: Vec::new(),
            seed: 0,
        }
    }
}

/// A scenario file.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// A name for reports (default: the file's stem).
    #[serde(default)]
    pub name: String,
    /// Control steps.
    pub steps: usize,
    /// Sampling rate (Hz): turns rad/s into rad/step (default 31, the thesis's FE rate).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// The controller.
    pub controller: ControllerSpec,
    /// The plant's differences.
    #[serde(default)]
    pub plant: PlantSpec,
    /// The sensor.
    #[serde(default)]
    pub sensor: SensorSpec,
    /// The task.
    pub task: TaskSpec,
    /// Folder of the scenario file, against which model paths are resolved.
    #[serde(skip)]
    pub base: PathBuf,
    /// The file it was read from (empty for one built in code), for messages.
    #[serde(skip)]
    pub file: PathBuf,
}

fn default_rate() -> f64 {
    31.0
}

/// The most steps a scenario may ask for: each step is two FE solves.
pub const MAX_STEPS: usize = 100_000;

impl Scenario {
    /// Reads and checks a scenario file.
    pub fn load(path: &Path) -> ControlResult<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| ControlError::File {
            path: path.display().to_string(),
            source,
        })?;
        let mut s: Scenario = toml::from_str(&text).map_err(|e| ControlError::Toml {
            path: path.display().to_string(),
            source: Box::new(e),
        })?;
        s.base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        s.file = path.to_path_buf();
        if s.name.is_empty() {
            s.name = (path.file_stem())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        s.validate()?;
        Ok(s)
    }

    /// The controller's model file, resolved.
    pub fn controller_model(&self) -> PathBuf {
        self.base.join(&self.controller.model)
    }

    /// The plant's model file, resolved.
    pub fn plant_model(&self) -> PathBuf {
        match &self.plant.model {
            Some(p) => self.base.join(p),
            None => self.controller_model(),
        }
    }

    /// Scale from the file's input unit to SI (mm → m for displacement, N for force, kPa
    /// → Pa for pressure).
    pub fn input_scale(&self) -> f64 {
        match self.controller.actuation {
            Actuation::Displacement => 1e-3,
            Actuation::Force => 1.0,
            Actuation::Pressure => 1e3,
        }
    }

    /// Checks ranges; the error names the file and the field.
    pub fn validate(&self) -> ControlResult<()> {
        let bad = |field: &'static str, problem: FieldProblem| ControlError::Field {
            file: self.file.clone(),
            field,
            problem,
        };
        let positive = |field, v: f64| match v > 0.0 && v.is_finite() {
            true => Ok(()),
            false => Err(bad(field, FieldProblem::NotPositive(v))),
        };
        let finite = |field, v: f64| match v.is_finite() {
            true => Ok(()),
            false => Err(bad(field, FieldProblem::NotFinite(v))),
        };
        let c = &self.controller;
        if self.steps == 0 || self.steps > MAX_STEPS {
            let (min, max, got) = (1, MAX_STEPS, self.steps);
            return Err(bad("steps", FieldProblem::Count { min, max, got }));
        }
        positive("rate_hz", self.rate_hz)?;
        positive("controller.gain", c.gain)?;
        positive("controller.model_gain", c.model_gain)?;
        if !(c.switch_rate > 0.0 && c.switch_rate < 1.0) {
            let problem = FieldProblem::NotInUnitInterval(c.switch_rate);
            return Err(bad("controller.switch_rate", problem));
        }
        finite("controller.initial", c.initial)?;
        let [lo, hi] = c.limits;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad("controller.limits", FieldProblem::Limits(c.limits)));
        }
        if !(lo..=hi).contains(&c.initial) {
            let (value, limits) = (c.initial, c.limits);
            return Err(bad(
                "controller.initial",
                FieldProblem::OutsideLimits { value, limits },
            ));
        }
        let p = &self.plant;
        positive("plant.young_factor", p.young_factor)?;
        finite("plant.weight", p.weight)?;
        finite("plant.input_offset", p.input_offset)?;
        finite("plant.input_gain", p.input_gain)?;
        let s = &self.sensor;
        if !(s.noise_mm >= 0.0 && s.noise_mm.is_finite()) {
            return Err(bad("sensor.noise_mm", FieldProblem::Negative(s.noise_mm)));
        }
        if s.latency > 100 {
            let (min, max, got) = (0, 100, s.latency);
            return Err(bad("sensor.latency", FieldProblem::Count { min, max, got }));
        }
        if let Some(r) = s.lost.iter().find(|r| r[0] > r[1]) {
            return Err(bad("sensor.lost", FieldProblem::Backwards(*r)));
        }
        self.validate_task()
            .map_err(|(field, problem)| bad(field, problem))
    }

    /// The task's field that is out of range, if one is.
    fn validate_task(&self) -> Result<(), (&'static str, FieldProblem)> {
        let finite = |field, v: &[f64]| match v.iter().find(|x| !x.is_finite()) {
            Some(x) => Err((field, FieldProblem::NotFinite(*x))),
            None => Ok(()),
        };
        // An angle per step beyond half a turn samples the path too coarsely to follow.
        let pace = |field, w: f64| match w.abs() <= std::f64::consts::PI {
            true => Ok(()),
            false => Err((field, FieldProblem::TooFast(w))),
        };
        match &self.task {
            TaskSpec::Position { offset_mm } => finite("task.offset_mm", offset_mm)?,
            TaskSpec::Circle {
                radius_mm,
                rad_per_s,
                rad_per_step,
                normal,
            } => {
                if !(*radius_mm > 0.0 && radius_mm.is_finite()) {
                    return Err(("task.radius_mm", FieldProblem::NotPositive(*radius_mm)));
                }
                match (rad_per_s, rad_per_step) {
                    (Some(w), None) if w.is_finite() => pace("task.rad_per_s", w / self.rate_hz)?,
                    (None, Some(w)) if w.is_finite() => pace("task.rad_per_step", *w)?,
                    _ => {
                        let problem = FieldProblem::ExactlyOne("rad_per_s", "rad_per_step");
                        return Err(("task", problem));
                    }
                }
                let n = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    return Err(("task.normal", FieldProblem::NoLength(*normal)));
                }
            }
            TaskSpec::Follow {
                amplitude_mm,
                rad_per_step,
                ..
            } => {
                finite("task.amplitude_mm", amplitude_mm)?;
                finite("task.rad_per_step", &[*rad_per_step])?;
                pace("task.rad_per_step", *rad_per_step)?;
            }
        }
        Ok(())
    }
}

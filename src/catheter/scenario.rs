//! The scenario file of `softsense catheter`: the catheter, the tube it goes through, the
//! insertion, the controller, the plant (a second beam model that differs from the
//! controller's) and the tracker.
//!
//! Lengths in the file are in millimetres (fields end in `_mm`), angles in degrees (`_deg`),
//! forces in N, the modulus in Pa; everything is SI once read.

use super::rig::{Catheter, SettleParams};
use super::soft_wall::SoftWallParams;
use super::tracker::Tracker;
use super::tube::{Centreline, Obstacle, Piece, Tube};
use super::{CatheterError, CatheterResult};
use crate::fem::beam::{BeamCable, BeamMaterial, BeamModel, BeamSection};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The catheter (thesis 5.5.1: 7 mm diameter; the rest is chosen, docs/catheter.md).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CatheterSpec {
    /// Length from the base on the insertion stage to the tip (mm; 166).
    #[serde(default = "d_length")]
    pub length_mm: f64,
    /// Outer diameter (mm; 7).
    #[serde(default = "d_diameter")]
    pub diameter_mm: f64,
    /// Beam elements of the controller's model (10).
    #[serde(default = "d_elements")]
    pub elements: usize,
    /// Young's modulus (Pa; 44.8e6: 20 N on one cable bends the free catheter 90°).
    #[serde(default = "d_young")]
    pub young_modulus: f64,
    /// Poisson's ratio (0.4).
    #[serde(default = "d_poisson")]
    pub poisson: f64,
    /// Number of cables, evenly spaced round the section (4).
    #[serde(default = "d_cables")]
    pub cables: usize,
    /// Cable distance from the centreline (mm; 2.5).
    #[serde(default = "d_offset")]
    pub cable_offset_mm: f64,
    /// Each cable's axial compliance (mm/N; 0.0117: a 0.3 mm steel wire of 166 mm).
    #[serde(default = "d_cable_compliance")]
    pub cable_compliance_mm_per_n: f64,
}

/// One piece of the tube's centreline, in mm and degrees.
#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum PieceSpec {
    /// A straight run.
    Straight {
        /// Length (mm).
        length_mm: f64,
    },
    /// A circular bend.
    Arc {
        /// Bend radius (mm).
        radius_mm: f64,
        /// Turned angle (degrees).
        angle_deg: f64,
        /// Which way it turns, about the tangent from the current normal (degrees; 0).
        #[serde(default)]
        plane_deg: f64,
    },
}

/// The rigid tube; its centreline is the desired path of the tip (5.5.3).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TubeSpec {
    /// Inner diameter (mm; 28, the thesis's).
    #[serde(default = "d_tube")]
    pub diameter_mm: f64,
    /// The pieces from the entrance, where the tip starts.
    pub pieces: Vec<PieceSpec>,
    /// A soft wall (none: the wall is rigid).
    #[serde(default)]
    pub soft: Option<SoftWallSpec>,
}

/// A soft wall round the tube (thesis 5.5.7.2): linear tetrahedra from the inner radius
/// out, the outer surface held.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SoftWallSpec {
    /// Wall thickness (mm; 3).
    #[serde(default = "d_wall_thickness")]
    pub thickness_mm: f64,
    /// Young's modulus (Pa; 100e3, soft tissue's order).
    #[serde(default = "d_wall_young")]
    pub young_modulus: f64,
    /// Poisson's ratio (0.45).
    #[serde(default = "d_wall_poisson")]
    pub poisson: f64,
    /// Cells round the circumference (24).
    #[serde(default = "d_wall_around")]
    pub around: usize,
    /// Cells through the thickness (2).
    #[serde(default = "d_wall_layers")]
    pub layers: usize,
    /// Cell length along the centreline (mm; 3).
    #[serde(default = "d_wall_ring_step")]
    pub ring_step_mm: f64,
}

impl SoftWallSpec {
    /// The wall's options in SI.
    pub fn params(&self) -> SoftWallParams {
        SoftWallParams {
            thickness: 1e-3 * self.thickness_mm,
            young_modulus: self.young_modulus,
            poisson: self.poisson,
            around: self.around,
            layers: self.layers,
            ring_step: 1e-3 * self.ring_step_mm,
        }
    }
}

fn d_wall_thickness() -> f64 {
    1e3 * SoftWallParams::default().thickness
}
fn d_wall_young() -> f64 {
    SoftWallParams::default().young_modulus
}
fn d_wall_poisson() -> f64 {
    SoftWallParams::default().poisson
}
fn d_wall_around() -> usize {
    SoftWallParams::default().around
}
fn d_wall_layers() -> usize {
    SoftWallParams::default().layers
}
fn d_wall_ring_step() -> f64 {
    1e3 * SoftWallParams::default().ring_step
}

/// Inner-surface nodes of a soft wall at most: its compliance is a dense matrix of them.
const MAX_WALL_NODES: usize = 4000;

/// A rigid obstacle in the tube: a point, or a segment such as a wire across it, with a
/// radius round it. Coordinates are the path's: the entrance at the origin, the first
/// piece along +x, the first bend towards +y.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// The point, or one end of the segment (mm).
    pub at_mm: [f64; 3],
    /// The segment's other end (mm; none: a point obstacle).
    #[serde(default)]
    pub to_mm: Option<[f64; 3]>,
    /// Radius round the point or segment (mm; 0).
    #[serde(default)]
    pub radius_mm: f64,
}

/// The insertion: the physician's, shared by robot and model and not controlled.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InsertionSpec {
    /// Insertion speed (mm/s; the thesis's are 0.6, 1.2 and 2.4).
    pub speed_mm_per_s: f64,
    /// Inserted length at the end of the motion (mm).
    pub end_mm: f64,
    /// Time held at `end_mm` after the motion (s; 0).
    #[serde(default)]
    pub hold_s: f64,
}

/// The control scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Scheme {
    /// Decoupled (5.3.2): insertion left alone, bending controlled on the plane Pyz with
    /// the J of the contact-including FE model.
    Decoupled,
    /// Coupled (the baseline of 5.3.1): insertion and the cables' antagonistic pairs
    /// driven together to a desired point moving along the path, with the J of a model
    /// that ignores the tube (`catheter::coupled`).
    Coupled,
}

/// The controllers.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// The scheme ("decoupled", or the "coupled" baseline).
    #[serde(default = "d_scheme")]
    pub scheme: Scheme,
    /// The coupled scheme checks the Jacobian's rotation every this many steps (0: never;
    /// each check is six more settles of the robot).
    #[serde(default)]
    pub rotation_check_every: usize,
    /// Proportional gain K_P (0.2).
    #[serde(default = "d_kp")]
    pub kp: f64,
    /// Differential gain K_D (0.002).
    #[serde(default = "d_kd")]
    pub kd: f64,
    /// Largest tension the FEM controller may give a cable (N; 40).
    #[serde(default = "d_max_tension")]
    pub max_tension_n: f64,
    /// A node within this of the wall is a contact row (mm; 1).
    #[serde(default = "d_alarm")]
    pub alarm_mm: f64,
}

/// The robot: a second beam model that differs from the controller's.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlantSpec {
    /// Beam elements (20: twice the model's by default).
    #[serde(default = "d_plant_elements")]
    pub elements: usize,
    /// Its Young's modulus over the model's (1).
    #[serde(default = "one")]
    pub young_factor: f64,
    /// Its cable offset over the model's (1).
    #[serde(default = "one")]
    pub cable_offset_factor: f64,
}

/// The tip tracker (thesis 5.5.1: an electromagnetic tracker at 20 Hz) and its
/// calibration to the robot (5.5.2: seven feature points on the tube, SVD).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerSpec {
    /// Noise of a tip measurement, per axis (mm, standard deviation; 0.1).
    #[serde(default = "d_noise")]
    pub noise_mm: f64,
    /// Noise of a feature-point measurement in the calibration (mm; 0.1).
    #[serde(default = "d_noise")]
    pub calibration_noise_mm: f64,
    /// Feature points on the tube for the calibration (7; at least 3).
    #[serde(default = "d_points")]
    pub calibration_points: usize,
    /// Rotation of the tracker's frame from the robot's, as a rotation vector (degrees).
    #[serde(default = "d_rotation")]
    pub rotation_deg: [f64; 3],
    /// Position of the robot's origin in the tracker's frame (mm).
    #[serde(default = "d_translation")]
    pub translation_mm: [f64; 3],
    /// Seed of the noise.
    #[serde(default)]
    pub seed: u64,
}

/// A `softsense catheter` scenario.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name in reports (the file's stem when empty).
    #[serde(default)]
    pub name: String,
    /// Control rate (Hz; 20, the tracker's).
    #[serde(default = "d_rate")]
    pub rate_hz: f64,
    /// The catheter.
    #[serde(default = "d_catheter")]
    pub catheter: CatheterSpec,
    /// The tube.
    pub tube: TubeSpec,
    /// Obstacles in the tube (`[[obstacle]]` tables; none by default).
    #[serde(default, rename = "obstacle")]
    pub obstacles: Vec<ObstacleSpec>,
    /// The insertion.
    pub insertion: InsertionSpec,
    /// The controllers.
    #[serde(default = "d_controller")]
    pub controller: ControllerSpec,
    /// The robot.
    #[serde(default = "d_plant")]
    pub plant: PlantSpec,
    /// The tracker.
    #[serde(default = "d_tracker")]
    pub tracker: TrackerSpec,
    #[serde(skip)]
    file: String,
}

fn d_length() -> f64 {
    166.0
}
fn d_diameter() -> f64 {
    7.0
}
fn d_elements() -> usize {
    10
}
fn d_young() -> f64 {
    44.8e6
}
fn d_poisson() -> f64 {
    0.4
}
fn d_cables() -> usize {
    4
}
fn d_offset() -> f64 {
    2.5
}
fn d_cable_compliance() -> f64 {
    0.0117
}
fn d_tube() -> f64 {
    28.0
}
fn d_scheme() -> Scheme {
    Scheme::Decoupled
}
fn d_kp() -> f64 {
    0.2
}
fn d_kd() -> f64 {
    0.002
}
fn d_max_tension() -> f64 {
    40.0
}
fn d_alarm() -> f64 {
    1.0
}
fn d_plant_elements() -> usize {
    20
}
fn one() -> f64 {
    1.0
}
fn d_noise() -> f64 {
    0.1
}
fn d_points() -> usize {
    7
}
fn d_rotation() -> [f64; 3] {
    [10.0, -20.0, 30.0]
}
fn d_translation() -> [f64; 3] {
    [120.0, -40.0, 300.0]
}
fn d_rate() -> f64 {
    20.0
}
fn d_catheter() -> CatheterSpec {
    toml::from_str("").expect("every catheter field has a default")
}
fn d_controller() -> ControllerSpec {
    toml::from_str("").expect("every controller field has a default")
}
fn d_plant() -> PlantSpec {
    toml::from_str("").expect("every plant field has a default")
}
fn d_tracker() -> TrackerSpec {
    toml::from_str("").expect("every tracker field has a default")
}

/// The path's sampling step (m): fine enough that the nearest point is found to well
/// under the thesis's 0.3 mm errors.
const PATH_STEP: f64 = 2e-4;

impl Scenario {
    /// Reads and checks a scenario file.
    pub fn load(path: &Path) -> CatheterResult<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| CatheterError::File {
            path: path.display().to_string(),
            source,
        })?;
        let mut s = Self::parse(&text, &path.display().to_string())?;
        if s.name.is_empty() {
            s.name = (path.file_stem())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        Ok(s)
    }

    /// Parses and checks scenario text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> CatheterResult<Self> {
        let mut s: Self = toml::from_str(text).map_err(|e| CatheterError::Toml {
            path: file.to_string(),
            source: Box::new(e),
        })?;
        s.file = file.to_string();
        s.validate()?;
        Ok(s)
    }

    /// Checks ranges; the error names the file and the field.
    pub fn validate(&self) -> CatheterResult<()> {
        let bad = |field: &'static str, problem: String| CatheterError::Field {
            file: self.file.clone(),
            field,
            problem,
        };
        let positive = |field, v: f64| match v > 0.0 && v.is_finite() {
            true => Ok(()),
            false => Err(bad(field, format!("must be > 0 and finite (got {v})"))),
        };
        let c = &self.catheter;
        positive("rate_hz", self.rate_hz)?;
        positive("catheter.length_mm", c.length_mm)?;
        positive("catheter.diameter_mm", c.diameter_mm)?;
        positive("catheter.young_modulus", c.young_modulus)?;
        positive("catheter.cable_offset_mm", c.cable_offset_mm)?;
        positive(
            "catheter.cable_compliance_mm_per_n",
            c.cable_compliance_mm_per_n,
        )?;
        if !(c.poisson > -1.0 && c.poisson < 0.5) {
            return Err(bad(
                "catheter.poisson",
                format!("must be in (-1, 0.5) (got {})", c.poisson),
            ));
        }
        if c.cable_offset_mm >= 0.5 * c.diameter_mm {
            return Err(bad(
                "catheter.cable_offset_mm",
                "must be inside the section (below half the diameter)".into(),
            ));
        }
        let count = |field, v: usize, min: usize, max: usize| match (min..=max).contains(&v) {
            true => Ok(()),
            false => Err(bad(field, format!("must be in {min}..={max} (got {v})"))),
        };
        count("catheter.elements", c.elements, 2, 400)?;
        count("catheter.cables", c.cables, 2, 8)?;
        count("plant.elements", self.plant.elements, 2, 400)?;
        count(
            "tracker.calibration_points",
            self.tracker.calibration_points,
            3,
            100,
        )?;
        positive("tube.diameter_mm", self.tube.diameter_mm)?;
        if self.tube.diameter_mm <= c.diameter_mm {
            return Err(bad(
                "tube.diameter_mm",
                "must exceed the catheter's diameter".into(),
            ));
        }
        if self.tube.pieces.is_empty() {
            return Err(bad("tube.pieces", "must hold at least one piece".into()));
        }
        self.centreline()
            .map_err(|e| bad("tube.pieces", e.to_string()))?;
        for o in &self.obstacles {
            let ends = o.at_mm.iter().chain(o.to_mm.iter().flatten());
            if !ends.into_iter().all(|v| v.is_finite()) {
                return Err(bad("obstacle", "at_mm and to_mm must be finite".into()));
            }
            if !(o.radius_mm >= 0.0 && o.radius_mm.is_finite()) {
                return Err(bad(
                    "obstacle.radius_mm",
                    format!("must be >= 0 (got {})", o.radius_mm),
                ));
            }
        }
        self.validate_soft()?;
        let i = &self.insertion;
        positive("insertion.speed_mm_per_s", i.speed_mm_per_s)?;
        positive("insertion.end_mm", i.end_mm)?;
        if !(i.hold_s >= 0.0 && i.hold_s.is_finite()) {
            return Err(bad(
                "insertion.hold_s",
                format!("must be >= 0 (got {})", i.hold_s),
            ));
        }
        if i.end_mm > c.length_mm {
            return Err(bad(
                "insertion.end_mm",
                format!("cannot pass the catheter's length {} mm", c.length_mm),
            ));
        }
        if i.end_mm >= self.path_length_mm() {
            return Err(bad(
                "insertion.end_mm",
                format!(
                    "must stay inside the tube ({:.1} mm long)",
                    self.path_length_mm()
                ),
            ));
        }
        if self.steps() > MAX_STEPS {
            return Err(bad(
                "insertion",
                format!("asks for {} steps; at most {MAX_STEPS}", self.steps()),
            ));
        }
        let k = &self.controller;
        if k.scheme == Scheme::Coupled && (c.cables < 4 || c.cables % 2 != 0) {
            return Err(bad(
                "catheter.cables",
                format!(
                    "the coupled scheme drives antagonistic pairs: an even number, at least 4 \
                     (got {})",
                    c.cables
                ),
            ));
        }
        positive("controller.kp", k.kp)?;
        if !(k.kd >= 0.0 && k.kd.is_finite()) {
            return Err(bad("controller.kd", format!("must be >= 0 (got {})", k.kd)));
        }
        positive("controller.max_tension_n", k.max_tension_n)?;
        positive("controller.alarm_mm", k.alarm_mm)?;
        positive("plant.young_factor", self.plant.young_factor)?;
        positive("plant.cable_offset_factor", self.plant.cable_offset_factor)?;
        if self.plant.cable_offset_factor * c.cable_offset_mm >= 0.5 * c.diameter_mm {
            return Err(bad(
                "plant.cable_offset_factor",
                "puts the plant's cables outside the section".into(),
            ));
        }
        let t = &self.tracker;
        for (field, v) in [
            ("tracker.noise_mm", t.noise_mm),
            ("tracker.calibration_noise_mm", t.calibration_noise_mm),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(bad(field, format!("must be >= 0 (got {v})")));
            }
        }
        if t.rotation_deg
            .iter()
            .chain(&t.translation_mm)
            .any(|v| !v.is_finite())
        {
            return Err(bad(
                "tracker",
                "rotation_deg and translation_mm must be finite".into(),
            ));
        }
        Ok(())
    }

    fn validate_soft(&self) -> CatheterResult<()> {
        let Some(w) = &self.tube.soft else {
            return Ok(());
        };
        let bad = |field: &'static str, problem: String| CatheterError::Field {
            file: self.file.clone(),
            field,
            problem,
        };
        for (field, v) in [
            ("tube.soft.thickness_mm", w.thickness_mm),
            ("tube.soft.young_modulus", w.young_modulus),
            ("tube.soft.ring_step_mm", w.ring_step_mm),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(bad(field, format!("must be > 0 and finite (got {v})")));
            }
        }
        if !(w.poisson > -1.0 && w.poisson < 0.5) {
            let problem = format!("must be in (-1, 0.5) (got {})", w.poisson);
            return Err(bad("tube.soft.poisson", problem));
        }
        if !(6..=96).contains(&w.around) || !(1..=8).contains(&w.layers) {
            let problem = format!(
                "around must be in 6..=96 and layers in 1..=8 (got {} and {})",
                w.around, w.layers
            );
            return Err(bad("tube.soft", problem));
        }
        let outer = 0.5 * self.tube.diameter_mm + w.thickness_mm;
        let tight = (self.tube.pieces.iter())
            .any(|p| matches!(p, PieceSpec::Arc { radius_mm, .. } if *radius_mm <= outer));
        if tight {
            let problem = format!("puts the wall's outer radius ({outer} mm) beyond a bend's radius: the mesh would fold");
            return Err(bad("tube.soft.thickness_mm", problem));
        }
        let nodes = w.around * ((self.path_length_mm() / w.ring_step_mm).ceil() as usize + 1);
        if nodes > MAX_WALL_NODES {
            let problem = format!(
                "gives {nodes} inner-surface nodes (around x rings); at most {MAX_WALL_NODES}"
            );
            return Err(bad("tube.soft.ring_step_mm", problem));
        }
        Ok(())
    }

    /// The file it was read from.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The pieces in SI.
    pub fn pieces(&self) -> Vec<Piece> {
        (self.tube.pieces.iter())
            .map(|p| match *p {
                PieceSpec::Straight { length_mm } => Piece::Straight {
                    length: 1e-3 * length_mm,
                },
                PieceSpec::Arc {
                    radius_mm,
                    angle_deg,
                    plane_deg,
                } => Piece::Arc {
                    radius: 1e-3 * radius_mm,
                    angle: angle_deg.to_radians(),
                    plane: plane_deg.to_radians(),
                },
            })
            .collect()
    }

    /// The path's length (mm).
    pub fn path_length_mm(&self) -> f64 {
        1e3 * self.pieces().iter().map(piece_length).sum::<f64>()
    }

    /// Arc-length intervals of the straight pieces (m).
    pub fn straight_parts(&self) -> Vec<[f64; 2]> {
        let mut at = 0.0;
        let mut out = Vec::new();
        for p in self.pieces() {
            if let Piece::Straight { .. } = p {
                out.push([at, at + piece_length(&p)]);
            }
            at += piece_length(&p);
        }
        out
    }

    /// The path: the entrance at the origin, along +x, the first bend's reference +y.
    pub fn centreline(&self) -> CatheterResult<Centreline> {
        Centreline::from_pieces(
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            &self.pieces(),
            PATH_STEP,
        )
    }

    /// The settle's options: the defaults with the controller's alarm distance.
    pub fn settle_params(&self) -> SettleParams {
        SettleParams {
            alarm: 1e-3 * self.controller.alarm_mm,
            ..SettleParams::default()
        }
    }

    /// The obstacles in SI.
    pub fn obstacles(&self) -> Vec<Obstacle> {
        (self.obstacles.iter())
            .map(|o| Obstacle {
                a: o.at_mm.map(|v| 1e-3 * v),
                b: o.to_mm.unwrap_or(o.at_mm).map(|v| 1e-3 * v),
                radius: 1e-3 * o.radius_mm,
            })
            .collect()
    }

    /// The tube with its obstacles, and its soft wall if it has one.
    pub fn tube(&self) -> CatheterResult<Tube> {
        let tube = Tube::new(self.centreline()?, 0.5e-3 * self.tube.diameter_mm)?
            .with_obstacles(self.obstacles())?;
        match &self.tube.soft {
            Some(w) => tube.with_soft_wall(&w.params()),
            None => Ok(tube),
        }
    }

    /// The controller's catheter (`plant` false) or the robot (`plant` true): straight
    /// along +x with its tip at the tube's entrance.
    pub fn catheter(&self, plant: bool) -> CatheterResult<Catheter> {
        let c = &self.catheter;
        let (elements, e_factor, r_factor) = match plant {
            false => (c.elements, 1.0, 1.0),
            true => (
                self.plant.elements,
                self.plant.young_factor,
                self.plant.cable_offset_factor,
            ),
        };
        let length = 1e-3 * c.length_mm;
        let nodes = (0..=elements)
            .map(|i| [length * (i as f64 / elements as f64 - 1.0), 0.0, 0.0])
            .collect();
        let section = BeamSection::circular(0.5e-3 * c.diameter_mm)?;
        let material = BeamMaterial::new(c.young_modulus * e_factor, c.poisson)?;
        let beam = BeamModel::new(nodes, section, material)?;
        let cables = (0..c.cables)
            .map(|i| BeamCable {
                offset: 1e-3 * c.cable_offset_mm * r_factor,
                angle: std::f64::consts::TAU * i as f64 / c.cables as f64,
            })
            .collect();
        Ok(Catheter {
            beam,
            cables,
            radius: 0.5e-3 * c.diameter_mm,
            cable_compliance: 1e-3 * c.cable_compliance_mm_per_n,
        })
    }

    /// Steps of the run: the motion, then the hold.
    pub fn steps(&self) -> usize {
        let i = &self.insertion;
        let motion = i.end_mm / i.speed_mm_per_s + i.hold_s;
        (motion * self.rate_hz).ceil() as usize + 1
    }

    /// Inserted length at step `k` (m).
    pub fn insertion_at(&self, k: usize) -> f64 {
        let i = &self.insertion;
        (1e-3 * i.speed_mm_per_s * k as f64 / self.rate_hz).min(1e-3 * i.end_mm)
    }

    /// The tracker, calibrated on `tube`'s feature points.
    pub fn tracker(&self, tube: &Tube) -> CatheterResult<Tracker> {
        let t = &self.tracker;
        Tracker::calibrated(
            self.tracker_from_robot(),
            1e-3 * t.noise_mm,
            1e-3 * t.calibration_noise_mm,
            tube,
            t.calibration_points,
            t.seed,
        )
    }

    /// The tracker's frame from the robot's (rotation vector in degrees, mm).
    pub fn tracker_from_robot(&self) -> crate::math::Iso3 {
        let t = &self.tracker;
        let r = nalgebra::Vector3::from(t.rotation_deg.map(f64::to_radians));
        let p = nalgebra::Vector3::from(t.translation_mm.map(|v| 1e-3 * v));
        crate::math::Iso3::new(p, r)
    }
}

/// A piece's arc length (m).
fn piece_length(p: &Piece) -> f64 {
    match *p {
        Piece::Straight { length } => length,
        Piece::Arc { radius, angle, .. } => radius * angle,
    }
}

/// The most steps a scenario may ask for (an hour at 20 Hz).
pub const MAX_STEPS: usize = 72_000;

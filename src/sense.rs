//! Marker-free force sensing, frame by frame (thesis 4.5, Algorithms 4.1-4.2): an RGB-D
//! frame in, "touched here, this hard" out.
//!
//! Per frame: depth + colour → points in the camera frame → the robot frame
//! (`robot_from_camera`) → crop to the robot's working box above the table → robot points by
//! a colour model (hue and chroma in CIELAB, robust to shading) and object points (the rest)
//! → KD-tree contact detection and Euclidean grouping ([`crate::contact`]) → location mapping
//! (each contact to the nearest surface node of the FE model at the actuated state, refined at
//! the estimated state) → registration of the surface features along their normal lines
//! ([`crate::register`]) → the intensity QP with FE updates ([`crate::inverse::frame`]).
//! Where no contact is seen (a weight hanging by a thin string), the model's declared force
//! points are the candidates and the one that explains the frame best is reported.
//!
//! A recording is a folder as written by `softsense scene generate`: `depth_NNNN.png`,
//! `color_NNNN.png`, `intrinsics.json`, a pose (`calibration.json` from `softsense calibrate`,
//! else `camera_pose.json`), optionally `actuators.json` (recorded actuator inputs) and
//! `truth.json` (only read to report errors, never for the estimate). Without recorded
//! inputs, the model's are used: the model file's, or the calibration's after
//! [`Sensor::use_calibrated_inputs`] (`rec.calibrated`), as `softsense sense` does.
//!
//! ```no_run
//! use softsense::sense::{Recording, SenseParams, Sensor};
//! let rec = Recording::open("clouds/scenes/tip_weight".as_ref()).unwrap();
//! let model = softsense::fem::model::Model::load(&rec.model_path().unwrap(), None).unwrap();
//! let sensor = Sensor::new(model, rec.robot_from_camera, SenseParams::default());
//! for &frame in &rec.frames {
//!     let obs = sensor.observe(&rec, frame).unwrap();
//!     let report = sensor.sense(frame, &obs, rec.actuators_of(frame));
//!     println!("{:?}", report.forces);
//! }
//! ```

use crate::calibrate::ActuatorCalibration;
use crate::contact::{detect_contacts, Contact, ContactParams};
use crate::fem::mesh::Surface;
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, Solution, SolverState};
use crate::inverse::frame::{
    choose_locations, estimate, estimate_after_choice, estimate_from, estimate_onwards,
    factorize_loop_tangent, Candidate, FrameEstimate, FrameParams, LinearisationPoint, LoopTimings,
};
use crate::inverse::intensity::Identifiability;
use crate::inverse::par_map;
use crate::io::intrinsics::{read_camera_model, CameraModel};
use crate::io::rgbd::read_frame;
use crate::math::{cross, dot, norm, sub, unit};
use crate::register::{surface_features, vertex_normals, FeatureParams, Registrar, SurfaceFeature};
use crate::scene::{ActuatorTruth, FrameTruth, Truth};
use crate::segment::color::rgb_to_lab;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use thiserror::Error;

/// Errors of the sensing stage (per recording; per-frame failures are [`FrameStatus`]es).
#[derive(Debug, Error)]
pub enum SenseError {
    /// A file of the recording is missing or unreadable.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// The recording folder has no frames.
    #[error("{0}: no depth_NNNN.png frames")]
    NoFrames(String),
    /// Image or intrinsics reading failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// Calibrated cable inputs that do not fit the model.
    #[error("calibrated cable inputs: {0}")]
    Calibration(String),
}

/// `Result` of the sensing stage.
pub type SenseResult<T> = std::result::Result<T, SenseError>;

/// Parameters of the sensing chain.
#[derive(Clone, Debug)]
pub struct SenseParams {
    /// Reference colour of the robot's silicone (sRGB); default the scene generator's green.
    pub robot_color: [u8; 3],
    /// Largest hue difference in CIELAB's a-b plane from the reference colour (degrees, 25).
    pub hue_tolerance_deg: f64,
    /// Smallest CIELAB chroma of a robot point (12): grey table and dark holes are not robot.
    pub min_chroma: f64,
    /// Margin around the model's bounding box kept by the crop (m, 0.03).
    pub crop_margin: f64,
    /// Points lower than the model's lowest point plus this are the table (m, 0.004).
    pub table_clearance: f64,
    /// Contact detection: more than 3 robot neighbours within 12 mm, 5 mm groups of
    /// 10-2000 points. The thesis used 4 mm with its camera closer; at 0.5 m a D415-like
    /// depth stream samples ~0.8 mm apart and leaves holes along the probe's silhouette, so
    /// 4 mm finds 9-18 probe points near the robot where 8 mm finds 70-100. A probe on a
    /// side face the camera sees at a grazing angle is farther still from every robot point
    /// it sees: 7.9 mm at best (two_probes frame 2, south leg), with one robot point within
    /// 8 mm and 100+ within 12 mm. An object within 12 mm that does not push gets a force
    /// near zero (pushing only), not a false load.
    pub contact: ContactParams,
    /// Feature points: 300 (the thesis used 51) on flat patches the camera sees, each at
    /// least 5 mm inside its patch (`flat_radius`, equal to the registration's `d_m`).
    /// A feature near a patch edge loses its patch when the surface slides by a few
    /// millimetres under a load, and its normal line then meets the neighbouring face.
    pub features: FeatureParams,
    /// Registration, intensity QP and FE updates.
    pub frame: FrameParams,
    /// Surface nodes within this of a seen contact's centroid are its location options (m,
    /// 0.015): the probe hides the touched point itself, so the centroid of the touching
    /// points sits off it (by ~8 mm, one mesh layer, with the camera looking down at 30°).
    pub location_radius: f64,
    /// At most this many options per contact, nearest first (16).
    pub location_options: usize,
    /// The first estimate of an untracked frame with seen contacts is a preview: it stops
    /// after this many FE updates (2; 0 or 1: no preview, the first update being at the
    /// unloaded state itself) unless it settles first, and the
    /// choice is made again at its state, nearer the estimated one than the free state is.
    /// If the locations stand the estimate goes on from there; else the new ones are
    /// estimated from the start. On the 55 held-out single-probe frames with a seen contact
    /// (seeds 101-707), the choice at the estimated state then moved in 3 frames instead of
    /// 19 (each a second full estimate), and in a frame where the free state's first pick
    /// inverts an element the preview's choice found the touched node (see the README).
    pub preview_updates: usize,
    /// How many times the choice is made again at an estimated state (2); each time it picks
    /// other locations, they are estimated. The last estimate is not checked again. With one
    /// check, a preview's choice that moved was estimated but not checked, and in 2 of 80
    /// held-out frames (56 one-probe, 24 two-probe) it stayed a node off (8.8-8.9 mm,
    /// 11.7% and 47% off, both reliable).
    pub location_checks: usize,
    /// Pool features within this of a seen contact join the frame's features (m, 0.03; 0
    /// turns it off): a point load's tangential part shows mostly near it, where features
    /// spread over the whole robot put only a few.
    pub local_features_radius: f64,
    /// Size of the dense pool (600).
    pub local_feature_pool: usize,
    /// A frame of a stream sensed with [`Sensor::track_frames`] starts from the previous
    /// frame's estimate when each contact is seen within this of where the previous frame
    /// saw it (m, 0.005: a third of `location_radius`). Its location choice is then made
    /// once, at the previous frame's state, beside the estimate; if it keeps the previous
    /// locations the estimate stands.
    pub track_radius: f64,
    /// Largest number of option combinations tried exhaustively (400); beyond, coordinate
    /// descent.
    pub max_combinations: usize,
    /// A frame with more seen contacts than this (6) is not estimated: it gets
    /// [`FrameStatus::TooManyContacts`]. Probes and fingers touch a robot in a few places;
    /// dozens of contacts come from depth and colour that do not match (two frames'
    /// images mixed, a camera out of sync) or from objects all around the robot. Estimated
    /// anyway, such a frame took 6 s (a probe_side colour frame with another scene's
    /// depth: 21 contacts, each FE estimate of their locations failing) and gave no
    /// answer. Every generated frame so far, bundled and held out, had at most 2.
    pub max_contacts: usize,
    /// At a seen contact, estimate a 3-D force (inward normal, pushing only, plus two
    /// tangential components) instead of a normal force alone (true).
    pub three_d: bool,
    /// A sensed frame is flagged unreliable ([`FrameReport::reliable`]) when the robust
    /// spread of its residual (`IntensityEstimate::residual_robust`) exceeds this many times
    /// the expected per-feature noise (`frame.intensity.sensor_sigma`), 1.5: the data
    /// scatter half as much again as the sensor explains. With 300 features the spread is
    /// known to a few percent, so a model that fits stays near 1: 0.60-0.90 on the 61 of 68
    /// sensed generated frames (bundled, held out and test) that fit; frames whose force
    /// sits a node (8-12 mm) off read 1.0-2.6, and an unseen contact 5.9.
    pub poor_fit: f64,
    /// A force whose largest one-sigma over all directions ([`ForceEstimate::sigma_max`])
    /// exceeds this fraction of its magnitude gets a warning that its direction (or, when
    /// the longest axis is along the force, its magnitude) is uncertain (0.025: its 2σ band
    /// is then wider than 5% of the force). Forces within 2σ of zero get none: their ±
    /// already says no load is found. The frame stays `reliable`; the warning says which
    /// part of the estimate is loose.
    pub direction_warning: f64,
}

impl Default for SenseParams {
    fn default() -> Self {
        let mut frame = FrameParams::default();
        // Each matched offset averages the points within 5 mm of the normal line: ~100 at
        // the D415-like 0.8 mm spacing at 0.5 m, of 0.5 mm depth noise and 1 mm depth steps
        // (0.29 mm) each: 0.58 mm / 10 ≈ 0.05 mm.
        let d_m = 0.005;
        frame.register.d_m = d_m;
        frame.intensity.sensor_sigma = 5e-5;
        frame.max_updates = 20;
        // 1 mN: far below the 5% of the lightest load (0.26 N) the estimates are held to.
        frame.force_tol = 1e-3;
        Self {
            robot_color: [40, 200, 60],
            hue_tolerance_deg: 25.0,
            min_chroma: 12.0,
            crop_margin: 0.03,
            table_clearance: 0.004,
            contact: ContactParams {
                radius_m: 0.012,
                ..ContactParams::default()
            },
            features: FeatureParams {
                count: 300,
                flat_radius: d_m,
                ..FeatureParams::default()
            },
            frame,
            three_d: true,
            poor_fit: 1.5,
            direction_warning: 0.025,
            location_radius: 0.015,
            location_options: 16,
            preview_updates: 2,
            location_checks: 2,
            max_combinations: 400,
            max_contacts: 6,
            local_features_radius: 0.03,
            local_feature_pool: 600,
            track_radius: 0.005,
        }
    }
}

/// A recorded (or generated) RGB-D sequence.
#[derive(Clone, Debug)]
pub struct Recording {
    /// The folder.
    pub dir: PathBuf,
    /// Intrinsics and depth units.
    pub camera: CameraModel,
    /// Rigid transform from camera to robot coordinates (4x4, row-major, m).
    pub robot_from_camera: [[f64; 4]; 4],
    /// Which file the pose came from.
    pub pose_file: PathBuf,
    /// Frame numbers, ascending.
    pub frames: Vec<usize>,
    /// Recorded actuator inputs per frame, if any.
    pub actuators: Option<Vec<Vec<ActuatorTruth>>>,
    /// The cable inputs of the calibration (`calibration.json`'s `actuators`), if the pose
    /// came from one: for frames without recorded inputs, see
    /// [`Sensor::use_calibrated_inputs`].
    pub calibrated: Option<Vec<ActuatorCalibration>>,
    /// The model file the calibration names (`calibration.json`'s `model`), as written.
    pub calibration_model: Option<String>,
    /// The generator's truth, if any (used for error reports only).
    pub truth: Option<Truth>,
}

fn file_err(path: &Path, e: impl std::fmt::Display) -> SenseError {
    SenseError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> SenseResult<T> {
    let text = std::fs::read_to_string(path).map_err(|e| file_err(path, e))?;
    serde_json::from_str(&text).map_err(|e| file_err(path, e))
}

#[derive(serde::Deserialize)]
struct PoseFile {
    robot_from_camera: [[f64; 4]; 4],
    /// The cable inputs `softsense calibrate` found (calibration.json only).
    #[serde(default)]
    actuators: Option<Vec<ActuatorCalibration>>,
    /// The model file the calibration used, relative to the file's folder unless absolute
    /// (calibration.json only).
    #[serde(default)]
    model: Option<String>,
}

/// Points of one frame in the robot frame, split by the colour model.
#[derive(Clone, Debug, Default)]
pub struct Observation {
    /// Robot points (m, robot frame).
    pub robot: Vec<[f64; 3]>,
    /// Other points inside the crop: what may touch the robot (m, robot frame).
    pub objects: Vec<[f32; 3]>,
    /// Pixel index of each robot point.
    pub robot_pixels: Vec<usize>,
    /// Pixel index of each object point.
    pub object_pixels: Vec<usize>,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// The colour frame, row-major.
    pub color: Vec<[u8; 3]>,
    /// Time spent reading, cropping and segmenting this frame (the other stages are zero).
    pub timings: StageTimings,
}

/// Milliseconds of a duration.
fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Where the time of one frame went (ms). Stage times add up the work done in each stage:
/// where candidate estimates run in parallel (rayon) they are summed over threads, so their
/// sum can exceed `total`, the wall time of the frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageTimings {
    /// Decoding the depth and colour PNGs and back-projecting depth into points.
    pub read: f64,
    /// Filter: transform to the robot frame and crop to the working box.
    pub crop: f64,
    /// Segment: the colour model splitting robot and object points.
    pub segment: f64,
    /// The free FE solve at the frame's actuator inputs (near zero when cached).
    pub free_solve: f64,
    /// Contact detection (KD-tree) and Euclidean grouping.
    pub contacts: f64,
    /// Location mapping: options per contact, their linearisation and the QPs choosing one.
    pub mapping: f64,
    /// Registration of the features along their normal lines (grid build included).
    pub register: f64,
    /// FE updates: Newton solves under the estimated forces.
    pub fe_update: f64,
    /// Compliance: tangent factorisation at the updated state and W = H K⁻¹ Hᵀ.
    pub compliance: f64,
    /// Intensity QPs (clarabel), identifiability and uncertainty included.
    pub qp: f64,
    /// Wall time of the whole frame: read to report.
    pub total: f64,
}

impl StageTimings {
    /// Stage names and values, in chain order (`total` last).
    pub fn named(&self) -> [(&'static str, f64); 11] {
        [
            ("read", self.read),
            ("crop", self.crop),
            ("segment", self.segment),
            ("free_solve", self.free_solve),
            ("contacts", self.contacts),
            ("mapping", self.mapping),
            ("register", self.register),
            ("fe_update", self.fe_update),
            ("compliance", self.compliance),
            ("qp", self.qp),
            ("total", self.total),
        ]
    }

    /// Adds the loop timings of one frame estimate.
    fn add_loop(&mut self, t: &LoopTimings) {
        self.register += t.register;
        self.fe_update += t.fe_update;
        self.compliance += t.compliance;
        self.qp += t.qp;
    }
}

/// Per-stage medians over frames (ms), in [`StageTimings::named`] order.
pub fn median_timings(timings: &[StageTimings]) -> Vec<(&'static str, f64)> {
    let named: Vec<_> = timings.iter().map(|t| t.named()).collect();
    StageTimings::default()
        .named()
        .iter()
        .enumerate()
        .map(|(k, (name, _))| {
            let mut v: Vec<f64> = named.iter().map(|n| n[k].1).collect();
            (*name, crate::math::median(&mut v))
        })
        .collect()
}

impl Recording {
    /// Opens a recording folder: finds the frames, reads intrinsics and the pose
    /// (`calibration.json` if present, else `camera_pose.json`), and the optional
    /// `actuators.json` and `truth.json`.
    pub fn open(dir: &Path) -> SenseResult<Self> {
        let entries = std::fs::read_dir(dir).map_err(|e| file_err(dir, e))?;
        let mut frames: Vec<usize> = entries
            .filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let num = name.strip_prefix("depth_")?.strip_suffix(".png")?;
                num.parse().ok()
            })
            .collect();
        frames.sort_unstable();
        if frames.is_empty() {
            return Err(SenseError::NoFrames(dir.display().to_string()));
        }
        let camera = read_camera_model(dir.join("intrinsics.json"))?;
        let calib = dir.join("calibration.json");
        let pose_file = if calib.exists() {
            calib
        } else {
            dir.join("camera_pose.json")
        };
        let pose: PoseFile = read_json(&pose_file)?;
        // A scale or shear in the pose would put every point somewhere else, and frames
        // were then estimated with nonsense, flagged unreliable at best.
        crate::calibrate::pose_from_matrix(&pose.robot_from_camera).map_err(|e| {
            let why = match e {
                crate::calibrate::CalibrateError::Pose(why) => why,
                e => e.to_string(),
            };
            file_err(
                &pose_file,
                format!("robot_from_camera is not a rigid transform: {why}"),
            )
        })?;
        let opt = |name: &str| {
            let p = dir.join(name);
            p.exists().then_some(p)
        };
        let actuators = opt("actuators.json").map(|p| read_json(&p)).transpose()?;
        let truth = opt("truth.json").map(|p| read_json(&p)).transpose()?;
        Ok(Self {
            dir: dir.to_path_buf(),
            camera,
            robot_from_camera: pose.robot_from_camera,
            calibrated: pose.actuators,
            calibration_model: pose.model,
            pose_file,
            frames,
            actuators,
            truth,
        })
    }

    /// The model file named by the truth (generated scenes), else by the calibration, if
    /// any (see [`Recording::model_named_by`]). A relative path is taken from the
    /// recording's folder; if nothing is there, as it is (recordings made before
    /// 2026-11-24 name it from the directory `scene generate` ran in).
    pub fn model_path(&self) -> Option<PathBuf> {
        let named = PathBuf::from(match &self.truth {
            Some(t) => &t.model_path,
            None => self.calibration_model.as_ref()?,
        });
        let in_dir = self.dir.join(&named);
        Some(if named.is_relative() && in_dir.exists() {
            in_dir
        } else {
            named
        })
    }

    /// The file that names [`Recording::model_path`]: `truth.json`, else the pose file
    /// (`calibration.json`); `None` when neither names a model.
    pub fn model_named_by(&self) -> Option<PathBuf> {
        if self.truth.is_some() {
            Some(self.dir.join("truth.json"))
        } else {
            self.calibration_model
                .as_ref()
                .map(|_| self.pose_file.clone())
        }
    }

    /// The recorded actuator inputs of `frame`, if any.
    pub fn actuators_of(&self, frame: usize) -> Option<&[ActuatorTruth]> {
        self.actuators
            .as_ref()
            .and_then(|a| a.get(frame))
            .map(|v| v.as_slice())
    }

    /// The truth of `frame`, if any.
    pub fn truth_of(&self, frame: usize) -> Option<&FrameTruth> {
        self.truth
            .as_ref()
            .and_then(|t| t.frames.iter().find(|f| f.frame == frame))
    }

    /// Paths of the depth and colour images of `frame`.
    pub fn frame_paths(&self, frame: usize) -> (PathBuf, PathBuf) {
        (
            self.dir.join(format!("depth_{frame:04}.png")),
            self.dir.join(format!("color_{frame:04}.png")),
        )
    }

    /// Reads `frame` and splits its points (robot frame, cropped to `bounds` when given)
    /// into robot and objects by the colour model of `params`.
    pub fn observe(
        &self,
        frame: usize,
        params: &SenseParams,
        bounds: Option<[[f64; 3]; 2]>,
    ) -> SenseResult<Observation> {
        let t0 = std::time::Instant::now();
        let (dp, cp) = self.frame_paths(frame);
        let mut cloud = read_frame(&dp, cp.exists().then_some(cp.as_path()), &self.camera)?;
        let colors = cloud.colors.take().unwrap_or_default();
        let t1 = std::time::Instant::now();
        // Filter: to the robot frame, cropped to the working box.
        let t = &self.robot_from_camera;
        let kept: Vec<(usize, [f64; 3])> = cloud
            .positions
            .iter()
            .enumerate()
            .filter(|(_, p)| p.iter().all(|c| c.is_finite()))
            .filter_map(|(i, p)| {
                let pc = p.map(|c| c as f64);
                let q = [0, 1, 2]
                    .map(|r| t[r][0] * pc[0] + t[r][1] * pc[1] + t[r][2] * pc[2] + t[r][3]);
                match bounds {
                    Some([lo, hi]) if (0..3).any(|k| q[k] < lo[k] || q[k] > hi[k]) => None,
                    _ => Some((i, q)),
                }
            })
            .collect();
        let t2 = std::time::Instant::now();
        // Segment: robot points by the colour model, the rest are objects.
        let reference = rgb_to_lab(params.robot_color);
        let ref_hue = reference[2].atan2(reference[1]);
        let tol = params.hue_tolerance_deg.to_radians();
        let mut obs = Observation {
            width: cloud.width,
            height: cloud.height,
            ..Default::default()
        };
        let is_robot = |c: [u8; 3]| {
            let lab = rgb_to_lab(c);
            let chroma = (lab[1] * lab[1] + lab[2] * lab[2]).sqrt();
            let dh = (lab[2].atan2(lab[1]) - ref_hue + std::f64::consts::PI)
                .rem_euclid(2.0 * std::f64::consts::PI)
                - std::f64::consts::PI;
            chroma >= params.min_chroma && dh.abs() <= tol
        };
        // Each distinct colour is classified once: a frame's robot pixels share a few
        // thousand colours among tens of thousands of pixels, and a Lab conversion costs
        // three cube roots.
        let mut seen: std::collections::HashMap<[u8; 3], bool> = Default::default();
        for (i, q) in kept {
            let robot = colors
                .get(i)
                .is_some_and(|&c| *seen.entry(c).or_insert_with(|| is_robot(c)));
            if robot {
                obs.robot.push(q);
                obs.robot_pixels.push(i);
            } else {
                obs.objects.push(q.map(|c| c as f32));
                obs.object_pixels.push(i);
            }
        }
        obs.color = colors;
        let t3 = std::time::Instant::now();
        obs.timings.read = ms(t1 - t0);
        obs.timings.crop = ms(t2 - t1);
        obs.timings.segment = ms(t3 - t2);
        Ok(obs)
    }
}

/// What happened to a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "status", content = "detail", rename_all = "snake_case")]
pub enum FrameStatus {
    /// Forces estimated.
    Sensed,
    /// Too few robot points (the colour model found no robot).
    NoRobot,
    /// No feature point could be registered.
    NoFeatures,
    /// The frame could not be read.
    Unreadable(String),
    /// The FE model or the QP failed; the message says how.
    NotSolved(String),
    /// More contacts seen than [`SenseParams::max_contacts`]: not estimated.
    TooManyContacts {
        /// Contacts seen.
        seen: usize,
        /// The limit.
        max: usize,
    },
}

impl std::fmt::Display for FrameStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrameStatus::Sensed => write!(f, "sensed"),
            FrameStatus::NoRobot => write!(f, "no robot (too few points of the robot's colour)"),
            FrameStatus::NoFeatures => write!(f, "no feature point registered"),
            FrameStatus::Unreadable(e) => write!(f, "unreadable: {e}"),
            FrameStatus::NotSolved(e) => write!(f, "not solved: {e}"),
            FrameStatus::TooManyContacts { seen, max } => write!(
                f,
                "too many contacts: {seen} seen, the limit is {max} (--max-contacts); not estimated (depth and colour that do not match, or objects all around the robot?)"
            ),
        }
    }
}

/// One estimated force.
#[derive(Clone, Debug, Serialize)]
pub struct ForceEstimate {
    /// Where the location came from: `contact` (seen) or `force point <name>` (declared).
    pub source: String,
    /// The seen contact's centroid (robot frame, m), for seen contacts.
    pub seen_at: Option<[f64; 3]>,
    /// Contact points in the seen group.
    pub contact_points: usize,
    /// The mapped FE location at the estimated state (robot frame, m).
    pub location: [f64; 3],
    /// The mapped surface node (seen contacts).
    pub node: Option<usize>,
    /// Force vector (N, robot frame).
    pub force: [f64; 3],
    /// Its magnitude (N).
    pub magnitude: f64,
    /// One-sigma uncertainty of the magnitude (N), from the sensor noise, W and the rows'
    /// residuals (see [`crate::inverse::frame::FrameEstimate::use_shared_point_uncertainty`]).
    pub sigma: f64,
    /// The largest one-sigma of the force over all directions (N): the square root of
    /// `covariance`'s largest eigenvalue (NaN if it has a NaN). Where `sigma` is small but
    /// this is not, the magnitude is known and the direction is not: the force's error is
    /// mostly tangential, along the covariance's longest axis.
    pub sigma_max: f64,
    /// Covariance of `force` (N², robot frame x, y, z; rows). The tangential spread is
    /// often several times the magnitude's: normal-line registration sees a tangential
    /// force only through the faces it tilts. One-sigma of a component along a unit
    /// vector u: sqrt(uᵀ C u); `sigma` is that along the force.
    pub covariance: [[f64; 3]; 3],
}

/// Errors of one estimated load against the truth.
#[derive(Clone, Debug, Serialize)]
pub struct LoadError {
    /// The true load's force (N).
    pub truth_force: [f64; 3],
    /// The true location (deformed, m).
    pub truth_at: [f64; 3],
    /// Index of the matched estimate (nearest location), if any.
    pub estimate: Option<usize>,
    /// Distance between the estimated and true locations (m).
    pub location_error: f64,
    /// |f_est − f_true| / |f_true|.
    pub force_error: f64,
    /// | |f_est| − |f_true| | / |f_true|.
    pub magnitude_error: f64,
}

/// The result of one frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Frame number.
    pub frame: usize,
    /// Outcome.
    #[serde(flatten)]
    pub status: FrameStatus,
    /// Robot and object points seen.
    pub robot_points: usize,
    /// Object points inside the crop.
    pub object_points: usize,
    /// Estimated forces.
    pub forces: Vec<ForceEstimate>,
    /// Actuator forces (N), one per cable, by name.
    pub actuators: Vec<(String, f64)>,
    /// Visible feature points of the last registration, and all.
    pub features_visible: usize,
    /// Number of feature points.
    pub features: usize,
    /// RMS of the normal-displacement residual (m).
    pub residual_rms: f64,
    /// Robust spread of the same residual (1.4826 × median |residual|, m).
    pub residual_robust: f64,
    /// FE updates in the last estimate.
    pub updates: usize,
    /// Whether the frame started from the previous frame's estimate ([`Sensor::track_frames`]):
    /// its contacts were where the previous frame's were (or neither frame saw one), so the
    /// previous locations and forces were the starting point instead of a choice and a
    /// loop from the unloaded state.
    pub tracked: bool,
    /// Force steps halved because their FE update failed, over the frame's estimates
    /// (`FrameParams::max_halvings`).
    pub halvings: usize,
    /// Whether the estimate passed the fit checks: the forces settled within
    /// `FrameParams::max_updates`, the residual is within [`SenseParams::poor_fit`] times
    /// the expected noise, and the forces are identifiable (no warning in
    /// `identifiability`). An unreliable frame keeps its estimate; its `warnings` say which
    /// check failed. False when nothing was estimated.
    pub reliable: bool,
    /// Identifiability of the last QP.
    pub identifiability: Option<Identifiability>,
    /// Warnings a user should read.
    pub warnings: Vec<String>,
    /// Errors against the truth, when the recording has one.
    pub errors: Option<Vec<LoadError>>,
    /// Wall time of sensing the frame, reading excluded (ms).
    pub ms: f64,
    /// Where the time went, per stage (ms; reading included in `total`).
    pub timings: StageTimings,
    /// Node positions of the final FE state (m, robot frame; empty if none), for pictures.
    #[serde(skip)]
    pub positions: Vec<[f64; 3]>,
}

impl FrameReport {
    /// Adds the loop timings and halvings of one of the frame's estimates.
    fn account(&mut self, est: &FrameEstimate) {
        self.timings.add_loop(&est.timings);
        self.halvings += est.halvings;
    }

    /// A report with `status` and nothing estimated yet.
    pub fn empty(frame: usize, status: FrameStatus) -> Self {
        Self {
            frame,
            status,
            robot_points: 0,
            object_points: 0,
            forces: Vec::new(),
            actuators: Vec::new(),
            features_visible: 0,
            features: 0,
            residual_rms: f64::NAN,
            residual_robust: f64::NAN,
            updates: 0,
            tracked: false,
            halvings: 0,
            reliable: false,
            identifiability: None,
            warnings: Vec::new(),
            errors: None,
            ms: 0.0,
            timings: StageTimings::default(),
            positions: Vec::new(),
        }
    }
}

/// What a sensed frame leaves for the next frame of a stream ([`Sensor::sense_tracked`],
/// [`Sensor::track_frames`]): its cable inputs, and where its loops ended.
#[derive(Clone, Debug)]
pub struct Track {
    /// The cable inputs of the frame.
    inputs: Vec<CableControl>,
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

/// Whether two cable inputs are the same within [`SAME_INPUT`].
fn same_inputs(a: &[CableControl], b: &[CableControl]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(a, b)| match (a, b) {
            (CableControl::Force(a), CableControl::Force(b))
            | (CableControl::Displacement(a), CableControl::Displacement(b)) => {
                (a - b).abs() <= SAME_INPUT
            }
            _ => false,
        })
}

/// The per-recording state: the model and its features.
pub struct Sensor {
    /// The FE model (its cable controls are replaced per frame by recorded inputs).
    pub model: Model,
    /// Feature points on the surface.
    pub features: Vec<SurfaceFeature>,
    /// Parameters.
    pub params: SenseParams,
    /// A dense pool of features (same rules), from which those near a seen contact join
    /// the frame's features.
    pub local_pool: Vec<SurfaceFeature>,
    /// The camera centre in the robot frame (m).
    pub eye: [f64; 3],
    /// Crop box in the robot frame (m).
    pub bounds: [[f64; 3]; 2],
    /// The model's surface (triangles and nodes), computed once.
    pub surface: Surface,
    /// Free solves of the latest distinct actuator inputs (a stream repeats them).
    free_cache: Mutex<Vec<(Vec<CableControl>, Arc<FreeState>)>>,
    /// The free solve at the model file's own inputs (`None`: it failed), solved once: new
    /// inputs are solved warm from it, so a free solve does not depend on which frames came
    /// before it (or ran beside it, see [`Sensor::sense_frames`]).
    free_base: OnceLock<Option<Solution>>,
    /// Where the model's own cable inputs (used for frames without recorded ones) come
    /// from.
    model_inputs: ModelInputs,
}

/// Where the cable inputs of a frame without recorded ones come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModelInputs {
    /// The model file's `[[cables]]`.
    #[default]
    ModelFile,
    /// A calibration's ([`Sensor::use_calibrated_inputs`]).
    Calibration,
}

/// [`Sensor::sense_frames`] with `workers` tasks on rayon's pool, each taking the next of
/// `frames` as soon as it is free and sensing it with `one`; the results go to `emit` in
/// frame order, on the calling thread.
#[cfg(feature = "parallel")]
fn in_parallel<E>(
    frames: &[usize],
    workers: usize,
    one: &(impl Fn(usize) -> (SenseResult<Observation>, FrameReport) + Sync),
    mut emit: impl FnMut(&SenseResult<Observation>, FrameReport) -> Result<(), E>,
) -> Result<(), E> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let lead = 2 * workers;
    let (next, emitted, stop) = (
        AtomicUsize::new(0),
        AtomicUsize::new(0),
        AtomicBool::new(false),
    );
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::scope(|scope| {
        let (next, emitted, stop) = (&next, &emitted, &stop);
        // rayon's scope blocks its caller until every task is done: a helper thread waits
        // for it, while this one emits.
        scope.spawn(move || {
            rayon::scope(|tasks| {
                for _ in 0..workers {
                    let tx = tx.clone();
                    tasks.spawn(move |_| loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(&frame) = frames.get(i) else { break };
                        // Not too far ahead of the output.
                        while i >= emitted.load(Ordering::Acquire) + lead
                            && !stop.load(Ordering::Relaxed)
                        {
                            std::thread::sleep(std::time::Duration::from_micros(200));
                        }
                        if stop.load(Ordering::Relaxed) || tx.send((i, one(frame))).is_err() {
                            break;
                        }
                    });
                }
            });
        });
        let mut ready = std::collections::BTreeMap::new();
        let mut want = 0;
        for (i, done) in rx {
            ready.insert(i, done);
            while let Some((obs, report)) = ready.remove(&want) {
                want += 1;
                if let Err(e) = emit(&obs, report) {
                    stop.store(true, Ordering::Relaxed);
                    return Err(e);
                }
                emitted.store(want, Ordering::Release);
            }
        }
        Ok(())
    })
}

/// Frames [`Sensor::sense_frames`] senses side by side by default: one per thread of
/// rayon's pool (`RAYON_NUM_THREADS` or the cores), 1 without the `parallel` feature.
pub fn default_window() -> usize {
    #[cfg(feature = "parallel")]
    {
        rayon::current_num_threads()
    }
    #[cfg(not(feature = "parallel"))]
    {
        1
    }
}

/// Locations tried, per round of a frame's location choice, after the chosen one could not
/// be estimated (each next-best by the same choice without the failed ones).
const LOCATION_RETRIES: usize = 2;

/// Free solves kept by a [`Sensor`]: one per distinct actuator input, the latest ones.
const FREE_CACHE: usize = 8;

/// The free equilibrium of one actuator input, and a solver state there (elements
/// evaluated, tangent with the cables factorized; `None` if that failed): every frame's
/// sensing loop starts from it, so its first FE update costs neither (see
/// [`crate::inverse::frame::estimate`]).
struct FreeState {
    solution: Solution,
    solver: Option<SolverState>,
}

/// Cable inputs closer than this (m or N) are the same input for the free-solve cache: far
/// below what moves the FE state by more than the Newton tolerance.
pub const SAME_INPUT: f64 = 1e-12;

impl Sensor {
    /// Prepares the features (flat patches the camera at `robot_from_camera` sees).
    pub fn new(model: Model, robot_from_camera: [[f64; 4]; 4], mut params: SenseParams) -> Self {
        let eye = [0, 1, 2].map(|r| robot_from_camera[r][3]);
        params.features.eye = Some(eye);
        let surface = model.problem.mesh.surface();
        let features = surface_features(
            &model.problem.mesh.nodes_in_rest,
            &surface,
            &params.features,
        );
        let local_pool = if params.local_features_radius > 0.0 {
            surface_features(
                &model.problem.mesh.nodes_in_rest,
                &surface,
                &FeatureParams {
                    count: params.local_feature_pool,
                    ..params.features.clone()
                },
            )
        } else {
            Vec::new()
        };
        // The pool's farthest-point sampling starts like the global one's, so it holds the
        // global features too (on the bundled robot 300 of its 395): near a contact they are
        // registered twice, and count twice. Known and kept, for now: dropping the repeats
        // (tried 2026-11-24) moved the force errors within their noise (held-out probe
        // frames 25 -> 24 of 32 within 5%, noise draws of the two-probe frames 42 -> 44 of
        // 54) but lowered the residual spread of frames whose force sits a node off, so two
        // of them (13.6% and 18.3% off) passed the fit check (`poor_fit`) they had failed.
        // Weighting the rows near a contact on purpose would have to keep that check sharp.
        let [lo, hi] = model.problem.mesh.bbox();
        let m = params.crop_margin;
        let bounds = [
            [lo[0] - m, lo[1] - m, lo[2] + params.table_clearance],
            [hi[0] + m, hi[1] + m, hi[2] + m],
        ];
        Self {
            model,
            features,
            params,
            local_pool,
            eye,
            bounds,
            surface,
            free_cache: Mutex::new(Vec::new()),
            free_base: OnceLock::new(),
            model_inputs: ModelInputs::ModelFile,
        }
    }

    /// Where the cable inputs of frames without recorded ones come from.
    pub fn model_inputs(&self) -> ModelInputs {
        self.model_inputs
    }

    /// Takes the cable inputs a calibration found (thesis 3.3: the camera pose and the
    /// initial actuator inputs) as the model's own, for frames without recorded inputs:
    /// each cable keeps the model file's control and takes the calibrated value of it (a
    /// displacement-controlled cable its shortening, a force-controlled one its tension).
    /// Recorded inputs ([`Recording::actuators_of`]) still take precedence. A calibrated
    /// cable the model does not have, or a value that is not finite, is refused: the
    /// calibration is of another model.
    pub fn use_calibrated_inputs(&mut self, calibrated: &[ActuatorCalibration]) -> SenseResult<()> {
        let mut cables = self.model.problem.cables.clone();
        for a in calibrated {
            let c = cables
                .iter_mut()
                .find(|c| c.name == a.name)
                .ok_or_else(|| {
                    SenseError::Calibration(format!(
                        "the model has no cable named {:?} (its cables: {})",
                        a.name,
                        self.model
                            .problem
                            .cables
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })?;
            if !(a.tension.is_finite() && a.shortening.is_finite()) {
                return Err(SenseError::Calibration(format!(
                    "cable {:?}: tension {} N, shortening {} m",
                    a.name, a.tension, a.shortening
                )));
            }
            c.control = match c.control {
                CableControl::Displacement(_) => CableControl::Displacement(a.shortening),
                CableControl::Force(_) => CableControl::Force(a.tension),
            };
        }
        self.model.problem.cables = cables;
        // The free solves were of the old inputs.
        self.free_base = OnceLock::new();
        self.free_cache = Mutex::new(Vec::new());
        self.model_inputs = ModelInputs::Calibration;
        Ok(())
    }

    /// Where objects touch the robot in `obs` (robot frame): the contacts a frame is sensed
    /// with (`SenseParams::contact`), none when no object point is in the crop.
    pub fn contacts(
        &self,
        obs: &Observation,
    ) -> Result<Vec<Contact>, crate::segment::SegmentError> {
        if obs.objects.is_empty() {
            return Ok(Vec::new());
        }
        let robot: Vec<[f32; 3]> = obs.robot.iter().map(|p| p.map(|c| c as f32)).collect();
        detect_contacts(&robot, &obs.objects, &self.params.contact)
    }

    /// Reads `frame` of `rec`, cropped to the robot's box, split by the colour model.
    pub fn observe(&self, rec: &Recording, frame: usize) -> SenseResult<Observation> {
        rec.observe(frame, &self.params, Some(self.bounds))
    }

    /// The free solve (no loads) of `model`, cached per distinct cable inputs. Inputs equal
    /// within [`SAME_INPUT`] share a solve (recorded shortenings differ by round-off from
    /// frame to frame); a new input is solved warm from the latest cached one.
    fn free_solve(&self, model: &Model) -> crate::fem::FemResult<Arc<FreeState>> {
        let key: Vec<CableControl> = model.problem.cables.iter().map(|c| c.control).collect();
        let same = |a: &[CableControl]| same_inputs(a, &key);
        let hit = match self.free_cache.lock() {
            Ok(cache) => cache.iter().find(|e| same(&e.0)).map(|e| e.1.clone()),
            Err(_) => None,
        };
        if let Some(s) = hit {
            return Ok(s);
        }
        let base = self.free_base.get_or_init(|| {
            self.model
                .problem
                .solve_static(&self.model.newton)
                .ok()
                .filter(|s| s.converged)
        });
        let s = match base {
            Some(start) => model.problem.solve_static_from(&model.newton, start)?,
            None => model.problem.solve_static(&model.newton)?,
        };
        let s = Arc::new(FreeState {
            solver: free_solver_state(model, &s),
            solution: s,
        });
        if let Ok(mut cache) = self.free_cache.lock() {
            // Frames sensed side by side may both have solved this input.
            if !cache.iter().any(|e| same(&e.0)) {
                if cache.len() >= FREE_CACHE {
                    cache.remove(0);
                }
                cache.push((key, Arc::clone(&s)));
            }
        }
        Ok(s)
    }

    /// The candidate forces at surface node `node` with outward normal `normal`: a pushing
    /// force along the inward normal, and with `three_d` two free tangential ones.
    fn candidates_at(&self, node: usize, normal: [f64; 3]) -> Vec<Candidate> {
        let inward = normal.map(|v| -v);
        let mut c = vec![Candidate::at_node(node, inward)];
        if self.params.three_d {
            let (t1, t2) = tangents(inward);
            for t in [t1, t2] {
                c.push(Candidate {
                    at: MappedPoint::node(node),
                    direction: t,
                    push_only: false,
                });
            }
        }
        c
    }

    /// The model with `actuators` as its cable controls (by name; unknown names ignored).
    fn actuated(&self, actuators: Option<&[ActuatorTruth]>) -> Model {
        let mut model = self.model.clone();
        model.problem.loads.clear();
        for a in actuators.unwrap_or_default() {
            if let Some(c) = model.problem.cables.iter_mut().find(|c| c.name == a.name) {
                c.control = if a.displacement_controlled {
                    CableControl::Displacement(a.shortening)
                } else {
                    CableControl::Force(a.tension)
                };
            }
        }
        model
    }

    /// Senses one frame. Never fails: problems are in the report's status.
    pub fn sense(
        &self,
        frame: usize,
        obs: &Observation,
        actuators: Option<&[ActuatorTruth]>,
    ) -> FrameReport {
        self.sense_with(frame, obs, actuators, None, false).0
    }

    /// [`Sensor::sense`], starting from `prev`, what the previous frame of a stream left,
    /// when the cable inputs are the same and its contacts are seen again (each within
    /// [`SenseParams::track_radius`]): the previous locations and forces start the loop,
    /// while the location choice is made at the previous state; if it keeps the locations
    /// the estimate stands (else it is made again at the estimated state, and a new
    /// location is estimated as in an untracked frame). A frame without contacts after one
    /// without contacts resumes each declared force point's loop. Returns the report
    /// ([`FrameReport::tracked`] says whether it started from `prev`) and what this frame
    /// leaves for the next (`None` when it failed or was flagged unreliable).
    pub fn sense_tracked(
        &self,
        frame: usize,
        obs: &Observation,
        actuators: Option<&[ActuatorTruth]>,
        prev: Option<&Track>,
    ) -> (FrameReport, Option<Track>) {
        self.sense_with(frame, obs, actuators, prev, true)
    }

    fn sense_with(
        &self,
        frame: usize,
        obs: &Observation,
        actuators: Option<&[ActuatorTruth]>,
        prev: Option<&Track>,
        want_track: bool,
    ) -> (FrameReport, Option<Track>) {
        let t0 = std::time::Instant::now();
        let mut report = FrameReport::empty(frame, FrameStatus::Sensed);
        report.robot_points = obs.robot.len();
        report.object_points = obs.objects.len();
        report.features = self.features.len();
        if actuators.is_none() {
            report.warnings.push(match self.model_inputs {
                ModelInputs::ModelFile => {
                    "no recorded actuator inputs: the model file's are used".into()
                }
                ModelInputs::Calibration => {
                    "no recorded actuator inputs: the calibrated ones are used".into()
                }
            });
        }
        report.timings = obs.timings;
        let track = match self.sense_into(obs, actuators, prev, want_track, &mut report) {
            Ok(track) => track.filter(|_| report.reliable),
            Err(status) => {
                report.status = status;
                None
            }
        };
        report.ms = ms(t0.elapsed());
        let t = &mut report.timings;
        t.total = t.read + t.crop + t.segment + report.ms;
        (report, track)
    }

    /// Observes and senses `frames` of `rec` as a stream, one after the other, each
    /// starting from what the one before left ([`Sensor::sense_tracked`]), and hands each
    /// observation and report to `emit` in order. The next frame is read and segmented
    /// while this one is sensed (on a second thread). On a real stream, where the load
    /// hardly changes from one frame to the next, a tracked frame needs one location choice
    /// instead of two, made beside its estimate, and one loop of two FE updates (the first
    /// almost free) instead of two loops from the unloaded state. A frame depends on the
    /// ones before it (unlike [`Sensor::sense_frames`]), but not on the thread count. Stops
    /// at the first error of `emit`.
    ///
    /// ```no_run
    /// # use softsense::sense::{Recording, SenseParams, Sensor};
    /// # use softsense::fem::model::Model;
    /// let rec = Recording::open("clouds/scenes/probe_press".as_ref())?;
    /// let model = Model::load("meshes/models/robot.toml".as_ref(), None)?;
    /// let sensor = Sensor::new(model, rec.robot_from_camera, SenseParams::default());
    /// sensor.track_frames(&rec, &rec.frames, |_obs, report| {
    ///     let tracked = if report.tracked { "tracked" } else { "cold" };
    ///     println!("frame {} ({tracked}): {}", report.frame, report.status);
    ///     Ok::<(), std::io::Error>(())
    /// })?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn track_frames<E>(
        &self,
        rec: &Recording,
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
                    Ok(o) => self.sense_tracked(frame, o, rec.actuators_of(frame), prev.as_ref()),
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

    /// Observes and senses `frames` of `rec`, up to `window` frames at a time in parallel,
    /// and hands each observation and report to `emit` in frame order (`window` 0 or 1, or
    /// without the `parallel` feature: one at a time). Frames are independent, so a report
    /// is the one [`Sensor::sense`] gives for its frame alone, whatever the window and
    /// thread count. An unreadable frame gets [`FrameStatus::Unreadable`]. Stops at the
    /// first error of `emit` (frames already being sensed are finished and dropped).
    ///
    /// The frames are `window` tasks on rayon's pool, each taking the next frame as soon as
    /// it is free; a frame's own parallel stages (element evaluations, location QPs) nest in
    /// the same pool, so a core whose task has run out of frames helps the ones still
    /// running. Much of a frame's FE work is serial (sparse Cholesky, scatter), so on two
    /// cores two frames side by side get through more frames per second than one at a time,
    /// each taking longer. Until 2026-11-26 the frames went in pairs in lockstep, and a
    /// pair waited for its slower frame: against that, measured in 8 paired rounds, probe
    /// frames (some take a second estimate) stream 1.26 times (probe_side) and 1.28 times
    /// (two_probes) as fast, the even tip_weight frames 0.98 times. A task runs at most
    /// `2 * window` frames ahead of the last one emitted.
    ///
    /// ```no_run
    /// # use softsense::sense::{Recording, SenseParams, Sensor};
    /// # use softsense::fem::model::Model;
    /// let rec = Recording::open("clouds/scenes/tip_weight".as_ref())?;
    /// let model = Model::load("meshes/models/robot.toml".as_ref(), None)?;
    /// let sensor = Sensor::new(model, rec.robot_from_camera, SenseParams::default());
    /// sensor.sense_frames(&rec, &rec.frames, 2, |_obs, report| {
    ///     println!("frame {}: {}", report.frame, report.status);
    ///     Ok::<(), std::io::Error>(())
    /// })?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn sense_frames<E>(
        &self,
        rec: &Recording,
        frames: &[usize],
        window: usize,
        mut emit: impl FnMut(&SenseResult<Observation>, FrameReport) -> Result<(), E>,
    ) -> Result<(), E> {
        let one = |frame: usize| {
            let obs = self.observe(rec, frame);
            let report = match &obs {
                Ok(o) => self.sense(frame, o, rec.actuators_of(frame)),
                Err(e) => FrameReport::empty(frame, FrameStatus::Unreadable(e.to_string())),
            };
            (obs, report)
        };
        #[cfg(feature = "parallel")]
        if window.min(frames.len()) > 1 {
            return in_parallel(frames, window.min(frames.len()), &one, emit);
        }
        #[cfg(not(feature = "parallel"))]
        let _ = window;
        for &frame in frames {
            let (obs, report) = one(frame);
            emit(&obs, report)?;
        }
        Ok(())
    }

    /// Whether a frame with cable inputs `inputs` and contacts seen at `centroids` can
    /// start from `track`: the same inputs, and each contact within
    /// [`SenseParams::track_radius`] of exactly one of the track's (contact detection does
    /// not keep an order from frame to frame). Returns, for each contact, the track's.
    fn track_order(
        &self,
        track: &Track,
        inputs: &[CableControl],
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
        if !same_inputs(&track.inputs, inputs)
            || candidates.is_empty()
            || seen.len() != centroids.len()
        {
            return None;
        }
        let r2 = self.params.track_radius.powi(2);
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

    fn sense_into(
        &self,
        obs: &Observation,
        actuators: Option<&[ActuatorTruth]>,
        prev: Option<&Track>,
        want_track: bool,
        report: &mut FrameReport,
    ) -> Result<Option<Track>, FrameStatus> {
        if obs.robot.len() < 50 {
            return Err(FrameStatus::NoRobot);
        }
        let model = self.actuated(actuators);
        let fail = |e: &dyn std::fmt::Display| FrameStatus::NotSolved(e.to_string());
        let clock = std::time::Instant::now();
        let free = self.free_solve(&model).map_err(|e| fail(&e))?;
        report.timings.free_solve = ms(clock.elapsed());
        let clock = std::time::Instant::now();
        let contacts = self.contacts(obs).map_err(|e| fail(&e))?;
        report.timings.contacts = ms(clock.elapsed());
        if contacts.len() > self.params.max_contacts {
            return Err(FrameStatus::TooManyContacts {
                seen: contacts.len(),
                max: self.params.max_contacts,
            });
        }
        let surface = &self.surface;
        let mut features = self.features.clone();
        let r2 = self.params.local_features_radius.powi(2);
        features.extend(self.local_pool.iter().filter(|f| {
            let p = f.position(&free.solution.positions);
            contacts.iter().any(|c| {
                let d = sub(p, c.centroid.map(|v| v as f64));
                dot(d, d) <= r2
            })
        }));
        report.features = features.len();
        let features = &features;
        let clock = std::time::Instant::now();
        let registrar = Registrar::new(&obs.robot);
        report.timings.register += ms(clock.elapsed());
        let solve_with = |cands: &[Candidate], params: &FrameParams| {
            estimate(
                &model,
                &registrar,
                features,
                cands,
                Some(&free.solution),
                free.solver.clone(),
                params,
            )
        };
        let solve = |cands: &[Candidate]| solve_with(cands, &self.params.frame);
        let inputs: Vec<CableControl> = model.problem.cables.iter().map(|c| c.control).collect();
        // A frame without contacts: each force point's estimate (the chosen one's taken out
        // for the report until the end), and which was chosen.
        let mut point_ends: Vec<Option<FrameEstimate>> = Vec::new();
        let mut chosen_point: Option<usize> = None;
        let (est, cands, groups) = if contacts.is_empty() {
            // Declared force points: the one explaining the frame best (estimated in
            // parallel, chosen in model order).
            if !model.force_points.is_empty() {
                report.warnings.push(format!(
                    "no contact seen: the model's {} declared force point(s) are the candidates",
                    model.force_points.len()
                ));
            }
            let sets: Vec<Vec<Candidate>> = model
                .force_points
                .iter()
                .map(|fp| {
                    fp.rows
                        .iter()
                        .map(|r| Candidate {
                            at: fp.point,
                            direction: r.entries.iter().fold([0.0; 3], |a, e| {
                                [a[0] + e.1[0], a[1] + e.1[1], a[2] + e.1[2]]
                            }),
                            push_only: true,
                        })
                        .collect()
                })
                .collect();
            // Tracked: each force point's loop resumes where the previous frame's ended.
            let ends = prev
                .filter(|t| same_inputs(&t.inputs, &inputs))
                .and_then(|t| match &t.ends {
                    Ends::ForcePoints(e) if e.len() == sets.len() => Some(e),
                    _ => None,
                });
            let index: Vec<usize> = (0..sets.len()).collect();
            let results = par_map(&index, |&i| match ends.and_then(|e| e[i].as_ref()) {
                Some(e) => estimate_from(
                    &model,
                    &registrar,
                    features,
                    &sets[i],
                    e.solution.as_ref(),
                    e.solver.clone(),
                    Some(&e.applied),
                    &self.params.frame,
                ),
                None => solve(&sets[i]),
            });
            report.tracked = ends.is_some_and(|e| e.iter().any(Option::is_some));
            for (fp, result) in model.force_points.iter().zip(results) {
                match result {
                    Ok(e) => {
                        report.account(&e);
                        let residual = e.estimate.residual_rms;
                        let better = chosen_point.is_none_or(|b| {
                            point_ends[b]
                                .as_ref()
                                .is_some_and(|c| residual < c.estimate.residual_rms)
                        });
                        if better {
                            chosen_point = Some(point_ends.len());
                        }
                        point_ends.push(Some(e));
                    }
                    Err(e) => {
                        report
                            .warnings
                            .push(format!("force point {}: {e}", fp.name));
                        point_ends.push(None);
                    }
                }
            }
            let best = chosen_point.and_then(|b| {
                let g = Group {
                    source: format!("force point {}", model.force_points[b].name),
                    seen_at: None,
                    points: 0,
                    node: None,
                    range: 0..sets[b].len(),
                };
                Some((point_ends[b].take()?, sets[b].clone(), vec![g]))
            });
            match best {
                Some(b) => b,
                None if model.force_points.is_empty() => {
                    report.warnings.push(
                        "no contact seen and the model declares no force points: only the actuators are estimated".into(),
                    );
                    let est = solve(&[]).map_err(|e| fail(&e))?;
                    report.account(&est);
                    (est, Vec::new(), Vec::new())
                }
                None => return Err(FrameStatus::NotSolved("every force point failed".into())),
            }
        } else {
            // Seen contacts: the options of each are the surface nodes near its centroid;
            // the data choose among them (linearised), at the actuated state and once more
            // at the estimated state.
            // Where the choice linearises: node positions, cable tensions and a solver
            // state there (the free equilibrium's, then the last estimate's).
            let mut x = free.solution.positions.clone();
            let mut tensions = free.solution.cable_tension.clone();
            let mut state = free.solver.clone();
            // The chosen node of each contact.
            let mut chosen: Vec<usize> = Vec::new();
            let mut out = None;
            let mut first_round = 0;
            let centroids: Vec<[f64; 3]> = contacts
                .iter()
                .map(|c| c.centroid.map(|v| v as f64))
                .collect();
            // The report group of contact `i` located at `node`, its candidates at `range`.
            let contact_group = |i: usize, node: usize, range: std::ops::Range<usize>| Group {
                source: "contact".into(),
                seen_at: Some(centroids[i]),
                points: contacts[i].points,
                node: Some(node),
                range,
            };
            // The options of each contact (surface nodes near its centroid at node positions
            // `x`, and their candidates) and the data's choice among them, linearised at
            // `x` with `state` (a solver state there, if any).
            let choose = |x: &[[f64; 3]],
                          tensions: &[f64],
                          state: Option<SolverState>,
                          excluded: &[Vec<usize>]| {
                let normals = vertex_normals(x, &surface.triangles);
                let options: Vec<(Vec<usize>, Vec<Vec<Candidate>>)> = contacts
                    .iter()
                    .map(|c| {
                        let nodes = near_nodes(
                            x,
                            &surface.nodes,
                            c.centroid.map(|v| v as f64),
                            self.params.location_radius,
                            self.params.location_options,
                        );
                        let opts = nodes
                            .iter()
                            .map(|&n| self.candidates_at(n, normals[n]))
                            .collect();
                        (nodes, opts)
                    })
                    .collect();
                let all: Vec<Vec<Vec<Candidate>>> = options.iter().map(|o| o.1.clone()).collect();
                let choice = choose_locations(
                    &model,
                    &registrar,
                    features,
                    &all,
                    LinearisationPoint {
                        positions: x,
                        tensions,
                        state,
                    },
                    &self.params.frame,
                    self.params.max_combinations,
                    excluded,
                )?;
                let picked: Vec<usize> = choice
                    .pick
                    .iter()
                    .zip(&options)
                    .map(|(&k, (nodes, _))| nodes[k])
                    .collect();
                Ok::<_, crate::inverse::InverseError>((options, choice, picked))
            };
            // A tracked frame: the loop starts from the previous frame's locations and
            // forces, and, at the same time, the data choose the locations linearised at
            // the previous frame's state (nearer than the free one). If they keep the
            // previous locations the estimate stands; else the choice is made again at the
            // estimated state, as in an untracked frame's second round.
            let resumable = prev.and_then(|t| {
                let order = self.track_order(t, &inputs, &centroids)?;
                let Ends::Contacts {
                    nodes: t_nodes,
                    candidates: t_candidates,
                    ranges: t_ranges,
                    estimate,
                    ..
                } = &t.ends
                else {
                    return None;
                };
                // The track's locations, candidates and forces in this frame's contact order.
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
                Some((estimate, nodes, candidates, applied, ranges))
            });
            if let Some((t, nodes, candidates, applied, ranges)) = resumable {
                let (tracked, choice) = crate::search::join(
                    crate::search::Parallelism::Rayon,
                    || {
                        estimate_from(
                            &model,
                            &registrar,
                            features,
                            &candidates,
                            t.solution.as_ref(),
                            t.solver.clone(),
                            Some(&applied),
                            &self.params.frame,
                        )
                    },
                    || {
                        let clock = std::time::Instant::now();
                        let c = choose(&t.positions, tensions_of(t), t.solver.clone(), &[]);
                        (c, ms(clock.elapsed()))
                    },
                );
                report.timings.mapping += choice.1;
                match tracked {
                    Ok(mut est) => {
                        report.account(&est);
                        report.tracked = true;
                        let groups = (0..contacts.len())
                            .map(|i| contact_group(i, nodes[i], ranges[i].clone()))
                            .collect();
                        x = est.positions.clone();
                        tensions = tensions_of(&est).to_vec();
                        state = est.solver.take();
                        let kept = matches!(&choice.0, Ok((_, _, picked)) if *picked == nodes);
                        chosen = nodes;
                        out = Some((est, candidates, groups));
                        first_round = if kept { 2 } else { 1 };
                    }
                    Err(e) => report.warnings.push(format!(
                        "not tracked: the estimate from the previous frame's failed ({e}); sensed from the unloaded state"
                    )),
                }
            }
            // The rounds of the choice: the first at the free state (its estimate a preview,
            // see `SenseParams::preview_updates`), one at the preview's state, then up to
            // `location_checks` at estimated states; each that picks other locations than
            // the last estimate's has them estimated.
            let preview_updates = self.params.preview_updates;
            // The first update is at the free state itself: a preview needs two.
            let previews = preview_updates >= 2;
            // A preview's estimate goes on from where it stopped.
            let finish = |p: &FrameEstimate, cands: &[Candidate], state: Option<SolverState>| {
                estimate_onwards(
                    &model,
                    &registrar,
                    features,
                    cands,
                    p,
                    state,
                    &self.params.frame,
                )
            };
            let mut rounds = match first_round {
                0 => 1 + usize::from(previews) + self.params.location_checks,
                1 => self.params.location_checks,
                _ => 0,
            };
            // Whether `out` is a preview: an estimate stopped after `preview_updates` FE
            // updates before it settled.
            let mut partial = false;
            // Whether the choice linearises at the free state (`x` is its positions).
            let mut at_free = first_round == 0;
            'rounds: while rounds > 0 {
                rounds -= 1;
                // Combinations whose estimate failed in this round (the FE model could not
                // carry the estimated load there, e.g. an element inverted under a point
                // load at a corner node): the next-best one is estimated instead.
                let mut failed: Vec<Vec<usize>> = Vec::new();
                // Why the last of them failed.
                let mut last_failure = None;
                loop {
                    let clock = std::time::Instant::now();
                    // The last estimate's state also starts the next frame, and a preview's
                    // goes on if its locations stand.
                    let choice = choose(
                        &x,
                        &tensions,
                        if want_track || partial {
                            state.clone()
                        } else {
                            state.take()
                        },
                        &failed,
                    );
                    report.timings.mapping += ms(clock.elapsed());
                    let (options, choice, picked) = match (choice, last_failure.take()) {
                        (Ok(c), failure) => {
                            if let Some(e) = failure {
                                report.warnings.push(format!(
                                    "{e}; the next-best location is estimated instead"
                                ));
                            }
                            c
                        }
                        // No location left to try (e.g. a contact with a single option).
                        (Err(_), Some(e)) if out.is_some() => {
                            report.warnings.push(format!(
                                "{e}; no other location is left: the last estimate's location is kept"
                            ));
                            break 'rounds;
                        }
                        (Err(_), Some(e)) => return Err(FrameStatus::NotSolved(e)),
                        (Err(e), None) => return Err(fail(&e)),
                    };
                    let pick = choice.pick.clone();
                    let stands = picked == chosen && out.is_some();
                    if stands && !std::mem::take(&mut partial) {
                        break 'rounds;
                    }
                    let (solved, cands, groups, preview) = if stands {
                        // The preview's locations stand: its estimate goes on from where it
                        // stopped.
                        let Some((p, cands, groups)) = out.take() else {
                            unreachable!("a preview is an estimate")
                        };
                        (finish(&p, &cands, state.take()), cands, groups, false)
                    } else {
                        let mut cands = Vec::new();
                        let mut groups = Vec::new();
                        for (i, ((nodes, opts), &k)) in options.iter().zip(&pick).enumerate() {
                            let start = cands.len();
                            cands.extend_from_slice(&opts[k]);
                            groups.push(contact_group(i, nodes[k], start..cands.len()));
                        }
                        // The first estimate of an untracked frame is a preview.
                        let preview = out.is_none() && first_round == 0 && previews;
                        let solved = if !preview {
                            solve_with(&cands, &self.params.frame)
                        } else {
                            let params = FrameParams {
                                max_updates: preview_updates,
                                ..self.params.frame.clone()
                            };
                            if at_free {
                                // The choice's QP at the free state is the loop's first
                                // update there.
                                estimate_after_choice(
                                    &model,
                                    &registrar,
                                    features,
                                    &cands,
                                    &free.solution,
                                    free.solver.clone(),
                                    &choice,
                                    &params,
                                )
                            } else {
                                solve_with(&cands, &params)
                            }
                        };
                        (solved, cands, groups, preview)
                    };
                    match solved {
                        Ok(mut est) => {
                            report.account(&est);
                            partial = preview && !est.settled;
                            chosen = picked;
                            x = est.positions.clone();
                            at_free = false;
                            tensions = tensions_of(&est).to_vec();
                            state = est.solver.take();
                            out = Some((est, cands, groups));
                            break;
                        }
                        Err(e) if failed.len() < LOCATION_RETRIES => {
                            last_failure = Some(format!(
                                "contact location (nodes {picked:?}) could not be estimated ({e})"
                            ));
                            failed.push(pick);
                        }
                        Err(e) if out.is_some() => {
                            report.warnings.push(format!(
                                "contact location (nodes {picked:?}) could not be estimated ({e}); the last estimate's location is kept"
                            ));
                            break 'rounds;
                        }
                        Err(e) => return Err(fail(&e)),
                    }
                }
            }
            // A preview left standing (its locations' next-best could not be estimated) is
            // finished.
            if std::mem::take(&mut partial) {
                if let Some((p, cands, groups)) = out.take() {
                    let mut est = finish(&p, &cands, state.take()).map_err(|e| fail(&e))?;
                    report.account(&est);
                    state = est.solver.take();
                    out = Some((est, cands, groups));
                }
            }
            let mut out = out.ok_or_else(|| FrameStatus::NotSolved("no estimate".into()))?;
            // `state` is the last estimate's solver state.
            out.0.solver = state;
            out
        };
        let mut est = est;
        est.use_shared_point_uncertainty(&registrar, features, &self.params.frame.register);
        let e = &est.estimate;
        report.features_visible = est.visible;
        report.positions.clone_from(&est.positions);
        report.residual_rms = e.residual_rms;
        report.updates = est.updates;
        let noise = self.params.frame.intensity.sensor_sigma;
        report.residual_robust = e.residual_robust;
        let fits = e.residual_robust <= self.params.poor_fit * noise;
        report.reliable = est.settled && fits;
        if !est.settled {
            report.warnings.push(format!(
                "unreliable: the forces did not settle within {} FE updates",
                est.updates
            ));
        }
        if !fits {
            report.warnings.push(format!(
                "unreliable: the residual's robust spread ({:.3} mm) is {:.1} times the expected noise ({:.3} mm): the model cannot explain this frame with its force locations (a contact not seen, a wrong location, or a deformation the loop did not follow)",
                e.residual_robust * 1e3,
                e.residual_robust / noise,
                noise * 1e3
            ));
        }
        report.identifiability = Some(e.identifiability.clone());
        if let Some(w) = &e.identifiability.warning {
            report.reliable = false;
            report.warnings.push(format!("unreliable: {w}"));
        }
        if let Some(w) = e.regularization_warning() {
            report.warnings.push(w);
        }
        report.actuators = model
            .problem
            .cables
            .iter()
            .map(|c| c.name.clone())
            .zip(e.actuator_forces.iter().copied())
            .collect();
        // What the contacts of a tracked frame leave: where seen, the chosen node, the range.
        type Seen = (Option<[f64; 3]>, Option<usize>, std::ops::Range<usize>);
        let seen: Vec<Seen> = if want_track && chosen_point.is_none() {
            groups
                .iter()
                .map(|g| (g.seen_at, g.node, g.range.clone()))
                .collect()
        } else {
            Vec::new()
        };
        for g in groups {
            let mut f = [0.0; 3];
            let mut var = 0.0;
            for k in g.range.clone() {
                let d = unit(cands[k].direction);
                for q in 0..3 {
                    f[q] += e.forces[k] * d[q];
                }
            }
            let magnitude = norm(f);
            // The components' (co)variance: the sandwich's when the estimate has it, else
            // the independent σ.
            let cov_kl = |k: usize, l: usize| match &e.force_covariance {
                Some(cov) if cov.nrows() == cands.len() => cov[(k, l)],
                _ if k == l => e.force_sigma.get(k).copied().unwrap_or(f64::NAN).powi(2),
                _ => 0.0,
            };
            // Magnitude sigma: that (co)variance projected on the force direction.
            let proj = |k: usize| {
                if magnitude > 0.0 {
                    dot(unit(cands[k].direction), f) / magnitude
                } else {
                    1.0
                }
            };
            // The same in the robot frame: Σ_kl u_k u_lᵀ cov_kl.
            let mut covariance = [[0.0; 3]; 3];
            for k in g.range.clone() {
                let uk = unit(cands[k].direction);
                for l in g.range.clone() {
                    let ul = unit(cands[l].direction);
                    let c = cov_kl(k, l);
                    var += proj(k) * proj(l) * c;
                    for (a, row) in covariance.iter_mut().enumerate() {
                        for (b, v) in row.iter_mut().enumerate() {
                            *v += uk[a] * ul[b] * c;
                        }
                    }
                }
            }
            let var = var.max(0.0);
            let at = cands[g.range.start].at.position(&est.positions);
            report.forces.push(ForceEstimate {
                source: g.source,
                seen_at: g.seen_at,
                contact_points: g.points,
                location: at,
                node: g.node,
                force: f,
                magnitude,
                sigma: var.sqrt(),
                sigma_max: largest_sigma(&covariance),
                covariance,
            });
        }
        for (i, f) in report.forces.iter().enumerate() {
            if f.magnitude > 2.0 * f.sigma_max
                && f.sigma_max > self.params.direction_warning * f.magnitude
            {
                // The longest axis is along the force when the magnitude's σ is most of it.
                let what = if f.sigma >= 0.5 * f.sigma_max {
                    "its magnitude"
                } else {
                    "its direction"
                };
                report.warnings.push(format!(
                    "force {i}: {what} is uncertain: 3-D σ {:.1} mN is {:.1}% of |F| (more than {:.1}%), σ of |F| {:.1} mN",
                    f.sigma_max * 1e3,
                    100.0 * f.sigma_max / f.magnitude,
                    100.0 * self.params.direction_warning,
                    f.sigma * 1e3
                ));
            }
        }
        if est.visible == 0 {
            return Err(FrameStatus::NoFeatures);
        }
        if !want_track {
            return Ok(None);
        }
        let ends = if let Some(b) = chosen_point {
            point_ends[b] = Some(est);
            Ends::ForcePoints(point_ends)
        } else {
            let mut centroids = Vec::new();
            let mut nodes = Vec::new();
            let mut ranges = Vec::new();
            for (at, node, range) in seen {
                // Only seen contacts are followed (not the actuators-only estimate).
                let (Some(at), Some(node)) = (at, node) else {
                    return Ok(None);
                };
                centroids.push(at);
                nodes.push(node);
                ranges.push(range);
            }
            if centroids.is_empty() {
                return Ok(None);
            }
            Ends::Contacts {
                centroids,
                nodes,
                candidates: cands,
                ranges,
                estimate: Box::new(est),
            }
        };
        Ok(Some(Track { inputs, ends }))
    }
}

/// A solver state at the free equilibrium `free` of `model` (without loads): elements
/// evaluated and the tangent with the cables' geometric stiffness factorized, as the
/// sensing loop's first FE update leaves it. `None` if either fails (the loop then does
/// both itself, and fails or falls back as it does without the state).
fn free_solver_state(model: &Model, free: &Solution) -> Option<SolverState> {
    let base = model.problem.without_loads();
    let mut solver = base.solver().ok()?;
    let x = &free.positions;
    solver.assemble(x, model.newton.tangent).ok()?;
    factorize_loop_tangent(&mut solver, x, &free.cable_tension, model.newton.tangent).ok()?;
    Some(solver.into_state())
}

/// The cable tensions of an estimate's last FE state (none if it has none: a choice
/// linearised there then fails and says so).
fn tensions_of(est: &FrameEstimate) -> &[f64] {
    est.solution.as_ref().map_or(&[], |s| &s.cable_tension[..])
}

struct Group {
    source: String,
    seen_at: Option<[f64; 3]>,
    points: usize,
    node: Option<usize>,
    range: std::ops::Range<usize>,
}

/// Up to `max` of `nodes` within `radius` of `p` at positions `x`, nearest first (at least
/// the nearest one).
fn near_nodes(x: &[[f64; 3]], nodes: &[usize], p: [f64; 3], radius: f64, max: usize) -> Vec<usize> {
    let mut d: Vec<(f64, usize)> = nodes
        .iter()
        .map(|&n| {
            let v = sub(x[n], p);
            (dot(v, v), n)
        })
        .collect();
    d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let within = d
        .iter()
        .filter(|e| e.0 <= radius * radius)
        .count()
        .clamp(1, max.max(1));
    d.iter().take(within).map(|e| e.1).collect()
}

/// Two unit vectors completing `n` (unit) to an orthonormal basis.
fn tangents(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t1 = unit(cross(n, a));
    (t1, cross(n, t1))
}

/// The square root of a symmetric 3x3 covariance's largest eigenvalue (0 for a negative
/// one from rounding), NaN when an entry is not finite.
pub fn largest_sigma(covariance: &[[f64; 3]; 3]) -> f64 {
    if covariance.iter().flatten().any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let m = nalgebra::Matrix3::from_fn(|r, c| 0.5 * (covariance[r][c] + covariance[c][r]));
    m.symmetric_eigenvalues().max().max(0.0).sqrt()
}

/// Matches each true load to the nearest estimate and reports the errors.
pub fn compare(report: &FrameReport, truth: &FrameTruth) -> Vec<LoadError> {
    truth
        .loads
        .iter()
        .map(|l| {
            let best = report
                .forces
                .iter()
                .enumerate()
                .map(|(i, f)| (i, norm(sub(f.location, l.at_deformed))))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let mag = l.magnitude.max(f64::MIN_POSITIVE);
            match best {
                Some((i, d)) => {
                    let f = &report.forces[i];
                    LoadError {
                        truth_force: l.force,
                        truth_at: l.at_deformed,
                        estimate: Some(i),
                        location_error: d,
                        force_error: norm(sub(f.force, l.force)) / mag,
                        magnitude_error: (f.magnitude - l.magnitude).abs() / mag,
                    }
                }
                None => LoadError {
                    truth_force: l.force,
                    truth_at: l.at_deformed,
                    estimate: None,
                    location_error: f64::INFINITY,
                    force_error: 1.0,
                    magnitude_error: 1.0,
                },
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::largest_sigma;

    #[test]
    fn the_largest_sigma_of_a_rotated_covariance_is_its_longest_axis() {
        // diag(1, 4, 9) turned 30° about z: the axes keep their lengths.
        let (s, c) = (0.5f64, 3f64.sqrt() / 2.0);
        let r = nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let m = r
            * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 4.0, 9.0))
            * r.transpose();
        let cov = [0, 1, 2].map(|i| [0, 1, 2].map(|j| m[(i, j)]));
        assert!((largest_sigma(&cov) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_covariance_with_a_nan_has_no_largest_sigma() {
        let mut cov = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        cov[1][2] = f64::NAN;
        assert!(largest_sigma(&cov).is_nan());
        assert_eq!(largest_sigma(&[[0.0; 3]; 3]), 0.0);
    }
}

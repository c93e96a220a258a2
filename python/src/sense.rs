//! Recordings and sensing; a frame's report crosses as the JSON `softsense sense --json`
//! prints for it.

use crate::error;
use crate::model::Model;
use pyo3::prelude::*;
use softsense::render::scene3d::{self, SceneParams};
use softsense::sense::{
    compare, FrameReport, Observation, Registration, Rig, SenseParams, SenseResult, Sensor as Sen,
};

/// A recording folder of one camera, or of several (one sub-folder each), as `softsense
/// sense` reads it (docs/recording-format.md).
#[pyclass(module = "softsense._softsense", frozen)]
pub struct Recording(pub Rig);

#[pymethods]
impl Recording {
    /// Opens a recording folder; `pose` is a camera pose file used instead of the folder's
    /// (a one-camera folder only).
    #[staticmethod]
    #[pyo3(signature = (path, pose=None))]
    fn open(path: std::path::PathBuf, pose: Option<std::path::PathBuf>) -> PyResult<Self> {
        let mut rig = Rig::open(&path).map_err(error)?;
        if let Some(pose) = pose {
            rig = rig.with_pose_file(&pose).map_err(error)?;
        }
        Ok(Recording(rig))
    }

    /// The folder.
    #[getter]
    fn path(&self) -> std::path::PathBuf {
        self.0.dir.clone()
    }

    /// Frame numbers (of any camera).
    #[getter]
    fn frames(&self) -> Vec<usize> {
        self.0.frames.clone()
    }

    /// The cameras' names (`["camera"]` for a one-camera folder).
    #[getter]
    fn cameras(&self) -> Vec<String> {
        self.0.camera_names()
    }

    /// The camera pose of a one-camera folder, row-major 4x4 (p_robot = T p_camera), or
    /// None (no pose, or several cameras: see `camera_poses`).
    #[getter]
    fn robot_from_camera(&self) -> Option<[[f64; 4]; 4]> {
        match self.0.cameras.as_slice() {
            [one] => one
                .recording
                .robot_from_camera
                .as_ref()
                .map(|p| p.to_matrix()),
            _ => None,
        }
    }

    /// Every camera's pose (None where it has none), in camera order.
    #[getter]
    fn camera_poses(&self) -> Vec<Option<[[f64; 4]; 4]>> {
        (self.0.cameras.iter())
            .map(|c| {
                c.recording
                    .robot_from_camera
                    .as_ref()
                    .map(|p| p.to_matrix())
            })
            .collect()
    }

    /// The model file the recording names (truth.json or calibration.json), or None.
    #[getter]
    fn model_path(&self) -> Option<std::path::PathBuf> {
        self.0.shared().model_path()
    }

    /// Warnings from opening the folder.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.0.warnings.clone()
    }
}

/// The sensing chain of one model and one recording (all its cameras fused).
#[pyclass(module = "softsense._softsense", frozen)]
pub struct Sensor {
    sensor: Sen,
    rec: Rig,
}

/// A frame's report as `softsense sense --json` prints it, with the errors against the
/// recording's truth when it has one.
fn json_of(rec: &Rig, mut report: FrameReport) -> PyResult<String> {
    if let Some(t) = rec.shared().truth_of(report.frame) {
        report.errors = Some(compare(&report, t));
    }
    serde_json::to_string(&report).map_err(error)
}

/// The first `n` frames of `rec` as the sensor's reference, and with `known_load` the
/// modulus calibrated on that frame, as `softsense sense --reference-frames
/// --known-load` does.
fn take_reference(
    sensor: &mut Sen,
    rec: &Rig,
    n: usize,
    known_load: Option<(usize, f64)>,
    sag: bool,
) -> PyResult<()> {
    if n == 0 {
        return match (known_load, sag) {
            (Some(_), _) => Err(error("known_load needs reference_frames")),
            (None, true) => Err(error("modulus_from_sag needs reference_frames")),
            (None, false) => Ok(()),
        };
    }
    if sag && known_load.is_some() {
        return Err(error("give known_load or modulus_from_sag, not both"));
    }
    if n >= rec.frames.len() {
        return Err(error(format!(
            "reference_frames {n}: the recording has {} frames; the reference must leave some to sense",
            rec.frames.len()
        )));
    }
    let frames = &rec.frames[..n];
    match known_load {
        Some((frame, _)) if !rec.frames.contains(&frame) || frames.contains(&frame) => Err(error(
            format!("known_load: frame {frame} is not a frame after the reference frames"),
        )),
        Some((frame, load)) => sensor
            .calibrate_modulus(rec, frames, frame, load, &Default::default())
            .map(|_| ())
            .map_err(error),
        None if sag => sensor
            .fit_modulus_from_sag(rec, frames, Default::default())
            .map(|_| ())
            .map_err(error),
        None => sensor
            .take_reference(rec, frames, Default::default())
            .map(|_| ())
            .map_err(error),
    }
}

#[pymethods]
impl Sensor {
    /// A sensor for `recording` with `model`, with `softsense sense`'s options: `features`
    /// (surface feature points), `registration` ("auto", "features" or "dense"),
    /// `robot_color` (sRGB), `max_contacts`, `reference_frames` (the first N frames, unloaded,
    /// as the reference), `known_load` ((frame, newtons): the modulus calibrated on it) and
    /// `modulus_from_sag` (the modulus from the reference frames' sag).
    /// The recording's cable inputs are used as the command line uses them (recorded, else
    /// its calibration's, else the model's).
    #[new]
    #[pyo3(signature = (model, recording, features=None, registration="auto", robot_color=(40, 200, 60), max_contacts=None, reference_frames=0, known_load=None, modulus_from_sag=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &Model,
        recording: &Recording,
        features: Option<usize>,
        registration: &str,
        robot_color: (u8, u8, u8),
        max_contacts: Option<usize>,
        reference_frames: usize,
        known_load: Option<(usize, f64)>,
        modulus_from_sag: bool,
    ) -> PyResult<Self> {
        let rec = recording.0.clone();
        let registration = match registration {
            "auto" => Registration::Auto,
            "features" => Registration::Features,
            "dense" => Registration::Dense,
            other => {
                return Err(error(format!(
                    "registration {other:?}: use \"auto\", \"features\" or \"dense\""
                )))
            }
        };
        if features == Some(0) {
            return Err(error("features: must be at least 1"));
        }
        let colour = [robot_color.0, robot_color.1, robot_color.2];
        let params = SenseParams::with_options(registration, colour, max_contacts, features);
        let mut sensor = Sen::for_rig(model.0.clone(), &rec, params).map_err(|e| {
            error(format!(
                "{e}: open it with pose=POSE.json, or find it with `softsense calibrate`"
            ))
        })?;
        sensor.use_recording_inputs(rec.shared()).map_err(error)?;
        take_reference(
            &mut sensor,
            &rec,
            reference_frames,
            known_load,
            modulus_from_sag,
        )?;
        Ok(Sensor { sensor, rec })
    }

    /// Senses one frame; returns its report as JSON. Never raises for a bad frame: its
    /// status says what went wrong. A frame the recording does not have raises.
    fn sense(&self, py: Python<'_>, frame: usize) -> PyResult<String> {
        if !self.rec.frames.contains(&frame) {
            return Err(error(format!(
                "no frame {frame} in the recording (frames {:?})",
                self.rec.frames
            )));
        }
        // One frame through the stream, so it is read and sensed exactly as in `sense_all`
        // and `softsense sense` (an unreadable frame gets its status).
        let mut out = self.stream(py, Some(vec![frame]), Some(1), |_, r| json_of(&self.rec, r))?;
        out.pop()
            .ok_or_else(|| error(format!("frame {frame} gave no report")))?
    }

    /// Senses `frames` (default: all), `window` of them side by side (default: the number
    /// of threads); returns their reports as JSON, in frame order. Every frame's answer is
    /// the same for any window.
    #[pyo3(signature = (frames=None, window=None))]
    fn sense_all(
        &self,
        py: Python<'_>,
        frames: Option<Vec<usize>>,
        window: Option<usize>,
    ) -> PyResult<Vec<String>> {
        let out = self.stream(py, frames, window, |_, r| json_of(&self.rec, r))?;
        out.into_iter().collect()
    }

    /// What holds for every frame in 3-D (the axes, each camera's pose and pinhole), as a
    /// JSON list of entities (`softsense::render::scene3d`): what `softsense.rerun` logs
    /// as static.
    fn scene_static(&self) -> PyResult<String> {
        let cameras: Vec<_> = self.rec.cameras.iter().map(|c| &c.recording).collect();
        serde_json::to_string(&scene3d::static_entities(&self.sensor, &cameras)).map_err(error)
    }

    /// Senses `frames` as `sense_all` does; returns per frame its report and its 3-D
    /// entities (both JSON): exactly what `softsense sense --rerun` logs for the frame.
    /// `images`: include each camera's colour frame.
    #[pyo3(signature = (frames=None, window=None, images=true))]
    fn sense_scenes(
        &self,
        py: Python<'_>,
        frames: Option<Vec<usize>>,
        window: Option<usize>,
        images: bool,
    ) -> PyResult<Vec<(String, String)>> {
        let params = SceneParams {
            images,
            ..SceneParams::default()
        };
        let out = self.stream(py, frames, window, |obs, r| {
            let entities = scene3d::frame_entities(&self.sensor, obs.as_ref().ok(), &r, &params);
            let entities = serde_json::to_string(&entities).map_err(error)?;
            Ok((json_of(&self.rec, r)?, entities))
        })?;
        out.into_iter().collect()
    }

    /// Number of surface feature points.
    #[getter]
    fn features(&self) -> usize {
        self.sensor.features.len()
    }
}

impl Sensor {
    /// Senses `frames` (default: all; each must be in the recording), `window` at a time,
    /// and maps each frame's observation and report with `each`, in frame order.
    fn stream<T: Send>(
        &self,
        py: Python<'_>,
        frames: Option<Vec<usize>>,
        window: Option<usize>,
        each: impl Fn(&SenseResult<Observation>, FrameReport) -> T + Sync,
    ) -> PyResult<Vec<T>> {
        let frames = frames.unwrap_or_else(|| self.rec.frames.clone());
        if let Some(f) = frames.iter().find(|f| !self.rec.frames.contains(f)) {
            return Err(error(format!("no frame {f} in the recording")));
        }
        let window = window
            .unwrap_or_else(softsense::sense::default_window)
            .max(1);
        let mut out = Vec::with_capacity(frames.len());
        py.detach(|| {
            self.sensor
                .sense_frames(&self.rec, &frames, window, |obs, report| {
                    out.push(each(obs, report));
                    Ok::<(), std::convert::Infallible>(())
                })
        })
        .unwrap_or_else(|never| match never {});
        Ok(out)
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Recording>()?;
    m.add_class::<Sensor>()
}

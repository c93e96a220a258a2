//! The sweep file: the ranges `scene sweep` draws scenes from, with their defaults and
//! checks.

use super::super::camera::CameraSpec;
use super::super::sensor::SensorModel;
use super::super::truth::TruthRanges;
use super::super::{Colors, SceneError, SceneResult};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A sweep file: the ranges scenes are drawn from (lengths in metres, angles in degrees,
/// forces in newtons, robot frame).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// FE model file (relative to the sweep file).
    pub model: String,
    /// Young's modulus override (Pa); default the model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub young: Option<f64>,
    /// Half side of the table under the robot (m, 0.3); 0 for none.
    #[serde(default = "default_table")]
    pub table_half: f64,
    /// Camera ranges.
    #[serde(default)]
    pub camera: CameraRanges,
    /// Probe ranges.
    #[serde(default)]
    pub probes: ProbeRanges,
    /// Occluder ranges.
    #[serde(default)]
    pub occluder: OccluderRanges,
    /// Sensor model of the 640x480 stream (other streams: the same disparity noise).
    #[serde(default)]
    pub sensor: SensorModel,
    /// Colours.
    #[serde(default)]
    pub colors: Colors,
    /// Redraw rules.
    #[serde(default)]
    pub validity: Validity,
    /// The body scenes are rendered from, when it is not the model (`[truth]`, drawn per
    /// scene; none: the model).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthRanges>,
    /// Unloaded frames written before each scene's loaded frame (frames, 0, at most
    /// [`MAX_REFERENCE_FRAMES`]): no loads, the same camera, body and cable inputs, so a
    /// scene can be sensed with `sense --reference-frames N` (or fewer, the rest sensed as
    /// unloaded frames). 0 writes the one loaded frame per scene, as before; written out
    /// only when not 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub reference_frames: usize,
    /// Times each scene's loaded frame is written (frames, 1, at most
    /// [`MAX_HELD_FRAMES`]): the same load held over that many frames, each with its own
    /// sensor noise, for `sense --hold` and `score --held`. Written out only when not 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub held_frames: usize,
}

/// Most frames a sweep holds each scene's load over.
pub const MAX_HELD_FRAMES: usize = 64;

fn one() -> usize {
    1
}

/// Most unloaded frames a sweep writes before each scene's loaded frame.
pub const MAX_REFERENCE_FRAMES: usize = 16;

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn default_table() -> f64 {
    0.3
}

/// Where the camera is drawn: on a sphere around `target`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraRanges {
    /// Distance from the target (m, [0.4, 0.6]).
    pub distance: [f64; 2],
    /// Azimuth about +z (degrees, [-180, 180]); 0 looks along +y, from the bundled
    /// scenes' side, 90 from +x.
    pub azimuth_deg: [f64; 2],
    /// Elevation: how far the camera looks down (degrees, [20, 45]).
    pub elevation_deg: [f64; 2],
    /// Streams drawn from with equal odds: "640x480" or "1280x720" (["640x480"]).
    pub streams: Vec<String>,
    /// Point looked at (m); default the centre of the robot's bounding box at rest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
    /// Cameras per scene (1): the first drawn as above, each next one `azimuth_spacing_deg`
    /// further in azimuth, with its own distance and elevation from the same ranges.
    /// Written out only when not 1, so one-camera sweep files stay as they were.
    #[serde(skip_serializing_if = "is_one")]
    pub count: usize,
    /// Azimuth from one camera of a scene to the next (degrees, 90); written out only with
    /// several cameras.
    #[serde(skip_serializing_if = "is_default_spacing")]
    pub azimuth_spacing_deg: f64,
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

fn is_default_spacing(deg: &f64) -> bool {
    *deg == CameraRanges::default().azimuth_spacing_deg
}

impl Default for CameraRanges {
    fn default() -> Self {
        Self {
            distance: [0.4, 0.6],
            azimuth_deg: [-180.0, 180.0],
            elevation_deg: [20.0, 45.0],
            streams: vec!["640x480".into()],
            target: None,
            count: 1,
            azimuth_spacing_deg: 90.0,
        }
    }
}

/// How probes are drawn: on surface nodes the camera sees, pushing within a cone about
/// the inward normal.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProbeRanges {
    /// Number of probes per scene, inclusive range ([1, 1]).
    pub count: [usize; 2],
    /// Force magnitude (N, [0.25, 0.9]).
    pub force: [f64; 2],
    /// Largest angle between the force and the inward normal (degrees, 15); drawn
    /// uniformly over the cone's solid angle.
    pub cone_deg: f64,
    /// Probe sphere radius (m, [0.006, 0.010]).
    pub radius: [f64; 2],
    /// Least distance between two probes' nodes (m, 0.04).
    pub min_separation: f64,
    /// Least cosine between the surface normal and the direction to the camera (0.3): a
    /// probe on a face seen edge-on is not "camera-visible".
    pub min_facing: f64,
    /// Least height of a probed node above the table (m, 0.015).
    pub min_height: f64,
}

impl Default for ProbeRanges {
    fn default() -> Self {
        Self {
            count: [1, 1],
            force: [0.25, 0.9],
            cone_deg: 15.0,
            radius: [0.006, 0.010],
            min_separation: 0.04,
            min_facing: 0.3,
            min_height: 0.015,
        }
    }
}

/// How much of the robot an occluder hides.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OccluderRanges {
    /// Share of the robot's pixels hidden by a sphere halfway between camera and robot,
    /// never over a probe ([0, 0]: no occluder). Drawn, then met within 2 points.
    pub fraction: [f64; 2],
}

/// When a draw is redrawn.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Validity {
    /// Least ratio of an element's deformed to rest volume (0.1): below it the element is
    /// (nearly) inverted and the FE answer is not a physical scene.
    pub min_volume_ratio: f64,
    /// Attempts per scene before the sweep gives up (200).
    pub max_attempts: usize,
}

impl Default for Validity {
    fn default() -> Self {
        Self {
            min_volume_ratio: 0.1,
            max_attempts: 200,
        }
    }
}

/// A sweep file with its resolved model path.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The parsed spec.
    pub spec: SweepSpec,
    /// The model path, resolved against the sweep file's folder.
    pub model_path: PathBuf,
    /// The `[truth]` mesh path, resolved against the sweep file's folder (none: the
    /// model's mesh).
    pub truth_mesh: Option<PathBuf>,
}

impl Sweep {
    /// Reads and checks a sweep file.
    pub fn load(path: &Path) -> SceneResult<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let spec: SweepSpec = toml::from_str(&text)
            .map_err(|e| SceneError::Spec(format!("{}: {e}", path.display())))?;
        spec.check()
            .map_err(|e| SceneError::Spec(format!("{}: {e}", path.display())))?;
        if let Some(t) = &spec.truth {
            t.check()?;
        }
        let model_path = super::super::beside(path, &spec.model);
        let truth_mesh = (spec.truth.as_ref())
            .and_then(|t| t.mesh.as_deref())
            .map(|m| super::super::beside(path, m));
        Ok(Self {
            spec,
            model_path,
            truth_mesh,
        })
    }
}

fn range_ok(r: [f64; 2], lo: f64, hi: f64) -> bool {
    r.iter().all(|v| v.is_finite()) && lo <= r[0] && r[0] <= r[1] && r[1] <= hi
}

impl SweepSpec {
    /// Checks every range; the error names the first bad field.
    pub fn check(&self) -> Result<(), String> {
        let (c, p) = (&self.camera, &self.probes);
        let checks: [(bool, &str); 16] = [
            (
                range_ok(c.distance, 0.05, 20.0),
                "camera.distance: [lo, hi] within 0.05-20 m",
            ),
            (
                range_ok(c.azimuth_deg, -360.0, 360.0),
                "camera.azimuth_deg: [lo, hi] within -360..360",
            ),
            (
                range_ok(c.elevation_deg, -89.0, 89.0),
                "camera.elevation_deg: [lo, hi] within -89..89",
            ),
            (
                !c.streams.is_empty() && c.streams.iter().all(|s| stream(s).is_some()),
                "camera.streams: one or more of \"640x480\", \"1280x720\"",
            ),
            (
                c.target.is_none_or(|t| t.iter().all(|v| v.is_finite())),
                "camera.target: finite",
            ),
            (
                (1..=8).contains(&c.count) && (-360.0..=360.0).contains(&c.azimuth_spacing_deg),
                "camera: count within 1-8, azimuth_spacing_deg within -360..360",
            ),
            (
                p.count[0] >= 1 && p.count[0] <= p.count[1] && p.count[1] <= 4,
                "probes.count: [lo, hi] within 1-4",
            ),
            (
                range_ok(p.force, 1e-6, 1e3),
                "probes.force: [lo, hi] within 1e-6..1000 N",
            ),
            ((0.0..=60.0).contains(&p.cone_deg), "probes.cone_deg: 0-60"),
            (
                range_ok(p.radius, 1e-4, 0.1),
                "probes.radius: [lo, hi] within 0.1-100 mm",
            ),
            (
                p.min_separation.is_finite()
                    && p.min_separation >= 0.0
                    && (-1.0..=1.0).contains(&p.min_facing)
                    && p.min_height.is_finite(),
                "probes: min_separation >= 0, min_facing in [-1, 1], min_height finite",
            ),
            (
                range_ok(self.occluder.fraction, 0.0, 0.8),
                "occluder.fraction: [lo, hi] within 0-0.8",
            ),
            (
                self.validity.min_volume_ratio.is_finite() && self.validity.max_attempts >= 1,
                "validity: min_volume_ratio finite, max_attempts >= 1",
            ),
            (
                self.table_half.is_finite() && self.table_half >= 0.0,
                "table_half: >= 0",
            ),
            (
                self.reference_frames <= MAX_REFERENCE_FRAMES,
                "reference_frames: 0-16",
            ),
            (
                (1..=MAX_HELD_FRAMES).contains(&self.held_frames),
                "held_frames: 1-64",
            ),
        ];
        if let Some((_, what)) = checks.iter().find(|c| !c.0) {
            return Err((*what).to_string());
        }
        self.sensor.validate()
    }
}

/// The camera of a named stream: the D415-like 640x480 or 1280x720 intrinsics.
pub(super) fn stream(name: &str) -> Option<CameraSpec> {
    match name {
        "640x480" => Some(CameraSpec::default()),
        "1280x720" => Some(CameraSpec::d415_1280x720()),
        _ => None,
    }
}

//! Synthetic truth, the direct model (design section 5, thesis 4.6): a scene file says which
//! FE model, which loads and actuator inputs per frame, where the camera is and how noisy
//! it is; [`generate`] solves the FE model per frame and ray-casts the deformed robot, the
//! probe and the table into RGB-D frames, with a `truth.json` of everything used. A scene
//! with several cameras (`[[cameras]]`) renders each solved frame from every camera, into
//! one sub-folder per camera ([`render`]).
//!
//! ```
//! use softsense::scene::camera::CameraSpec;
//! let s = CameraSpec::default();
//! let cam = s.camera().unwrap();
//! // The optical axis passes through the principal point and hits the target.
//! let dist = (0..3).map(|k| (s.target[k] - s.eye[k]).powi(2)).sum::<f64>().sqrt();
//! let p = cam.backproject(s.cx, s.cy, dist);
//! assert!((0..3).all(|k| (p[k] - s.target[k]).abs() < 1e-12));
//! ```

pub mod camera;
pub mod markers;
pub mod render;
pub mod sweep;
pub mod truth;
pub use crate::geometry::raycast;
pub use render::{render_frame, Rendered, RenderedView, SceneView};
pub mod sensor;
pub use crate::recording::schema::{
    ActuatorTruth, CableInput, CavityInput, FrameInput, FrameTruth, LoadInput, LoadKind, LoadTruth,
    ViewTruth,
};
/// `truth.json` as `scene generate` writes it.
pub type Truth = crate::recording::schema::Truth<SceneSpec>;

use crate::camera::Camera;
use crate::fem::material::Material;
use crate::fem::mesh::Surface;
use crate::fem::model::Model;
use crate::fem::solve::{apply_cable_inputs, apply_cavity_inputs};
use crate::fem::solve::{MappedPoint, PointLoad, Problem};
use crate::recording::schema::TruthModel;
use crate::recording::RecordingWriter;
use camera::{CameraSpec, NamedCameraSpec};
use sensor::SensorModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of scene generation.
#[derive(Debug, Error)]
pub enum SceneError {
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// The scene file is malformed or inconsistent.
    #[error("scene: {0}")]
    Spec(String),
    /// The FE model failed to load or solve.
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
    /// A recording file could not be written.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
    /// A `[truth]` field has a value that cannot be used.
    #[error("{field} = {value}: {problem}")]
    BadTruth {
        /// The field, e.g. `truth.young_factor`.
        field: String,
        /// Its value as written.
        value: String,
        /// What is wrong with it.
        problem: String,
    },
    /// Newton did not converge for a frame.
    #[error("frame {frame}: the FE solve did not converge")]
    NotConverged {
        /// The frame.
        frame: usize,
    },
}

/// `Result` of the scene stage.
pub type SceneResult<T> = std::result::Result<T, SceneError>;

/// Largest accepted image side (pixels).
pub const MAX_SIDE: u32 = 4096;
/// Largest accepted number of frames in a scene file.
pub const MAX_FRAMES: usize = 10_000;

/// Colours (0-255 RGB) of the rendered objects.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Colors {
    /// The robot.
    pub robot: [u8; 3],
    /// The probe.
    pub probe: [u8; 3],
    /// The table.
    pub table: [u8; 3],
    /// Occluders.
    pub occluder: [u8; 3],
}

impl Default for Colors {
    fn default() -> Self {
        Self {
            robot: [40, 200, 60],
            probe: [220, 40, 40],
            table: [150, 150, 160],
            occluder: [90, 90, 95],
        }
    }
}

/// A scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// FE model file (relative to the scene file).
    pub model: String,
    /// Young's modulus override (Pa).
    #[serde(default)]
    pub young: Option<f64>,
    /// Random seed of the sensor model.
    #[serde(default)]
    pub seed: u64,
    /// Half side of the square table at z = 0 (m); 0 for none.
    #[serde(default = "default_table")]
    pub table_half: f64,
    /// Height of the table's top (m); default: the model's lowest point at rest, where the
    /// robot's base stands (and where `sense` expects the table).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table_z: Option<f64>,
    /// Spheres between the camera and the robot that hide part of it (not touching it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub occluders: Vec<Occluder>,
    /// Colours.
    #[serde(default)]
    pub colors: Colors,
    /// Painted markers (`[markers]`; none by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub markers: Option<markers::MarkerPaint>,
    /// The body the frames are rendered from, when it is not the model (`[truth]`; none:
    /// the model).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<truth::TruthSpec>,
    /// Camera (unused, and not written out, when `cameras` is given).
    #[serde(default)]
    pub camera: CameraSpec,
    /// Several cameras (`[[cameras]]`, instead of `[camera]`), each rendered into its own
    /// sub-folder; empty for one camera.
    #[serde(default)]
    pub cameras: Vec<NamedCameraSpec>,
    /// Sensor model.
    #[serde(default)]
    pub sensor: SensorModel,
    /// Frames.
    pub frames: Vec<FrameInput>,
}

fn default_table() -> f64 {
    0.3
}

// By hand only to leave `camera` out when `cameras` is given: a spec written out (a
// sweep's scene file, `truth.json`) must load again, and `[camera]` beside `[[cameras]]` is
// refused. Field order and what is left out are the derived ones'.
impl Serialize for SceneSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut out = s.serialize_struct("SceneSpec", 13)?;
        out.serialize_field("model", &self.model)?;
        out.serialize_field("young", &self.young)?;
        out.serialize_field("seed", &self.seed)?;
        out.serialize_field("table_half", &self.table_half)?;
        match self.table_z.is_some() {
            true => out.serialize_field("table_z", &self.table_z)?,
            false => out.skip_field("table_z")?,
        }
        match self.occluders.is_empty() {
            false => out.serialize_field("occluders", &self.occluders)?,
            true => out.skip_field("occluders")?,
        }
        out.serialize_field("colors", &self.colors)?;
        match self.markers.is_some() {
            true => out.serialize_field("markers", &self.markers)?,
            false => out.skip_field("markers")?,
        }
        match self.truth.is_some() {
            true => out.serialize_field("truth", &self.truth)?,
            false => out.skip_field("truth")?,
        }
        match self.cameras.is_empty() {
            true => {
                out.serialize_field("camera", &self.camera)?;
                out.skip_field("cameras")?;
            }
            false => {
                out.skip_field("camera")?;
                out.serialize_field("cameras", &self.cameras)?;
            }
        }
        out.serialize_field("sensor", &self.sensor)?;
        out.serialize_field("frames", &self.frames)?;
        out.end()
    }
}

/// A sphere that hides part of the scene from the camera (an arm, a cable, a tool).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Occluder {
    /// Centre in the robot frame (m).
    pub center: [f64; 3],
    /// Radius (m).
    pub radius: f64,
}

/// `name` as written in the file `file`: relative to the file's folder unless absolute.
pub(crate) fn beside(file: &Path, name: &str) -> PathBuf {
    let p = PathBuf::from(name);
    if p.is_relative() {
        file.parent().unwrap_or(Path::new(".")).join(p)
    } else {
        p
    }
}

/// A scene file with its resolved model path.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The parsed spec.
    pub spec: SceneSpec,
    /// The model path, resolved against the scene file's folder.
    pub model_path: PathBuf,
    /// The `[truth]` mesh path, resolved against the scene file's folder (none: the
    /// model's mesh).
    pub truth_mesh: Option<PathBuf>,
}

impl Scene {
    /// Reads and checks a scene file.
    pub fn load(path: &Path) -> SceneResult<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let spec: SceneSpec = toml::from_str(&text)
            .map_err(|e| SceneError::Spec(format!("{}: {e}", path.display())))?;
        let in_file = |e: String| SceneError::Spec(format!("{}: {e}", path.display()));
        let keys: toml::Table = toml::from_str(&text).map_err(|e| in_file(e.to_string()))?;
        check_cameras(&spec, keys.contains_key("camera")).map_err(in_file)?;
        spec.sensor.validate().map_err(in_file)?;
        if spec.frames.is_empty() || spec.frames.len() > MAX_FRAMES {
            return Err(SceneError::Spec(format!(
                "{}: needs 1..={MAX_FRAMES} frames, has {}",
                path.display(),
                spec.frames.len()
            )));
        }
        if let Some(t) = &spec.truth {
            t.check()?;
        }
        let model_path = beside(path, &spec.model);
        let truth_mesh = (spec.truth.as_ref())
            .and_then(|t| t.mesh.as_deref())
            .map(|m| beside(path, m));
        Ok(Self {
            spec,
            model_path,
            truth_mesh,
        })
    }

    /// The scene's cameras ([`SceneSpec::views`]).
    pub fn views(&self) -> Vec<SceneView> {
        self.spec.views()
    }

    /// Loads the FE model with the scene's material override.
    pub fn model(&self) -> SceneResult<Model> {
        let mut model = Model::load(&self.model_path, None)?;
        if let Some(e) = self.spec.young {
            model.problem.material = Material::new(e, model.problem.material.poisson())?;
        }
        Ok(model)
    }

    /// The body the frames are rendered from: `model` (the scene's [`Scene::model`]) as the
    /// scene's `[truth]` changes it, or `model` itself without one.
    pub fn truth_body(&self, model: &Model) -> SceneResult<Model> {
        let Some(t) = &self.spec.truth else {
            return Ok(model.clone());
        };
        match &self.truth_mesh {
            Some(mesh) => {
                let on_mesh = truth::on_mesh(&self.model_path, mesh, model)?;
                t.body(&on_mesh, &model.problem.material)
            }
            None => t.body(model, &model.problem.material),
        }
    }

    /// What `truth.json` says of the scene's `[truth]` body (`body`: [`Scene::truth_body`]),
    /// its mesh file relative to `out` when it can be; `None` without `[truth]`.
    fn truth_record(&self, body: &Model, out: &Path) -> Option<TruthModel> {
        let t = self.spec.truth.as_ref()?;
        let mesh = (self.truth_mesh.clone())
            .or_else(|| Model::mesh_file(&self.model_path).ok())
            .unwrap_or_default();
        let shown = relative_to(&mesh, out).unwrap_or(mesh);
        Some(t.record(body, shown.display().to_string()))
    }
}

/// Refuses `[camera]` beside `[[cameras]]` (`has_camera`: the file has a `[camera]`
/// table), camera names that are not folder names or not unique, and any camera that
/// [`CameraSpec::check`] or [`MAX_SIDE`] refuses.
fn check_cameras(spec: &SceneSpec, has_camera: bool) -> Result<(), String> {
    if has_camera && !spec.cameras.is_empty() {
        return Err(
            "both [camera] and [[cameras]]: give one camera as [camera], or every \
                    camera (with a name) as [[cameras]]"
                .into(),
        );
    }
    for (i, c) in spec.cameras.iter().enumerate() {
        c.check_name()?;
        if spec.cameras[..i].iter().any(|o| o.name == c.name) {
            return Err(format!(
                "two cameras are named {}: names must differ",
                c.name
            ));
        }
    }
    for view in spec.views() {
        let c = &view.camera;
        if c.width > MAX_SIDE || c.height > MAX_SIDE {
            return Err(view.named(format!("image larger than {MAX_SIDE} pixels")));
        }
        c.check().map_err(|e| view.named(e))?;
    }
    Ok(())
}

/// The nearest surface node to `p` in the rest mesh.
pub fn nearest_surface_node(
    nodes: &[[f64; 3]],
    surface_nodes: &[usize],
    p: [f64; 3],
) -> Option<usize> {
    surface_nodes
        .iter()
        .copied()
        .min_by(|&a, &b| dist2(nodes[a], p).total_cmp(&dist2(nodes[b], p)))
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]) * (a[k] - b[k])).sum()
}

/// Farthest a load's `at` may be from the robot's nearest surface node (m). The surface
/// nodes of the bundled meshes are ~9 mm apart, so a point on the surface is within ~7 mm
/// of one; a point farther than this is a typo or a unit slip (millimetres for metres),
/// and snapping it to a node would make a scene other than the one asked for.
pub const MAX_LOAD_OFFSET: f64 = 0.02;

/// Each cavity's input in a frame: the frame's own, else the model's.
fn cavity_inputs(
    cavities: &[crate::fem::solve::Cavity],
    given: &[CavityInput],
) -> Vec<CavityInput> {
    use crate::fem::solve::CavityControl;
    (cavities.iter())
        .map(|c| match given.iter().find(|g| g.name == c.name) {
            Some(g) => g.clone(),
            None => {
                let (pressure, volume) = match c.control {
                    CavityControl::Pressure(p) => (Some(p), None),
                    CavityControl::Volume(v) => (None, Some(v)),
                };
                CavityInput {
                    name: c.name.clone(),
                    pressure,
                    volume,
                }
            }
        })
        .collect()
}

/// Frame `index`'s FE problem (the model with the frame's cable inputs and loads), and
/// each load's surface node and point of application; every input checked, nothing solved.
/// `surface` is the model mesh's (the same for every frame: cables and loads do not change
/// the mesh).
pub(crate) fn frame_problem(
    model: &Model,
    surface: &Surface,
    spec: &SceneSpec,
    index: usize,
) -> SceneResult<(Problem, Vec<(usize, MappedPoint)>)> {
    let frame = spec
        .frames
        .get(index)
        .ok_or_else(|| SceneError::Spec(format!("no frame {index}")))?;
    let mut problem = model.problem.clone();
    apply_cable_inputs(&mut problem.cables, &frame.cables)
        .and_then(|()| apply_cavity_inputs(&mut problem.cavities, &frame.cavities))
        .map_err(|e| SceneError::Spec(format!("frame {index}: {e}")))?;
    let rest = problem.mesh.nodes_in_rest.clone();
    let mut nodes_of_loads = Vec::new();
    for (k, l) in frame.loads.iter().enumerate() {
        let bad = if !l.at.iter().all(|f| f.is_finite()) {
            Some(format!("at = {:?} must be finite (metres)", l.at))
        } else if !l.force.iter().all(|f| f.is_finite()) {
            Some(format!("force = {:?} must be finite (newtons)", l.force))
        } else if !(l.radius > 0.0 && l.radius.is_finite()) {
            Some(format!(
                "radius = {} must be positive and finite (metres, e.g. 0.004)",
                l.radius
            ))
        } else {
            None
        };
        if let Some(bad) = bad {
            return Err(SceneError::Spec(format!(
                "[[frames]] {index}, [[frames.loads]] {k}: {bad}"
            )));
        }
        let node = nearest_surface_node(&rest, &surface.nodes, l.at)
            .ok_or_else(|| SceneError::Spec("the mesh has no surface".into()))?;
        let off = dist2(rest[node], l.at).sqrt();
        if off > MAX_LOAD_OFFSET {
            let [x, y, z] = rest[node];
            return Err(SceneError::Spec(format!(
                "frame {index}, load {k}: at = [{}, {}, {}] is {:.1} mm from the robot's nearest surface node, at [{x:.4}, {y:.4}, {z:.4}] (at most {:.0} mm allowed); `at` is in metres, in the robot frame at rest",
                l.at[0],
                l.at[1],
                l.at[2],
                off * 1e3,
                MAX_LOAD_OFFSET * 1e3
            )));
        }
        // A probe presses on a surface node; a weight hangs from exactly `at` (a hook).
        let at = match l.kind {
            LoadKind::Weight => MappedPoint::locate(&problem.mesh, l.at, 1e-4)
                .unwrap_or_else(|_| MappedPoint::node(node)),
            LoadKind::Probe => MappedPoint::node(node),
        };
        problem.loads.push(PointLoad { at, force: l.force });
        nodes_of_loads.push((node, at));
    }
    Ok((problem, nodes_of_loads))
}

/// Each load's truth from its surface node and point of application (`x`: the solved
/// node positions).
pub(crate) fn load_truths(
    frame: &FrameInput,
    nodes_of_loads: &[(usize, MappedPoint)],
    rest: &[[f64; 3]],
    x: &[[f64; 3]],
) -> Vec<LoadTruth> {
    frame
        .loads
        .iter()
        .zip(nodes_of_loads)
        .map(|(l, &(node, at))| {
            let mag = l.force.iter().map(|f| f * f).sum::<f64>().sqrt();
            let probe_center = (l.kind == LoadKind::Probe && mag > 0.0)
                .then(|| [0, 1, 2].map(|k| x[node][k] - l.radius * l.force[k] / mag));
            LoadTruth {
                kind: l.kind,
                node,
                at_rest: at.position(rest),
                at_deformed: at.position(x),
                force: l.force,
                magnitude: mag,
                probe_center,
                radius: l.radius,
            }
        })
        .collect()
}

/// The scene's table height (m): `table_z`, else the lowest rest node's z.
pub fn table_height(spec: &SceneSpec, rest: &[[f64; 3]]) -> f64 {
    spec.table_z
        .unwrap_or_else(|| rest.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min))
}

/// Refuses a depth unit with which the robot's depths (at rest) would not fit the 16
/// bits of a depth PNG, or would round to zero: either way the images came out all zero.
fn check_depth_unit(unit: f64, camera: &Camera, nodes: &[[f64; 3]]) -> Result<(), String> {
    let (mut near, mut far) = (f64::INFINITY, 0.0f64);
    for &p in nodes {
        let z = camera.depth_of(p);
        if z.is_finite() && z > 0.0 {
            near = near.min(z);
            far = far.max(z);
        }
    }
    if far == 0.0 {
        return Ok(()); // the robot is behind the camera; rendering says so
    }
    // The farthest depth must fit in 65535 units and the nearest be at least one unit.
    let (lo, hi) = (far / 65535.0, near);
    if !(lo..=hi).contains(&unit) {
        return Err(format!(
            "sensor.depth_unit {unit} m cannot encode the robot's depths ({near:.3} to \
             {far:.3} m) in a 16-bit image; use {lo:.2e} to {hi:.2e} m (0.001 is millimetres)"
        ));
    }
    Ok(())
}

/// `target` as a path relative to the folder `base` (both must exist), e.g.
/// `../../meshes/m.toml`; the absolute `target` when the two share no folder but the root
/// (`/tmp/out` and `/work/m.toml`); `None` when either cannot be resolved.
pub fn relative_to(target: &Path, base: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let target = std::fs::canonicalize(target).ok()?;
    let base = std::fs::canonicalize(base).ok()?;
    let (t, b): (Vec<_>, Vec<_>) = (target.components().collect(), base.components().collect());
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if t[..common]
        .iter()
        .all(|c| matches!(c, Component::Prefix(_) | Component::RootDir))
    {
        return Some(target);
    }
    let mut rel = PathBuf::new();
    for _ in common..b.len() {
        rel.push("..");
    }
    for c in &t[common..] {
        rel.push(c);
    }
    Some(rel)
}

/// The file of the painted markers' true positions in a generated recording.
pub const MARKERS_TRUTH: &str = "markers_truth.csv";

/// Generates every frame into `out`: `depth_NNNN.png` (16-bit), `color_NNNN.png`,
/// `intrinsics.json`, `camera_pose.json`, `actuators.json` and `truth.json`, and with
/// `[markers]` the markers' true positions per frame ([`MARKERS_TRUTH`]). With
/// `[[cameras]]`, each camera's images, `intrinsics.json` and `camera_pose.json` go in
/// `out/NAME/`, the rest stays in `out` once.
/// `progress` is called after each frame with (done, total).
pub fn generate(
    scene: &Scene,
    out: &Path,
    progress: impl FnMut(usize, usize),
) -> SceneResult<Truth> {
    let model = scene.model()?;
    let body = scene.truth_body(&model)?;
    write_recording(
        scene,
        &model,
        &body,
        out,
        |i| render_frame(scene, &body, i),
        progress,
    )
}

/// [`generate`] with the frames made by `render` (frame index → rendered frame): `model`
/// is the model the recording names, `body` the one the frames are rendered from
/// ([`Scene::truth_body`]).
pub(crate) fn write_recording(
    scene: &Scene,
    model: &Model,
    body: &Model,
    out: &Path,
    mut render: impl FnMut(usize) -> SceneResult<Rendered>,
    mut progress: impl FnMut(usize, usize),
) -> SceneResult<Truth> {
    let writer = RecordingWriter::create(out)?;
    let spec = &scene.spec;
    let rest = &body.problem.mesh.nodes_in_rest;
    let views = spec.views();
    let mut cameras = Vec::with_capacity(views.len());
    for view in &views {
        let camera = view.make_camera()?;
        check_depth_unit(spec.sensor.depth_unit, &camera, rest)
            .map_err(|e| SceneError::Spec(view.named(e)))?;
        let folder = match &view.name {
            Some(name) => RecordingWriter::create(&out.join(name))?,
            None => writer.clone(),
        };
        folder.write_camera(&camera, spec.sensor.depth_unit)?;
        cameras.push((camera, folder, [view.camera.width, view.camera.height]));
    }
    let total = spec.frames.len();
    // Every frame's inputs are checked before any is solved: a slip in the last frame
    // should not cost the minutes of the ones before it.
    let surface = body.problem.mesh.surface();
    for i in 0..total {
        frame_problem(body, &surface, spec, i)?;
    }
    let painted = (spec.markers.as_ref())
        .map(|paint| markers::PaintedMarkers::bind(paint, rest, &surface, &cameras[0].0))
        .transpose()?;
    let mut frames = Vec::new();
    let mut marker_positions = Vec::new();
    for i in 0..total {
        let r = render(i)?;
        assert_eq!(r.views.len(), cameras.len(), "one rendered view per camera");
        for (view, (_, folder, size)) in r.views.into_iter().zip(&cameras) {
            folder.write_frame(i, *size, view.depth, &view.color)?;
        }
        frames.push(r.truth);
        marker_positions.push(r.markers);
        progress(i + 1, total);
    }
    if let Some(painted) = painted {
        let path = writer.dir().join(MARKERS_TRUTH);
        crate::recording::tracks::write_tracks(&path, &painted.truth_tracks(&marker_positions))
            .map_err(|e| SceneError::File {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
    }
    let actuators: Vec<&Vec<ActuatorTruth>> = frames.iter().map(|f| &f.actuators).collect();
    writer.write_json("actuators.json", &actuators)?;
    // actuators.json holds cables only: a model with cavities also gets inputs.json (which
    // readers take first) with the same cable inputs and every cavity's input.
    if !model.problem.cavities.is_empty() {
        let inputs: Vec<FrameInput> = (frames.iter().zip(&spec.frames))
            .map(|(f, s)| FrameInput {
                cables: f.actuators.iter().map(ActuatorTruth::commanded).collect(),
                cavities: cavity_inputs(&model.problem.cavities, &s.cavities),
                loads: Vec::new(),
            })
            .collect();
        writer.write_json("inputs.json", &inputs)?;
    }
    let truth = Truth {
        scene: spec.clone(),
        model_path: relative_to(&scene.model_path, out)
            .unwrap_or_else(|| scene.model_path.clone())
            .display()
            .to_string(),
        material: [
            model.problem.material.young(),
            model.problem.material.poisson(),
        ],
        truth_model: scene.truth_record(body, out),
        frames,
    };
    writer.write_json("truth.json", &truth)?;
    Ok(truth)
}

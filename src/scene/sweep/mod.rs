//! Random scenes for measuring accuracy (`softsense scene sweep`): a sweep file states
//! ranges (camera distance, azimuth, elevation and stream; probe count, force, cone,
//! size; occluded share of the robot; sensor noise), and [`draw`] makes scene `index` of a
//! sweep from them. A draw whose load pushes the robot through the table, nearly inverts
//! an element or does not converge is redrawn, never generated.
//!
//! Scene `index` depends only on (sweep file, seed, index): a longer sweep with the same
//! seed starts with the same scenes.

use super::camera::CameraSpec;
use super::truth::{self, TruthSpec};
use super::{render_frame, Occluder, Rendered, Scene, SceneError};
use super::{SceneResult, SceneSpec};
use crate::camera::Camera;
use crate::fem::mesh::signed_volume;
use crate::fem::model::Model;
use crate::fem::FemError;
use crate::geometry::raycast::{ray_sphere, Bvh};
use crate::math::rand::uniform;
use crate::math::{cross, dot, norm, sub};
use crate::recording::schema::{FrameInput, LoadInput, LoadKind};
use crate::register::vertex_normals;
mod camera;
mod spec;

use camera::{camera_of, draw_camera, draw_more_cameras, rig_cameras};

use serde::{Deserialize, Serialize};
pub use spec::{
    CameraRanges, OccluderRanges, ProbeRanges, Sweep, SweepSpec, Validity, MAX_HELD_FRAMES,
    MAX_REFERENCE_FRAMES,
};
use std::borrow::Cow;
use std::path::Path;

/// What was drawn for one scene, and why earlier attempts were redrawn.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DrawRecord {
    /// Scene index in the sweep.
    pub index: usize,
    /// Attempts made (1 = the first draw was kept).
    pub attempts: usize,
    /// Why each redrawn attempt was rejected.
    pub rejected: Vec<String>,
    /// Camera distance (m), azimuth and elevation (degrees).
    pub distance: f64,
    /// Azimuth (degrees).
    pub azimuth_deg: f64,
    /// Elevation (degrees).
    pub elevation_deg: f64,
    /// Stream.
    pub stream: String,
    /// Share of the robot's pixels the occluder hides (0 without one).
    pub occluded: f64,
    /// The second and later cameras of a scene with several (`camera.count`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub more_cameras: Vec<CameraDraw>,
    /// The body drawn from the sweep's `[truth]` (absent without one: the model).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthSpec>,
}

/// Where one more camera of a scene was drawn (it has the first camera's stream).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CameraDraw {
    /// Distance from the target (m).
    pub distance: f64,
    /// Azimuth (degrees): the first camera's plus a multiple of the spacing.
    pub azimuth_deg: f64,
    /// Elevation (degrees).
    pub elevation_deg: f64,
}

/// One drawn, solved and checked scene.
pub struct Drawn {
    /// The scene (one frame).
    pub scene: Scene,
    /// Its rendered frame.
    pub rendered: Rendered,
    /// What was drawn.
    pub record: DrawRecord,
}

/// Draws from scene `index`'s own stream of uniforms: attempt `attempt`, `n`-th number.
struct Draws {
    seed: u64,
    index: u64,
    attempt: u64,
    n: u64,
}

impl Draws {
    fn next(&mut self) -> f64 {
        self.n += 1;
        uniform(self.seed, self.index, self.attempt, self.n)
    }
    fn within(&mut self, r: [f64; 2]) -> f64 {
        r[0] + (r[1] - r[0]) * self.next()
    }
    fn pick(&mut self, n: usize) -> usize {
        ((self.next() * n as f64) as usize).min(n - 1)
    }
}

/// The surface nodes a probe may press on for `camera`: seen from the camera at rest,
/// facing it by at least `min_facing`, `min_height` above the table, not held; all judged
/// on `x`, the robot under gravity and its cable inputs, as the camera will see it.
fn probe_candidates(prepared: &Prepared, eye: [f64; 3], p: &ProbeRanges) -> Vec<usize> {
    let Prepared {
        unloaded: x,
        bvh,
        normals,
        table_z,
        held,
        ..
    } = prepared;
    prepared
        .surface_nodes
        .iter()
        .copied()
        .filter(|&v| {
            let d = sub(x[v], eye);
            let dist = norm(d);
            let facing = -dot(d, normals[v]) / dist;
            x[v][2] >= *table_z + p.min_height
                && facing >= p.min_facing
                && held.binary_search(&v).is_err()
                && bvh
                    .cast(eye, d)
                    .is_some_and(|h| (h.t - 1.0).abs() * dist < 1e-6)
        })
        .collect()
}

/// A force of `magnitude` within `cone_deg` of `inward`, uniform over the cone's solid angle.
fn cone_force(r: &mut Draws, inward: [f64; 3], cone_deg: f64, magnitude: f64) -> [f64; 3] {
    let a = if inward[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t1 = unit(cross(inward, a));
    let t2 = cross(inward, t1);
    let cos_t = 1.0 - r.next() * (1.0 - cone_deg.to_radians().cos());
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = std::f64::consts::TAU * r.next();
    [0, 1, 2]
        .map(|k| magnitude * (cos_t * inward[k] + sin_t * (phi.cos() * t1[k] + phi.sin() * t2[k])))
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = norm(a);
    a.map(|c| c / l)
}

/// The robot's pixels at rest as (ray, depth along the ray), to size an occluder.
fn robot_rays(camera: &Camera, bvh: &Bvh) -> Vec<([f64; 3], f64)> {
    let k = &camera.intrinsics;
    let mut rays = Vec::new();
    for v in 0..k.height {
        for u in 0..k.width {
            let d = camera.ray(u as f64, v as f64);
            if let Some(h) = bvh.cast(camera.eye(), d) {
                rays.push((d, h.t));
            }
        }
    }
    rays
}

/// An occluder halfway to a random robot point, hiding about `share` of `rays` and none of
/// the rays to `keep` (the probes); `None` when no such sphere is found.
fn place_occluder(
    r: &mut Draws,
    eye: [f64; 3],
    rays: &[([f64; 3], f64)],
    keep: &[[f64; 3]],
    share: f64,
) -> Option<Occluder> {
    if rays.is_empty() {
        return None;
    }
    let hidden = |o: &Occluder| {
        rays.iter()
            .filter(|(d, t)| ray_sphere(eye, *d, o.center, o.radius).is_some_and(|h| h.t < *t))
            .count() as f64
            / rays.len() as f64
    };
    for _ in 0..20 {
        let (d, t) = rays[r.pick(rays.len())];
        let center = [0, 1, 2].map(|k| eye[k] + 0.5 * t * d[k]);
        let dist = 0.5 * t * norm(d);
        let (mut lo, mut hi) = (0.0, 0.9 * dist);
        for _ in 0..30 {
            let mid = 0.5 * (lo + hi);
            if hidden(&Occluder {
                center,
                radius: mid,
            }) < share
            {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let o = Occluder { center, radius: hi };
        let clear = keep
            .iter()
            .all(|&p| ray_sphere(eye, sub(p, eye), o.center, o.radius).is_none_or(|h| h.t >= 1.0));
        if clear && (hidden(&o) - share).abs() <= 0.02 {
            return Some(o);
        }
    }
    None
}

/// How far a load may push the surface below the table (m): one depth unit, below what
/// the camera can see.
const TABLE_TOLERANCE: f64 = 0.001;

/// Least distance of a surface node other than the pressed one from a probe's centre,
/// in probe radii.
const PROBE_CLEARANCE: f64 = 0.9;
/// Least probe pixels per probe: a probe the camera cannot see is not the scene asked for.
const MIN_PROBE_PIXELS: usize = 20;

/// Why a solved draw is not a physical scene, if it is not.
fn physical_fault(
    prepared: &Prepared,
    body: &Body,
    spec: &SceneSpec,
    r: &Rendered,
    min_volume_ratio: f64,
) -> Option<String> {
    let (table_z, unloaded_low) = (prepared.table_z, prepared.unloaded_low);
    let mesh = &body.model.problem.mesh;
    let (x0, x) = (&mesh.nodes_in_rest, &r.positions);
    let worst = mesh
        .tets
        .iter()
        .map(|t| {
            let v = |p: &[[f64; 3]]| signed_volume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]);
            v(x) / v(x0)
        })
        .fold(f64::INFINITY, f64::min);
    if worst < min_volume_ratio {
        return Some(format!("an element's volume ratio is {worst:.3}"));
    }
    if spec.table_half > 0.0 {
        // The FE model has no contact with the table: under gravity alone a body may sag
        // below it, so only a load pushing the surface lower than that is unphysical.
        let low = x.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
        let floor = table_z.min(unloaded_low) - TABLE_TOLERANCE;
        if low < floor {
            return Some(format!(
                "the surface goes {:.1} mm into the table",
                (floor - low) * 1e3
            ));
        }
        for l in &r.truth.loads {
            if l.probe_center.is_some_and(|c| c[2] < table_z + l.radius) {
                return Some("a probe touches the table".into());
            }
        }
    }
    // A probe pressing into a crevice would cut into the robot beside its node: the
    // sphere touches the surface only where it presses.
    for l in &r.truth.loads {
        if let Some(c) = l.probe_center {
            let cut = body
                .surface_nodes
                .iter()
                .any(|&v| v != l.node && norm(sub(x[v], c)) < PROBE_CLEARANCE * l.radius);
            if cut {
                return Some("a probe sphere cuts into the robot beside its node".into());
            }
        }
    }
    // The probes are drawn where the first camera sees them: counted in its view.
    let t = &r.truth;
    let probe_pixels = t.views.first().map_or(t.pixels[1], |v| v.pixels[1]);
    if probe_pixels < MIN_PROBE_PIXELS * t.loads.len() {
        return Some(format!("the probes show {probe_pixels} pixels"));
    }
    let probes: Vec<_> = r
        .truth
        .loads
        .iter()
        .filter_map(|l| l.probe_center.map(|c| (c, l.radius)))
        .collect();
    for (i, a) in probes.iter().enumerate() {
        for b in &probes[i + 1..] {
            if norm(sub(a.0, b.0)) < a.1 + b.1 {
                return Some("two probes overlap".into());
            }
        }
    }
    None
}

/// What every draw of a sweep shares: the model at rest, its surface, normals and
/// ray-casting hierarchy of the unloaded solution (gravity and the model's cable inputs),
/// as the camera sees the robot before a probe touches it.
pub struct Prepared {
    /// The FE model (with the sweep's Young's modulus).
    pub model: Model,
    normals: Vec<[f64; 3]>,
    bvh: Bvh,
    target: [f64; 3],
    table_z: f64,
    unloaded_low: f64,
    unloaded: Vec<[f64; 3]>,
    surface_nodes: Vec<usize>,
    held: Vec<usize>,
    /// The model on the `[truth]` mesh, when the sweep's truth has one.
    truth_on_mesh: Option<Model>,
}

/// The body a scene of a sweep is rendered from: the model, or the body its `[truth]`
/// draw makes ([`TruthSpec::body`]), with that body's surface nodes.
pub struct Body<'p> {
    /// The scene's drawn truth (`None`: the model).
    pub truth: Option<TruthSpec>,
    /// The FE model of the body.
    pub model: Cow<'p, Model>,
    surface_nodes: Cow<'p, [usize]>,
}

impl Prepared {
    /// The unloaded node positions (m) that probe places and directions are drawn on.
    pub fn unloaded(&self) -> &[[f64; 3]] {
        &self.unloaded
    }

    /// Loads the sweep's model and solves it unloaded.
    pub fn new(sweep: &Sweep) -> SceneResult<Self> {
        let mut model = Model::load(&sweep.model_path, None)?;
        if let Some(e) = sweep.spec.young {
            model.problem.material =
                crate::fem::material::Material::new(e, model.problem.material.poisson())?;
        }
        let truth_on_mesh = (sweep.truth_mesh.as_ref())
            .map(|mesh| truth::on_mesh(&sweep.model_path, mesh, &model))
            .transpose()?;
        let mesh = &model.problem.mesh;
        let x0 = &mesh.nodes_in_rest;
        let surface = mesh.surface();
        let [lo, hi] = mesh.bbox();
        let unloaded = model.problem.solve_static(&model.newton)?;
        if !unloaded.converged {
            return Err(SceneError::Spec(
                "the unloaded FE solve did not converge".into(),
            ));
        }
        Ok(Self {
            normals: vertex_normals(&unloaded.positions, &surface.triangles),
            bvh: Bvh::new(&unloaded.positions, &surface.triangles),
            target: sweep
                .spec
                .camera
                .target
                .unwrap_or([0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]))),
            table_z: x0.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min),
            unloaded_low: unloaded
                .positions
                .iter()
                .map(|p| p[2])
                .fold(f64::INFINITY, f64::min),
            unloaded: unloaded.positions,
            held: model.problem.held_nodes(),
            surface_nodes: surface.nodes,
            model,
            truth_on_mesh,
        })
    }

    /// Scene `index`'s body in a sweep of seed `seed`: its `[truth]` drawn
    /// ([`truth::TruthRanges::draw`]), or the model without one.
    pub fn body(&self, sweep: &Sweep, seed: u64, index: usize) -> SceneResult<Body<'_>> {
        let Some(ranges) = &sweep.spec.truth else {
            return Ok(Body {
                truth: None,
                model: Cow::Borrowed(&self.model),
                surface_nodes: Cow::Borrowed(&self.surface_nodes),
            });
        };
        let drawn = ranges.draw(seed, index, sweep.truth_mesh.as_deref());
        let nominal = &self.model.problem.material;
        let (model, surface_nodes) = match &self.truth_on_mesh {
            Some(on_mesh) => {
                let body = drawn.body(on_mesh, nominal)?;
                let nodes = body.problem.mesh.surface().nodes;
                (body, Cow::Owned(nodes))
            }
            None => (
                drawn.body(&self.model, nominal)?,
                Cow::Borrowed(&self.surface_nodes[..]),
            ),
        };
        Ok(Body {
            truth: Some(drawn),
            model: Cow::Owned(model),
            surface_nodes,
        })
    }
}

/// Draws scene `index` of `sweep` (seed `seed`), solving and checking each attempt.
pub fn draw(sweep: &Sweep, prepared: &Prepared, seed: u64, index: usize) -> SceneResult<Drawn> {
    let body = prepared.body(sweep, seed, index)?;
    draw_body(sweep, prepared, &body, seed, index)
}

/// [`draw`] rendering from `body` ([`Prepared::body`]).
fn draw_body(
    sweep: &Sweep,
    prepared: &Prepared,
    body: &Body,
    seed: u64,
    index: usize,
) -> SceneResult<Drawn> {
    let mut rejected = Vec::new();
    for attempt in 0..sweep.spec.validity.max_attempts {
        let mut r = Draws {
            seed,
            index: index as u64,
            attempt: attempt as u64,
            n: 0,
        };
        match try_draw(sweep, prepared, body, &mut r)? {
            Ok((scene, rendered, mut record)) => {
                record.index = index;
                record.attempts = attempt + 1;
                record.rejected = rejected;
                record.truth = body.truth.clone();
                return Ok(Drawn {
                    scene,
                    rendered,
                    record,
                });
            }
            Err(why) => rejected.push(why),
        }
    }
    Err(SceneError::Spec(format!(
        "scene {index}: no physical scene in {} attempts; the last were rejected because: {}",
        sweep.spec.validity.max_attempts,
        rejected
            .iter()
            .rev()
            .take(3)
            .cloned()
            .collect::<Vec<_>>()
            .join("; ")
    )))
}

/// The probes' nodes and loads among `candidates`, or why none could be placed.
fn draw_loads(
    r: &mut Draws,
    p: &ProbeRanges,
    candidates: &[usize],
    x0: &[[f64; 3]],
    normals: &[[f64; 3]],
) -> Result<(Vec<usize>, Vec<LoadInput>), String> {
    if candidates.is_empty() {
        return Err("no camera-visible surface node to probe".into());
    }
    let count = p.count[0] + r.pick(p.count[1] - p.count[0] + 1);
    let mut nodes: Vec<usize> = Vec::new();
    for _ in 0..50 {
        if nodes.len() == count {
            break;
        }
        let v = candidates[r.pick(candidates.len())];
        if nodes
            .iter()
            .all(|&w| norm(sub(x0[v], x0[w])) >= p.min_separation)
        {
            nodes.push(v);
        }
    }
    if nodes.len() < count {
        return Err(format!(
            "no {count} probe places {:.0} mm apart",
            p.min_separation * 1e3
        ));
    }
    let loads = nodes
        .iter()
        .map(|&v| {
            let magnitude = r.within(p.force);
            let force = cone_force(r, normals[v].map(|c| -c), p.cone_deg, magnitude);
            LoadInput {
                kind: LoadKind::Probe,
                at: x0[v],
                force,
                radius: r.within(p.radius),
            }
        })
        .collect();
    Ok((nodes, loads))
}

/// The attempt's scene rendered from `body`; or why it is redrawn, when its FE solve fails
/// as an unphysical scene does.
fn render_attempt(scene: &Scene, body: &Body) -> SceneResult<Result<Rendered, String>> {
    match render_frame(scene, &body.model, 0) {
        Ok(rendered) => Ok(Ok(rendered)),
        Err(SceneError::NotConverged { .. }) => Ok(Err("the FE solve did not converge".into())),
        // The load turned an element inside out on the way (Newton's steps, or the
        // solution itself): no physical scene, another draw.
        Err(SceneError::Fem(
            e @ (FemError::InvertedElement { .. }
            | FemError::NoConvergence { .. }
            | FemError::NotPositiveDefinite { .. }),
        )) => Ok(Err(format!("the FE solve failed ({e})"))),
        Err(e) => Err(e),
    }
}

/// One attempt: the scene, its rendered frame and what was drawn; or why it is redrawn.
type Attempt = Result<(Scene, Rendered, DrawRecord), String>;

fn try_draw(
    sweep: &Sweep,
    prepared: &Prepared,
    body: &Body,
    r: &mut Draws,
) -> SceneResult<Attempt> {
    let spec = &sweep.spec;
    let Prepared {
        model,
        normals,
        bvh,
        target,
        unloaded,
        ..
    } = prepared;
    let x0 = &model.problem.mesh.nodes_in_rest;
    let mut record = draw_camera(r, &spec.camera)?;
    let cam = camera_of(&record, *target)?;
    let camera = cam
        .camera()
        .ok_or_else(|| SceneError::Spec("camera: degenerate pose".into()))?;
    let candidates = probe_candidates(prepared, cam.eye, &spec.probes);
    let (nodes, loads) = match draw_loads(r, &spec.probes, &candidates, x0, normals) {
        Ok(drawn) => drawn,
        Err(why) => return Ok(Err(why)),
    };
    let mut occluders = Vec::new();
    let share = r.within(spec.occluder.fraction);
    if share > 0.0 {
        let keep: Vec<[f64; 3]> = nodes.iter().map(|&v| unloaded[v]).collect();
        match place_occluder(r, cam.eye, &robot_rays(&camera, bvh), &keep, share) {
            Some(o) => occluders.push(o),
            None => {
                return Ok(Err(format!(
                    "no occluder hides {:.0}% and leaves the probes seen",
                    share * 100.0
                )))
            }
        }
    }
    record.more_cameras = draw_more_cameras(r, &spec.camera, record.azimuth_deg);
    let mut sensor = spec.sensor.clone();
    sensor.depth_k *= CameraSpec::default().fx / cam.fx;
    sensor.depth_step_k *= CameraSpec::default().fx / cam.fx;
    let cameras = rig_cameras(&record, &cam, *target)?;
    let scene = Scene {
        spec: SceneSpec {
            model: sweep.model_path.display().to_string(),
            young: spec.young,
            seed: r.seed.wrapping_mul(1_000_003).wrapping_add(r.index),
            table_half: spec.table_half,
            table_z: None,
            occluders,
            colors: spec.colors.clone(),
            markers: None,
            truth: body.truth.clone(),
            camera: cam,
            cameras,
            sensor,
            frames: vec![FrameInput {
                cables: Vec::new(),
                cavities: Vec::new(),
                loads,
            }],
        },
        model_path: sweep.model_path.clone(),
        truth_mesh: sweep.truth_mesh.clone(),
    };
    let rendered = match render_attempt(&scene, body)? {
        Ok(rendered) => rendered,
        Err(why) => return Ok(Err(why)),
    };
    let ratio = spec.validity.min_volume_ratio;
    if let Some(fault) = physical_fault(prepared, body, &scene.spec, &rendered, ratio) {
        return Ok(Err(fault));
    }
    // The occluder is placed in the first camera's view.
    let t = &rendered.truth;
    let (robot, occluded) =
        (t.views.first()).map_or((t.pixels[0], t.occluded), |v| (v.pixels[0], v.occluded));
    record.occluded = occluded as f64 / (robot + occluded).max(1) as f64;
    Ok(Ok((scene, rendered, record)))
}

/// Draws scene `index` ([`draw`]) and writes its recording into `dir`; returns the scene
/// (its model path the sweep's) and what was drawn.
pub fn write_drawn(
    sweep: &Sweep,
    prepared: &Prepared,
    seed: u64,
    index: usize,
    dir: &Path,
) -> SceneResult<(Scene, DrawRecord)> {
    let body = prepared.body(sweep, seed, index)?;
    let Drawn {
        mut scene,
        rendered,
        record,
    } = draw_body(sweep, prepared, &body, seed, index)?;
    scene.model_path = sweep.model_path.clone();
    let (unloaded, held) = (sweep.spec.reference_frames, sweep.spec.held_frames);
    if unloaded > 0 || held > 1 {
        // The unloaded frames first, then the loaded one as many times as it is held,
        // every frame rendered at its own index so no two share their sensor noise.
        let loaded = scene.spec.frames.clone();
        let cables = loaded.first().map_or_else(Vec::new, |f| f.cables.clone());
        let cavities = loaded.first().map_or_else(Vec::new, |f| f.cavities.clone());
        let unloaded_frames = (0..unloaded).map(|_| FrameInput {
            cables: cables.clone(),
            cavities: cavities.clone(),
            loads: Vec::new(),
        });
        let held_frames = (0..held).flat_map(|_| loaded.iter().cloned());
        scene.spec.frames = unloaded_frames.chain(held_frames).collect();
        super::write_recording(
            &scene,
            &prepared.model,
            &body.model,
            dir,
            |i| render_frame(&scene, &body.model, i),
            |_, _| {},
        )?;
        return Ok((scene, record));
    }
    let mut once = Some(rendered);
    super::write_recording(
        &scene,
        &prepared.model,
        &body.model,
        dir,
        |_| {
            once.take()
                .ok_or_else(|| SceneError::Spec("one frame per scene".into()))
        },
        |_, _| {},
    )?;
    Ok((scene, record))
}

/// `path` as a file in `out` names it: relative to `out` when it can be.
fn shown_from(out: &Path, path: &Path) -> String {
    (super::relative_to(path, out).unwrap_or_else(|| path.to_path_buf()))
        .display()
        .to_string()
}

/// Draws and writes `count` scenes into `out`: `sweep.toml` (the spec with every default
/// filled in, the seed and the count), `scene_NNNN.toml` and the recording `scene_NNNN/`
/// per scene, and `draws.json` (what was drawn, and why attempts were redrawn).
/// `progress` is called after each scene with (done, total).
pub fn run(
    sweep: &Sweep,
    out: &Path,
    count: usize,
    seed: u64,
    mut progress: impl FnMut(usize, usize),
) -> SceneResult<Vec<DrawRecord>> {
    let io = |path: &Path, e: &dyn std::fmt::Display| SceneError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out).map_err(|e| io(out, &e))?;
    let prepared = Prepared::new(sweep)?;
    let mut spec = sweep.spec.clone();
    spec.model = shown_from(out, &sweep.model_path);
    let truth_mesh = (sweep.truth_mesh.as_deref()).map(|m| shown_from(out, m));
    if let Some(t) = &mut spec.truth {
        t.mesh.clone_from(&truth_mesh);
    }
    let body = toml::to_string(&spec).map_err(|e| SceneError::Spec(e.to_string()))?;
    let header = format!(
        "# The sweep file as drawn from, every default filled in; remake it with\n\
         # softsense scene sweep sweep.toml NEW_DIR --count {count} --seed {seed}\n\
         # (model path relative to this folder).\n"
    );
    crate::io::atomic::write(
        &out.join("sweep.toml"),
        format!("{header}{body}").as_bytes(),
    )
    .map_err(|e| io(&out.join("sweep.toml"), &e))?;
    let mut records = Vec::new();
    for index in 0..count {
        let dir = out.join(format!("scene_{index:04}"));
        let (scene, record) = write_drawn(sweep, &prepared, seed, index, &dir)?;
        let mut file_spec = scene.spec;
        file_spec.model = spec.model.clone();
        if let Some(t) = &mut file_spec.truth {
            t.mesh.clone_from(&truth_mesh);
        }
        let text = toml::to_string(&file_spec).map_err(|e| SceneError::Spec(e.to_string()))?;
        let name = out.join(format!("scene_{index:04}.toml"));
        crate::io::atomic::write(&name, text.as_bytes()).map_err(|e| io(&name, &e))?;
        records.push(record);
        let draws = out.join("draws.json");
        crate::recording::write_json(&draws, &records)?;
        progress(index + 1, count);
    }
    Ok(records)
}

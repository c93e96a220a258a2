//! Rendering a scene's frame: the FE model is solved once, then every camera of the scene
//! ray-casts the deformed robot, the probes, the table and the occluders into its own
//! depth and colour images, with its own noise draw ([`SceneView::seed`]).

use super::camera::CameraSpec;
use super::markers::PaintedMarkers;
use super::raycast::{self, Bvh};
use super::{
    frame_problem, load_truths, table_height, ActuatorTruth, FrameTruth, LoadTruth, Scene,
    SceneError, SceneResult, SceneSpec,
};
use crate::camera::Camera;
use crate::fem::mesh::Surface;
use crate::fem::model::Model;
use crate::fem::solve::CableControl;
use crate::recording::schema::ViewTruth;

/// One camera a scene renders: its `[camera]`, or one of its `[[cameras]]`.
#[derive(Clone, Debug)]
pub struct SceneView {
    /// The camera's name (its sub-folder), `None` for a scene's single `[camera]`.
    pub name: Option<String>,
    /// Intrinsics and pose.
    pub camera: CameraSpec,
    /// Seed of this camera's sensor noise: the scene's for `[camera]`, else drawn from the
    /// scene's seed and the camera's index ([`crate::math::rand::camera_seed`]).
    pub seed: u64,
}

impl SceneView {
    /// `message` about this camera, naming it when it has a name.
    pub fn named(&self, message: impl std::fmt::Display) -> String {
        match &self.name {
            Some(name) => format!("camera {name}: {message}"),
            None => message.to_string(),
        }
    }

    /// The camera this view's spec describes, or why there is none.
    pub fn make_camera(&self) -> SceneResult<Camera> {
        self.camera.camera().ok_or_else(|| {
            let fault = (self.camera.check().err())
                .unwrap_or_else(|| "camera: no camera can be made from the spec".into());
            SceneError::Spec(self.named(fault))
        })
    }
}

impl SceneSpec {
    /// The cameras the scene renders, in order: `[camera]` alone, or every `[[cameras]]`.
    pub fn views(&self) -> Vec<SceneView> {
        if self.cameras.is_empty() {
            return vec![SceneView {
                name: None,
                camera: self.camera.clone(),
                seed: self.seed,
            }];
        }
        (self.cameras.iter().enumerate())
            .map(|(i, c)| SceneView {
                name: Some(c.name.clone()),
                camera: c.camera.clone(),
                seed: crate::math::rand::camera_seed(self.seed, i),
            })
            .collect()
    }
}

/// One camera's images of a frame.
#[derive(Clone, Debug)]
pub struct RenderedView {
    /// Depth in sensor units, row-major (0 = hole).
    pub depth: Vec<u16>,
    /// RGB, row-major.
    pub color: Vec<[u8; 3]>,
}

/// One rendered frame.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// Every camera's images, in the order of [`SceneSpec::views`].
    pub views: Vec<RenderedView>,
    /// The frame's truth.
    pub truth: FrameTruth,
    /// The deformed node positions (m).
    pub positions: Vec<[f64; 3]>,
    /// The painted markers' positions on the deformed surface (m; empty without markers).
    pub markers: Vec<[f64; 3]>,
}

/// A frame solved: what every camera renders.
struct Solved {
    surface: Surface,
    rest: Vec<[f64; 3]>,
    positions: Vec<[f64; 3]>,
    loads: Vec<LoadTruth>,
    actuators: Vec<ActuatorTruth>,
    newton_iterations: usize,
}

/// Solves frame `index` of the scene.
fn solve_frame(scene: &Scene, model: &Model, index: usize) -> SceneResult<Solved> {
    let spec = &scene.spec;
    let frame = spec
        .frames
        .get(index)
        .ok_or_else(|| SceneError::Spec(format!("no frame {index}")))?;
    let surface = model.problem.mesh.surface();
    let (problem, nodes_of_loads) = frame_problem(model, &surface, spec, index)?;
    let rest = problem.mesh.nodes_in_rest.clone();
    let sol = problem.solve_static(&model.newton)?;
    if !sol.converged {
        return Err(SceneError::NotConverged { frame: index });
    }
    let loads = load_truths(frame, &nodes_of_loads, &rest, &sol.positions);
    let actuators = problem
        .cables
        .iter()
        .enumerate()
        .map(|(i, c)| ActuatorTruth {
            name: c.name.clone(),
            displacement_controlled: matches!(c.control, CableControl::Displacement(_)),
            shortening: sol.cable_shortening.get(i).copied().unwrap_or(f64::NAN),
            tension: sol.cable_tension.get(i).copied().unwrap_or(f64::NAN),
        })
        .collect();
    Ok(Solved {
        surface,
        rest,
        positions: sol.positions,
        loads,
        actuators,
        newton_iterations: sol.iterations,
    })
}

/// Solves frame `index` of the scene once and renders it from every camera.
pub fn render_frame(scene: &Scene, model: &Model, index: usize) -> SceneResult<Rendered> {
    let spec = &scene.spec;
    let solved = solve_frame(scene, model, index)?;
    let views = spec.views();
    let cameras = (views.iter())
        .map(SceneView::make_camera)
        .collect::<SceneResult<Vec<_>>>()?;
    // The paint is on the robot, not in a camera: placed once (facing the first camera).
    let painted = (spec.markers.as_ref())
        .map(|paint| PaintedMarkers::bind(paint, &solved.rest, &solved.surface, &cameras[0]))
        .transpose()?;
    let markers = (painted.as_ref()).map_or_else(Vec::new, |p| p.positions(&solved.positions));
    let bvh = Bvh::new(&solved.positions, &solved.surface.triangles);
    let probes: Vec<([f64; 3], f64)> = (solved.loads.iter())
        .filter_map(|l| l.probe_center.map(|c| (c, l.radius)))
        .collect();
    let table_z = table_height(spec, &solved.rest);
    let mut rendered = Vec::with_capacity(views.len());
    let mut truths = Vec::with_capacity(views.len());
    for (view, camera) in views.iter().zip(&cameras) {
        let hits = cast_pixels(spec, camera, &bvh, &probes, table_z);
        let marked = (painted.as_ref()).map(|p| marker_mask(p, camera, &hits, &markers));
        let (images, truth) = shade_view(spec, view, &hits, marked.as_deref(), index);
        rendered.push(images);
        truths.push(truth);
    }
    let mut pixels = [0usize; 3];
    for t in &truths {
        (0..3).for_each(|k| pixels[k] += t.pixels[k]);
    }
    let occluded = truths.iter().map(|t| t.occluded).sum();
    let one_camera = spec.cameras.is_empty();
    Ok(Rendered {
        views: rendered,
        truth: FrameTruth {
            frame: index,
            loads: solved.loads,
            actuators: solved.actuators,
            newton_iterations: solved.newton_iterations,
            pixels,
            occluded,
            views: if one_camera { Vec::new() } else { truths },
        },
        positions: solved.positions,
        markers,
    })
}

/// One camera's depth and colour images from its pixel hits (`marked`: per pixel, whether
/// it shows a painted marker), with its noise draw, and its pixel counts.
fn shade_view(
    spec: &SceneSpec,
    view: &SceneView,
    hits: &[PixelHit],
    marked: Option<&[bool]>,
    index: usize,
) -> (RenderedView, ViewTruth) {
    let w = view.camera.width as usize;
    let z: Vec<f64> = hits.iter().map(|h| h.0).collect();
    let cosi: Vec<f64> = hits.iter().map(|h| h.1).collect();
    let depth = spec.sensor.depth(&z, &cosi, w, view.seed, index as u64);
    let cols = [
        spec.colors.robot,
        spec.colors.probe,
        spec.colors.table,
        spec.colors.occluder,
    ];
    let color = hits
        .iter()
        .enumerate()
        .map(|(i, &(_, c, obj, _))| {
            let base = match (&spec.markers, marked.and_then(|m| m.get(i))) {
                (Some(m), Some(true)) => m.colour,
                _ if obj < NONE => cols[obj],
                _ => [0, 0, 0],
            };
            let shade = 0.4 + 0.6 * c;
            let rgb = base.map(|b| b as f64 * shade);
            spec.sensor.color(rgb, view.seed, index as u64, i as u64)
        })
        .collect();
    let mut pixels = [0usize; 3];
    for hh in hits {
        if hh.2 < 3 {
            pixels[hh.2] += 1;
        }
    }
    let truth = ViewTruth {
        camera: view.name.clone().unwrap_or_default(),
        pixels,
        occluded: hits.iter().filter(|h| h.3).count(),
    };
    (RenderedView { depth, color }, truth)
}

/// Per pixel, whether its ray hit the body within a painted marker's radius (`positions`:
/// the markers' deformed positions).
fn marker_mask(
    painted: &PaintedMarkers,
    camera: &Camera,
    hits: &[PixelHit],
    positions: &[[f64; 3]],
) -> Vec<bool> {
    let w = camera.intrinsics.width as usize;
    let points: Vec<Option<[f64; 3]>> = (hits.iter().enumerate())
        .map(|(i, h)| (h.2 == 0).then(|| camera.backproject((i % w) as f64, (i / w) as f64, h.0)))
        .collect();
    painted.painted(&points, positions)
}

/// One pixel's ray: the nearest hit's depth, cosine of incidence and object (0 robot, 1
/// probe, 2 table, 3 occluder; `(0, 1, NONE)` for none), and whether an occluder hides
/// the robot there.
type PixelHit = (f64, f64, usize, bool);
const NONE: usize = 4;

/// Per pixel, row-major: [`PixelHit`].
fn cast_pixels(
    spec: &SceneSpec,
    camera: &Camera,
    bvh: &Bvh,
    probes: &[([f64; 3], f64)],
    table_z: f64,
) -> Vec<PixelHit> {
    let (w, h) = (
        camera.intrinsics.width as usize,
        camera.intrinsics.height as usize,
    );
    let o = camera.eye();
    let cast = |i: usize| -> PixelHit {
        let (u, v) = ((i % w) as f64, (i / w) as f64);
        let d = camera.ray(u, v);
        let dn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let mut best: Option<(raycast::Hit, usize)> = None;
        let mut consider = |hit: Option<raycast::Hit>, obj: usize| {
            if let Some(hh) = hit {
                if best.as_ref().is_none_or(|b| hh.t < b.0.t) {
                    best = Some((hh, obj));
                }
            }
        };
        let robot = bvh.cast(o, d);
        let robot_t = robot.as_ref().map(|h| h.t);
        consider(robot, 0);
        for &(c, r) in probes {
            consider(raycast::ray_sphere(o, d, c, r), 1);
        }
        if spec.table_half > 0.0 {
            let plane = raycast::ray_plane(o, d, [0.0, 0.0, 1.0], table_z, spec.table_half);
            consider(plane, 2);
        }
        let mut hidden = false;
        for oc in &spec.occluders {
            let hit = raycast::ray_sphere(o, d, oc.center, oc.radius);
            hidden |= matches!((&hit, robot_t), (Some(h), Some(t)) if h.t < t);
            consider(hit, 3);
        }
        match best {
            Some((hit, obj)) => {
                let c =
                    (hit.normal[0] * d[0] + hit.normal[1] * d[1] + hit.normal[2] * d[2]).abs() / dn;
                (hit.t, c, obj, hidden)
            }
            None => (0.0, 1.0, NONE, hidden),
        }
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..w * h).into_par_iter().map(cast).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..w * h).map(cast).collect()
    }
}

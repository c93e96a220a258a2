//! What a sensed frame looks like in 3-D, as plain data: named entities (points, lines,
//! meshes, arrows, ellipsoids, images, camera models, text, scalars) in the robot frame.
//!
//! Defined once here, and written out by two thin translators: the `.rrd` writer behind
//! the `rerun` feature (`render::rrd`, `softsense sense --rerun`) and the Python package's
//! `softsense.rerun` (through `rerun-sdk`). The entity paths are docs/rerun.md's table.

use crate::math::Mat3;
use crate::recording::Recording;
use crate::sense::{FrameReport, FrameStatus, Observation, Sensor};
use serde::Serialize;

/// The entity that carries the robot frame's axes (z up: the models' gravity is -z).
pub const WORLD: &str = "world";
/// Robot points of every camera (m, robot frame).
pub const ROBOT_POINTS: &str = "world/points/robot";
/// Points inside the crop that are not the robot: what may touch it.
pub const OBJECT_POINTS: &str = "world/points/objects";
/// The FE surface at the frame's estimated state (the rest state when nothing was solved).
pub const FE_SURFACE: &str = "world/fe_surface";
/// The frame's feature points on the FE surface: blue where the final estimate registered
/// them, grey where not.
pub const FEATURES: &str = "world/features";
/// A line from each registered feature to the point cloud's surface along its normal.
pub const RESIDUALS: &str = "world/features/residuals";
/// Where contacts were seen.
pub const CONTACTS: &str = "world/contacts";
/// The estimated forces, drawn from their locations.
pub const FORCES: &str = "world/forces";
/// Each force's one-sigma ellipsoid, around its arrow's tip.
pub const FORCE_SIGMA: &str = "world/forces/sigma";
/// The frame's status line, then one entry per warning.
pub const STATUS: &str = "status";
/// The registration residual's RMS (mm), over frames.
pub const RESIDUAL_PLOT: &str = "plots/residual_mm";

/// Camera `name`'s pose in the robot frame.
pub fn camera_path(name: &str) -> String {
    format!("world/cameras/{name}")
}

/// Camera `name`'s pinhole model (the image plane).
pub fn pinhole_path(name: &str) -> String {
    format!("world/cameras/{name}/image")
}

/// Camera `name`'s colour frame.
pub fn image_path(name: &str) -> String {
    format!("world/cameras/{name}/image/rgb")
}

/// Force `i`'s magnitude (N), over frames.
pub fn force_plot_path(i: usize) -> String {
    format!("plots/force_{i}")
}

/// How a frame is drawn.
#[derive(Clone, Debug)]
pub struct SceneParams {
    /// Arrow length per newton (m/N); default: a quarter of the model's bounding-box
    /// diagonal per newton.
    pub force_scale: Option<f64>,
    /// Radius of a cloud point (m); default 0.4 mm.
    pub point_radius: f32,
    /// Include each camera's colour frame; default true.
    pub images: bool,
}

impl Default for SceneParams {
    fn default() -> Self {
        SceneParams {
            force_scale: None,
            point_radius: 4e-4,
            images: true,
        }
    }
}

/// Severity of a [`Shape::Text`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    /// A sensed frame.
    Info,
    /// A warning, or an unreliable frame.
    Warn,
    /// A frame that gave no forces.
    Error,
}

/// One thing to draw. Positions are metres in the robot frame, colours sRGB.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Shape {
    /// The robot frame's axes: right-handed, z up.
    ZUp,
    /// A rigid pose, child frame into parent.
    Transform {
        /// Translation (m).
        translation: [f32; 3],
        /// Rotation matrix, as its three columns.
        rotation_columns: [[f32; 3]; 3],
    },
    /// A pinhole camera model, its image plane drawn `plane_distance` in front.
    Pinhole {
        /// Focal lengths fx, fy (pixels).
        focal: [f32; 2],
        /// Principal point cx, cy (pixels).
        principal: [f32; 2],
        /// Image width and height (pixels).
        resolution: [u32; 2],
        /// Where the viewer draws the image plane (m).
        plane_distance: f32,
    },
    /// An RGB image.
    Image {
        /// Width (pixels).
        width: u32,
        /// Height (pixels).
        height: u32,
        /// Row-major, 3 bytes a pixel.
        rgb: Vec<u8>,
    },
    /// Points.
    Points {
        /// Positions (m).
        positions: Vec<[f32; 3]>,
        /// One colour per point, or one for all.
        colors: Vec<[u8; 3]>,
        /// Radius (m).
        radius: f32,
        /// One label per point, or none.
        labels: Vec<String>,
    },
    /// Line strips.
    Lines {
        /// Each strip's vertices (m).
        strips: Vec<Vec<[f32; 3]>>,
        /// Colour.
        color: [u8; 3],
        /// Line radius (m).
        radius: f32,
    },
    /// A triangle mesh.
    Mesh {
        /// Vertices (m).
        vertices: Vec<[f32; 3]>,
        /// Unit normal per vertex.
        normals: Vec<[f32; 3]>,
        /// Vertex indices, counter-clockwise seen from outside.
        triangles: Vec<[u32; 3]>,
        /// Colour.
        color: [u8; 3],
    },
    /// Arrows.
    Arrows {
        /// Where each starts (m).
        origins: Vec<[f32; 3]>,
        /// Each one's vector (m).
        vectors: Vec<[f32; 3]>,
        /// Colour.
        color: [u8; 3],
        /// One label per arrow.
        labels: Vec<String>,
    },
    /// Ellipsoids.
    Ellipsoids {
        /// Centres (m).
        centers: Vec<[f32; 3]>,
        /// Half-axes along the rotated x, y, z (m).
        half_sizes: Vec<[f32; 3]>,
        /// Rotations, unit quaternions (x, y, z, w).
        quaternions: Vec<[f32; 4]>,
        /// Colour.
        color: [u8; 3],
    },
    /// A log line.
    Text {
        /// Severity.
        level: Level,
        /// The line.
        text: String,
    },
    /// One value of a time series.
    Scalar {
        /// The value.
        value: f64,
    },
    /// Nothing here in this frame (a camera that did not read it).
    Clear,
}

/// A shape at an entity path.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Entity {
    /// Slash-separated path, e.g. [`FORCES`].
    pub path: String,
    /// What is drawn there.
    pub shape: Shape,
}

impl Entity {
    fn new(path: impl Into<String>, shape: Shape) -> Self {
        Entity {
            path: path.into(),
            shape,
        }
    }
}

const ROBOT_GREEN: [u8; 3] = [60, 190, 80];
const OBJECT_ORANGE: [u8; 3] = [235, 140, 40];
const SURFACE_GREY: [u8; 3] = [170, 200, 175];
const REGISTERED_BLUE: [u8; 3] = [40, 110, 230];
const HIDDEN_GREY: [u8; 3] = [140, 140, 140];
const RESIDUAL_RED: [u8; 3] = [220, 40, 40];
const CONTACT_YELLOW: [u8; 3] = [240, 210, 30];
const FORCE_RED: [u8; 3] = [230, 30, 30];
const SIGMA_PINK: [u8; 3] = [240, 120, 150];

fn f32s(p: [f64; 3]) -> [f32; 3] {
    p.map(|v| v as f32)
}

/// What does not change over a recording: the axes and every camera's pose and pinhole.
/// `cameras` are the sensor's cameras' recordings, in [`Sensor::cameras`] order.
pub fn static_entities(sensor: &Sensor, cameras: &[&Recording]) -> Vec<Entity> {
    let mut out = vec![Entity::new(WORLD, Shape::ZUp)];
    let size = model_diagonal(sensor);
    for (camera, rec) in sensor.cameras.iter().zip(cameras) {
        let pose = &camera.robot_from_camera;
        let r = pose.rotation;
        out.push(Entity::new(
            camera_path(&camera.name),
            Shape::Transform {
                translation: f32s(pose.translation),
                rotation_columns: [0, 1, 2].map(|c| [r[0][c], r[1][c], r[2][c]].map(|v| v as f32)),
            },
        ));
        let k = &rec.camera.intrinsics;
        out.push(Entity::new(
            pinhole_path(&camera.name),
            Shape::Pinhole {
                focal: [k.fx as f32, k.fy as f32],
                principal: [k.cx as f32, k.cy as f32],
                resolution: [k.width, k.height],
                plane_distance: (0.25 * size) as f32,
            },
        ));
    }
    out
}

/// The model's rest bounding-box diagonal (m).
fn model_diagonal(sensor: &Sensor) -> f64 {
    let [lo, hi] = sensor.model.problem.mesh.bbox();
    (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt()
}

/// Everything drawn for one frame: each camera's image (or a clear), the points, the FE
/// surface, the features and their residual lines, the contacts, the forces with their
/// one-sigma ellipsoids, the status and warnings, and the plotted values. `obs` is the
/// frame's observation when it could be read. Every frame has the same entities but for
/// one plot per force, so a viewer never shows a previous frame's arrows.
pub fn frame_entities(
    sensor: &Sensor,
    obs: Option<&Observation>,
    report: &FrameReport,
    params: &SceneParams,
) -> Vec<Entity> {
    let mut out = Vec::new();
    if params.images {
        for (k, camera) in sensor.cameras.iter().enumerate() {
            let view = obs.and_then(|o| o.views.iter().find(|v| v.camera == k));
            let shape = match view {
                Some(v) => Shape::Image {
                    width: v.width,
                    height: v.height,
                    rgb: v.color.iter().flatten().copied().collect(),
                },
                None => Shape::Clear,
            };
            out.push(Entity::new(image_path(&camera.name), shape));
        }
    }
    let robot: Vec<[f32; 3]> =
        obs.map_or(Vec::new(), |o| o.robot.iter().map(|p| f32s(*p)).collect());
    let objects = obs.map_or(Vec::new(), |o| o.objects.clone());
    out.push(points(
        ROBOT_POINTS,
        robot,
        vec![ROBOT_GREEN],
        params.point_radius,
    ));
    out.push(points(
        OBJECT_POINTS,
        objects,
        vec![OBJECT_ORANGE],
        params.point_radius,
    ));
    let x = match report.positions.is_empty() {
        true => &sensor.model.problem.mesh.nodes_in_rest,
        false => &report.positions,
    };
    out.push(fe_surface(sensor, x));
    out.extend(features(report, x, params.point_radius));
    out.extend(forces(sensor, report, params));
    out.extend(status(report));
    out.push(Entity::new(
        RESIDUAL_PLOT,
        Shape::Scalar {
            value: report.residual_rms * 1e3,
        },
    ));
    for (i, f) in report.forces.iter().enumerate() {
        out.push(Entity::new(
            force_plot_path(i),
            Shape::Scalar { value: f.magnitude },
        ));
    }
    out
}

fn points(path: &str, positions: Vec<[f32; 3]>, colors: Vec<[u8; 3]>, radius: f32) -> Entity {
    Entity::new(
        path,
        Shape::Points {
            positions,
            colors,
            radius,
            labels: Vec::new(),
        },
    )
}

/// The FE boundary surface at node positions `x`.
fn fe_surface(sensor: &Sensor, x: &[[f64; 3]]) -> Entity {
    let triangles = &sensor.surface.triangles;
    let normals = crate::geometry::triangle::vertex_normals(x, triangles);
    Entity::new(
        FE_SURFACE,
        Shape::Mesh {
            vertices: x.iter().map(|p| f32s(*p)).collect(),
            normals: normals.iter().map(|n| f32s(*n)).collect(),
            triangles: triangles.iter().map(|t| t.map(|i| i as u32)).collect(),
            color: SURFACE_GREY,
        },
    )
}

/// The frame's feature points at `x` (the report's final state) and, where its estimate
/// registered them, the line to the surface they were matched to: the report's own
/// registration, not a new one.
fn features(report: &FrameReport, x: &[[f64; 3]], radius: f32) -> [Entity; 2] {
    let (mut positions, mut colors, mut strips) = (Vec::new(), Vec::new(), Vec::new());
    for (f, m) in report.matches.iter() {
        let (p, n) = (f.position(x), f.normal(x));
        positions.push(f32s(p));
        colors.push(if m.is_some() {
            REGISTERED_BLUE
        } else {
            HIDDEN_GREY
        });
        if let Some(m) = m {
            let q: [f64; 3] = std::array::from_fn(|i| p[i] + m.offset * n[i]);
            strips.push(vec![f32s(p), f32s(q)]);
        }
    }
    [
        points(FEATURES, positions, colors, 2.5 * radius),
        Entity::new(
            RESIDUALS,
            Shape::Lines {
                strips,
                color: RESIDUAL_RED,
                radius: 0.5 * radius,
            },
        ),
    ]
}

/// Contacts, force arrows and their one-sigma ellipsoids.
fn forces(sensor: &Sensor, report: &FrameReport, params: &SceneParams) -> [Entity; 3] {
    let scale = params
        .force_scale
        .unwrap_or_else(|| 0.25 * model_diagonal(sensor));
    let (mut seen, mut seen_labels) = (Vec::new(), Vec::new());
    let (mut origins, mut vectors, mut labels) = (Vec::new(), Vec::new(), Vec::new());
    let (mut centers, mut half_sizes, mut quaternions) = (Vec::new(), Vec::new(), Vec::new());
    for (i, f) in report.forces.iter().enumerate() {
        if let Some(at) = f.seen_at {
            seen.push(f32s(at));
            seen_labels.push(format!("{i}: {}", f.source));
        }
        let v = f.force.map(|c| c * scale);
        origins.push(f32s(f.location));
        vectors.push(f32s(v));
        labels.push(format!(
            "{i}: {:.3} N ±{:.3} (3-D)",
            f.magnitude, f.sigma_max
        ));
        let (half, q) = sigma_ellipsoid(&f.covariance, scale);
        centers.push(f32s(std::array::from_fn(|k| f.location[k] + v[k])));
        half_sizes.push(half);
        quaternions.push(q);
    }
    [
        Entity::new(
            CONTACTS,
            Shape::Points {
                colors: vec![CONTACT_YELLOW],
                positions: seen,
                radius: 4.0 * params.point_radius,
                labels: seen_labels,
            },
        ),
        Entity::new(
            FORCES,
            Shape::Arrows {
                origins,
                vectors,
                color: FORCE_RED,
                labels,
            },
        ),
        Entity::new(
            FORCE_SIGMA,
            Shape::Ellipsoids {
                centers,
                half_sizes,
                quaternions,
                color: SIGMA_PINK,
            },
        ),
    ]
}

/// Half-axes (one sigma in each principal direction, times `scale` in m/N) and rotation
/// (unit quaternion x, y, z, w) of the ellipsoid of a force covariance (N²).
pub fn sigma_ellipsoid(covariance: &[[f64; 3]; 3], scale: f64) -> ([f32; 3], [f32; 4]) {
    let c = Mat3::from_fn(|i, j| 0.5 * (covariance[i][j] + covariance[j][i]));
    let eig = c.symmetric_eigen();
    let mut axes = eig.eigenvectors;
    // A rotation needs determinant +1; an eigenvector's sign is free.
    if axes.determinant() < 0.0 {
        axes.set_column(2, &(-axes.column(2)));
    }
    let half = [0, 1, 2].map(|k| (eig.eigenvalues[k].max(0.0).sqrt() * scale) as f32);
    let rotation = nalgebra::Rotation3::from_matrix_unchecked(axes);
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&rotation);
    // nalgebra stores a quaternion as (i, j, k, w): rerun's (x, y, z, w).
    (half, q.coords.map(|v| v as f32).into())
}

/// The status line (with its level) and one entry per warning.
fn status(report: &FrameReport) -> Vec<Entity> {
    let level = match (&report.status, report.reliable) {
        (FrameStatus::Sensed, true) => Level::Info,
        (FrameStatus::Sensed, false) => Level::Warn,
        _ => Level::Error,
    };
    let text = match report.status {
        FrameStatus::Sensed => format!(
            "frame {}: sensed, {} force(s), {}/{} features, residual {:.2} mm",
            report.frame,
            report.forces.len(),
            report.features_visible,
            report.features,
            report.residual_rms * 1e3
        ),
        ref s => format!("frame {}: {s}", report.frame),
    };
    let mut out = vec![Entity::new(STATUS, Shape::Text { level, text })];
    out.extend(report.warnings.iter().map(|w| {
        Entity::new(
            STATUS,
            Shape::Text {
                level: Level::Warn,
                text: w.clone(),
            },
        )
    }));
    out
}

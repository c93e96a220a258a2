//! Painted markers in generated scenes (issue 36): coloured discs on the FE surface that
//! move with it, for [`crate::markers::detect`] to find in the RGB-D frames.
//!
//! A scene's `[markers]` table gives the paint colour, the disc radius and either the
//! marker points (`at`, robot frame at rest, each snapped to its nearest surface point) or
//! a `count` spread over the surface the camera faces. Each marker is bound to its surface
//! triangle at rest (barycentric weights, [`crate::fem::bind::bind_markers`]) and follows the
//! deformed mesh; a pixel whose ray hits the body within `radius` of a marker's deformed
//! position takes the marker's colour (shaded like the body). `scene generate` writes the
//! deformed positions per frame to `markers_truth.csv` (softsense track format, robot
//! frame).

use super::{SceneError, SceneResult};
use crate::camera::Camera;
use crate::fem::bind::{bind_markers, BoundMarker};
use crate::fem::mesh::Surface;
use crate::math::{dot, norm, sub};
use crate::recording::tracks::{MarkerTracks, TrackFrame};
use serde::{Deserialize, Serialize};

/// The `[markers]` table of a scene file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MarkerPaint {
    /// Paint colour (0-255 RGB; default [30, 60, 230], a blue unlike the robot, probe and
    /// table colours).
    #[serde(default = "default_colour")]
    pub colour: [u8; 3],
    /// Radius of each painted disc (m; default 0.003).
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// Marker points (m, robot frame at rest), each snapped to its nearest surface point.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at: Vec<[f64; 3]>,
    /// Or this many markers spread over the surface facing the camera (see
    /// [`spread_markers`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<usize>,
}

fn default_colour() -> [u8; 3] {
    [30, 60, 230]
}

fn default_radius() -> f64 {
    0.003
}

/// Farthest a marker's `at` may be from the surface (m): a point farther is a typo or a
/// unit slip, as for loads ([`super::MAX_LOAD_OFFSET`]).
pub const MAX_MARKER_OFFSET: f64 = super::MAX_LOAD_OFFSET;

/// Most markers a scene may paint.
pub const MAX_MARKERS: usize = 1000;

/// Markers closer than this many radii would paint one merged blob.
pub const MIN_SPACING_RADII: f64 = 3.0;

/// The markers of a scene, bound to the surface at rest.
#[derive(Clone, Debug)]
pub struct PaintedMarkers {
    /// Paint colour (0-255 RGB).
    pub colour: [u8; 3],
    /// Disc radius (m).
    pub radius: f64,
    /// The markers, named `m0`, `m1`, ... in order.
    pub markers: Vec<BoundMarker>,
}

/// The surface nodes `count` markers are spread over: nodes facing the camera (the eye
/// within 60° of the vertex normal) whose neighbourhood within `2·radius` is flat (every
/// surface node there on the same side, its normal less than 90° from the node's, has it
/// within 10°), so that a disc is neither
/// seen at a grazing angle nor folded over an edge. Farthest-point sampling then picks
/// `count` of them, starting from the one nearest their centroid.
pub fn spread_markers(
    rest: &[[f64; 3]],
    surface: &Surface,
    camera: &Camera,
    radius: f64,
    count: usize,
) -> SceneResult<Vec<[f64; 3]>> {
    let n = &surface.vertex_normals;
    let eye = camera.eye();
    let (cos_view, cos_flat) = (60f64.to_radians().cos(), 10f64.to_radians().cos());
    let facing: Vec<usize> = (surface.nodes.iter().copied())
        .filter(|&v| {
            let to_eye = sub(eye, rest[v]);
            dot(n[v], to_eye) > cos_view * norm(to_eye)
        })
        .collect();
    let flat: Vec<usize> = (facing.iter().copied())
        .filter(|&v| {
            surface.nodes.iter().all(|&w| {
                // The far side of a thin body (normals opposed) is no edge.
                let c = dot(n[w], n[v]);
                norm(sub(rest[w], rest[v])) > 2.0 * radius || c <= 0.0 || c > cos_flat
            })
        })
        .collect();
    if flat.len() < count {
        return Err(SceneError::Spec(format!(
            "markers.count = {count}, but only {} surface nodes face the camera on flat ground",
            flat.len()
        )));
    }
    let mut centroid = [0.0; 3];
    for &v in &flat {
        (0..3).for_each(|k| centroid[k] += rest[v][k] / flat.len() as f64);
    }
    let mut nearest: Vec<f64> = flat.iter().map(|&v| norm(sub(rest[v], centroid))).collect();
    let mut chosen = Vec::with_capacity(count);
    // The first pick is the node nearest the centroid; then the node farthest from all picks.
    let mut next = (0..flat.len()).min_by(|&a, &b| nearest[a].total_cmp(&nearest[b]));
    nearest.iter_mut().for_each(|d| *d = f64::INFINITY);
    while chosen.len() < count {
        let Some(i) = next else { break };
        let p = rest[flat[i]];
        chosen.push(p);
        for (j, &v) in flat.iter().enumerate() {
            nearest[j] = nearest[j].min(norm(sub(rest[v], p)));
        }
        next = (0..flat.len()).max_by(|&a, &b| nearest[a].total_cmp(&nearest[b]));
    }
    Ok(chosen)
}

impl PaintedMarkers {
    /// Binds the scene's markers to the rest surface (`rest`: the rest node positions).
    pub fn bind(
        paint: &MarkerPaint,
        rest: &[[f64; 3]],
        surface: &Surface,
        camera: &Camera,
    ) -> SceneResult<Self> {
        let r = paint.radius;
        if !(r.is_finite() && r > 0.0) {
            return Err(SceneError::Spec(format!(
                "markers.radius must be a finite number > 0 (m), got {r}"
            )));
        }
        let points = match (&paint.at[..], paint.count) {
            ([], Some(n)) if (1..=MAX_MARKERS).contains(&n) => {
                spread_markers(rest, surface, camera, r, n)?
            }
            (at, None) if !at.is_empty() && at.len() <= MAX_MARKERS => at.to_vec(),
            _ => {
                return Err(SceneError::Spec(format!(
                    "[markers] needs either `at` (1 to {MAX_MARKERS} points) or `count` (1 to {MAX_MARKERS}), not both"
                )))
            }
        };
        if let Some(p) = points.iter().find(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(SceneError::Spec(format!("markers.at: {p:?} is not finite")));
        }
        let names: Vec<String> = (0..points.len()).map(|i| format!("m{i}")).collect();
        let markers = bind_markers(rest, surface, &names, &points, MAX_MARKER_OFFSET)
            .map_err(|e| SceneError::Spec(format!("markers.at: {e}")))?;
        let at_rest: Vec<[f64; 3]> = markers.iter().map(|m| m.at.position(rest)).collect();
        for i in 0..at_rest.len() {
            for j in 0..i {
                let d = norm(sub(at_rest[i], at_rest[j]));
                if d < MIN_SPACING_RADII * r {
                    return Err(SceneError::Spec(format!(
                        "markers m{j} and m{i} are {:.1} mm apart on the surface: less than {MIN_SPACING_RADII} radii ({:.1} mm), their discs would merge",
                        d * 1e3,
                        MIN_SPACING_RADII * r * 1e3
                    )));
                }
            }
        }
        Ok(Self {
            colour: paint.colour,
            radius: r,
            markers,
        })
    }

    /// The markers' positions on the deformed surface (`x`: node positions, m).
    pub fn positions(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.markers.iter().map(|m| m.at.position(x)).collect()
    }

    /// Which of `points` (robot frame; `None` where a pixel saw no body) lie within the
    /// radius of one of `positions`.
    pub fn painted(&self, points: &[Option<[f64; 3]>], positions: &[[f64; 3]]) -> Vec<bool> {
        let r2 = self.radius * self.radius;
        points
            .iter()
            .map(|p| {
                p.is_some_and(|p| {
                    positions
                        .iter()
                        .any(|m| (0..3).map(|k| (p[k] - m[k]).powi(2)).sum::<f64>() <= r2)
                })
            })
            .collect()
    }

    /// The track file of the markers' true positions, one frame per entry of `frames`.
    pub fn truth_tracks(&self, frames: &[Vec<[f64; 3]>]) -> MarkerTracks {
        MarkerTracks {
            names: self.markers.iter().map(|m| m.name.clone()).collect(),
            frames: (frames.iter().enumerate())
                .map(|(i, p)| TrackFrame {
                    frame: i as u64,
                    positions: p.iter().map(|&q| Some(q)).collect(),
                })
                .collect(),
        }
    }
}

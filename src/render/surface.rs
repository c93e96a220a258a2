//! Scalar fields on a triangle surface, rendered with a z-buffer from a camera.

use super::canvas::{Canvas, Rgb, BLACK, WHITE};
use super::colormap::{colorbar, finite_range, ColorMap};
use super::font::text_size;
use super::project::{cross, normalize, NEAR_Z};
use super::RenderError;
use crate::camera::Camera;
use crate::math::sub;

/// The values shown on a surface.
#[derive(Clone, Copy, Debug)]
pub enum SurfaceValues<'a> {
    /// One value per vertex, interpolated across each triangle (perspective-correct).
    PerVertex(&'a [f64]),
    /// One value per triangle.
    PerTriangle(&'a [f64]),
    /// No values: the surface in a neutral grey, for the shape alone.
    None,
}

/// A triangle surface in the robot frame with values on it.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceMesh<'a> {
    /// Vertex positions in the robot frame (m).
    pub vertices_in_robot: &'a [[f64; 3]],
    /// Triangles as vertex indices, counter-clockwise seen from outside (as
    /// [`crate::fem::mesh::TetMesh::surface`] gives them).
    pub triangles: &'a [[usize; 3]],
    /// The scalar field.
    pub values: SurfaceValues<'a>,
    /// Extra points in the robot frame with a value each (e.g. feature points with their
    /// residual), drawn as discs coloured by the same map where they are not hidden by the
    /// surface.
    pub markers: &'a [([f64; 3], f64)],
}

/// How [`surface_map`] draws.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceMapParams {
    /// Title written above the picture.
    pub title: String,
    /// Label over the colour bar (the quantity and its unit, e.g. "residual mm").
    pub value_label: String,
    /// The colour map.
    pub colormap: ColorMap,
    /// Value range `[lo, hi]` of the map; `None` takes the finite range of the values
    /// (symmetric about 0 for [`ColorMap::Diverging`]).
    pub range: Option<[f64; 2]>,
    /// Skip triangles facing away from the camera (needs outward, consistent winding).
    pub cull_back_faces: bool,
    /// Background colour.
    pub background: Rgb,
    /// Marker disc radius, pixels.
    pub marker_radius: f64,
}

impl Default for SurfaceMapParams {
    fn default() -> Self {
        SurfaceMapParams {
            title: String::new(),
            value_label: String::new(),
            colormap: ColorMap::Sequential,
            range: None,
            cull_back_faces: true,
            background: WHITE,
            marker_radius: 4.0,
        }
    }
}

/// Pixels added to the right of the camera image for the colour bar.
pub const COLORBAR_PANEL: u32 = 90;
/// Pixels added above the camera image for the title.
pub const TITLE_BAND: u32 = 24;

/// The depth-tested rendering of the surface alone (camera image size), as colour and
/// per-pixel inverse depth (0 where nothing was drawn).
struct Raster {
    canvas: Canvas,
    inv_depth: Vec<f64>,
}

/// Renders `mesh` from `view`: each visible pixel shows the nearest triangle, coloured by
/// the value map and shaded by how squarely the triangle faces the camera (so the shape
/// reads), with a colour bar on the right and the title on top. The picture is the camera
/// image (`view.intrinsics` width x height) plus [`COLORBAR_PANEL`] columns and
/// [`TITLE_BAND`] rows. Triangles with a vertex behind the camera are skipped (no clipping).
pub fn surface_map(
    mesh: &SurfaceMesh<'_>,
    view: &Camera,
    params: &SurfaceMapParams,
) -> Result<Canvas, RenderError> {
    let nv = mesh.vertices_in_robot.len();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i >= nv) {
            return Err(RenderError::TriangleIndex {
                triangle: t,
                index,
                vertices: nv,
            });
        }
    }
    let values: &[f64] = match mesh.values {
        SurfaceValues::PerVertex(v) => {
            check_len("per-vertex values", nv, v.len())?;
            v
        }
        SurfaceValues::PerTriangle(v) => {
            check_len("per-triangle values", mesh.triangles.len(), v.len())?;
            v
        }
        SurfaceValues::None => &[],
    };
    let marker_values: Vec<f64> = mesh.markers.iter().map(|m| m.1).collect();
    let all: Vec<f64> = values.iter().chain(&marker_values).copied().collect();
    let range = params.range.unwrap_or_else(|| match params.colormap {
        ColorMap::Diverging => super::colormap::symmetric_range(&all),
        ColorMap::Sequential => finite_range(&all).unwrap_or([0.0, 1.0]),
    });
    let k = &view.intrinsics;
    let raster = rasterize(mesh, view, params, range)?;
    let (w, h) = (k.width, k.height);
    let mut out = Canvas::new(
        w.saturating_add(COLORBAR_PANEL),
        h.saturating_add(TITLE_BAND),
        params.background,
    )?;
    out.blit(&raster.canvas, 0, i64::from(TITLE_BAND));
    // Markers, depth-tested against the surface (a small tolerance lets points that lie on
    // it show).
    for (p, v) in mesh.markers {
        let Some((uv, z)) = view.project_robot(*p) else {
            continue;
        };
        let (x, y) = (uv[0].round(), uv[1].round());
        if x >= 0.0 && y >= 0.0 && x < f64::from(w) && y < f64::from(h) {
            let i = y as usize * w as usize + x as usize;
            let surf = raster.inv_depth[i];
            if surf > 0.0 && 1.0 / surf < z * (1.0 - 2e-3) - 1e-4 {
                continue;
            }
        }
        let at = [uv[0], uv[1] + f64::from(TITLE_BAND)];
        out.disc(at, params.marker_radius + 1.0, BLACK);
        out.disc(at, params.marker_radius, params.colormap.map(*v, range));
    }
    let title_scale = if text_size(&params.title, 2).0 + 12 <= out.width() {
        2
    } else {
        1
    };
    out.text(6, 4, &params.title, BLACK, title_scale);
    if !values.is_empty() || !mesh.markers.is_empty() {
        let bar_h = i64::from(h).saturating_sub(60).max(20);
        colorbar(
            &mut out,
            [i64::from(w) + 14, i64::from(TITLE_BAND) + 30, 16, bar_h],
            params.colormap,
            range,
            &params.value_label,
        );
    }
    Ok(out)
}

fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), RenderError> {
    if expected == got {
        Ok(())
    } else {
        Err(RenderError::Length {
            what,
            expected,
            got,
        })
    }
}

fn rasterize(
    mesh: &SurfaceMesh<'_>,
    view: &Camera,
    params: &SurfaceMapParams,
    range: [f64; 2],
) -> Result<Raster, RenderError> {
    let k = &view.intrinsics;
    let mut canvas = Canvas::new(k.width, k.height, params.background)?;
    let (w, h) = (k.width as usize, k.height as usize);
    let mut inv_depth = vec![0.0f64; w * h];
    let cam: Vec<[f64; 3]> = mesh
        .vertices_in_robot
        .iter()
        .map(|p| view.camera_from_robot().apply(*p))
        .collect();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let p = tri.map(|i| cam[i]);
        if p.iter()
            .any(|q| !(q[2] > NEAR_Z) || !q.iter().all(|c| c.is_finite()))
        {
            continue;
        }
        let Some(n) = normalize(cross(sub(p[1], p[0]), sub(p[2], p[0]))) else {
            continue;
        };
        // View ray towards the centroid; the triangle faces the camera when n · ray < 0.
        let c = [0, 1, 2].map(|j| (p[0][j] + p[1][j] + p[2][j]) / 3.0);
        let Some(ray) = normalize(c) else { continue };
        let facing = n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2];
        if params.cull_back_faces && facing >= 0.0 {
            continue;
        }
        let shade = 0.35 + 0.65 * facing.abs();
        let uv = p.map(|q| [k.fx * q[0] / q[2] + k.cx, k.fy * q[1] / q[2] + k.cy]);
        let iz = p.map(|q| 1.0 / q[2]);
        let vals: [f64; 3] = match mesh.values {
            SurfaceValues::PerVertex(v) => tri.map(|i| v[i]),
            SurfaceValues::PerTriangle(v) => [v[t]; 3],
            SurfaceValues::None => [f64::NAN; 3],
        };
        let neutral = matches!(mesh.values, SurfaceValues::None);
        let area = (uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1])
            - (uv[1][1] - uv[0][1]) * (uv[2][0] - uv[0][0]);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        let min = |j: usize| uv[0][j].min(uv[1][j]).min(uv[2][j]);
        let max = |j: usize| uv[0][j].max(uv[1][j]).max(uv[2][j]);
        let x0 = min(0).ceil().max(0.0);
        let x1 = max(0).floor().min(w as f64 - 1.0);
        let y0 = min(1).ceil().max(0.0);
        let y1 = max(1).floor().min(h as f64 - 1.0);
        if !(x0 <= x1 && y0 <= y1) {
            continue;
        }
        for y in y0 as usize..=y1 as usize {
            for x in x0 as usize..=x1 as usize {
                let q = [x as f64, y as f64];
                // Barycentric weights from edge functions, all of the area's sign inside.
                let e = |a: [f64; 2], b: [f64; 2]| {
                    ((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0])) / area
                };
                let b = [e(uv[1], uv[2]), e(uv[2], uv[0]), e(uv[0], uv[1])];
                if b.iter().any(|&bi| bi < -1e-9) {
                    continue;
                }
                let inv = b[0] * iz[0] + b[1] * iz[1] + b[2] * iz[2];
                let i = y * w + x;
                if inv <= inv_depth[i] {
                    continue;
                }
                inv_depth[i] = inv;
                let rgb = if neutral {
                    [200, 200, 200]
                } else {
                    // Perspective-correct interpolation: weights b_i / z_i, renormalised.
                    let wsum = inv;
                    let v = (0..3).map(|j| b[j] * iz[j] * vals[j]).sum::<f64>() / wsum;
                    params.colormap.map(v, range)
                };
                let shaded = rgb.map(|c| (f64::from(c) * shade).round().clamp(0.0, 255.0) as u8);
                canvas.set(x as i64, y as i64, shaded);
            }
        }
    }
    Ok(Raster { canvas, inv_depth })
}

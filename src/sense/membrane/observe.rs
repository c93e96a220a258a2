//! The observation half of membrane sensing: each surface node the camera sees is read
//! along its own camera ray, against a rest reference taken on unloaded frames.

use crate::camera::lens::Lens;
use crate::camera::PinholeIntrinsics;
use crate::cloud::PointCloud;
use crate::math::pose::Pose;

/// Options of the node observation.
#[derive(Clone, Debug)]
pub struct ObserveParams {
    /// Half-width of the pixel window around a node's pixel (px; default 2, a 5x5 window).
    pub half_window: usize,
    /// Fewest valid pixels a window needs (default 5).
    pub min_pixels: usize,
}

impl Default for ObserveParams {
    fn default() -> Self {
        Self {
            half_window: 2,
            min_pixels: 5,
        }
    }
}

/// A surface node as the camera sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeRay {
    /// The node (mesh index).
    pub node: usize,
    /// Its pixel (column, row), rounded.
    pub pixel: [usize; 2],
    /// The unit ray from the camera centre through the node (robot frame).
    pub direction: [f64; 3],
    /// Range along the ray per metre of depth: |p| / z of the node in the camera frame.
    pub range_per_depth: f64,
}

/// The rays of `nodes` (rest positions `x`, robot frame) through a camera: nodes behind
/// it, outside its image or where its lens has no ray are left out.
pub fn node_rays(
    x: &[[f64; 3]],
    nodes: &[usize],
    camera_from_robot: &Pose,
    k: &PinholeIntrinsics,
    lens: &Lens,
) -> Vec<NodeRay> {
    let robot_from_camera = camera_from_robot.inverse();
    let (w, h) = (k.width as f64, k.height as f64);
    nodes
        .iter()
        .filter_map(|&node| {
            let p = camera_from_robot.apply(x[node]);
            let uv = lens.project(k, p)?;
            let (u, v) = (uv[0].round(), uv[1].round());
            if !(u >= 0.0 && v >= 0.0 && u < w && v < h) {
                return None;
            }
            let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            let d = robot_from_camera.rotate(p.map(|c| c / len));
            Some(NodeRay {
                node,
                pixel: [u as usize, v as usize],
                direction: d,
                range_per_depth: len / p[2],
            })
        })
        .collect()
}

/// The median depth (m) of the valid points of an organized camera-frame `cloud` in the
/// window around `pixel`; `None` with fewer than `params.min_pixels` valid points.
pub fn window_depth(cloud: &PointCloud, pixel: [usize; 2], params: &ObserveParams) -> Option<f64> {
    let (w, h) = (cloud.width as usize, cloud.height as usize);
    let r = params.half_window;
    let mut z = Vec::with_capacity((2 * r + 1) * (2 * r + 1));
    for v in pixel[1].saturating_sub(r)..(pixel[1] + r + 1).min(h) {
        for u in pixel[0].saturating_sub(r)..(pixel[0] + r + 1).min(w) {
            let d = cloud.positions[v * w + u][2];
            if d.is_finite() && d > 0.0 {
                z.push(f64::from(d));
            }
        }
    }
    if z.len() < params.min_pixels.max(1) {
        return None;
    }
    Some(crate::math::median(&mut z))
}

/// Options of the rest reference.
#[derive(Clone, Debug)]
pub struct ReferenceParams {
    /// A node whose depth scatters more than this over the scatter frames is not observed
    /// (m, 1.4826 x the median absolute deviation; default 0.5 mm).
    pub max_scatter: f64,
    /// Floor on a node's sigma (m; default 0.05 mm, half the depth's 0.1 mm step).
    pub sigma_floor: f64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            max_scatter: 5e-4,
            sigma_floor: 5e-5,
        }
    }
}

/// A node observed from its rest reading.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeReference {
    /// The node's ray.
    pub ray: NodeRay,
    /// Its mean depth over the rest frames (m).
    pub rest_depth: f64,
    /// Its depth's noise, one sigma (m).
    pub sigma: f64,
}

impl NodeReference {
    /// Where the camera sees the node at rest (robot frame), given the camera centre there.
    pub fn rest_position(&self, camera_centre: [f64; 3]) -> [f64; 3] {
        let r = self.rest_depth * self.ray.range_per_depth;
        [0, 1, 2].map(|c| camera_centre[c] + r * self.ray.direction[c])
    }

    /// How far the node moved along its ray from rest in `cloud` (m, away from the
    /// camera positive); `None` where the window has too few points.
    pub fn motion(&self, cloud: &PointCloud, params: &ObserveParams) -> Option<f64> {
        let z = window_depth(cloud, self.ray.pixel, params)?;
        Some((z - self.rest_depth) * self.ray.range_per_depth)
    }
}

/// The rest reference of `rays`: the mean depth over `rest` frames, the noise from the
/// `scatter` frames (unloaded too, e.g. the rest of the unloaded stretch); nodes without
/// a reading in every rest frame, or scattering more than allowed, are left out.
pub fn rest_reference(
    rays: Vec<NodeRay>,
    rest: &[&PointCloud],
    scatter: &[&PointCloud],
    observe: &ObserveParams,
    params: &ReferenceParams,
) -> Vec<NodeReference> {
    rays.into_iter()
        .filter_map(|ray| {
            let depths: Option<Vec<f64>> = rest
                .iter()
                .map(|c| window_depth(c, ray.pixel, observe))
                .collect();
            let depths = depths.filter(|d| !d.is_empty())?;
            let rest_depth = depths.iter().sum::<f64>() / depths.len() as f64;
            let mut dev: Vec<f64> = (scatter.iter())
                .filter_map(|c| window_depth(c, ray.pixel, observe))
                .map(|z| z - rest_depth)
                .collect();
            let mad = if dev.len() >= 3 {
                let mid = crate::math::median(&mut dev.clone());
                dev.iter_mut().for_each(|d| *d = (*d - mid).abs());
                1.4826 * crate::math::median(&mut dev)
            } else {
                f64::INFINITY
            };
            (mad <= params.max_scatter).then(|| NodeReference {
                ray,
                rest_depth,
                sigma: mad.max(params.sigma_floor),
            })
        })
        .collect()
}

/// A body seen from inside splits its surface in two: the nodes whose outward normal
/// faces the camera (the inner face, which the camera sees) and those whose normal faces
/// away from it (the outer face, where a contact pushes). Held nodes are in neither.
#[derive(Clone, Debug, PartialEq)]
pub struct InsideView {
    /// Surface nodes facing the camera.
    pub seen: Vec<usize>,
    /// Surface nodes facing away, with the inward unit direction a push there takes.
    pub pushed: Vec<(usize, [f64; 3])>,
}

/// Splits the surface of `mesh` (rest positions) as seen from `camera_centre` (robot
/// frame), leaving out `held` nodes (sorted).
pub fn inside_view(
    mesh: &crate::fem::mesh::TetMesh,
    camera_centre: [f64; 3],
    held: &[usize],
) -> InsideView {
    let surface = mesh.surface();
    let x = &mesh.nodes_in_rest;
    let mut view = InsideView {
        seen: Vec::new(),
        pushed: Vec::new(),
    };
    for &v in &surface.nodes {
        if held.binary_search(&v).is_ok() {
            continue;
        }
        let n = surface.vertex_normals[v];
        let away: f64 = (0..3).map(|c| n[c] * (x[v][c] - camera_centre[c])).sum();
        if away < 0.0 {
            view.seen.push(v);
        } else {
            view.pushed.push((v, n.map(|c| -c)));
        }
    }
    view
}

/// The compliance of the observed nodes' range readings (rows: `refs` in order) to a unit
/// push at each of `pushed` (columns) and to each of the `loads` rows at unit size (columns
/// after the pushes), linear about the model's rest shape. A fixed pixel's ray meets the
/// surface, normal n, moved by δ at a range changed by n·δ / n·u (u the ray): its row is
/// n / n·u at the node (`normals[i]` is ref i's node's unit normal).
pub fn ray_compliance(
    model: &crate::fem::model::Model,
    refs: &[NodeReference],
    normals: &[[f64; 3]],
    pushed: &[(usize, [f64; 3])],
    loads: Vec<crate::fem::constraint::ConstraintRow>,
) -> crate::fem::FemResult<nalgebra::DMatrix<f64>> {
    use crate::fem::constraint::{ConstraintRow, RowKind};
    use crate::fem::solve::MappedPoint;
    let mut rows: Vec<ConstraintRow> = (refs.iter().zip(normals))
        .map(|(r, n)| {
            let u = r.ray.direction;
            let nu = n[0] * u[0] + n[1] * u[1] + n[2] * u[2];
            ConstraintRow {
                kind: RowKind::Effector,
                entries: vec![(r.ray.node, n.map(|c| c / nu))],
            }
        })
        .collect();
    for (v, d) in pushed {
        rows.push(ConstraintRow::along_unit(
            RowKind::Force,
            &MappedPoint::node(*v),
            *d,
        )?);
    }
    rows.extend(loads);
    let x = &model.problem.mesh.nodes_in_rest;
    let mut solver = model.problem.solver()?;
    solver.tangent_at(x, crate::fem::tet4::Tangent::Definite)?;
    let zero = vec![0.0; solver.ndof()];
    let (cols, _) = solver.compliance_columns(&rows, x, &zero, refs.len())?;
    Ok(cols.rows(0, refs.len()).into_owned())
}

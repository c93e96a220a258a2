//! Sensing a membrane seen from inside (issue 53; docs/real-data.md): the camera sees the
//! inner face of an inflated membrane and the contact pushes on its outer face, which it
//! cannot see. The method is the one `tools/real/punyo_reference.py` fixed, which serves
//! as its oracle:
//!
//! - each surface node the camera sees is observed along its own camera ray, against a
//!   rest reference taken on unloaded frames ([`rest_reference`]);
//! - the membrane's rest shape is what the camera sees there: each observed node (with its
//!   layer copies) is moved along its ray to the rest range before the FE model is
//!   linearised ([`crate::fem::shell::move_surface`]);
//! - the pressure change from the rest frames is a known load on the inner face;
//! - the unknown load is a non-negative inward push at every node of the outer face
//!   ([`crate::inverse::pushes`]);
//! - the stiffness is one scale on the model's modulus and pre-tension together, fitted on
//!   frames with a known load ([`MembraneSensor::fit_stiffness`]); the sigma is the unloaded frames' scatter in
//!   quadrature with a model error proportional to the force.

mod fit;
mod observe;

pub use fit::{FitFrame, SigmaCalibration, StiffnessFit, StiffnessRound};
pub use observe::{
    inside_view, node_rays, rest_reference, window_depth, InsideView, NodeRay, NodeReference,
    ObserveParams, ReferenceParams,
};

use crate::camera::lens::Lens;
use crate::camera::PinholeIntrinsics;
use crate::cloud::PointCloud;
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::FemError;
use crate::inverse::pushes::{solve_pushes, PushParams, PushProblem};
use crate::inverse::InverseError;
use crate::math::pose::Pose;
use nalgebra::DMatrix;
use serde::Serialize;

/// Why a membrane sensor cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum MembraneError {
    /// The model is not a shell.
    #[error(
        "the membrane's model must be a shell ([mesh] shell = {{ thickness, ... }}) without \
         cables, cavities or loads; this one is a solid"
    )]
    NotAShell,
    /// No rest frames were given.
    #[error("no rest frames: the first frames must show the membrane unloaded")]
    NoRestFrames,
    /// A rest frame's pressure is not a number.
    #[error(
        "rest frame {index}: its pressure is {pressure} (a rest frame needs one: the recorded \
         inputs give each frame one cavity pressure)"
    )]
    RestPressure {
        /// Index among the rest frames.
        index: usize,
        /// The value.
        pressure: f64,
    },
    /// Too few nodes are observed.
    #[error(
        "only {observed} of the membrane's nodes are seen steadily in the rest frames \
         (at least {needed} are needed): check the camera pose and the rest frames"
    )]
    TooFewObserved {
        /// Nodes observed.
        observed: usize,
        /// Nodes needed.
        needed: usize,
    },
    /// The rest frames do not lie on the model's surface.
    #[error(
        "the rest frames lie {median_m:.4} m (median) from the model's membrane along the \
         camera rays, more than {limit_m} m: the camera pose or the mesh is wrong"
    )]
    PoseOff {
        /// Median distance along the rays (m).
        median_m: f64,
        /// The limit (m).
        limit_m: f64,
    },
    /// The stiffness fit has no usable frame.
    #[error("stiffness fit: {0}")]
    Fit(String),
    /// The FE model failed.
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The push problem failed.
    #[error(transparent)]
    Inverse(#[from] InverseError),
}

/// Result of this module.
pub type MembraneResult<T> = Result<T, MembraneError>;

/// Options of membrane sensing.
#[derive(Clone, Debug)]
pub struct MembraneParams {
    /// How a node is read from a frame.
    pub observe: ObserveParams,
    /// Which nodes the rest frames keep.
    pub reference: ReferenceParams,
    /// A node that moved more than this along its ray in a frame is an outlier there (m;
    /// default 20 mm).
    pub max_motion: f64,
    /// Fewest observed nodes a frame needs to be sensed (default 10).
    pub min_rows: usize,
    /// The rest frames may lie this far from the model's surface, median along the rays
    /// (m; default 3 mm): further means the pose or the mesh is wrong.
    pub max_pose_offset: f64,
    /// A node is observed only where its ray meets the membrane at an incidence cosine of
    /// at least this (default 0.3, within 72.5° of the normal).
    pub min_incidence: f64,
    /// The push problem's options.
    pub push: PushParams,
}

impl Default for MembraneParams {
    fn default() -> Self {
        Self {
            observe: ObserveParams::default(),
            reference: ReferenceParams::default(),
            max_motion: 0.02,
            min_rows: 10,
            max_pose_offset: 0.003,
            min_incidence: 0.3,
            push: PushParams::default(),
        }
    }
}

/// The camera that watches the membrane.
#[derive(Clone, Copy, Debug)]
pub struct MembraneCamera<'a> {
    /// Its intrinsics.
    pub intrinsics: &'a PinholeIntrinsics,
    /// Its lens (pinhole, distortion or ray table).
    pub lens: &'a Lens,
    /// Its pose.
    pub robot_from_camera: &'a Pose,
}

/// A frame's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MembraneStatus {
    /// Sensed.
    Ok,
    /// Fewer nodes than [`MembraneParams::min_rows`] were read.
    TooFewNodes,
    /// The frame's pressure is missing or not a number.
    NoPressure,
    /// The frame's files are missing.
    MissingFrame,
    /// The frame's files cannot be read (a corrupt image).
    Unreadable,
    /// The push problem's solver did not solve it.
    SolverFailed,
}

/// What one frame reads.
#[derive(Clone, Debug, Serialize)]
pub struct MembraneEstimate {
    /// How the frame ended (the numbers are zero unless `ok`).
    pub status: MembraneStatus,
    /// The net contact force on the membrane (N, robot frame).
    pub net_force: [f64; 3],
    /// Its magnitude (N).
    pub magnitude: f64,
    /// One sigma of the magnitude (N): the unloaded scatter in quadrature with the model
    /// error times the magnitude.
    pub sigma: f64,
    /// The centre of pressure (m, robot frame, on the rest shape).
    pub centre_of_pressure: [f64; 3],
    /// The outer-face nodes of the contact patch (pushes above the patch share).
    pub patch_nodes: Vec<usize>,
    /// The patch's area (m², the nodes' shares of the outer face).
    pub patch_area: f64,
    /// Nodes read in the frame.
    pub nodes_read: usize,
    /// The pressure change from the rest frames (Pa).
    pub pressure_change: f64,
    /// Chi-square of the fit (whitened residual's squared norm).
    pub chi2: f64,
}

impl MembraneEstimate {
    /// A frame with no estimate.
    pub fn failed(status: MembraneStatus) -> Self {
        Self {
            status,
            net_force: [0.0; 3],
            magnitude: 0.0,
            sigma: 0.0,
            centre_of_pressure: [0.0; 3],
            patch_nodes: Vec::new(),
            patch_area: 0.0,
            nodes_read: 0,
            pressure_change: 0.0,
            chi2: f64::NAN,
        }
    }
}

/// A membrane sensor: the observed nodes, the compliance of their ray readings to the
/// pushes and to the pressure, and the calibration of the stiffness and sigma.
#[derive(Clone, Debug)]
pub struct MembraneSensor {
    /// The observed nodes, with their rest readings.
    pub refs: Vec<NodeReference>,
    /// The outer-face nodes and the inward unit direction of a push there.
    pub pushed: Vec<(usize, [f64; 3])>,
    /// The pushed nodes' rest positions (m).
    pub push_positions: Vec<[f64; 3]>,
    /// The pushed nodes' shares of the outer face's area (m²).
    pub push_areas: Vec<f64>,
    /// The mean pressure of the rest frames (Pa).
    pub rest_pressure: f64,
    /// The median distance of the rest frames from the model's membrane along the rays (m).
    pub pose_offset: f64,
    /// The factor on the model's stiffness (modulus and pre-tension; default 1, set by
    /// [`MembraneSensor::fit_stiffness`]).
    pub stiffness_scale: f64,
    /// The sigma's terms (default: none, set by [`MembraneSensor::calibrate_sigma`]).
    pub sigma: SigmaCalibration,
    /// Options.
    pub params: MembraneParams,
    /// Readings per unit push at stiffness scale 1 (m/N; rows `refs`, columns `pushed`).
    push_compliance: DMatrix<f64>,
    /// Readings per pascal at stiffness scale 1 (m/Pa; one per ref).
    pressure_compliance: Vec<f64>,
}

impl MembraneSensor {
    /// Builds the sensor of `model` (a shell) watched by `camera` from its `rest` frames
    /// (clouds in the camera frame, with their pressures in Pa) and `still` frames
    /// (unloaded as well; their scatter is each node's noise).
    pub fn new(
        model: &Model,
        camera: MembraneCamera,
        rest: &[(&PointCloud, f64)],
        still: &[&PointCloud],
        params: MembraneParams,
    ) -> MembraneResult<Self> {
        if model.problem.shell.is_none() {
            return Err(MembraneError::NotAShell);
        }
        if rest.is_empty() {
            return Err(MembraneError::NoRestFrames);
        }
        if let Some(index) = rest.iter().position(|(_, p)| !p.is_finite()) {
            let pressure = rest[index].1;
            return Err(MembraneError::RestPressure { index, pressure });
        }
        let rest_pressure = rest.iter().map(|(_, p)| p).sum::<f64>() / rest.len() as f64;
        let problem = &model.problem;
        let camera_from_robot = camera.robot_from_camera.inverse();
        let centre = camera.robot_from_camera.apply([0.0; 3]);
        let view = inside_view(&problem.mesh, centre, &problem.held_nodes());
        let x = &problem.mesh.nodes_in_rest;
        let rays = node_rays(
            x,
            &view.seen,
            &camera_from_robot,
            camera.intrinsics,
            camera.lens,
        );
        let rest_clouds: Vec<&PointCloud> = rest.iter().map(|(c, _)| *c).collect();
        let refs = rest_reference(
            rays,
            &rest_clouds,
            still,
            &params.observe,
            &params.reference,
        );
        // A ray grazing the membrane reads its motion amplified by 1 / cos (and the
        // window straddles the slope): such nodes are not observed.
        let normals = problem.mesh.surface().vertex_normals;
        let refs: Vec<NodeReference> = (refs.into_iter())
            .filter(|r| {
                let (n, u) = (normals[r.ray.node], r.ray.direction);
                -(n[0] * u[0] + n[1] * u[1] + n[2] * u[2]) >= params.min_incidence
            })
            .collect();
        if refs.len() < params.min_rows {
            return Err(MembraneError::TooFewObserved {
                observed: refs.len(),
                needed: params.min_rows,
            });
        }
        // The rest shape is the seen one: each node moves along its ray to its rest range.
        let n_surface = problem.shell.map_or(x.len(), |s| x.len() / (s.layers + 1));
        let mut offsets = Vec::with_capacity(refs.len());
        let moves: Vec<(usize, [f64; 3])> = (refs.iter())
            .map(|r| {
                let seen = r.rest_position(centre);
                let d = [0, 1, 2].map(|c| seen[c] - x[r.ray.node][c]);
                offsets.push((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
                (r.ray.node % n_surface, d)
            })
            .collect();
        let pose_offset = crate::math::median(&mut offsets);
        if pose_offset.is_nan() || pose_offset > params.max_pose_offset {
            return Err(MembraneError::PoseOff {
                median_m: pose_offset,
                limit_m: params.max_pose_offset,
            });
        }
        let mut reshaped = model.clone();
        reshaped.problem = crate::fem::shell::move_surface(problem, &moves)?;
        let view = inside_view(&reshaped.problem.mesh, centre, &problem.held_nodes());
        let surface = reshaped.problem.mesh.surface();
        let x = &reshaped.problem.mesh.nodes_in_rest;
        let areas = node_areas(x, &surface);
        let (push_compliance, pressure_compliance) =
            compliance(&reshaped, &refs, &view, &surface, &areas)?;
        Ok(Self {
            push_positions: view.pushed.iter().map(|(v, _)| x[*v]).collect(),
            push_areas: view.pushed.iter().map(|(v, _)| areas[*v]).collect(),
            pushed: view.pushed,
            refs,
            rest_pressure,
            pose_offset,
            stiffness_scale: 1.0,
            sigma: SigmaCalibration::default(),
            params,
            push_compliance,
            pressure_compliance,
        })
    }

    /// How far each observed node moved along its ray in `cloud` (m; `None` where it was
    /// not read).
    pub fn observe(&self, cloud: &PointCloud) -> Vec<Option<f64>> {
        (self.refs.iter())
            .map(|r| r.motion(cloud, &self.params.observe))
            .map(|m| m.filter(|m| m.abs() <= self.params.max_motion))
            .collect()
    }

    /// The contact load of a frame whose nodes moved by `motions` ([`Self::observe`]) at
    /// pressure `pressure` (Pa).
    pub fn estimate(&self, motions: &[Option<f64>], pressure: f64) -> MembraneEstimate {
        self.estimate_at(motions, pressure, self.stiffness_scale)
    }

    fn estimate_at(&self, motions: &[Option<f64>], pressure: f64, scale: f64) -> MembraneEstimate {
        if !pressure.is_finite() {
            return MembraneEstimate::failed(MembraneStatus::NoPressure);
        }
        let rows: Vec<usize> = (0..self.refs.len())
            .filter(|&i| motions.get(i).copied().flatten().is_some())
            .collect();
        if rows.len() < self.params.min_rows {
            let mut e = MembraneEstimate::failed(MembraneStatus::TooFewNodes);
            e.nodes_read = rows.len();
            return e;
        }
        let dp = pressure - self.rest_pressure;
        let mut compliance = self.push_compliance.select_rows(&rows);
        compliance.scale_mut(1.0 / scale);
        let problem = PushProblem {
            compliance,
            free: (rows.iter())
                .map(|&i| self.pressure_compliance[i] * dp / scale)
                .collect(),
            observed: rows.iter().map(|&i| motions[i].unwrap_or(0.0)).collect(),
            sigma: rows.iter().map(|&i| self.refs[i].sigma).collect(),
            directions: self.pushed.iter().map(|(_, d)| *d).collect(),
            positions: self.push_positions.clone(),
        };
        let mut out = MembraneEstimate::failed(MembraneStatus::SolverFailed);
        out.nodes_read = rows.len();
        out.pressure_change = dp;
        let Ok(est) = solve_pushes(&problem, &self.params.push) else {
            return out;
        };
        if !est.status.is_solution() {
            return out;
        }
        out.status = MembraneStatus::Ok;
        out.net_force = est.net_force;
        out.magnitude = est.magnitude;
        out.sigma = self.sigma.sigma(est.magnitude);
        out.centre_of_pressure = est.centre_of_pressure;
        out.patch_area = est.patch.iter().map(|&i| self.push_areas[i]).sum();
        out.patch_nodes = est.patch.iter().map(|&i| self.pushed[i].0).collect();
        out.chi2 = est.chi2;
        out
    }
}

impl MembraneSensor {
    /// A frame's push problem at stiffness scale 1 in Gram form, for the fit: `G0 = WᵀW`,
    /// `Wᵀo` and `Wᵀq`, W the whitened push compliance of the nodes read, o the whitened
    /// motions and q the whitened motions the pressure change alone makes. At scale s the
    /// pushes minimise ½ λᵀ G0 λ − (s Wᵀo − Wᵀq)ᵀ λ (the problem times s²). `None` when
    /// the frame cannot be sensed.
    fn gram(&self, motions: &[Option<f64>], pressure: f64) -> Option<fit::Gram> {
        let rows: Vec<usize> = (0..self.refs.len())
            .filter(|&i| motions.get(i).copied().flatten().is_some())
            .collect();
        if !pressure.is_finite() || rows.len() < self.params.min_rows {
            return None;
        }
        let dp = pressure - self.rest_pressure;
        let mut w = self.push_compliance.select_rows(&rows);
        let mut o = nalgebra::DVector::zeros(rows.len());
        let mut q = nalgebra::DVector::zeros(rows.len());
        for (k, &i) in rows.iter().enumerate() {
            let s = self.refs[i].sigma;
            w.row_mut(k).scale_mut(1.0 / s);
            o[k] = motions[i].unwrap_or(0.0) / s;
            q[k] = self.pressure_compliance[i] * dp / s;
        }
        let wt = w.transpose();
        Some(fit::Gram {
            g0: &wt * &w,
            wo: &wt * o,
            wq: wt * q,
        })
    }

    /// The net force of pushes `lambda` (N).
    fn net_force(&self, lambda: &nalgebra::DVector<f64>) -> [f64; 3] {
        let mut f = [0.0; 3];
        for (l, (_, d)) in lambda.iter().zip(&self.pushed) {
            for c in 0..3 {
                f[c] += l * d[c];
            }
        }
        f
    }
}

/// The compliance of the observed rays to unit pushes at the outer face and to a unit
/// pressure on the inner face, linear about the rest shape.
fn compliance(
    model: &Model,
    refs: &[NodeReference],
    view: &InsideView,
    surface: &crate::fem::mesh::Surface,
    areas: &[f64],
) -> MembraneResult<(DMatrix<f64>, Vec<f64>)> {
    // A pressure inside pushes the inner face away from the cavity: against its outward
    // normal (the inner face's outward normal faces the camera).
    let held = model.problem.held_nodes();
    let pressure = ConstraintRow {
        kind: RowKind::Force,
        entries: (view.seen.iter())
            .filter(|v| held.binary_search(v).is_err())
            .map(|&v| (v, surface.vertex_normals[v].map(|c| -c * areas[v])))
            .collect(),
    };
    let normals: Vec<[f64; 3]> = refs
        .iter()
        .map(|r| surface.vertex_normals[r.ray.node])
        .collect();
    let cols = observe::ray_compliance(model, refs, &normals, &view.pushed, vec![pressure])?;
    let np = view.pushed.len();
    let pushes = cols.columns(0, np).into_owned();
    let per_pa = cols.column(np).iter().copied().collect();
    Ok((pushes, per_pa))
}

/// Each node's share of the surface's area (a third of each surface triangle's), the
/// nodes at `x`.
fn node_areas(x: &[[f64; 3]], surface: &crate::fem::mesh::Surface) -> Vec<f64> {
    let mut area = vec![0.0; x.len()];
    for t in &surface.triangles {
        let [a, b, c] = t.map(|v| x[v]);
        let n = crate::math::cross(crate::math::sub(b, a), crate::math::sub(c, a));
        let share = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() / 6.0;
        for &v in t {
            area[v] += share;
        }
    }
    area
}

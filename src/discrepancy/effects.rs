//! The library of candidate effects: each a parametrised change of the model (or of the
//! measurement), applied exactly for simulation and linearised for fitting.

use super::body::{Body, TOP_TETS};
use super::{DiscrepancyError, DiscrepancyResult};
use crate::camera::Camera;
use crate::fem::material::Material;
use crate::fem::solve::{CableControl, CavityControl, MappedPoint, PointLoad, Problem};
use serde::{Deserialize, Serialize};

/// One candidate effect (its parameters live beside it, see [`Effect`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum EffectKind {
    /// Self-weight: density scaled by (1 + p0).
    Gravity,
    /// Global compliance scaled by (1 + p0): Young's modulus divided by (1 + p0) (the
    /// displacements are then nearly linear in p0).
    Young,
    /// Compliance of one leg (0 north, 1 east, 2 south, 3 west) scaled by (1 + p0): its
    /// Young's modulus divided by (1 + p0).
    LegStiffness {
        /// The leg.
        leg: usize,
    },
    /// An unmodelled constant point load at a surface node: force (p0, p1, p2) in N.
    PointLoad {
        /// The node.
        node: usize,
    },
    /// Each actuator's input offset by p_i: the cables' first (N for force-controlled, m for
    /// displacement-controlled), then the cavities' (Pa for pressure-controlled, m^3 for
    /// volume-controlled).
    ActuatorOffset,
    /// Camera pose error: measured = R(ω) true + t, parameters (ω, t) in rad and m.
    CameraPose,
    /// Depth recorded as (1 + p0) z + p1 (p1 in m).
    Depth,
    /// Poisson ratio changed by p0.
    Poisson,
}

impl EffectKind {
    /// Number of parameters (`actuators`, the cables and cavities, for the actuator offset).
    pub fn n_params(&self, actuators: usize) -> usize {
        match self {
            EffectKind::Gravity
            | EffectKind::Young
            | EffectKind::LegStiffness { .. }
            | EffectKind::Poisson => 1,
            EffectKind::PointLoad { .. } => 3,
            EffectKind::ActuatorOffset => actuators,
            EffectKind::CameraPose => 6,
            EffectKind::Depth => 2,
        }
    }

    /// Extra penalty parameters for the choice among alternatives (the load's location).
    pub fn choice_params(&self) -> usize {
        usize::from(matches!(self, EffectKind::PointLoad { .. }))
    }

    /// Whether the effect changes the FE model (else the measurement).
    pub fn is_model(&self) -> bool {
        !matches!(self, EffectKind::CameraPose | EffectKind::Depth)
    }

    /// A short name for tables.
    pub fn name(&self) -> String {
        match self {
            EffectKind::Gravity => "gravity (density scale)".into(),
            EffectKind::Young => "global compliance (1/Young) scale".into(),
            EffectKind::LegStiffness { leg } => {
                format!(
                    "{} compliance scale",
                    super::features::REGION_NAMES[leg + 1]
                )
            }
            EffectKind::PointLoad { node } => format!("point load at node {node}"),
            EffectKind::ActuatorOffset => "actuator offsets".into(),
            EffectKind::CameraPose => "camera pose error".into(),
            EffectKind::Depth => "depth scale and offset".into(),
            EffectKind::Poisson => "Poisson ratio".into(),
        }
    }

    /// Finite-difference step per parameter for model effects; `actuator_steps` is the
    /// actuator offset's, one per actuator ([`actuator_steps`]).
    pub fn fd_step(&self, actuator_steps: &[f64]) -> Vec<f64> {
        match self {
            EffectKind::Gravity | EffectKind::Young | EffectKind::LegStiffness { .. } => vec![0.05],
            EffectKind::Poisson => vec![-0.02],
            EffectKind::ActuatorOffset => actuator_steps.to_vec(),
            EffectKind::PointLoad { .. } => vec![0.05; 3],
            EffectKind::CameraPose => vec![1e-3; 6],
            EffectKind::Depth => vec![1e-3; 2],
        }
    }
}

/// An effect with parameter values.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Effect {
    /// Which effect.
    #[serde(flatten)]
    pub kind: EffectKind,
    /// Parameter values.
    pub params: Vec<f64>,
}

impl Effect {
    /// ‖self − truth‖ / ‖truth‖ over the parameter vectors (how far a fit is from the truth).
    pub fn relative_error(&self, truth: &Effect) -> f64 {
        let n = truth.params.iter().map(|v| v * v).sum::<f64>().sqrt();
        let d = self
            .params
            .iter()
            .zip(&truth.params)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        d / n.max(1e-300)
    }
}

/// Side ([`Body::sector`]) of each tetrahedron by its centroid: None in the clamp and
/// from [`TOP_TETS`] of the free length (the four-legged robot's base block and top
/// platform; its legs are the sides).
pub fn tet_legs(problem: &Problem, body: &Body) -> Vec<Option<usize>> {
    let m = &problem.mesh;
    (0..m.tets.len())
        .map(|t| {
            let c = m.corners(t);
            let p = [0, 1, 2].map(|k| c.iter().map(|q| q[k]).sum::<f64>() / 4.0);
            (!body.in_clamp(p) && body.height(p) < TOP_TETS).then(|| body.sector(p))
        })
        .collect()
}

/// Applies the model effects to a problem (measurement effects are ignored here).
pub fn apply_model(
    problem: &mut Problem,
    effects: &[Effect],
    legs: &[Option<usize>],
) -> DiscrepancyResult<()> {
    for e in effects {
        let p = &e.params;
        let get = |i: usize| p.get(i).copied().unwrap_or(0.0);
        match e.kind {
            EffectKind::Gravity => problem.density *= (1.0 + get(0)).max(0.0),
            EffectKind::Young => {
                let m = problem.material;
                problem.material =
                    Material::new(m.young() / (1.0 + get(0)).max(0.05), m.poisson())?;
            }
            EffectKind::Poisson => {
                let m = problem.material;
                let nu = (m.poisson() + get(0)).clamp(-0.9, 0.499);
                problem.material = Material::new(m.young(), nu)?;
            }
            EffectKind::LegStiffness { leg } => {
                if problem.young_scale.len() != legs.len() {
                    problem.young_scale = vec![1.0; legs.len()];
                }
                let f = 1.0 / (1.0 + get(0)).max(0.05);
                for (s, l) in problem.young_scale.iter_mut().zip(legs) {
                    if *l == Some(leg) {
                        *s *= f;
                    }
                }
            }
            EffectKind::PointLoad { node } => {
                if node >= problem.mesh.num_nodes() {
                    return Err(DiscrepancyError::Data(format!(
                        "load node {node} out of range"
                    )));
                }
                problem.loads.push(PointLoad {
                    at: MappedPoint::node(node),
                    force: [get(0), get(1), get(2)],
                });
            }
            EffectKind::ActuatorOffset => {
                let nc = problem.cables.len();
                for (i, c) in problem.cables.iter_mut().enumerate() {
                    c.control = match c.control {
                        CableControl::Force(f) => CableControl::Force(f + get(i)),
                        CableControl::Displacement(s) => CableControl::Displacement(s + get(i)),
                    };
                }
                for (i, c) in problem.cavities.iter_mut().enumerate() {
                    c.control = match c.control {
                        CavityControl::Pressure(p) => CavityControl::Pressure(p + get(nc + i)),
                        CavityControl::Volume(v) => CavityControl::Volume(v + get(nc + i)),
                    };
                }
            }
            EffectKind::CameraPose | EffectKind::Depth => {}
        }
    }
    Ok(())
}

/// Rotation matrix exp(\[ω\]x) (Rodrigues).
pub fn rotation(w: [f64; 3]) -> [[f64; 3]; 3] {
    let th = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let k = if th > 1e-15 {
        w.map(|c| c / th)
    } else {
        [0.0, 0.0, 1.0]
    };
    let (s, c) = th.sin_cos();
    let mut r = [[0.0; 3]; 3];
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            let kk: f64 = (0..3).map(|m| kx[i][m] * kx[m][j]).sum();
            r[i][j] = f64::from(u8::from(i == j)) + s * kx[i][j] + (1.0 - c) * kk;
        }
    }
    r
}

/// Rotation vector of a rotation matrix (inverse of [`rotation`], angles below π).
pub fn rotation_vector(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let tr = r[0][0] + r[1][1] + r[2][2];
    let th = ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
    let v = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]];
    let f = if th < 1e-12 {
        0.5
    } else {
        th / (2.0 * th.sin())
    };
    v.map(|c| c * f)
}

/// Undoes the measurement effects on measured points (robot frame): returns the points
/// as they would be with a correct camera pose and depth.
pub fn correct_points(points: &[[f64; 3]], effects: &[Effect], camera: &Camera) -> Vec<[f64; 3]> {
    let mut out = points.to_vec();
    // Measured = nominal pose applied to a depth-scaled camera point, which equals the pose
    // error applied to a point scaled about the nominal eye: undo the depth, then the pose.
    for e in effects.iter().filter(|e| e.kind == EffectKind::Depth) {
        let p = &e.params;
        if p.len() != 2 {
            continue;
        }
        let eye = camera.eye();
        for q in out.iter_mut() {
            let zm = camera.depth_of(*q);
            if zm > 0.0 {
                let z = (zm - p[1]) / (1.0 + p[0]);
                *q = [0, 1, 2].map(|k| eye[k] + (q[k] - eye[k]) * z / zm);
            }
        }
    }
    for e in effects.iter().filter(|e| e.kind == EffectKind::CameraPose) {
        let p = &e.params;
        if p.len() != 6 {
            continue;
        }
        let r = rotation([p[0], p[1], p[2]]);
        for q in out.iter_mut() {
            let d = [q[0] - p[3], q[1] - p[4], q[2] - p[5]];
            *q = [0, 1, 2].map(|k| (0..3).map(|m| r[m][k] * d[m]).sum());
        }
    }
    out
}

/// Linear sensitivity rows of a measurement effect at a feature point `p` with normal `n`:
/// the change of the residual (measured minus model, along n) per parameter.
pub fn measurement_row(kind: EffectKind, p: [f64; 3], n: [f64; 3], camera: &Camera) -> Vec<f64> {
    match kind {
        EffectKind::CameraPose => {
            let pxn = [
                p[1] * n[2] - p[2] * n[1],
                p[2] * n[0] - p[0] * n[2],
                p[0] * n[1] - p[1] * n[0],
            ];
            vec![pxn[0], pxn[1], pxn[2], n[0], n[1], n[2]]
        }
        EffectKind::Depth => {
            let eye = camera.eye();
            let z = camera.depth_of(p);
            let nd: f64 = (0..3).map(|k| n[k] * (p[k] - eye[k])).sum::<f64>() / z.max(1e-9);
            vec![z * nd, nd]
        }
        _ => Vec::new(),
    }
}

/// The number of actuators an actuator offset has: the cables, then the cavities.
pub fn actuator_count(problem: &Problem) -> usize {
    problem.cables.len() + problem.cavities.len()
}

/// The finite-difference step of each actuator's offset: 0.5 mm of shortening or 0.05 N of
/// tension per cable, then 100 Pa of pressure or 10 mm^3 of volume per cavity.
pub fn actuator_steps(problem: &Problem) -> Vec<f64> {
    let cables = problem.cables.iter().map(|c| match c.control {
        CableControl::Displacement(_) => 5e-4,
        CableControl::Force(_) => 0.05,
    });
    let cavities = problem.cavities.iter().map(|c| match c.control {
        CavityControl::Pressure(_) => 100.0,
        CavityControl::Volume(_) => 1e-8,
    });
    cables.chain(cavities).collect()
}

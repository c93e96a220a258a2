//! Simultaneous calibration by particle swarm optimisation (thesis 3.3.1): the pose
//! (T, α, β, γ; 3.10-3.11) and the cable tensions λ_a ≥ 0 together minimise (3.9),
//! Σ‖R δ_cam + T − (W_ea λ_a + δ_e^free)‖², with the FE model linearised at its current
//! state so that an evaluation costs no FE solve. After each PSO the FE model is re-solved
//! at the tensions found and linearised again; the calibration stops when the error stops
//! dropping or after a set number of updates.
//!
//! Each particle is [t_x, t_y, t_z, α, β, γ, λ_1 … λ_m]: t is where the centroid of the
//! measured points lands (so that the translation box does not depend on how far the
//! camera is), and R = Rot(Z, α) Rot(Y, β) Rot(X, γ) R_c (3.11) turns the current best
//! rotation R_c, so the angles stay small and far from gimbal lock.
//!
//! ```
//! use softsense::calibrate::pso::{minimise, PsoParams};
//! let p = PsoParams::default();
//! let f = |x: &[f64]| (x[0] - 0.3).powi(2) + (x[1] + 0.2).powi(2);
//! let best = minimise(f, &[-1.0, -1.0], &[1.0, 1.0], &[0.0, 0.0], &p, 0);
//! assert!((best.x[0] - 0.3).abs() < 1e-6 && (best.x[1] + 0.2).abs() < 1e-6);
//! ```

use super::feature::{
    check_points, rms_distance, FeatureCalibration, FeatureModel, FeatureStatus, Linear,
};
use super::{CalibrateError, CalibrateResult};
use crate::fem::model::Model;
use crate::fem::solve::MappedPoint;
use crate::math::rand::uniform;
use crate::math::{Iso3, Point3, Vec3};
use nalgebra::{Rotation3, Translation3, UnitQuaternion};

/// Options of the simultaneous (PSO) calibration.
#[derive(Clone, Debug)]
pub struct PsoParams {
    /// Particles in the swarm; default 40.
    pub particles: usize,
    /// Iterations of one PSO run (t_max of 3.14); default 400.
    pub iterations: usize,
    /// Inertia weight at the first iteration (ω_start of 3.14); default 0.9.
    pub w_start: f64,
    /// Inertia weight at the last iteration (ω_end of 3.14); default 0.4.
    pub w_end: f64,
    /// Acceleration towards the particle's own best (c_1 of 3.12); default 1.5.
    pub c1: f64,
    /// Acceleration towards the swarm's best (c_2 of 3.12); default 1.5.
    pub c2: f64,
    /// PSO runs per FE update, the best kept ("PSO is running several times"); default 3.
    pub runs: usize,
    /// At most this many FE updates (re-solve and re-linearise); default 10.
    pub max_updates: usize,
    /// An update that lowers the RMS error by less than this fraction does not count as a
    /// drop; default 0.01.
    pub residual_tol: f64,
    /// Stop (converged) after this many updates in a row without a drop; default 2.
    pub patience: usize,
    /// Half-width of the search box of the translation, about the current best (m);
    /// default 0.05.
    pub search_translation: f64,
    /// Half-width of the search box of each angle α, β, γ (degrees); default 15.
    pub search_angle_deg: f64,
    /// Half-width of the search box of each tension, clipped at 0 (N); default 0.5.
    pub search_tension: f64,
    /// Largest velocity per iteration, as a fraction of the box width; default 0.2.
    pub max_velocity: f64,
    /// Seed of the random numbers R_1, R_2 and the initial particles; default 1.
    pub seed: u64,
}

impl Default for PsoParams {
    fn default() -> Self {
        Self {
            particles: 40,
            iterations: 400,
            w_start: 0.9,
            w_end: 0.4,
            c1: 1.5,
            c2: 1.5,
            runs: 3,
            max_updates: 10,
            residual_tol: 0.01,
            patience: 2,
            search_translation: 0.05,
            search_angle_deg: 15.0,
            search_tension: 0.5,
            max_velocity: 0.2,
            seed: 1,
        }
    }
}

fn check_pso_params(p: &PsoParams) -> CalibrateResult<()> {
    let bad = |s: &str| Err(CalibrateError::Param(s.into()));
    if p.particles < 2 || p.iterations == 0 || p.runs == 0 || p.max_updates == 0 {
        return bad("particles must be at least 2; iterations, runs and max_updates positive");
    }
    let positive = [
        p.search_translation,
        p.search_angle_deg,
        p.search_tension,
        p.max_velocity,
    ];
    if !positive.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return bad("search_translation, search_angle_deg, search_tension and max_velocity must be positive");
    }
    if ![p.w_start, p.w_end, p.c1, p.c2, p.residual_tol]
        .iter()
        .all(|v| v.is_finite())
    {
        return bad("w_start, w_end, c1, c2 and residual_tol must be finite");
    }
    Ok(())
}

/// The inertia weight ω(t) = ω_start − (ω_start − ω_end) t / t_max (3.14).
pub fn inertia(params: &PsoParams, t: usize) -> f64 {
    let tmax = params.iterations.max(1) as f64;
    params.w_start - (params.w_start - params.w_end) / tmax * t as f64
}

/// The best point one swarm found.
#[derive(Clone, Debug)]
pub struct SwarmBest {
    /// Its position.
    pub x: Vec<f64>,
    /// Its objective value.
    pub value: f64,
    /// Objective evaluations spent.
    pub evaluations: usize,
}

/// One PSO run minimising `f` over the box [`lower`, `upper`]: velocity (3.12), position
/// (3.13), inertia (3.14), global-best neighbourhood, velocities clamped to
/// `max_velocity` × the box width and positions to the box. Particle 0 starts at `start`
/// (so the result is never worse than it), the others uniformly in the box. R_1 and R_2
/// are drawn per particle, dimension and iteration from a hash of (`seed`, `run`, t,
/// particle, dimension): the same numbers whatever the thread count.
pub fn minimise(
    mut f: impl FnMut(&[f64]) -> f64,
    lower: &[f64],
    upper: &[f64],
    start: &[f64],
    params: &PsoParams,
    run: u64,
) -> SwarmBest {
    let d = lower.len();
    let seed = params.seed ^ run.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let rand =
        |t: usize, i: usize, k: usize, s: u64| uniform(seed, t as u64, i as u64, 3 * k as u64 + s);
    let vmax: Vec<f64> = (0..d)
        .map(|k| params.max_velocity * (upper[k] - lower[k]))
        .collect();
    let mut pos: Vec<Vec<f64>> = (0..params.particles)
        .map(|i| match i {
            0 => (0..d).map(|k| start[k].clamp(lower[k], upper[k])).collect(),
            _ => (0..d)
                .map(|k| lower[k] + (upper[k] - lower[k]) * rand(0, i, k, 0))
                .collect(),
        })
        .collect();
    let mut vel = vec![vec![0.0; d]; params.particles];
    let mut own: Vec<f64> = pos.iter().map(|p| f(p)).collect();
    let mut own_best = pos.clone();
    let g = (0..own.len())
        .min_by(|a, b| own[*a].total_cmp(&own[*b]))
        .unwrap_or(0);
    let (mut g_val, mut g_best) = (own[g], own_best[g].clone());
    for t in 0..params.iterations {
        let w = inertia(params, t);
        for i in 0..params.particles {
            for k in 0..d {
                let (r1, r2) = (rand(t + 1, i, k, 1), rand(t + 1, i, k, 2));
                let v = w * vel[i][k]
                    + params.c1 * r1 * (own_best[i][k] - pos[i][k])
                    + params.c2 * r2 * (g_best[k] - pos[i][k]);
                vel[i][k] = v.clamp(-vmax[k], vmax[k]);
                let x = pos[i][k] + vel[i][k];
                pos[i][k] = x.clamp(lower[k], upper[k]);
                if pos[i][k] != x {
                    vel[i][k] = 0.0;
                }
            }
            let v = f(&pos[i]);
            if v < own[i] {
                own[i] = v;
                own_best[i].clone_from(&pos[i]);
                if v < g_val {
                    g_val = v;
                    g_best.clone_from(&pos[i]);
                }
            }
        }
    }
    SwarmBest {
        x: g_best,
        value: g_val,
        evaluations: params.particles * (params.iterations + 1),
    }
}

/// A pose and tensions with their RMS error (m) at the FE state of those tensions.
#[derive(Clone)]
struct Trial {
    pose: Iso3,
    tensions: Vec<f64>,
    residual: f64,
}

/// The rotation of the angles [α, β, γ] (3.11): Rot(Z, α) Rot(Y, β) Rot(X, γ).
fn rotation(a: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_euler_angles(a[2], a[1], a[0]))
}

/// `params.runs` PSO runs on (3.9) linearised by `lin`, in a box about `best`; returns
/// the best pose and tensions and the evaluations spent.
fn swarm_fit(
    lin: &Linear,
    camera: &[[f64; 3]],
    best: &Trial,
    params: &PsoParams,
    update: usize,
) -> (Iso3, Vec<f64>, usize) {
    let na = lin.w.ncols();
    let n = camera.len() as f64;
    let centroid = camera.iter().fold(Vec3::zeros(), |a, p| a + Vec3::from(*p)) / n;
    let q: Vec<Vec3> = camera.iter().map(|p| Vec3::from(*p) - centroid).collect();
    let rc = best.pose.rotation;
    let tc = best.pose * Point3::from(centroid);
    let (st, sa) = (
        params.search_translation,
        params.search_angle_deg.to_radians(),
    );
    let mut centre = vec![tc.x, tc.y, tc.z, 0.0, 0.0, 0.0];
    centre.extend(&best.tensions);
    let half: Vec<f64> = [st, st, st, sa, sa, sa]
        .into_iter()
        .chain(std::iter::repeat_n(params.search_tension, na))
        .collect();
    let lower: Vec<f64> = (0..centre.len())
        .map(|k| match k {
            0..6 => centre[k] - half[k],
            _ => (centre[k] - half[k]).max(0.0),
        })
        .collect();
    let upper: Vec<f64> = centre.iter().zip(&half).map(|(c, h)| c + h).collect();
    let objective = |w: &[f64]| -> f64 {
        let r = rotation(&w[3..6]) * rc;
        let t = Vec3::new(w[0], w[1], w[2]);
        let lambda = &w[6..];
        let mut s = 0.0;
        for (i, qi) in q.iter().enumerate() {
            let p = r * qi + t;
            for k in 0..3 {
                let row = 3 * i + k;
                let pred =
                    lin.delta_free[row] + (0..na).map(|j| lin.w[(row, j)] * lambda[j]).sum::<f64>();
                s += (p[k] - pred).powi(2);
            }
        }
        s
    };
    let mut found: Option<SwarmBest> = None;
    let mut evaluations = 0;
    for run in 0..params.runs {
        let id = (update * params.runs + run) as u64;
        let b = minimise(objective, &lower, &upper, &centre, params, id);
        evaluations += b.evaluations;
        if found.as_ref().is_none_or(|f| b.value < f.value) {
            found = Some(b);
        }
    }
    let w = found.map(|b| b.x).unwrap_or(centre);
    let r = rotation(&w[3..6]) * rc;
    let t = Vec3::new(w[0], w[1], w[2]) - r * centroid;
    (
        Iso3::from_parts(Translation3::from(t), r),
        w[6..].to_vec(),
        evaluations,
    )
}

/// Simultaneous calibration (3.3.1): from the start pose `start` (robot from camera) and
/// the start tensions (N, one per cable), PSO on the linearised (3.9) after each FE
/// update. `camera_points` are the measured feature points (camera frame, m), one for
/// each of `features`. Stops converged after `params.patience` updates in a row that do
/// not lower the RMS error by `params.residual_tol`; returns the best pose and tensions.
pub fn calibrate_pso(
    model: &Model,
    features: &[MappedPoint],
    camera_points: &[[f64; 3]],
    start: &Iso3,
    start_tensions: &[f64],
    params: &PsoParams,
) -> CalibrateResult<FeatureCalibration> {
    check_pso_params(params)?;
    check_points(features, camera_points)?;
    let mut fe = FeatureModel::new(model, features, start_tensions)?;
    let mut best = Trial {
        pose: *start,
        tensions: fe.tensions().to_vec(),
        residual: rms_distance(start, camera_points, &fe.positions()),
    };
    let (mut status, mut stall, mut evaluations) = (FeatureStatus::MaxUpdates, 0, 0);
    let mut history = Vec::new();
    for update in 0..params.max_updates {
        let lin = fe.linearise()?;
        let (pose, tensions, spent) = swarm_fit(&lin, camera_points, &best, params, update);
        evaluations += spent;
        fe.resolve(&tensions)?;
        let residual = rms_distance(&pose, camera_points, &fe.positions());
        history.push(residual);
        let dropped = residual < best.residual * (1.0 - params.residual_tol);
        if residual < best.residual {
            best = Trial {
                pose,
                tensions: fe.tensions().to_vec(),
                residual,
            };
        }
        stall = if dropped { 0 } else { stall + 1 };
        if stall >= params.patience {
            status = FeatureStatus::Converged;
            break;
        }
    }
    Ok(FeatureCalibration {
        robot_from_camera: best.pose,
        tensions: best.tensions,
        residual_rms: best.residual,
        fe_updates: history.len(),
        evaluations,
        status,
        history,
    })
}

//! The model-discrepancy workflow (design section 6): find where simulation and measurement
//! disagree, name the missing effect from a library of candidates, add it to the model and
//! show the gap shrink on held-out frames.
//!
//! Residuals are measured per frame at feature points (surface-triangle centroids, face
//! normals, see [`features`]) as the offset of the measured surface along the model's normal
//! line, each with its noise from the sensor model (σ = k z² plus depth quantisation, along
//! the normal, averaged over the points the line gathers). Per region a chi-square-like
//! score z = (χ² − n)/√(2n) says whether the disagreement is above the noise floor.
//! Candidate effects ([`effects`]) are linearised about the nominal solution of every frame
//! (finite differences of FE solves for material, gravity and actuators; compliance rows,
//! with the cables' geometric stiffness, for point loads; closed forms for camera pose and
//! depth), fitted on training frames by least squares, compared by BIC, refined with
//! exact FE re-solves (chord iterations; Gauss-Newton for point loads, whose compliance is
//! re-linearised at the current estimate),
//! and kept only if they also lower the held-out χ². Stepwise: add the best candidate
//! (refitted jointly with the kept effects) while BIC and held-out χ² improve, drop kept
//! effects a later one made redundant, then try swapping each kept effect for another
//! candidate. When that path ends above the noise floor or with more than two effects,
//! every pair of candidates is fitted jointly (two effects at once can make the first
//! pick wrong) and the best pair, if it beats the path's answer by the same BIC and
//! held-out tests, is the new start. Every re-solve is warm-started from the frame's
//! nominal solution; a chord step that overshoots is halved.
//!
//! ```
//! use softsense::discrepancy::effects::{rotation, rotation_vector};
//! let w = [0.01, -0.02, 0.005];
//! let back = rotation_vector(&rotation(w));
//! assert!((0..3).all(|k| (back[k] - w[k]).abs() < 1e-12));
//! ```

pub mod data;
pub mod effects;
pub mod features;
pub mod generate;
pub mod report;

use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{CableControl, MappedPoint, PointLoad, Problem, Solution};
use crate::register::{farthest_point_sampling, RegisterParams, Registrar};
use crate::scene::raycast::Bvh;
use crate::scene::FrameInput;
use data::Recording;
use effects::{apply_model, correct_points, measurement_row, tet_legs, Effect, EffectKind};
use features::{choose_features, measure_offset, Feature, REGION_NAMES};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use thiserror::Error;

/// Errors of the discrepancy workflow.
#[derive(Debug, Error)]
pub enum DiscrepancyError {
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// The recording or the parameters are inconsistent.
    #[error("discrepancy: {0}")]
    Data(String),
    /// The FE model failed.
    #[error(transparent)]
    Fem(#[from] crate::fem::FemError),
    /// Scene generation failed.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
}

/// `Result` of the discrepancy workflow.
pub type DiscrepancyResult<T> = std::result::Result<T, DiscrepancyError>;

/// Parameters of the workflow.
#[derive(Clone, Debug, Serialize)]
pub struct DiscrepancyParams {
    /// Fraction of the frames held out for confirmation (every k-th frame).
    pub holdout: f64,
    /// Number of feature points (surface-triangle centroids).
    pub features: usize,
    /// Features below this height (m) are skipped (the fixed base).
    pub min_feature_z: f64,
    /// Features need one flat plane around them within this radius (m).
    pub flat_radius: f64,
    /// Normal-line radius of the registration (m).
    pub line_radius: f64,
    /// Largest offset along the normal line (m).
    pub line_length: f64,
    /// Fewest measured points on a line for a residual.
    pub min_points: usize,
    /// Features seen more obliquely than this (degrees from the view ray) are skipped.
    pub max_view_angle_deg: f64,
    /// Noise added in quadrature to the sensor model's per-feature σ (m): mesh and
    /// linearisation floor.
    pub sigma_floor: f64,
    /// A region is significant when z = (χ² − n)/√(2n) exceeds this.
    pub z_significant: f64,
    /// An effect must lower the BIC by at least this much.
    pub bic_margin: f64,
    /// An effect must lower the held-out χ² by at least this fraction of the held-out rows.
    pub holdout_gain: f64,
    /// Candidate locations of an unmodelled point load.
    pub load_candidates: usize,
    /// Largest number of effects added greedily.
    pub max_effects: usize,
    /// Most chord (fixed-Jacobian Gauss-Newton) iterations with exact FE re-solves per
    /// step (they stop early once a step lowers χ² by less than 0.2 %).
    pub refine_iterations: usize,
    /// Candidates (best by the linear fit) refined exactly before choosing, besides the
    /// best of every effect type.
    pub refine_candidates: usize,
    /// Huber threshold of the linear fits (in σ; 0 for plain least squares).
    pub huber: f64,
    /// Pairs of candidates (best by the joint linear fit) refined exactly when the
    /// forward path ends above the noise floor or with more than two effects (0: none).
    pub pair_candidates: usize,
}

impl Default for DiscrepancyParams {
    fn default() -> Self {
        Self {
            holdout: 0.25,
            features: 300,
            min_feature_z: 0.02,
            flat_radius: 0.006,
            line_radius: 0.0015,
            line_length: 0.008,
            min_points: 3,
            max_view_angle_deg: 70.0,
            sigma_floor: 0.0,
            z_significant: 4.0,
            bic_margin: 10.0,
            holdout_gain: 0.02,
            load_candidates: 24,
            max_effects: 3,
            refine_iterations: 8,
            refine_candidates: 5,
            huber: 3.0,
            pair_candidates: 6,
        }
    }
}

/// The answer.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Outcome {
    /// The residual is at the noise floor: nothing is missing.
    NoMissingEffect,
    /// These effects explain the residual down to the noise floor on held-out frames.
    Explained {
        /// The fitted effects.
        effects: Vec<FittedEffect>,
    },
    /// Significant residual remains in these regions (ranked); `partial` are effects that
    /// passed the criteria but did not bring the residual to the noise floor.
    UnexplainedResidual {
        /// Region names, most significant first.
        regions: Vec<String>,
        /// Effects kept on the way (not claimed as the explanation).
        partial: Vec<FittedEffect>,
    },
}

/// A fitted effect with its 1-σ uncertainty.
#[derive(Clone, Debug, Serialize)]
pub struct FittedEffect {
    /// The effect and its parameters.
    pub effect: Effect,
    /// Human-readable name.
    pub name: String,
    /// Standard deviation per parameter.
    pub sigma: Vec<f64>,
}

/// Residual statistics of one region (or all).
#[derive(Clone, Debug, Serialize)]
pub struct RegionStats {
    /// Region name.
    pub region: String,
    /// Residual rows.
    pub n: usize,
    /// Sum of squared normalised residuals.
    pub chi2: f64,
    /// (χ² − n)/√(2n).
    pub z: f64,
    /// RMS residual (m).
    pub rms: f64,
    /// RMS noise σ (m): the noise floor.
    pub noise_rms: f64,
}

/// One candidate's score in a greedy step.
#[derive(Clone, Debug, Serialize)]
pub struct CandidateScore {
    /// Effect name.
    pub name: String,
    /// Parameters (fitted jointly with the effects already kept).
    pub k: usize,
    /// Training χ².
    pub chi2: f64,
    /// BIC = χ² + k ln n.
    pub bic: f64,
    /// Whether χ² is from the exact refinement (else from the linear fit).
    pub refined: bool,
}

/// One step of the model selection.
#[derive(Clone, Debug, Serialize)]
pub struct Step {
    /// What the step tried: `add` a candidate, `swap out` a kept effect for a candidate,
    /// or `drop` a kept effect (candidates are then the kept sets without one effect).
    pub action: String,
    /// BIC with the effects kept so far.
    pub bic_current: f64,
    /// Candidates, best first.
    pub candidates: Vec<CandidateScore>,
    /// Held-out χ² before and after the best candidate (NaN when not tried).
    pub holdout_chi2: [f64; 2],
    /// Whether the best candidate was taken.
    pub accepted: bool,
}

/// Residual of one feature in one frame.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Residual {
    /// Feature index.
    pub feature: usize,
    /// Residual along the normal, measured minus model (m).
    pub r: f64,
    /// Noise σ (m).
    pub sigma: f64,
}

/// Everything the workflow found.
#[derive(Clone, Debug, Serialize)]
pub struct Explanation {
    /// The answer.
    pub outcome: Outcome,
    /// Training and held-out frame indices.
    pub split: [Vec<usize>; 2],
    /// Held-out statistics per region before any effect (last entry: all).
    pub before: Vec<RegionStats>,
    /// Held-out statistics per region with the kept effects (last entry: all).
    pub after: Vec<RegionStats>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// The feature points.
    pub features: Vec<Feature>,
    /// Held-out residuals per held-out frame, before and after.
    pub holdout_residuals: [Vec<Vec<Residual>>; 2],
    /// Effects kept (also inside the outcome).
    pub kept: Vec<FittedEffect>,
}

/// The problem of one frame: the model with the recorded cable inputs and known loads.
pub fn frame_problem(model: &Model, input: &FrameInput) -> DiscrepancyResult<Problem> {
    let mut p = model.problem.clone();
    for c in &input.cables {
        let cable = p
            .cables
            .iter_mut()
            .find(|k| k.name == c.name)
            .ok_or_else(|| DiscrepancyError::Data(format!("no cable named {:?}", c.name)))?;
        cable.control = match (c.shorten, c.force) {
            (Some(s), None) => CableControl::Displacement(s),
            (None, Some(f)) => CableControl::Force(f),
            _ => {
                return Err(DiscrepancyError::Data(format!(
                    "cable {:?}: give exactly one of shorten, force",
                    c.name
                )))
            }
        };
    }
    if !input.loads.is_empty() {
        let surface = p.mesh.surface();
        for l in &input.loads {
            let node =
                crate::scene::nearest_surface_node(&p.mesh.nodes_in_rest, &surface.nodes, l.at)
                    .ok_or_else(|| DiscrepancyError::Data("the mesh has no surface".into()))?;
            p.loads.push(PointLoad {
                at: MappedPoint::node(node),
                force: l.force,
            });
        }
    }
    Ok(p)
}

/// Candidate nodes of an unmodelled point load: surface nodes above 30 mm spread evenly.
pub fn load_candidates(problem: &Problem, count: usize) -> Vec<usize> {
    let s = problem.mesh.surface();
    let x = &problem.mesh.nodes_in_rest;
    let c: Vec<usize> = s
        .nodes
        .iter()
        .copied()
        .filter(|&v| x[v][2] > 0.03)
        .collect();
    farthest_point_sampling(x, &c, count)
}

/// Holdout frame indices: every k-th frame (k = round(1/fraction)), at least one, and at
/// least one training frame.
pub fn split_frames(n: usize, fraction: f64) -> [Vec<usize>; 2] {
    if n < 2 || fraction.is_nan() || fraction <= 0.0 {
        return [(0..n).collect(), Vec::new()];
    }
    let k = (1.0 / fraction.min(0.5)).round().max(2.0) as usize;
    let hold: Vec<usize> = (0..n).filter(|i| i % k == k - 1).collect();
    let hold = if hold.is_empty() { vec![n - 1] } else { hold };
    let train = (0..n).filter(|i| !hold.contains(i)).collect();
    [train, hold]
}

/// The library's candidate effects for a model.
pub fn candidate_kinds(problem: &Problem, params: &DiscrepancyParams) -> Vec<EffectKind> {
    let mut v = vec![EffectKind::Gravity, EffectKind::Young, EffectKind::Poisson];
    v.extend((0..4).map(|leg| EffectKind::LegStiffness { leg }));
    if !problem.cables.is_empty() {
        v.push(EffectKind::ActuatorOffset);
    }
    v.push(EffectKind::CameraPose);
    v.push(EffectKind::Depth);
    v.extend(
        load_candidates(problem, params.load_candidates)
            .into_iter()
            .map(|node| EffectKind::PointLoad { node }),
    );
    v
}

/// Effects kept or tried: candidate index and parameters.
type Kept = Vec<(usize, Vec<f64>)>;
/// Sensitivity rows ([feature][param]) replacing a candidate's nominal ones, per kept effect.
type Sens = Vec<Option<Vec<Vec<f64>>>>;

/// Per-frame context: recorded problem, nominal solution, sensitivities.
struct FrameCtx {
    problem: Problem,
    /// Nominal solution (the warm start of every re-solve).
    nominal: Solution,
    /// Sensitivity rows per candidate: [feature][param].
    sens: Vec<Vec<Vec<f64>>>,
}

struct Workflow<'a> {
    model: &'a Model,
    rec: &'a Recording,
    params: &'a DiscrepancyParams,
    features: Vec<Feature>,
    triangles: Vec<[usize; 3]>,
    legs: Vec<Option<usize>>,
    kinds: Vec<EffectKind>,
    frames: Vec<FrameCtx>,
    register: RegisterParams,
}

/// Solves a frame's problem, warm-started from the frame's nominal solution when given
/// (the effects change it a little: Newton then needs a few iterations from there).
fn solve_frame(
    model: &Model,
    p: &Problem,
    frame: usize,
    start: Option<&Solution>,
) -> DiscrepancyResult<Solution> {
    let sol = match start {
        Some(s) => p.solve_static_from(&model.newton, s)?,
        None => p.solve_static(&model.newton)?,
    };
    if !sol.converged {
        return Err(DiscrepancyError::Data(format!(
            "frame {frame}: the FE solve did not converge"
        )));
    }
    Ok(sol)
}

impl<'a> Workflow<'a> {
    fn new(
        model: &'a Model,
        rec: &'a Recording,
        params: &'a DiscrepancyParams,
    ) -> DiscrepancyResult<Self> {
        let surface = model.problem.mesh.surface();
        let rest = &model.problem.mesh.nodes_in_rest;
        let features = choose_features(
            rest,
            &surface,
            params.features,
            params.min_feature_z,
            params.flat_radius,
        );
        if features.is_empty() {
            return Err(DiscrepancyError::Data(
                "no feature point on the surface".into(),
            ));
        }
        let legs = tet_legs(&model.problem);
        let kinds = candidate_kinds(&model.problem, params);
        let register = RegisterParams {
            features: features.len(),
            d_m: params.line_radius,
            d_l: params.line_length,
            average: true,
            ..Default::default()
        };
        let mut w = Self {
            model,
            rec,
            params,
            features,
            triangles: surface.triangles,
            legs,
            kinds,
            frames: Vec::new(),
            register,
        };
        for (i, f) in rec.frames.iter().enumerate() {
            let ctx = w.frame_ctx(i, &f.input)?;
            w.frames.push(ctx);
        }
        Ok(w)
    }

    fn feature_rows(&self, x: &[[f64; 3]]) -> Vec<([f64; 3], [f64; 3])> {
        self.features.iter().map(|f| f.at(x)).collect()
    }

    /// Compliance at the solution `sol` (with the cables' geometric stiffness: under
    /// tensions of a newton or two it is far from negligible) of the feature rows (along
    /// the normals of `pn`), then 3 force rows per node of `nodes`: column nf + 3j + k is
    /// the motion of every feature along its normal per unit force k at node j.
    fn load_compliance(
        &self,
        problem: &Problem,
        sol: &Solution,
        pn: &[([f64; 3], [f64; 3])],
        nodes: &[usize],
    ) -> DiscrepancyResult<DMatrix<f64>> {
        let mut rows = Vec::with_capacity(self.features.len() + 3 * nodes.len());
        for (f, (_, n)) in self.features.iter().zip(pn) {
            let n = if n.iter().all(|c| *c == 0.0) {
                [0.0, 0.0, 1.0]
            } else {
                *n
            };
            rows.push(ConstraintRow::along(RowKind::Effector, &f.mapped(), n)?);
        }
        for &node in nodes {
            rows.extend(ConstraintRow::point3(
                RowKind::Force,
                &MappedPoint::node(node),
            ));
        }
        let x = &sol.positions;
        let mut solver = problem.solver()?;
        solver.factorize_with_cables(x, &sol.cable_tension)?;
        let zero = vec![0.0; solver.ndof()];
        Ok(solver.compliance(&rows, x, &zero)?.w)
    }

    /// Sensitivity rows ([feature][force component]) of the point loads among `kept`
    /// (None for the other effects) re-linearised at the state the kept effects deform
    /// frame `i` into: a large load bends the robot enough that the compliance at the
    /// nominal state points a chord step away from the true force (Gauss-Newton instead).
    fn load_sens_at(&self, i: usize, kept: &[(usize, Vec<f64>)]) -> DiscrepancyResult<Sens> {
        let nodes: Vec<Option<usize>> = kept
            .iter()
            .map(|(c, _)| match self.kinds[*c] {
                EffectKind::PointLoad { node } => Some(node),
                _ => None,
            })
            .collect();
        let list: Vec<usize> = nodes.iter().flatten().copied().collect();
        if list.is_empty() {
            return Ok(vec![None; kept.len()]);
        }
        let ctx = &self.frames[i];
        let mut prob = ctx.problem.clone();
        apply_model(&mut prob, &self.effects_of(kept), &self.legs)?;
        let sol = solve_frame(self.model, &prob, i, Some(&ctx.nominal))?;
        let pn = self.feature_rows(&sol.positions);
        let w = self.load_compliance(&prob, &sol, &pn, &list)?;
        let nf = self.features.len();
        let mut j = 0;
        Ok(nodes
            .iter()
            .map(|n| {
                n.map(|_| {
                    let c0 = nf + 3 * j;
                    j += 1;
                    (0..nf)
                        .map(|r| (0..3).map(|k| w[(r, c0 + k)]).collect())
                        .collect()
                })
            })
            .collect())
    }

    fn frame_ctx(&self, index: usize, input: &FrameInput) -> DiscrepancyResult<FrameCtx> {
        let problem = frame_problem(self.model, input)?;
        let nominal = solve_frame(self.model, &problem, index, None)?;
        let x0 = nominal.positions.clone();
        let pn0 = self.feature_rows(&x0);
        let dispc: Vec<bool> = problem
            .cables
            .iter()
            .map(|c| matches!(c.control, CableControl::Displacement(_)))
            .collect();
        let load_nodes: Vec<usize> = self
            .kinds
            .iter()
            .filter_map(|k| match k {
                EffectKind::PointLoad { node } => Some(*node),
                _ => None,
            })
            .collect();
        let nf = self.features.len();
        let w = if load_nodes.is_empty() {
            None
        } else {
            Some(self.load_compliance(&problem, &nominal, &pn0, &load_nodes)?)
        };
        let mut sens = Vec::with_capacity(self.kinds.len());
        let mut load_i = 0;
        for kind in &self.kinds {
            let rows_k: Vec<Vec<f64>> = match kind {
                EffectKind::PointLoad { .. } => {
                    let w = w
                        .as_ref()
                        .ok_or_else(|| DiscrepancyError::Data("no compliance".into()))?;
                    let c0 = nf + 3 * load_i;
                    load_i += 1;
                    (0..nf)
                        .map(|i| (0..3).map(|k| w[(i, c0 + k)]).collect())
                        .collect()
                }
                EffectKind::CameraPose | EffectKind::Depth => pn0
                    .iter()
                    .map(|(p, n)| measurement_row(*kind, *p, *n, &self.rec.camera))
                    .collect(),
                _ => {
                    let steps = kind.fd_step(&dispc);
                    let mut cols = Vec::with_capacity(steps.len());
                    for (j, h) in steps.iter().enumerate() {
                        let mut pp = vec![0.0; steps.len()];
                        pp[j] = *h;
                        let mut prob = problem.clone();
                        apply_model(
                            &mut prob,
                            &[Effect {
                                kind: *kind,
                                params: pp,
                            }],
                            &self.legs,
                        )?;
                        let xj = solve_frame(self.model, &prob, index, Some(&nominal))?.positions;
                        let col: Vec<f64> = self
                            .features
                            .iter()
                            .zip(&pn0)
                            .map(|(f, (p, n))| {
                                let (q, _) = f.at(&xj);
                                (0..3).map(|k| n[k] * (q[k] - p[k])).sum::<f64>() / h
                            })
                            .collect();
                        cols.push(col);
                    }
                    (0..nf)
                        .map(|i| cols.iter().map(|c| c[i]).collect())
                        .collect()
                }
            };
            sens.push(rows_k);
        }
        Ok(FrameCtx {
            problem,
            nominal,
            sens,
        })
    }

    /// Exact residuals of frame `i` with the effects applied.
    fn residuals(&self, i: usize, effects: &[Effect]) -> DiscrepancyResult<Vec<Residual>> {
        let ctx = &self.frames[i];
        // Measurement effects alone leave the nominal solution as it is.
        let solved;
        let x = if effects.iter().any(|e| e.kind.is_model()) {
            let mut prob = ctx.problem.clone();
            apply_model(&mut prob, effects, &self.legs)?;
            solved = solve_frame(self.model, &prob, i, Some(&ctx.nominal))?;
            &solved.positions
        } else {
            &ctx.nominal.positions
        };
        let cam = &self.rec.camera;
        let pts = correct_points(&self.rec.frames[i].points, effects, cam);
        let registrar = Registrar::new(&pts);
        let bvh = Bvh::new(x, &self.triangles);
        let eye = cam.eye();
        let s = &self.rec.sensor;
        let cos_max = self.params.max_view_angle_deg.to_radians().cos();
        let mut out = Vec::new();
        for (fi, f) in self.features.iter().enumerate() {
            let (p, n) = f.at(x);
            let d = [0, 1, 2].map(|k| p[k] - eye[k]);
            let dl = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let facing = -(0..3).map(|k| n[k] * d[k]).sum::<f64>() / dl.max(1e-12);
            if facing < cos_max {
                continue;
            }
            // Occluded when the view ray hits another surface clearly before the feature.
            if let Some(h) = bvh.cast(eye, d) {
                if h.t < 1.0 - 2e-3 / dl.max(1e-12) {
                    continue;
                }
            }
            let Some(m) = measure_offset(&registrar, p, n, &self.register) else {
                continue;
            };
            if m.points < self.params.min_points {
                continue;
            }
            let z = cam.depth_of(p);
            let nd = facing * dl / z.max(1e-9);
            let sz2 = (s.depth_k * z * z).powi(2) * f64::from(u8::from(s.enabled))
                + s.depth_unit * s.depth_unit / 12.0;
            let sigma2 = sz2 * nd * nd / m.points as f64 + self.params.sigma_floor.powi(2);
            out.push(Residual {
                feature: fi,
                r: m.offset,
                sigma: sigma2.sqrt(),
            });
        }
        Ok(out)
    }

    fn all_residuals(&self, effects: &[Effect]) -> DiscrepancyResult<Vec<Vec<Residual>>> {
        (0..self.frames.len())
            .map(|i| self.residuals(i, effects))
            .collect()
    }

    /// Residuals of `frames` only (the others empty).
    fn some_residuals(
        &self,
        frames: &[usize],
        effects: &[Effect],
    ) -> DiscrepancyResult<Vec<Vec<Residual>>> {
        (0..self.frames.len())
            .map(|i| {
                if frames.contains(&i) {
                    self.residuals(i, effects)
                } else {
                    Ok(Vec::new())
                }
            })
            .collect()
    }

    fn stats(&self, res: &[Vec<Residual>], frames: &[usize]) -> Vec<RegionStats> {
        let nreg = REGION_NAMES.len();
        let mut acc = vec![(0usize, 0.0f64, 0.0f64, 0.0f64); nreg + 1];
        for &i in frames {
            for r in &res[i] {
                let g = self.features[r.feature].region;
                for a in [g, nreg] {
                    acc[a].0 += 1;
                    acc[a].1 += (r.r / r.sigma).powi(2);
                    acc[a].2 += r.r * r.r;
                    acc[a].3 += r.sigma * r.sigma;
                }
            }
        }
        acc.iter()
            .enumerate()
            .map(|(g, &(n, chi2, rr, ss))| {
                let nf = n.max(1) as f64;
                RegionStats {
                    region: REGION_NAMES.get(g).copied().unwrap_or("all").to_string(),
                    n,
                    chi2,
                    z: if n > 0 {
                        (chi2 - nf) / (2.0 * nf).sqrt()
                    } else {
                        0.0
                    },
                    rms: (rr / nf).sqrt(),
                    noise_rms: (ss / nf).sqrt(),
                }
            })
            .collect()
    }

    /// Linear least squares over `frames` for the parameter increments of `kinds`
    /// (candidate indices), with Huber reweighting (threshold `params.huber` in units of
    /// σ) against rows the linearisation does not hold for (a face sliding past an edge):
    /// returns (increments, plain χ² after, covariance, rows).
    fn fit(
        &self,
        res: &[Vec<Residual>],
        frames: &[usize],
        kinds: &[usize],
        over: Option<&[Sens]>,
    ) -> Option<(Vec<f64>, f64, DMatrix<f64>, usize)> {
        let k: usize = kinds
            .iter()
            .map(|&c| self.frames[0].sens[c].first().map_or(0, |r| r.len()))
            .sum();
        let mut rows: Vec<f64> = Vec::new();
        let mut ys: Vec<f64> = Vec::new();
        for &i in frames {
            for r in &res[i] {
                for (j, &c) in kinds.iter().enumerate() {
                    let s = over
                        .and_then(|o| o.get(i)?.get(j)?.as_ref())
                        .unwrap_or(&self.frames[i].sens[c]);
                    rows.extend(s[r.feature].iter().map(|v| v / r.sigma));
                }
                ys.push(r.r / r.sigma);
            }
        }
        let n = ys.len();
        if n <= k || k == 0 {
            return None;
        }
        let mut w = vec![1.0; n];
        let mut out = None;
        let passes = if self.params.huber > 0.0 { 5 } else { 1 };
        for _ in 0..passes {
            let mut a = DMatrix::<f64>::zeros(k, k);
            let mut b = DVector::<f64>::zeros(k);
            for (j, (&y, &wj)) in ys.iter().zip(&w).enumerate() {
                let row = &rows[j * k..(j + 1) * k];
                for p in 0..k {
                    b[p] += wj * row[p] * y;
                    for q in 0..k {
                        a[(p, q)] += wj * row[p] * row[q];
                    }
                }
            }
            // Scale for conditioning, then a tiny ridge.
            let d: Vec<f64> = (0..k).map(|p| a[(p, p)].max(1e-300).sqrt()).collect();
            let mut sa = a.clone();
            for p in 0..k {
                for q in 0..k {
                    sa[(p, q)] /= d[p] * d[q];
                }
                sa[(p, p)] += 1e-10;
            }
            let inv = sa.try_inverse()?;
            let bs = DVector::from_fn(k, |p, _| b[p] / d[p]);
            let ts = &inv * &bs;
            let theta: Vec<f64> = (0..k).map(|p| ts[p] / d[p]).collect();
            let mut chi2 = 0.0;
            for (j, &y) in ys.iter().enumerate() {
                let row = &rows[j * k..(j + 1) * k];
                let e = y - row.iter().zip(&theta).map(|(a, t)| a * t).sum::<f64>();
                chi2 += e * e;
                let c = self.params.huber;
                w[j] = if c > 0.0 && e.abs() > c {
                    c / e.abs()
                } else {
                    1.0
                };
            }
            let cov = DMatrix::from_fn(k, k, |p, q| inv[(p, q)] / (d[p] * d[q]));
            out = Some((theta, chi2, cov, n));
        }
        out
    }

    fn chi2(&self, res: &[Vec<Residual>], frames: &[usize]) -> (f64, usize) {
        frames
            .iter()
            .flat_map(|&i| &res[i])
            .fold((0.0, 0), |(c, n), r| (c + (r.r / r.sigma).powi(2), n + 1))
    }

    fn effects_of(&self, kept: &[(usize, Vec<f64>)]) -> Vec<Effect> {
        kept.iter()
            .map(|(c, p)| Effect {
                kind: self.kinds[*c],
                params: p.clone(),
            })
            .collect()
    }
}

/// The effects kept so far with their covariance and the residuals of all frames.
struct State {
    kept: Kept,
    cov: DMatrix<f64>,
    res: Vec<Vec<Residual>>,
}

/// The model selection: BIC on training frames, confirmation on held-out frames.
struct Search<'w, 'a> {
    wf: &'w Workflow<'a>,
    train: &'w [usize],
    hold: &'w [usize],
    ln_n: f64,
}

impl Search<'_, '_> {
    /// Penalised parameters of a set of effects (a load's location counts as one more).
    fn k_of(&self, kept: &[(usize, Vec<f64>)]) -> usize {
        kept.iter()
            .map(|(c, p)| p.len() + self.wf.kinds[*c].choice_params())
            .sum()
    }

    fn bic(&self, chi2: f64, kept: &[(usize, Vec<f64>)]) -> f64 {
        chi2 + self.k_of(kept) as f64 * self.ln_n
    }

    /// Chord iterations (fixed-Jacobian Gauss-Newton with exact FE re-solves and
    /// re-registration; point loads' rows re-linearised at every iterate) of all parameters
    /// of `trial` on the training frames, keeping the best iterate (a step can overshoot):
    /// returns its χ² and the covariance.
    fn refine(&self, trial: &mut Kept) -> DiscrepancyResult<(f64, DMatrix<f64>)> {
        let wf = self.wf;
        let idx: Vec<usize> = trial.iter().map(|(k, _)| *k).collect();
        let mut res_t = wf.some_residuals(self.train, &wf.effects_of(trial))?;
        let mut cov = DMatrix::zeros(0, 0);
        let mut best_chi = wf.chi2(&res_t, self.train).0;
        for _ in 0..wf.params.refine_iterations {
            // Point loads away from zero: their Jacobian at the current estimate.
            let moved = trial.iter().any(|(c, p)| {
                matches!(wf.kinds[*c], EffectKind::PointLoad { .. }) && p.iter().any(|v| *v != 0.0)
            });
            let over: Option<Vec<Sens>> = if moved {
                (0..wf.frames.len())
                    .map(|i| {
                        if self.train.contains(&i) {
                            wf.load_sens_at(i, trial)
                        } else {
                            Ok(Vec::new())
                        }
                    })
                    .collect::<DiscrepancyResult<_>>()
                    .ok()
            } else {
                None
            };
            let Some((d, _, cv, _)) = wf.fit(&res_t, self.train, &idx, over.as_deref()) else {
                break;
            };
            cov = cv;
            // A chord step can overshoot where the effect is strongly nonlinear (a large
            // load bending a leg): halve it before giving up. A step the FE model cannot
            // solve counts as an overshoot (the start solved).
            let mut found = None;
            let mut scale = 1.0;
            for _ in 0..3 {
                let mut next = trial.clone();
                add_increments(&mut next, &d.iter().map(|v| v * scale).collect::<Vec<_>>());
                let res_n = match wf.some_residuals(self.train, &wf.effects_of(&next)) {
                    Ok(r) => r,
                    Err(_) => {
                        scale *= 0.5;
                        continue;
                    }
                };
                let chi = wf.chi2(&res_n, self.train).0;
                if std::env::var_os("SOFTSENSE_DEBUG").is_some() {
                    eprintln!("refine {next:?} scale {scale} chi2 {chi:.1}");
                }
                if chi < best_chi {
                    found = Some((next, res_n, chi));
                    break;
                }
                scale *= 0.5;
            }
            let Some((next, res_n, chi)) = found else {
                break;
            };
            // Chord steps converge linearly: stop once they no longer pay (a strongly
            // nonlinear effect such as a Poisson ratio far below the nominal one needs
            // several; most candidates stop after one or two).
            let small = best_chi - chi < 2e-3 * best_chi;
            best_chi = chi;
            *trial = next;
            res_t = res_n;
            if small {
                break;
            }
        }
        Ok((best_chi, cov))
    }

    /// A step not yet decided: its candidates and the state's held-out χ².
    fn step(
        &self,
        action: String,
        bic_current: f64,
        candidates: impl IntoIterator<Item = CandidateScore>,
        state: &State,
    ) -> Step {
        Step {
            action,
            bic_current,
            candidates: candidates.into_iter().collect(),
            holdout_chi2: [self.wf.chi2(&state.res, self.hold).0, f64::NAN],
            accepted: false,
        }
    }

    /// Refines `trial` exactly, records its χ² and BIC in `score` and keeps it in `best`
    /// when its BIC is the lowest so far. A trial the FE model cannot solve (absurd
    /// parameters) is not a candidate: its score becomes infinite.
    fn refine_scored(
        &self,
        score: &mut CandidateScore,
        mut trial: Kept,
        best: &mut Option<(f64, Kept, DMatrix<f64>)>,
    ) {
        score.refined = true;
        let Ok((chi2, cov)) = self.refine(&mut trial) else {
            score.chi2 = f64::INFINITY;
            score.bic = f64::INFINITY;
            return;
        };
        score.chi2 = chi2;
        score.bic = chi2 + score.k as f64 * self.ln_n;
        if best.as_ref().is_none_or(|b| score.bic < b.0) {
            *best = Some((score.bic, trial, cov));
        }
    }

    /// The state with `trial` (residuals of all frames, covariance scaled by the
    /// training χ² per degree of freedom when above 1).
    fn state_of(&self, trial: Kept, cov: DMatrix<f64>) -> DiscrepancyResult<State> {
        let res = self.wf.all_residuals(&self.wf.effects_of(&trial))?;
        let (chi_t, n_t) = self.wf.chi2(&res, self.train);
        let scale = (chi_t / (n_t.saturating_sub(cov.nrows()).max(1)) as f64).max(1.0);
        Ok(State {
            kept: trial,
            cov: cov * scale,
            res,
        })
    }

    /// Whether the held-out χ² of `res` is lower than the state's by the required gain.
    fn holdout_gain(&self, state: &State, res: &[Vec<Residual>]) -> (f64, f64, bool) {
        let (h_cur, n_hold) = self.wf.chi2(&state.res, self.hold);
        let (h_new, _) = self.wf.chi2(res, self.hold);
        let ok =
            self.hold.is_empty() || h_cur - h_new > self.wf.params.holdout_gain * n_hold as f64;
        (h_cur, h_new, ok)
    }

    /// One step: add the best candidate to the kept effects (or, with `replace`, to the
    /// kept effects without that one: a swap), all refitted jointly. The linear fits rank
    /// the candidates; the best few are refined exactly and the choice is made on their
    /// exact χ². Returns the step and the new state when the step is accepted (BIC lower
    /// by the margin and held-out χ² lower).
    fn try_add(
        &self,
        state: &State,
        replace: Option<usize>,
    ) -> DiscrepancyResult<(Step, Option<State>)> {
        let wf = self.wf;
        let params = wf.params;
        let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
        let mut base = state.kept.clone();
        let (action, base_res) = match replace {
            None => ("add".to_string(), None),
            Some(j) => {
                let (c, _) = base.remove(j);
                // The others alone may not solve (they compensated the one taken out).
                let Ok(res) = wf.some_residuals(self.train, &wf.effects_of(&base)) else {
                    let step = self.step(
                        format!("swap out {}", wf.kinds[c].name()),
                        bic_current,
                        [],
                        state,
                    );
                    return Ok((step, None));
                };
                (format!("swap out {}", wf.kinds[c].name()), Some((c, res)))
            }
        };
        let res = base_res.as_ref().map_or(&state.res, |(_, r)| r);
        let removed = base_res.as_ref().map(|(c, _)| *c);
        let mut cands: Vec<(usize, CandidateScore, Vec<f64>)> = Vec::new();
        for c in 0..wf.kinds.len() {
            if base.iter().any(|(k, _)| *k == c) || removed == Some(c) {
                continue;
            }
            let mut idx: Vec<usize> = base.iter().map(|(k, _)| *k).collect();
            idx.push(c);
            if let Some((theta, chi2, _, _)) = wf.fit(res, self.train, &idx, None) {
                let kind = wf.kinds[c];
                let k = self.k_of(&base)
                    + kind.n_params(wf.model.problem.cables.len())
                    + kind.choice_params();
                cands.push((
                    c,
                    CandidateScore {
                        name: wf.kinds[c].name(),
                        k,
                        chi2,
                        bic: chi2 + k as f64 * self.ln_n,
                        refined: false,
                    },
                    theta,
                ));
            }
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        // Refined: the best few by the linear fit and the best of every effect type (the
        // linearisation about the nominal solution can rank a right effect low once a
        // large kept effect has moved the robot, e.g. cable offsets after +40 % weight).
        let mut seen = Vec::new();
        let chosen: Vec<bool> = cands
            .iter()
            .enumerate()
            .map(|(i, (c, _, _))| {
                let kind = std::mem::discriminant(&wf.kinds[*c]);
                let first = !seen.contains(&kind);
                if first {
                    seen.push(kind);
                }
                i < params.refine_candidates || first
            })
            .collect();
        let mut best: Option<(f64, Kept, DMatrix<f64>)> = None;
        for ((c, score, theta), _) in cands.iter_mut().zip(&chosen).filter(|(_, &ch)| ch) {
            let mut trial = base.clone();
            trial.push((
                *c,
                vec![0.0; wf.kinds[*c].n_params(wf.model.problem.cables.len())],
            ));
            add_increments(&mut trial, theta);
            self.refine_scored(score, trial, &mut best);
        }
        cands.sort_by(|a, b| {
            b.1.refined
                .cmp(&a.1.refined)
                .then(a.1.bic.total_cmp(&b.1.bic))
        });
        let mut step = self.step(
            action,
            bic_current,
            cands.iter().map(|c| c.1.clone()),
            state,
        );
        let Some((best_bic, trial, cov)) = best else {
            return Ok((step, None));
        };
        if best_bic > bic_current - params.bic_margin {
            return Ok((step, None));
        }
        // Effects the FE model cannot solve on the held-out frames are not confirmed.
        let Ok(next) = self.state_of(trial, cov) else {
            return Ok((step, None));
        };
        let (_, h_new, ok) = self.holdout_gain(state, &next.res);
        step.holdout_chi2[1] = h_new;
        step.accepted = ok;
        Ok((step, ok.then_some(next)))
    }

    /// Every pair of candidates fitted jointly from the nominal model (`res0`: residuals
    /// with no effect): the forward path can start from a wrong first pick when two
    /// effects combine (one effect alone fits neither). The linear fits rank the pairs; the
    /// best few are refined exactly. The best pair replaces the state when it has a lower
    /// BIC (by the margin unless it has fewer parameters) and, on held-out frames, a lower
    /// χ² (by the holdout gain; with fewer parameters: not higher by more than it).
    fn try_pairs(
        &self,
        state: &State,
        res0: &[Vec<Residual>],
    ) -> DiscrepancyResult<(Step, Option<State>)> {
        let wf = self.wf;
        let params = wf.params;
        let nc = wf.model.problem.cables.len();
        let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
        let mut cands: Vec<(Kept, CandidateScore, Vec<f64>)> = Vec::new();
        for a in 0..wf.kinds.len() {
            for b in a + 1..wf.kinds.len() {
                let Some((theta, chi2, _, _)) = wf.fit(res0, self.train, &[a, b], None) else {
                    continue;
                };
                let trial: Kept = [a, b]
                    .iter()
                    .map(|&c| (c, vec![0.0; wf.kinds[c].n_params(nc)]))
                    .collect();
                let k = self.k_of(&trial);
                let name = format!("{} + {}", wf.kinds[a].name(), wf.kinds[b].name());
                let score = CandidateScore {
                    name,
                    k,
                    chi2,
                    bic: chi2 + k as f64 * self.ln_n,
                    refined: false,
                };
                cands.push((trial, score, theta));
            }
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        cands.truncate(params.pair_candidates);
        let mut best: Option<(f64, Kept, DMatrix<f64>)> = None;
        for (trial, score, theta) in cands.iter_mut() {
            let mut trial = trial.clone();
            add_increments(&mut trial, theta);
            self.refine_scored(score, trial, &mut best);
        }
        cands.sort_by(|a, b| a.1.bic.total_cmp(&b.1.bic));
        let candidates = cands.iter().map(|c| c.1.clone());
        let mut step = self.step("pair".into(), bic_current, candidates, state);
        let Some((best_bic, trial, cov)) = best else {
            return Ok((step, None));
        };
        let simpler = self.k_of(&trial) < self.k_of(&state.kept);
        let margin = if simpler { 0.0 } else { params.bic_margin };
        if best_bic >= bic_current - margin {
            return Ok((step, None));
        }
        // Effects the FE model cannot solve on the held-out frames are not confirmed.
        let Ok(next) = self.state_of(trial, cov) else {
            return Ok((step, None));
        };
        let (h_cur, h_new, ok) = self.holdout_gain(state, &next.res);
        let (_, n_hold) = wf.chi2(&state.res, self.hold);
        step.holdout_chi2[1] = h_new;
        step.accepted = if simpler {
            h_new <= h_cur + params.holdout_gain * n_hold as f64
        } else {
            ok
        };
        let accepted = step.accepted;
        Ok((step, accepted.then_some(next)))
    }

    /// Whether the residuals of all frames are at the noise floor (no significant region,
    /// overall z below the threshold).
    fn at_floor(&self, res: &[Vec<Residual>]) -> bool {
        let all: Vec<usize> = (0..self.wf.frames.len()).collect();
        let s = self.wf.stats(res, &all);
        let z = self.wf.params.z_significant;
        significant(&s, z).is_empty() && s.last().is_some_and(|a| a.z <= z)
    }

    /// Forward selection then swaps from `state`. Forward: add the best candidate
    /// (refitted jointly with the kept ones) while it lowers the BIC and the held-out χ²;
    /// after each addition drop kept effects the new one made redundant (a wrong first
    /// pick that absorbed part of two effects). Swap: replace a kept effect by another
    /// candidate when that lowers the BIC (the forward order can lock in an effect that
    /// only mimics the missing one).
    fn greedy(&self, mut state: State, steps: &mut Vec<Step>) -> DiscrepancyResult<State> {
        let max = self.wf.params.max_effects;
        while state.kept.len() < max && !self.at_floor(&state.res) {
            let (step, accepted) = self.try_add(&state, None)?;
            steps.push(step);
            let Some(next) = accepted else { break };
            state = next;
            self.prune(&mut state, steps)?;
        }
        let mut rounds = 0;
        while state.kept.len() >= 2 && rounds < max {
            rounds += 1;
            let mut swapped = false;
            for j in 0..state.kept.len() {
                let (step, accepted) = self.try_add(&state, Some(j))?;
                steps.push(step);
                if let Some(next) = accepted {
                    state = next;
                    self.prune(&mut state, steps)?;
                    swapped = true;
                    break;
                }
            }
            if !swapped {
                break;
            }
        }
        Ok(state)
    }

    /// Drops kept effects whose removal (the others refitted) lowers the BIC without
    /// raising the held-out χ² by more than the holdout gain.
    fn prune(&self, state: &mut State, steps: &mut Vec<Step>) -> DiscrepancyResult<()> {
        let wf = self.wf;
        while state.kept.len() >= 2 {
            let bic_current = self.bic(wf.chi2(&state.res, self.train).0, &state.kept);
            let mut scores = Vec::new();
            let mut best: Option<(f64, Kept, DMatrix<f64>)> = None;
            for j in 0..state.kept.len() {
                let mut trial = state.kept.clone();
                let (c, _) = trial.remove(j);
                let Ok((chi2, cov)) = self.refine(&mut trial) else {
                    continue;
                };
                let bic = self.bic(chi2, &trial);
                scores.push(CandidateScore {
                    name: format!("without {}", wf.kinds[c].name()),
                    k: self.k_of(&trial),
                    chi2,
                    bic,
                    refined: true,
                });
                if best.as_ref().is_none_or(|b| bic < b.0) {
                    best = Some((bic, trial, cov));
                }
            }
            scores.sort_by(|a, b| a.bic.total_cmp(&b.bic));
            let mut step = self.step("drop".into(), bic_current, scores, state);
            let Some((bic, trial, cov)) = best.filter(|b| b.0 < bic_current) else {
                steps.push(step);
                return Ok(());
            };
            let _ = bic;
            let Ok(next) = self.state_of(trial, cov) else {
                steps.push(step);
                return Ok(());
            };
            let (h_cur, h_new, _) = self.holdout_gain(state, &next.res);
            let (_, n_hold) = wf.chi2(&state.res, self.hold);
            step.holdout_chi2[1] = h_new;
            step.accepted = h_new <= h_cur + wf.params.holdout_gain * n_hold as f64;
            let accepted = step.accepted;
            steps.push(step);
            if !accepted {
                return Ok(());
            }
            *state = next;
        }
        Ok(())
    }
}

fn significant(stats: &[RegionStats], z: f64) -> Vec<String> {
    let mut v: Vec<&RegionStats> = stats[..stats.len().saturating_sub(1)]
        .iter()
        .filter(|s| s.n > 0 && s.z > z)
        .collect();
    v.sort_by(|a, b| b.z.total_cmp(&a.z));
    v.into_iter().map(|s| s.region.clone()).collect()
}

/// Runs the workflow on a model and a recording.
pub fn explain(
    model: &Model,
    rec: &Recording,
    params: &DiscrepancyParams,
) -> DiscrepancyResult<Explanation> {
    if !(0.0..1.0).contains(&params.holdout) {
        return Err(DiscrepancyError::Data(format!(
            "holdout fraction {} not in [0, 1)",
            params.holdout
        )));
    }
    let wf = Workflow::new(model, rec, params)?;
    let split = split_frames(rec.frames.len(), params.holdout);
    let [train, hold] = &split;
    let res0 = wf.all_residuals(&[])?;
    let before = wf.stats(&res0, hold);
    let search = Search {
        wf: &wf,
        train,
        hold,
        ln_n: (wf.chi2(&res0, train).1.max(2) as f64).ln(),
    };
    let mut state = State {
        kept: Vec::new(),
        cov: DMatrix::<f64>::zeros(0, 0),
        res: res0.clone(),
    };
    let mut steps = Vec::new();
    if !search.at_floor(&res0) {
        state = search.greedy(state, &mut steps)?;
        // Two effects at once can defeat the forward path (its first pick fits neither):
        // when it ends above the noise floor or with more than two effects (a sign that
        // it pieced the answer together), fit every pair jointly and continue from the
        // best pair if it does better.
        if params.pair_candidates > 0 && (state.kept.len() > 2 || !search.at_floor(&state.res)) {
            let (step, accepted) = search.try_pairs(&state, &res0)?;
            steps.push(step);
            if let Some(next) = accepted {
                state = search.greedy(next, &mut steps)?;
            }
        }
    }
    let State {
        kept,
        cov: cov_kept,
        res,
    } = state;
    let after = wf.stats(&res, hold);
    let mut fitted = Vec::new();
    let mut o = 0;
    for (c, p) in &kept {
        let sigma = (0..p.len())
            .map(|j| {
                cov_kept
                    .get((o + j, o + j))
                    .copied()
                    .unwrap_or(f64::NAN)
                    .max(0.0)
                    .sqrt()
            })
            .collect();
        o += p.len();
        fitted.push(FittedEffect {
            effect: Effect {
                kind: wf.kinds[*c],
                params: p.clone(),
            },
            name: wf.kinds[*c].name(),
            sigma,
        });
    }
    let eval = if hold.is_empty() {
        wf.stats(&res, train)
    } else {
        after.clone()
    };
    let regions = significant(&eval, params.z_significant);
    let overall_ok = eval.last().is_some_and(|a| a.z <= params.z_significant);
    let outcome = if regions.is_empty() && overall_ok {
        if fitted.is_empty() {
            Outcome::NoMissingEffect
        } else {
            Outcome::Explained {
                effects: fitted.clone(),
            }
        }
    } else {
        let regions = if regions.is_empty() {
            vec!["all".to_string()]
        } else {
            regions
        };
        Outcome::UnexplainedResidual {
            regions,
            partial: fitted.clone(),
        }
    };
    let pick = |r: &[Vec<Residual>]| hold.iter().map(|&i| r[i].clone()).collect::<Vec<_>>();
    Ok(Explanation {
        outcome,
        split: split.clone(),
        before,
        after,
        steps,
        features: wf.features.clone(),
        holdout_residuals: [pick(&res0), pick(&res)],
        kept: fitted,
    })
}

/// Held-out and training statistics (last entry: all regions) with the given effects
/// applied exactly: a diagnostic, e.g. the residual at the true effects of a generated set.
pub fn evaluate(
    model: &Model,
    rec: &Recording,
    params: &DiscrepancyParams,
    effects: &[Effect],
) -> DiscrepancyResult<[Vec<RegionStats>; 2]> {
    let wf = Workflow::new(model, rec, params)?;
    let [train, hold] = split_frames(rec.frames.len(), params.holdout);
    let res = wf.all_residuals(effects)?;
    Ok([wf.stats(&res, &train), wf.stats(&res, &hold)])
}

fn add_increments(effects: &mut [(usize, Vec<f64>)], d: &[f64]) {
    let mut o = 0;
    for (_, p) in effects.iter_mut() {
        for v in p.iter_mut() {
            *v += d.get(o).copied().unwrap_or(0.0);
            o += 1;
        }
    }
}

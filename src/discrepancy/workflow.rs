//! The workflow's entry points ([`explain`], [`evaluate`]) and the state every stage shares:
//! the model, the recording, the feature points, the candidate effects and the per-frame
//! contexts.

use super::body::{Body, LOAD_HEIGHT};
use super::effects::{tet_legs, Effect, EffectKind};
use super::explanation::{Explanation, FittedEffect, Outcome, RegionStats, Residual};
use super::features::{choose_features, Feature};
use super::frame::FrameCtx;
use super::holdout::split_frames;
use super::select::{significant, Search, State};
use super::{data::RobotFrames, DiscrepancyError, DiscrepancyParams, DiscrepancyResult};
use crate::fem::model::Model;
use crate::fem::solve::Problem;
use crate::register::{farthest_point_sampling, RegisterParams};
use nalgebra::DMatrix;

/// Effects kept or tried: candidate index and parameters.
pub(super) type Kept = Vec<(usize, Vec<f64>)>;

/// Candidate nodes of an unmodelled point load: surface nodes higher than [`LOAD_HEIGHT`]
/// of the body's free length, spread evenly.
pub fn load_candidates(problem: &Problem, body: &Body, count: usize) -> Vec<usize> {
    let s = problem.mesh.surface();
    let x = &problem.mesh.nodes_in_rest;
    let c: Vec<usize> = s
        .nodes
        .iter()
        .copied()
        .filter(|&v| body.height(x[v]) > LOAD_HEIGHT)
        .collect();
    farthest_point_sampling(x, &c, count)
}

/// The library's candidate effects for a model.
pub fn candidate_kinds(
    problem: &Problem,
    body: &Body,
    params: &DiscrepancyParams,
) -> Vec<EffectKind> {
    let mut v = vec![EffectKind::Gravity, EffectKind::Young, EffectKind::Poisson];
    v.extend((0..4).map(|leg| EffectKind::LegStiffness { leg }));
    if super::effects::actuator_count(problem) > 0 {
        v.push(EffectKind::ActuatorOffset);
    }
    v.push(EffectKind::CameraPose);
    v.push(EffectKind::Depth);
    v.extend(
        load_candidates(problem, body, params.load_candidates)
            .into_iter()
            .map(|node| EffectKind::PointLoad { node }),
    );
    v
}

/// What every stage of the workflow reads.
pub(super) struct Workflow<'a> {
    pub(super) model: &'a Model,
    pub(super) rec: &'a RobotFrames,
    pub(super) params: &'a DiscrepancyParams,
    /// Feature points on the rest surface.
    pub(super) features: Vec<Feature>,
    /// Surface triangles (for occlusion tests).
    pub(super) triangles: Vec<[usize; 3]>,
    /// Leg of each tetrahedron (None: base block and top platform).
    pub(super) legs: Vec<Option<usize>>,
    /// Candidate effects; a candidate index points in here.
    pub(super) kinds: Vec<EffectKind>,
    /// Per-frame contexts, in recording order.
    pub(super) frames: Vec<FrameCtx>,
    /// Normal-line registration of the features.
    pub(super) register: RegisterParams,
}

impl<'a> Workflow<'a> {
    /// Chooses the features and candidates and builds every frame's context.
    pub(super) fn new(
        model: &'a Model,
        rec: &'a RobotFrames,
        params: &'a DiscrepancyParams,
    ) -> DiscrepancyResult<Self> {
        let surface = model.problem.mesh.surface();
        let rest = &model.problem.mesh.nodes_in_rest;
        let body = Body::of(&model.problem)?;
        let features = choose_features(
            rest,
            &surface,
            params.features,
            &body,
            params.min_feature_height,
            params.flat_radius,
        );
        if features.is_empty() {
            return Err(DiscrepancyError::Data(
                "no feature point on the surface".into(),
            ));
        }
        let legs = tet_legs(&model.problem, &body);
        let kinds = candidate_kinds(&model.problem, &body, params);
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

    /// The effects of candidate indices with their parameters.
    pub(super) fn effects_of(&self, kept: &[(usize, Vec<f64>)]) -> Vec<Effect> {
        kept.iter()
            .map(|(c, p)| Effect {
                kind: self.kinds[*c],
                params: p.clone(),
            })
            .collect()
    }

    /// The kept effects with their 1-σ from the covariance `cov` (parameters in order).
    fn fitted_effects(&self, kept: &Kept, cov: &DMatrix<f64>) -> Vec<FittedEffect> {
        let mut fitted = Vec::new();
        let mut o = 0;
        for (c, p) in kept {
            let sigma = (0..p.len())
                .map(|j| {
                    cov.get((o + j, o + j))
                        .copied()
                        .unwrap_or(f64::NAN)
                        .max(0.0)
                        .sqrt()
                })
                .collect();
            o += p.len();
            fitted.push(FittedEffect {
                effect: Effect {
                    kind: self.kinds[*c],
                    params: p.clone(),
                },
                name: self.kinds[*c].name(),
                sigma,
            });
        }
        fitted
    }
}

/// The answer from the statistics `eval` (last entry: all regions) with the effects kept;
/// `rows_before`: the scored rows without any effect. Effects under which fewer than
/// `params.min_rows_kept` of those rows are still measured explain nothing.
fn outcome(
    eval: &[RegionStats],
    rows_before: usize,
    params: &DiscrepancyParams,
    fitted: &[FittedEffect],
) -> Outcome {
    let z_significant = params.z_significant;
    let regions = significant(eval, z_significant);
    let overall_ok = eval.last().is_some_and(|a| a.z <= z_significant);
    let rows = eval.last().map_or(0, |a| a.n) as f64;
    let measured = rows >= params.min_rows_kept * rows_before as f64;
    if regions.is_empty() && overall_ok && measured {
        if fitted.is_empty() {
            Outcome::NoMissingEffect
        } else {
            Outcome::Explained {
                effects: fitted.to_vec(),
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
            partial: fitted.to_vec(),
        }
    }
}

/// Runs the workflow on a model and a recording.
pub fn explain(
    model: &Model,
    rec: &RobotFrames,
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
    // Without held-out frames (`holdout` 0, or one frame) the before/after statistics are
    // over the training frames: statistics over no frame would read as a perfect fit.
    let scored = if hold.is_empty() { train } else { hold };
    let before = wf.stats(&res0, scored);
    let search = Search {
        wf: &wf,
        train,
        hold,
        ln_n: (wf.chi2(&res0, train).1.max(2) as f64).ln(),
    };
    let mut steps = Vec::new();
    let State {
        kept,
        cov: cov_kept,
        res,
    } = search.select(&res0, &mut steps)?;
    let after = wf.stats(&res, scored);
    let fitted = wf.fitted_effects(&kept, &cov_kept);
    // `before` and `after` are over the scored frames already: their last entry (all
    // regions) holds the rows the verdict weighs.
    let rows_before = before.last().map_or(0, |a| a.n);
    let outcome = outcome(&after, rows_before, params, &fitted);
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
    rec: &RobotFrames,
    params: &DiscrepancyParams,
    effects: &[Effect],
) -> DiscrepancyResult<[Vec<RegionStats>; 2]> {
    let wf = Workflow::new(model, rec, params)?;
    let [train, hold] = split_frames(rec.frames.len(), params.holdout);
    let res = wf.all_residuals(effects)?;
    Ok([wf.stats(&res, &train), wf.stats(&res, &hold)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(n: usize, z: f64) -> Vec<RegionStats> {
        vec![RegionStats {
            region: "all".into(),
            n,
            chi2: n as f64,
            z,
            rms: 1e-4,
            noise_rms: 1e-4,
        }]
    }

    fn depth() -> FittedEffect {
        FittedEffect {
            effect: Effect {
                kind: EffectKind::Depth,
                params: vec![0.86, -0.054],
            },
            name: EffectKind::Depth.name(),
            sigma: vec![0.0, 0.0],
        }
    }

    #[test]
    fn an_effect_that_leaves_the_features_unmeasured_explains_nothing() {
        let p = DiscrepancyParams::default();
        let e = [depth()];
        // At the floor with the rows kept: explained.
        let kept = outcome(&stats(900, 0.0), 1000, &p, &e);
        assert!(matches!(kept, Outcome::Explained { .. }), "{kept:?}");
        // At the floor because the rows are gone (χ² = 0 over none): not explained.
        for n in [0, 400] {
            let lost = outcome(&stats(n, 0.0), 1000, &p, &e);
            assert!(
                matches!(lost, Outcome::UnexplainedResidual { .. }),
                "{n}: {lost:?}"
            );
        }
        let none = outcome(&stats(1000, 0.0), 1000, &p, &[]);
        assert!(matches!(none, Outcome::NoMissingEffect), "{none:?}");
    }
}

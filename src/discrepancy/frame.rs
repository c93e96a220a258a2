//! Per-frame context: the recorded problem of a frame, its nominal FE solution and the
//! sensitivity of every feature to every candidate effect about that solution.

use super::effects::{apply_model, measurement_row, Effect, EffectKind};
use super::workflow::Workflow;
use super::{DiscrepancyError, DiscrepancyResult};
use crate::fem::constraint::{ConstraintRow, RowKind};
use crate::fem::model::Model;
use crate::fem::solve::{apply_cable_inputs, apply_cavity_inputs};
use crate::fem::solve::{MappedPoint, PointLoad, Problem, Solution};
use crate::recording::FrameInput;
use nalgebra::DMatrix;

/// Sensitivity rows ([feature][param]) replacing a candidate's nominal ones, per kept effect.
pub(super) type Sens = Vec<Option<Vec<Vec<f64>>>>;

/// Feature points with their normals at node positions.
type FeatureRows = [([f64; 3], [f64; 3])];

/// Per-frame context: recorded problem, nominal solution, sensitivities.
pub(super) struct FrameCtx {
    pub(super) problem: Problem,
    /// Nominal solution (the warm start of every re-solve).
    pub(super) nominal: Solution,
    /// Sensitivity rows per candidate: [feature][param].
    pub(super) sens: Vec<Vec<Vec<f64>>>,
}

/// The problem of one frame: the model with the recorded cable inputs and known loads.
pub fn frame_problem(model: &Model, input: &FrameInput) -> DiscrepancyResult<Problem> {
    let mut p = model.problem.clone();
    apply_cable_inputs(&mut p.cables, &input.cables)?;
    apply_cavity_inputs(&mut p.cavities, &input.cavities)?;
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

/// Solves a frame's problem, warm-started from the frame's nominal solution when given
/// (the effects change it a little: Newton then needs a few iterations from there).
pub(super) fn solve_frame(
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

/// Columns `c0..c0 + 3` of the compliance `w` as rows [feature][force component].
fn load_rows(w: &DMatrix<f64>, nf: usize, c0: usize) -> Vec<Vec<f64>> {
    (0..nf)
        .map(|r| (0..3).map(|k| w[(r, c0 + k)]).collect())
        .collect()
}

impl Workflow<'_> {
    pub(super) fn feature_rows(&self, x: &[[f64; 3]]) -> Vec<([f64; 3], [f64; 3])> {
        self.features.iter().map(|f| f.at(x)).collect()
    }

    /// Compliance at the solution `sol` (with the cables' geometric stiffness: under
    /// tensions of a newton or two it is far from negligible) of the feature rows (along
    /// the normals of `pn`), then 3 force rows per node of `nodes`: column nf + 3j + k is
    /// the motion of every feature along its normal per unit force k at node j.
    pub(super) fn load_compliance(
        &self,
        problem: &Problem,
        sol: &Solution,
        pn: &FeatureRows,
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
        solver.factorize_with_cables(x, &sol.actuator_forces())?;
        let zero = vec![0.0; solver.ndof()];
        Ok(solver.compliance(&rows, x, &zero)?.w)
    }

    /// Sensitivity rows ([feature][force component]) of the point loads among `kept`
    /// (None for the other effects) re-linearised at the state the kept effects deform
    /// frame `i` into: a large load bends the robot enough that the compliance at the
    /// nominal state points a chord step away from the true force (Gauss-Newton instead).
    pub(super) fn load_sens_at(
        &self,
        i: usize,
        kept: &[(usize, Vec<f64>)],
    ) -> DiscrepancyResult<Sens> {
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
                    load_rows(&w, nf, c0)
                })
            })
            .collect())
    }

    /// The context of frame `index`: its problem, nominal solution and the sensitivity
    /// rows of every candidate (compliance rows for point loads, closed forms for the
    /// measurement effects, finite differences of FE solves for the others).
    pub(super) fn frame_ctx(
        &self,
        index: usize,
        input: &FrameInput,
    ) -> DiscrepancyResult<FrameCtx> {
        let problem = frame_problem(self.model, input)?;
        let nominal = solve_frame(self.model, &problem, index, None)?;
        let pn0 = self.feature_rows(&nominal.positions);
        let steps = super::effects::actuator_steps(&problem);
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
                    load_rows(w, nf, c0)
                }
                EffectKind::CameraPose | EffectKind::Depth => pn0
                    .iter()
                    .map(|(p, n)| measurement_row(*kind, *p, *n, &self.rec.camera))
                    .collect(),
                _ => {
                    let fd = FdStart {
                        problem: &problem,
                        nominal: &nominal,
                        index,
                        pn0: &pn0,
                    };
                    self.fd_rows(&fd, *kind, &kind.fd_step(&steps))?
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

    /// Sensitivity rows of a model effect by forward differences of FE solves (steps
    /// `steps`, one per parameter) about the nominal solution.
    fn fd_rows(
        &self,
        fd: &FdStart,
        kind: EffectKind,
        steps: &[f64],
    ) -> DiscrepancyResult<Vec<Vec<f64>>> {
        let mut cols = Vec::with_capacity(steps.len());
        for (j, h) in steps.iter().enumerate() {
            let mut pp = vec![0.0; steps.len()];
            pp[j] = *h;
            let mut prob = fd.problem.clone();
            apply_model(&mut prob, &[Effect { kind, params: pp }], &self.legs)?;
            let xj = solve_frame(self.model, &prob, fd.index, Some(fd.nominal))?.positions;
            let col: Vec<f64> = self
                .features
                .iter()
                .zip(fd.pn0)
                .map(|(f, (p, n))| {
                    let (q, _) = f.at(&xj);
                    (0..3).map(|k| n[k] * (q[k] - p[k])).sum::<f64>() / h
                })
                .collect();
            cols.push(col);
        }
        Ok((0..self.features.len())
            .map(|i| cols.iter().map(|c| c[i]).collect())
            .collect())
    }
}

/// The nominal state finite differences start from.
struct FdStart<'p> {
    problem: &'p Problem,
    nominal: &'p Solution,
    index: usize,
    pn0: &'p FeatureRows,
}

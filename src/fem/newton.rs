//! Static equilibrium by Newton iterations: load steps, the residual with cable tensions,
//! the step with the displacement-controlled cables' tension corrections, and the
//! [`Solution`].

use super::cable::CableControl;
use super::cavity::CavityControl;
use super::material::von_mises;
use super::mesh::{norm, sub};
use super::problem::Problem;
use super::solve::Solver;
use super::tet4::Tangent;
use super::{FemError, FemResult};
use faer::Mat;
use serde::Serialize;

/// Newton options.
#[derive(Debug, Clone, Serialize)]
pub struct NewtonParams {
    /// Maximum iterations.
    pub max_iterations: usize,
    /// Relative residual tolerance (against the applied force scale).
    pub rel_tol: f64,
    /// Absolute residual tolerance (N).
    pub abs_tol: f64,
    /// Equal load increments (1 = apply everything at once).
    pub load_steps: usize,
    /// Converged when a correction is smaller than this times the displacement norm.
    pub step_tol: f64,
    /// Tolerance on the gaps of displacement-controlled cables (m): 0 means 1e-12 of the
    /// mesh's largest coordinate.
    pub gap_tol: f64,
    /// Corotational or Neo-Hookean tangent (the rotated K0, or the projected one, is used
    /// as fallback if the consistent one is indefinite).
    #[serde(skip)]
    pub tangent: Tangent,
}

/// The most load steps a model may ask for. Each step is a Newton solve of its own
/// (about a second on the bundled robot), so this is already hours; `100000000` ran
/// for ever without a word.
pub const MAX_LOAD_STEPS: usize = 10_000;

/// The most Newton iterations per load step. Newton converges in a handful when it
/// converges at all; more only delays the "did not converge" message.
pub const MAX_ITERATIONS: usize = 1_000;

impl NewtonParams {
    /// Checks the settings a model file can give; the error names the `[newton]` field.
    pub fn validate(&self) -> FemResult<()> {
        let bad = |field: &str, value: String, want: &str| {
            Err(FemError::Model(format!(
                "[newton] {field} = {value}: must be {want}"
            )))
        };
        if !(1..=MAX_LOAD_STEPS).contains(&self.load_steps) {
            let want = format!("an integer from 1 to {MAX_LOAD_STEPS}");
            return bad("load_steps", self.load_steps.to_string(), &want);
        }
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            let want = format!("an integer from 1 to {MAX_ITERATIONS}");
            return bad("max_iterations", self.max_iterations.to_string(), &want);
        }
        // NaN compares false, so it fails this test too.
        if !(self.rel_tol > 0.0 && self.rel_tol < 1.0) {
            let want = "a number between 0 and 1 (exclusive), e.g. 1e-10";
            return bad("rel_tol", self.rel_tol.to_string(), want);
        }
        Ok(())
    }
}

impl Default for NewtonParams {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            rel_tol: 1e-10,
            abs_tol: 1e-12,
            load_steps: 1,
            step_tol: 1e-10,
            gap_tol: 0.0,
            tangent: Tangent::Consistent,
        }
    }
}

/// The result of a static solve.
#[derive(Debug, Clone, Serialize)]
pub struct Solution {
    /// Node positions.
    pub positions: Vec<[f64; 3]>,
    /// Node displacements from rest.
    pub displacement: Vec<[f64; 3]>,
    /// External nodal forces at equilibrium (loads, gravity, cables; reactions at fixed
    /// nodes and base springs excluded).
    pub external_force: Vec<[f64; 3]>,
    /// Cable tensions (N), in model order.
    pub cable_tension: Vec<f64>,
    /// Displacement-controlled cables that went slack (they would have had to push).
    pub cable_slack: Vec<bool>,
    /// Cable shortenings (m), in model order.
    pub cable_shortening: Vec<f64>,
    /// Cavity pressures (Pa), in model order.
    #[serde(default)]
    pub cavity_pressure: Vec<f64>,
    /// Cavity volume changes from rest (m^3), in model order.
    #[serde(default)]
    pub cavity_volume_change: Vec<f64>,
    /// Von Mises stress per tetrahedron (Pa).
    pub von_mises: Vec<f64>,
    /// Newton iterations done.
    pub iterations: usize,
    /// Residual norm per iteration (N).
    pub residuals: Vec<f64>,
    /// Whether Newton converged.
    pub converged: bool,
}

/// A (node, 3-vector) row: a cable's d shortening / dx, a cavity's d volume change / dx.
type NodeRow = Vec<(usize, [f64; 3])>;

impl Solution {
    /// The actuators' multipliers: cable tensions (N), then cavity pressures (Pa), as the
    /// tangent with the actuators' stiffness takes them.
    pub fn actuator_forces(&self) -> Vec<f64> {
        let mut f = self.cable_tension.clone();
        f.extend_from_slice(&self.cavity_pressure);
        f
    }
}

/// Actuator `i`'s control (cables, then cavities): a given multiplier (tension, pressure)
/// or a given displacement (shortening, volume change).
fn control_of(p: &Problem, i: usize) -> CableControl {
    match p.cables.get(i) {
        Some(c) => c.control,
        None => match p.cavities[i - p.cables.len()].control {
            CavityControl::Pressure(q) => CableControl::Force(q),
            CavityControl::Volume(v) => CableControl::Displacement(v),
        },
    }
}

/// The number of actuators: cables and cavities.
fn actuator_count(p: &Problem) -> usize {
    p.cables.len() + p.cavities.len()
}

/// A Newton solve between iterations.
struct NewtonRun {
    /// Node positions.
    x: Vec<[f64; 3]>,
    /// External forces of the whole load (node-major 3n).
    f_ext: Vec<f64>,
    /// Cable lengths at rest (m).
    l0: Vec<f64>,
    /// Actuator multipliers: cable tensions (N), then cavity pressures (Pa).
    tension: Vec<f64>,
    /// Displacement-controlled cables that went slack.
    slack: Vec<bool>,
    /// Displacement-controlled actuators (cables still taut, volume-controlled cavities).
    disp_cables: Vec<usize>,
    /// Started from a given equilibrium.
    warm: bool,
    /// Residual norm per iteration (N).
    residuals: Vec<f64>,
    /// Newton steps done.
    iterations: usize,
}

/// The residual of one iteration at load fraction s.
struct Residual {
    /// s f_ext + Σ Hᵀ λ − f_int on the free DOFs.
    r: Vec<f64>,
    /// Its norm (N).
    norm: f64,
    /// Force scale: applied and internal forces, reactions at held nodes included (N).
    scale: f64,
    /// Each actuator's row at the current positions.
    rows: Vec<NodeRow>,
    /// Gap of each displacement-controlled actuator: wanted minus actual displacement.
    gaps: Vec<f64>,
}

/// Tolerance on the gaps of displacement-controlled cables (m) and, times the squared
/// largest coordinate, of volume-controlled cavities (m^3).
fn gap_scale(p: &Problem, params: &NewtonParams) -> (f64, f64) {
    let size = (p.mesh.bbox().iter().flatten())
        .fold(0.0f64, |m, c| m.max(c.abs()))
        .max(1e-100);
    let tol = if params.gap_tol > 0.0 {
        params.gap_tol
    } else {
        1e-12 * size
    };
    (tol, tol * size * size)
}

impl Solver<'_> {
    /// Scatters a (node, 3-vector) row into a free-DOF column.
    pub fn row_to_dofs(&self, row: &[(usize, [f64; 3])], out: &mut [f64]) {
        for (n, v) in row {
            if let Some(d) = self.dofs.node_dof.get(*n).copied().flatten() {
                for k in 0..3 {
                    out[d + k] += v[k];
                }
            }
        }
    }

    /// Static equilibrium by Newton iterations (with optional load stepping).
    pub fn solve_static(&mut self, params: &NewtonParams) -> FemResult<Solution> {
        self.solve_static_from(params, None)
    }

    /// Static equilibrium by Newton iterations, from `start` (one load step) when given.
    pub fn solve_static_from(
        &mut self,
        params: &NewtonParams,
        start: Option<&Solution>,
    ) -> FemResult<Solution> {
        self.solve_static_observed(params, start, &mut |_, _| {})
    }

    /// As [`Solver::solve_static_from`], calling `step_done(step, steps)` after each
    /// load step (for progress reports).
    pub fn solve_static_observed(
        &mut self,
        params: &NewtonParams,
        start: Option<&Solution>,
        step_done: &mut dyn FnMut(usize, usize),
    ) -> FemResult<Solution> {
        params.validate()?;
        let mut run = self.newton_start(start);
        let steps = if run.warm {
            1
        } else {
            params.load_steps.max(1)
        };
        let mut converged = false;
        for step in 1..=steps {
            let s = step as f64 / steps as f64;
            converged = self.load_step(params, &mut run, s)?;
            if !converged {
                return Err(FemError::NoConvergence {
                    iterations: run.iterations,
                    residual: run.residuals.last().copied().unwrap_or(f64::NAN),
                });
            }
            step_done(step, steps);
        }
        Ok(self.solution(run, converged))
    }

    /// The start of a Newton solve: from `start` if it fits the problem (held nodes at
    /// their prescribed places, its tensions on displacement-controlled cables), else rest.
    fn newton_start(&self, start: Option<&Solution>) -> NewtonRun {
        let p = self.problem;
        let nn = p.mesh.num_nodes();
        let warm = start.filter(|s| {
            s.positions.len() == nn
                && s.cable_tension.len() == p.cables.len()
                && s.cavity_pressure.len() == p.cavities.len()
        });
        let x = match warm {
            Some(s) => {
                let mut x = s.positions.clone();
                // Held nodes keep their prescribed positions.
                let x0 = p.initial_positions();
                for v in p.held_nodes() {
                    x[v] = x0[v];
                }
                x
            }
            None => p.initial_positions(),
        };
        let na = actuator_count(p);
        let tension = (0..na)
            .map(|i| match control_of(p, i) {
                CableControl::Force(f) => f,
                CableControl::Displacement(_) => warm.map_or(0.0, |s| s.actuator_forces()[i]),
            })
            .collect();
        NewtonRun {
            x,
            f_ext: self.external_forces(),
            l0: p
                .cables
                .iter()
                .map(|c| c.length(&p.mesh.nodes_in_rest))
                .collect(),
            tension,
            slack: vec![false; p.cables.len()],
            disp_cables: (0..na)
                .filter(|&i| matches!(control_of(p, i), CableControl::Displacement(_)))
                .collect(),
            warm: warm.is_some(),
            residuals: Vec::new(),
            iterations: 0,
        }
    }

    /// Newton iterations at load fraction `s` until converged (true) or out of iterations.
    fn load_step(&mut self, params: &NewtonParams, run: &mut NewtonRun, s: f64) -> FemResult<bool> {
        let (gap_scale, volume_scale) = gap_scale(self.problem, params);
        let nc = self.problem.cables.len();
        let mut last_step = f64::INFINITY;
        for _ in 0..params.max_iterations {
            self.assemble(&run.x, params.tangent)?;
            let res = self.residual(run, s)?;
            run.residuals.push(res.norm);
            let gaps_ok = (res.gaps.iter().zip(&run.disp_cables)).all(|(g, &ci)| {
                let tol = if ci < nc { gap_scale } else { volume_scale };
                g.abs() <= tol.max(1e-10 * g.abs())
            });
            // Converged: residual small, or the last correction is at round-off level
            // (ill-conditioned systems cannot reduce the residual further).
            let small = res.norm <= params.abs_tol + params.rel_tol * res.scale
                || last_step <= params.step_tol;
            // A cold start takes at least one step; a warm start already in equilibrium
            // (e.g. the free state when the loads added to it are still zero) is kept.
            if small && gaps_ok && (run.iterations > 0 || run.warm) {
                // A cable can only pull (lambda >= 0): a displacement-controlled cable
                // that would have to push goes slack (zero tension) and Newton goes on.
                // Cavities are not slack: a negative pressure (suction) is a valid input.
                let pushing = |&ci: &usize| ci < nc && run.tension[ci] < 0.0;
                if let Some(pos) = run.disp_cables.iter().position(pushing) {
                    let ci = run.disp_cables.remove(pos);
                    run.tension[ci] = 0.0;
                    run.slack[ci] = true;
                    last_step = f64::INFINITY;
                    continue;
                }
                return Ok(true);
            }
            run.iterations += 1;
            last_step = self.newton_step(params, run, &res)?;
        }
        Ok(false)
    }

    /// The residual at the run's positions (as last assembled) and load fraction `s`; sets
    /// the force-controlled cables' tensions to their share of the load.
    fn residual(&self, run: &mut NewtonRun, s: f64) -> FemResult<Residual> {
        let p = self.problem;
        // residual r = s f_ext + sum H^T lambda - f_int on free DOFs
        let mut full: Vec<f64> = run.f_ext.iter().map(|f| s * f).collect();
        let rows: Vec<NodeRow> = (p.cables.iter().map(|c| c.row(&run.x)))
            .chain(p.cavities.iter().map(|c| c.row(&run.x)))
            .collect();
        for (ci, row) in rows.iter().enumerate() {
            let lam = match control_of(p, ci) {
                CableControl::Force(f) => s * f,
                CableControl::Displacement(_) => run.tension[ci],
            };
            run.tension[ci] = lam;
            for (n, v) in row {
                for k in 0..3 {
                    full[3 * n + k] += lam * v[k];
                }
            }
        }
        let scale = norm_vec(&full) + norm_vec(&self.internal_force);
        for (f, fi) in full.iter_mut().zip(&self.internal_force) {
            *f -= fi;
        }
        let r = self.dofs.gather(&full);
        let rn = norm_vec(&r);
        if !rn.is_finite() {
            return Err(FemError::NoConvergence {
                iterations: run.iterations,
                residual: rn,
            });
        }
        let gaps = run
            .disp_cables
            .iter()
            .map(|&ci| match control_of(p, ci) {
                CableControl::Displacement(d) => s * d - actuator_value(p, run, ci),
                CableControl::Force(_) => 0.0,
            })
            .collect();
        Ok(Residual {
            r,
            norm: rn,
            scale,
            rows,
            gaps,
        })
    }

    /// One Newton step from the residual `res`: factorizes the tangent with the cables,
    /// solves for the correction and the taut cables' tension corrections, moves the
    /// nodes. Returns the correction's size relative to the displacement.
    fn newton_step(
        &mut self,
        params: &NewtonParams,
        run: &mut NewtonRun,
        res: &Residual,
    ) -> FemResult<f64> {
        let p = self.problem;
        self.factorize_or_rotated(&run.x, params.tangent, &run.tension)?;
        let nd = self.dofs.ndof;
        let nc = run.disp_cables.len();
        let mut b = Mat::<f64>::zeros(nd, 1 + nc);
        for (i, v) in res.r.iter().enumerate() {
            b[(i, 0)] = *v;
        }
        for (j, &ci) in run.disp_cables.iter().enumerate() {
            let mut col = vec![0.0; nd];
            self.row_to_dofs(&res.rows[ci], &mut col);
            for (i, v) in col.iter().enumerate() {
                b[(i, 1 + j)] = *v;
            }
        }
        let hd: Vec<Vec<f64>> = (0..nc)
            .map(|j| (0..nd).map(|i| b[(i, 1 + j)]).collect())
            .collect();
        self.solve_in_place(&mut b)?;
        let mut dx: Vec<f64> = (0..nd).map(|i| b[(i, 0)]).collect();
        if nc > 0 {
            correct_tensions(run, &b, &hd, &res.gaps, &mut dx)?;
        }
        for (v, d) in self.dofs.node_dof.iter().enumerate() {
            if let Some(d) = d {
                for k in 0..3 {
                    run.x[v][k] += dx[d + k];
                }
            }
        }
        let un = (0..p.mesh.num_nodes())
            .map(|v| norm(sub(run.x[v], p.mesh.nodes_in_rest[v])).powi(2))
            .sum::<f64>()
            .sqrt();
        Ok(norm_vec(&dx) / un.max(f64::MIN_POSITIVE))
    }

    /// The solution at the end of a Newton solve.
    fn solution(&self, run: NewtonRun, converged: bool) -> Solution {
        let p = self.problem;
        let nn = p.mesh.num_nodes();
        let x = run.x;
        let mut external_force: Vec<[f64; 3]> = (run.f_ext.chunks_exact(3))
            .map(|f| [f[0], f[1], f[2]])
            .collect();
        let rows = (p.cables.iter().map(|c| c.row(&x))).chain(p.cavities.iter().map(|c| c.row(&x)));
        for (ci, row) in rows.enumerate() {
            for (n, v) in row {
                for k in 0..3 {
                    external_force[n][k] += run.tension[ci] * v[k];
                }
            }
        }
        let displacement = (0..nn)
            .map(|v| sub(x[v], p.mesh.nodes_in_rest[v]))
            .collect();
        Solution {
            cable_shortening: p
                .cables
                .iter()
                .zip(&run.l0)
                .map(|(c, l)| l - c.length(&x))
                .collect(),
            cavity_volume_change: p.cavities.iter().map(|c| c.volume_change(&x)).collect(),
            cavity_pressure: run.tension[p.cables.len()..].to_vec(),
            positions: x,
            displacement,
            external_force,
            cable_tension: run.tension[..p.cables.len()].to_vec(),
            cable_slack: run.slack,
            von_mises: self.elements.iter().map(|e| von_mises(&e.stress)).collect(),
            iterations: run.iterations,
            residuals: run.residuals,
            converged,
        }
    }
}

/// Actuator `i`'s displacement at the run's positions: a cable's shortening (m), a cavity's
/// volume change (m^3).
fn actuator_value(p: &Problem, run: &NewtonRun, i: usize) -> f64 {
    match p.cables.get(i) {
        Some(c) => run.l0[i] - c.length(&run.x),
        None => p.cavities[i - p.cables.len()].volume_change(&run.x),
    }
}

/// The taut displacement-controlled cables' tension corrections dλ and their share of the
/// step: with `b` = K⁻¹ [r, H_dᵀ] and `hd` the rows H_d, W dλ = gap − H_d u0 for
/// W = H_d K⁻¹ H_dᵀ; then dx += K⁻¹ H_dᵀ dλ.
fn correct_tensions(
    run: &mut NewtonRun,
    b: &Mat<f64>,
    hd: &[Vec<f64>],
    gaps: &[f64],
    dx: &mut [f64],
) -> FemResult<()> {
    let nd = dx.len();
    let nc = run.disp_cables.len();
    // W dlambda = gap - H u0
    let w = nalgebra::DMatrix::from_fn(nc, nc, |i, j| {
        (0..nd).map(|k| hd[i][k] * b[(k, 1 + j)]).sum::<f64>()
    });
    let rhs = nalgebra::DVector::from_fn(nc, |i, _| {
        gaps[i] - (0..nd).map(|k| hd[i][k] * dx[k]).sum::<f64>()
    });
    let dl = w
        .lu()
        .solve(&rhs)
        .ok_or_else(|| FemError::Singular("cable compliance matrix is singular".into()))?;
    for (j, &ci) in run.disp_cables.iter().enumerate() {
        run.tension[ci] += dl[j];
        for (k, d) in dx.iter_mut().enumerate() {
            *d += dl[j] * b[(k, 1 + j)];
        }
    }
    Ok(())
}

/// Euclidean norm of a slice.
pub fn norm_vec(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

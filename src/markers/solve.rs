//! The forces of one frame from its markers (thesis 4.4.1, equations 4.4-4.10).
//!
//! The FE model holds the actuators at their inputs (4.7/4.8: a force-controlled cable at
//! its force, a displacement-controlled one at its shortening), so their share is part of
//! the free motion. The unknowns are the intensities at the candidates along their allowed
//! directions. Each update solves the FE model under the current intensities, linearises
//! there (W_ef, the compliance between the visible markers' rows and the unknowns, condensed
//! on the displacement-held cables) and applies the analytic least squares (4.9):
//! Δλ_f = (W_efᵀW_ef)⁻¹W_efᵀ(δ_e^r − δ_e). It stops when the update or the change of the
//! markers' residual is small.

use super::bind::{BoundMarker, CandidateLocation};
use super::{MarkersParams, MarkersResult};
use crate::fem::constraint::ConstraintRow;
use crate::fem::solve::{CableControl, NewtonParams, Problem, Solution};
use crate::inverse::intensity::IntensityParams;
use crate::inverse::{loads_of, lsq, total_force, Candidate};
use crate::math::Vec3;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// How a frame's estimate ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum MarkersStatus {
    /// The updates settled (`force_tol` or `residual_tol`).
    Converged,
    /// Fewer rows than unknowns (Corollary 1) or a rank-deficient W_ef: no forces.
    NotIdentifiable {
        /// Rows of the visible markers (3 each).
        rows: usize,
        /// Force unknowns.
        unknowns: usize,
    },
    /// `max_updates` were done without settling; the forces are the last iterate.
    NotConverged,
}

/// The estimate of one frame.
#[derive(Debug, Clone, Serialize)]
pub struct MarkerFrame {
    /// The frame number.
    pub frame: u64,
    /// How the estimate ended.
    pub status: MarkersStatus,
    /// The force vector at each candidate (N); empty when not identifiable.
    pub forces: Vec<[f64; 3]>,
    /// The unknowns λ_f (N), candidate by candidate, direction by direction.
    pub intensities: Vec<f64>,
    /// One sigma of each unknown from the marker noise (N): sqrt of diag σ²(W_efᵀW_ef)⁻¹.
    pub sigma: Vec<f64>,
    /// Covariance of the unknowns σ²(W_efᵀW_ef)⁻¹ (N²).
    #[serde(skip)]
    pub covariance: Option<DMatrix<f64>>,
    /// I_w = ‖W_ef⁺‖₂ of the visible markers and the candidates (N/m).
    pub i_w: f64,
    /// I_e = ‖f_computed − f_applied‖₂ over all candidates' force vectors (N), when the
    /// truth is known ([`MarkerFrame::set_truth`]).
    pub i_e: Option<f64>,
    /// Indices of the markers whose rows were left out (hidden).
    pub hidden: Vec<usize>,
    /// Rows used (3 per visible marker, summed over the frames stacked by
    /// [`MarkerSensor::solve_frames`]).
    pub rows: usize,
    /// Force unknowns.
    pub unknowns: usize,
    /// FE updates done.
    pub updates: usize,
    /// RMS of the markers' residual at the last FE state (m).
    pub residual_rms: f64,
    /// Warnings (identifiability, FE).
    pub warnings: Vec<String>,
    /// The last FE state (under `intensities` when converged, else under the iterate before
    /// them), to warm-start the next frame.
    #[serde(skip)]
    pub solution: Option<Solution>,
}

impl MarkerFrame {
    /// Sets I_e from the applied force vectors (N, one per candidate).
    pub fn set_truth(&mut self, applied: &[[f64; 3]]) {
        if applied.len() != self.forces.len() {
            return;
        }
        let s: f64 = (self.forces.iter().zip(applied))
            .map(|(f, a)| crate::math::norm(crate::math::sub(*f, *a)).powi(2))
            .sum();
        self.i_e = Some(s.sqrt());
    }
}

/// The FE model, markers and candidates of a recording.
#[derive(Debug, Clone)]
pub struct MarkerSensor {
    /// The FE problem; its cables carry the actuator inputs. [`MarkerSensor::new`] drops its
    /// point loads; loads put back here are known loads, held in every frame and not solved.
    pub problem: Problem,
    /// Newton options of the FE updates.
    pub newton: NewtonParams,
    /// The markers, in track-file order.
    pub markers: Vec<BoundMarker>,
    /// The candidate force locations.
    pub locations: Vec<CandidateLocation>,
    /// Options.
    pub params: MarkersParams,
    /// Per marker, the variance of its bound (reference) position in units of σ²: 1/N when
    /// it was bound at the mean of N measured unloaded frames, 0 (the default) when the
    /// bound position is exact. It enters the forces' covariance
    /// ([`MarkerSensor::with_reference_frames`]).
    pub reference_variance: Vec<f64>,
    /// The covariance, in units of σ² (3 rows per marker, marker order), of the offset a
    /// tracker-to-robot calibration adds alike to every frame's marker positions
    /// ([`crate::markers::calib::rigid_fit_covariance`]); `None` without one.
    pub calibration_covariance: Option<DMatrix<f64>>,
    /// The locations' candidate forces in order: one per unknown.
    candidates: Vec<Candidate>,
    force_rows: Vec<ConstraintRow>,
}

impl MarkerSensor {
    /// A sensor on `problem` (its point loads dropped).
    pub fn new(
        problem: &Problem,
        newton: NewtonParams,
        markers: Vec<BoundMarker>,
        locations: Vec<CandidateLocation>,
        params: MarkersParams,
    ) -> MarkersResult<Self> {
        let (candidates, force_rows) = unknowns_of(&locations)?;
        Ok(Self {
            problem: problem.without_loads(),
            newton,
            reference_variance: vec![0.0; markers.len()],
            calibration_covariance: None,
            markers,
            locations,
            params,
            candidates,
            force_rows,
        })
    }

    /// The same sensor with each marker's bound position the mean of `counts[m]` measured
    /// frames (0: exact): the reference's noise is then common to every frame measured
    /// against it, and the forces' covariance includes it.
    pub fn with_reference_frames(mut self, counts: &[usize]) -> Self {
        assert_eq!(counts.len(), self.markers.len(), "one count per marker");
        self.reference_variance = (counts.iter())
            .map(|&n| if n == 0 { 0.0 } else { 1.0 / n as f64 })
            .collect();
        self
    }

    /// The same body (known loads included), markers, solver and parameters with other
    /// candidate locations (nothing is solved).
    pub fn with_locations(&self, locations: Vec<CandidateLocation>) -> MarkersResult<Self> {
        let (candidates, force_rows) = unknowns_of(&locations)?;
        Ok(Self {
            problem: self.problem.clone(),
            newton: self.newton.clone(),
            markers: self.markers.clone(),
            locations,
            params: self.params.clone(),
            reference_variance: self.reference_variance.clone(),
            calibration_covariance: self.calibration_covariance.clone(),
            candidates,
            force_rows,
        })
    }

    /// Number of force unknowns.
    pub fn unknowns(&self) -> usize {
        self.force_rows.len()
    }

    /// The force vector of each location from the unknowns: its candidates' loads summed.
    fn force_vectors(&self, lambda: &[f64]) -> Vec<[f64; 3]> {
        let loads = loads_of(&self.candidates, lambda);
        let mut k = 0;
        (self.locations.iter())
            .map(|l| {
                k += l.unknowns();
                total_force(&loads[k - l.unknowns()..k])
            })
            .collect()
    }

    /// The FE equilibrium under `lambda` (warm-started from `start`) and W_ef of the markers
    /// `visible` there, condensed on the held actuators (displacement-controlled cables,
    /// volume-controlled cavities): W_ef − W_ea W_aa⁻¹ W_af.
    pub fn linearise(
        &self,
        lambda: &[f64],
        visible: &[usize],
        start: Option<&Solution>,
    ) -> MarkersResult<(Solution, DMatrix<f64>)> {
        let loads = loads_of(&self.candidates, lambda);
        let mut solver = self.problem.solver()?.with_loads(loads)?;
        let sol = solver.solve_static_from(&self.newton, start)?;
        let x = &sol.positions;
        crate::inverse::linearise::factorize_loop_tangent(
            &mut solver,
            x,
            &sol.actuator_forces(),
            self.newton.tangent,
        )?;
        let mut rows: Vec<ConstraintRow> = visible
            .iter()
            .flat_map(|&m| self.markers[m].rows())
            .collect();
        let ne = rows.len();
        // Held actuators: displacement-controlled cables and volume-controlled cavities.
        let held = (self.problem.cables.iter())
            .filter(|c| matches!(c.control, CableControl::Displacement(_)))
            .map(|c| ConstraintRow::cable(c, x));
        let held_cavities = (self.problem.cavities.iter())
            .filter(|c| matches!(c.control, crate::fem::solve::CavityControl::Volume(_)))
            .map(|c| ConstraintRow::cavity(c, x));
        let before = rows.len();
        rows.extend(held.chain(held_cavities));
        let na = rows.len() - before;
        rows.extend(self.force_rows.iter().cloned());
        let n = self.unknowns();
        let zero = vec![0.0; solver.ndof()];
        let (cols, _) = solver.compliance_columns(&rows, x, &zero, ne)?;
        let mut w_ef = cols.view((0, na), (ne, n)).clone_owned();
        if na > 0 {
            let w_ea = cols.view((0, 0), (ne, na));
            let w_aa = cols.view((ne, 0), (na, na)).clone_owned();
            let w_af = cols.view((ne, na), (na, n));
            let inv = w_aa.try_inverse().ok_or_else(|| {
                crate::fem::FemError::Singular("W_aa of the held actuators is singular".into())
            })?;
            w_ef -= w_ea * inv * w_af;
        }
        Ok((sol, w_ef))
    }

    /// The forces of one frame from its measured marker positions (m, model frame; `None`:
    /// hidden), starting from the previous frame's estimate when given.
    pub fn solve_frame(
        &self,
        frame: u64,
        measured: &[Option<[f64; 3]>],
        previous: Option<&MarkerFrame>,
    ) -> MarkersResult<MarkerFrame> {
        self.solve_frames(frame, &[measured], previous)
    }

    /// The forces of `frame` from the marker positions of several frames taken to carry the
    /// same forces (thesis 4.4.2, Remark 2: results accumulated over frames), their rows
    /// stacked in one least squares: with independent marker noise, k frames divide the
    /// forces' σ by √k. `measured` holds one entry per marker for each frame, the last
    /// being `frame`'s; the hidden markers reported are the last frame's. Corollary 1 is
    /// checked on the distinct markers visible in any of them (a repeated row adds no rank).
    pub fn solve_frames(
        &self,
        frame: u64,
        measured: &[&[Option<[f64; 3]>]],
        previous: Option<&MarkerFrame>,
    ) -> MarkersResult<MarkerFrame> {
        assert!(!measured.is_empty(), "at least one frame");
        assert!(
            measured.iter().all(|m| m.len() == self.markers.len()),
            "one entry per marker"
        );
        let n = self.unknowns();
        let last = measured[measured.len() - 1];
        let visible: Vec<usize> = (0..self.markers.len())
            .filter(|&m| measured.iter().any(|f| f[m].is_some()))
            .collect();
        let stacked = stack_rows(measured, &visible);
        let hidden = (0..last.len()).filter(|&m| last[m].is_none()).collect();
        let mut out = unidentified(frame, 3 * visible.len(), n, hidden, stacked.len());
        if 3 * visible.len() < n || n == 0 {
            out.warnings.push(format!(
                "{} marker rows for {n} unknowns: the forces are not identifiable (Corollary 1 needs rows >= unknowns)",
                3 * visible.len()
            ));
            return Ok(out);
        }
        let Some(it) = self.iterate(&mut out, &stacked, &visible, previous)? else {
            return Ok(out);
        };
        if it.status == MarkersStatus::NotConverged {
            out.warnings.push(format!(
                "the forces did not settle in {} FE updates",
                self.params.max_updates
            ));
        }
        let noise = (it.start.as_ref()).map(|sol| self.noise_covariance(&stacked, &visible, sol));
        self.finish(&mut out, &it.w_ef, noise, it.lambda, it.status);
        out.solution = it.start;
        Ok(out)
    }

    /// The FE updates of one estimate on the `stacked` rows of the `visible` markers, from
    /// `previous` when it fits; `out` gets the updates done and the residual. `None` (with a
    /// warning in `out`) when W_ef is rank deficient.
    fn iterate(
        &self,
        out: &mut MarkerFrame,
        stacked: &[(usize, usize, f64)],
        visible: &[usize],
        previous: Option<&MarkerFrame>,
    ) -> MarkersResult<Option<Iterated>> {
        let (rows, n) = (stacked.len(), self.unknowns());
        let prev_ok = previous.filter(|p| p.intensities.len() == n);
        let mut lambda = prev_ok.map_or(vec![0.0; n], |p| p.intensities.clone());
        let mut start = prev_ok.and_then(|p| p.solution.clone());
        let mut last_rms = f64::NAN;
        let mut w_ef = DMatrix::zeros(rows, n);
        let mut status = MarkersStatus::NotConverged;
        for update in 0..self.params.max_updates {
            let (sol, w) = self.linearise(&lambda, visible, start.as_ref())?;
            let model: Vec<[f64; 3]> = (visible.iter())
                .map(|&m| self.markers[m].at.position(&sol.positions))
                .collect();
            w_ef = DMatrix::from_fn(rows, n, |i, k| {
                let (j, a, _) = stacked[i];
                w[(3 * j + a, k)]
            });
            let r = DVector::from_iterator(rows, stacked.iter().map(|&(j, a, t)| t - model[j][a]));
            let rms = (r.norm_squared() / rows as f64).sqrt();
            out.updates = update + 1;
            out.residual_rms = rms;
            let gram = w_ef.tr_mul(&w_ef);
            let Some(chol) = gram.cholesky() else {
                out.warnings
                    .push("W_ef is rank deficient: the forces are not identifiable".into());
                return Ok(None);
            };
            let step = chol.solve(&w_ef.tr_mul(&r));
            // The residual at this state is the one of `lambda`: a small step or a residual
            // that no longer changes means `lambda` is the answer.
            let settled = step.amax() <= self.params.force_tol
                || (rms - last_rms).abs() <= self.params.residual_tol * last_rms;
            start = Some(sol);
            if settled {
                status = MarkersStatus::Converged;
                break;
            }
            lambda
                .iter_mut()
                .zip(step.iter())
                .for_each(|(l, s)| *l += s);
            last_rms = rms;
        }
        Ok(Some(Iterated {
            lambda,
            w_ef,
            status,
            start,
        }))
    }

    /// The covariance of the stacked residual rows (m²): σ² on the diagonal for each
    /// measurement, plus the reference's share σ² v_m (I − n nᵀ) between all rows of
    /// marker m, in any stacked frame (the same reference enters them all), plus the
    /// calibration's offset when given. Only the reference's tangential noise stays:
    /// binding projects the measured reference on the surface (normal n at the FE state
    /// `sol`), which removes its normal part.
    fn noise_covariance(
        &self,
        stacked: &[(usize, usize, f64)],
        visible: &[usize],
        sol: &Solution,
    ) -> DMatrix<f64> {
        let s2 = self.params.sigma * self.params.sigma;
        let tangent: Vec<[[f64; 3]; 3]> = (visible.iter())
            .map(|&m| {
                let [a, b, c, _] = (self.markers[m].at.nodes).map(|v| Vec3::from(sol.positions[v]));
                let n = (b - a).cross(&(c - a)).normalize();
                let v = self.reference_variance[m];
                [0, 1, 2].map(|i| [0, 1, 2].map(|k| v * (f64::from(i == k) - n[i] * n[k])))
            })
            .collect();
        let rows = stacked.len();
        DMatrix::from_fn(rows, rows, |i, k| {
            let ((ji, ai, _), (jk, ak, _)) = (stacked[i], stacked[k]);
            let own = if i == k { 1.0 } else { 0.0 };
            let reference = if ji == jk { tangent[ji][ai][ak] } else { 0.0 };
            let calibration = (self.calibration_covariance.as_ref())
                .map_or(0.0, |c| c[(3 * visible[ji] + ai, 3 * visible[jk] + ak)]);
            s2 * (own + reference + calibration)
        })
    }

    /// Fills in the forces, their covariance and I_w from the last linearisation; `noise`
    /// is the rows' covariance (σ² I when not given).
    fn finish(
        &self,
        out: &mut MarkerFrame,
        w_ef: &DMatrix<f64>,
        noise: Option<DMatrix<f64>>,
        lambda: Vec<f64>,
        status: MarkersStatus,
    ) {
        let n = w_ef.ncols();
        let ident = lsq::identifiability(w_ef, n, IntensityParams::default().max_i_w);
        out.i_w = ident.i_w;
        let s2 = self.params.sigma * self.params.sigma;
        out.covariance = lsq::covariance_with(w_ef, |a| match &noise {
            Some(c) => Some(a * c * a.transpose()),
            None => Some(a * a.transpose() * s2),
        });
        out.sigma = match &out.covariance {
            Some(c) => (0..n).map(|k| c[(k, k)].max(0.0).sqrt()).collect(),
            None => lsq::gauss_markov_sigma(w_ef, self.params.sigma),
        };
        out.warnings.extend(ident.warning);
        out.forces = self.force_vectors(&lambda);
        out.intensities = lambda;
        out.status = status;
    }
}

/// The candidate forces of `locations`, in order, and their rows.
fn unknowns_of(
    locations: &[CandidateLocation],
) -> MarkersResult<(Vec<Candidate>, Vec<ConstraintRow>)> {
    let mut rows = Vec::new();
    for l in locations {
        rows.extend(l.rows()?);
    }
    let candidates = (locations.iter())
        .flat_map(|l| l.candidates.iter().copied())
        .collect();
    Ok((candidates, rows))
}

/// Where [`MarkerSensor::iterate`] ended.
struct Iterated {
    /// The unknowns λ_f (N).
    lambda: Vec<f64>,
    /// W_ef of the stacked rows at the last linearisation.
    w_ef: DMatrix<f64>,
    /// Whether the updates settled.
    status: MarkersStatus,
    /// The last FE state.
    start: Option<Solution>,
}

/// Each stacked row of the `measured` frames: (index into `visible`, axis, measured
/// coordinate), frame by frame, the visible markers' rows in order.
fn stack_rows(measured: &[&[Option<[f64; 3]>]], visible: &[usize]) -> Vec<(usize, usize, f64)> {
    (measured.iter())
        .flat_map(|f| {
            visible.iter().enumerate().flat_map(move |(j, &m)| {
                f[m].into_iter()
                    .flat_map(move |p| (0..3).map(move |a| (j, a, p[a])))
            })
        })
        .collect()
}

/// A frame not (yet) identified: no forces, I_w infinite, `rows` stacked rows of which
/// `marker_rows` distinct, `n` unknowns, the last frame's `hidden` markers.
fn unidentified(
    frame: u64,
    marker_rows: usize,
    n: usize,
    hidden: Vec<usize>,
    rows: usize,
) -> MarkerFrame {
    MarkerFrame {
        frame,
        status: MarkersStatus::NotIdentifiable {
            rows: marker_rows,
            unknowns: n,
        },
        forces: Vec::new(),
        intensities: Vec::new(),
        sigma: Vec::new(),
        covariance: None,
        i_w: f64::INFINITY,
        i_e: None,
        hidden,
        rows,
        unknowns: n,
        updates: 0,
        residual_rms: f64::NAN,
        warnings: Vec::new(),
        solution: None,
    }
}

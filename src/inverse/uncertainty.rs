//! How sure the forces are: the covariance of the features' offsets from the points they
//! share ([`SharedPoints`]), and the forces' covariance from it
//! ([`FrameEstimate::use_shared_point_uncertainty`]).

use super::sensing::FrameEstimate;
use crate::register::FeatureMatches;

impl FrameEstimate {
    /// Replaces the forces' Gauss-Markov σ (independent feature rows, the loop's) with their
    /// covariance from the points the rows share ([`SharedPoints`] of the loop's own
    /// [`FrameEstimate::matches`]):
    /// neighbouring features average some of the same points, so their offsets' errors are
    /// correlated, and near a contact, where the force is decided, they overlap most. A row
    /// whose residual is larger than its spread from the points' noise has its errors
    /// scaled up to its residual (the rows' correlations kept): what the noise model leaves
    /// out (e.g. a bias in how the points near the probe's edge are selected) shows in the
    /// residuals, and the σ then cover it. Each force's variance also gains the square of
    /// its last change in the loop ([`FrameEstimate::last_change`]): the linearisation's
    /// share. The forces do not change. Returns whether the σ were replaced (not when a
    /// match is the single nearest point or the forces are not identifiable).
    pub fn use_shared_point_uncertainty(&mut self) -> bool {
        let Some(shared) = SharedPoints::of(&self.matches) else {
            return false;
        };
        let e = &self.estimate;
        let Some(residuals) = self.problem.residuals(&e.actuator_forces, &e.forces) else {
            return false;
        };
        if residuals.len() != shared.rows.len() {
            return false;
        }
        // sqrt(max(1, r_i² / C_ii)): never below the noise model.
        let variances = shared.row_variances();
        let scale: Vec<f64> = residuals
            .iter()
            .zip(&variances)
            .map(|(r, v)| (r * r / v).max(1.0).sqrt())
            .map(|s| if s.is_finite() { s } else { 1.0 })
            .collect();
        let Some(cov) = self
            .problem
            .force_covariance_with(|a| shared.sandwich_scaled(a, &scale))
        else {
            return false;
        };
        self.set_force_covariance(cov);
        true
    }

    /// Takes `cov` (the rows' share of the forces' covariance) as the forces' covariance,
    /// with the linearisation's share added: the QP's answer still moved by the loop's
    /// last change from the previous state to this one, so it is known only to about that.
    /// The σ are its diagonal's square roots.
    pub(super) fn set_force_covariance(&mut self, mut cov: nalgebra::DMatrix<f64>) {
        if self.last_change.len() == cov.nrows() {
            for (i, d) in self.last_change.iter().enumerate() {
                cov[(i, i)] += d * d;
            }
        }
        self.estimate.force_sigma = (0..cov.nrows())
            .map(|i| cov[(i, i)].max(0.0).sqrt())
            .collect();
        self.estimate.force_covariance = Some(cov);
    }
}

/// The points behind the offsets of a registration's matched features (the rows of the
/// sensing loop's linearised problem, in its order): row i's offset is the mean of
/// its n_i points, so with independent points of variance s_p² the covariance of rows i
/// and j is Σ s_p² / (n_i n_j) over the points p they share. A point's s_p² is the largest
/// of its rows' spreads: a row's spread is its points' scatter about their offset, never
/// below the median over the rows. Depth noise sets the median; where a row's points
/// scatter more (a dented patch near a contact, a silhouette, grazing view) its offset
/// also depends more on which of them the camera happens to see (e.g. the part a probe
/// hides), and the spread says by how much.
#[derive(Clone, Debug)]
pub struct SharedPoints {
    /// Each row's points (indices into the registrar's finite points, ascending).
    pub rows: Vec<Vec<u32>>,
    /// Each row's per-point variance along the line (m²): its points' scatter, at least the
    /// median over the rows.
    pub row_spread: Vec<f64>,
}

impl SharedPoints {
    /// The points of `matches`. `None` unless the matches average
    /// ([`crate::register::RegisterParams::average`]) and some row has two points or more.
    pub fn of(matches: &FeatureMatches) -> Option<Self> {
        let own: Vec<Option<f64>> = (matches.points.iter())
            .map(|s| {
                let n = s.indices.len();
                (n > 1).then(|| s.scatter / (n - 1) as f64)
            })
            .collect();
        let mut variances: Vec<f64> = own.iter().flatten().copied().collect();
        if variances.is_empty() {
            return None;
        }
        let median = crate::math::median(&mut variances);
        let row_spread = own
            .into_iter()
            .map(|v| v.map_or(median, |v| v.max(median)))
            .collect();
        let rows = (matches.points.iter()).map(|s| s.indices.clone()).collect();
        Some(Self { rows, row_spread })
    }

    /// The covariance of the rows' offsets (m², rows x rows).
    pub fn matrix(&self) -> nalgebra::DMatrix<f64> {
        let m = self.rows.len();
        let mut c = nalgebra::DMatrix::<f64>::zeros(m, m);
        for (_, owners) in self.owners() {
            let s2 = self.point_spread(&owners);
            for &a in &owners {
                for &b in &owners {
                    c[(a, b)] += s2;
                }
            }
        }
        let n: Vec<f64> = self.rows.iter().map(|r| r.len() as f64).collect();
        for i in 0..m {
            for j in 0..m {
                c[(i, j)] /= n[i] * n[j];
            }
        }
        c
    }

    /// B C Bᵀ for the rows' covariance C ([`SharedPoints::matrix`]) and `b` (k x rows),
    /// without forming C: Σ_points s_p² v vᵀ, v = Σ over the rows holding the point of
    /// b's column / n_row.
    pub fn sandwich(&self, b: &nalgebra::DMatrix<f64>) -> Option<nalgebra::DMatrix<f64>> {
        self.sandwich_scaled(b, &vec![1.0; self.rows.len()])
    }

    /// Row i's variance in [`SharedPoints::matrix`] (m²).
    pub fn row_variance(&self, i: usize) -> f64 {
        self.row_variances()[i]
    }

    /// Every row's variance in [`SharedPoints::matrix`] (m²).
    pub fn row_variances(&self) -> Vec<f64> {
        let mut v = vec![0.0; self.rows.len()];
        for (_, owners) in self.owners() {
            let s2 = self.point_spread(&owners);
            for &i in &owners {
                v[i] += s2;
            }
        }
        for (v, r) in v.iter_mut().zip(&self.rows) {
            *v /= (r.len() * r.len()) as f64;
        }
        v
    }

    /// [`SharedPoints::sandwich`] with row i's errors scaled by `scale[i]`: B D C D Bᵀ, D =
    /// diag(scale), the rows' correlations unchanged. `None` when a length does not fit.
    pub fn sandwich_scaled(
        &self,
        b: &nalgebra::DMatrix<f64>,
        scale: &[f64],
    ) -> Option<nalgebra::DMatrix<f64>> {
        if b.ncols() != self.rows.len() || scale.len() != self.rows.len() {
            return None;
        }
        let k = b.nrows();
        let mut out = nalgebra::DMatrix::<f64>::zeros(k, k);
        let mut v = nalgebra::DVector::<f64>::zeros(k);
        for (_, owners) in self.owners() {
            v.fill(0.0);
            for &i in &owners {
                let w = scale[i] / self.rows[i].len() as f64;
                v.axpy(w, &b.column(i), 1.0);
            }
            out.ger(self.point_spread(&owners), &v, &v, 1.0);
        }
        Some(out)
    }

    /// The variance of a point held by rows `owners`: the largest of their spreads.
    fn point_spread(&self, owners: &[usize]) -> f64 {
        owners
            .iter()
            .map(|&i| self.row_spread[i])
            .fold(0.0, f64::max)
    }

    /// Each point used, with the rows holding it (ascending), in point order.
    fn owners(&self) -> Vec<(u32, Vec<usize>)> {
        let mut pairs: Vec<(u32, usize)> = self
            .rows
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.iter().map(move |&q| (q, i)))
            .collect();
        pairs.sort_unstable();
        let mut out: Vec<(u32, Vec<usize>)> = Vec::new();
        for (q, i) in pairs {
            match out.last_mut() {
                Some((p, rows)) if *p == q => rows.push(i),
                _ => out.push((q, vec![i])),
            }
        }
        out
    }
}

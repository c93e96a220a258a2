//! From an estimate to a reported force ([`ForceEstimate`]): the sum of its candidates'
//! forces, their covariance in the robot frame and the magnitude's σ, and the blending in
//! of the other locations that explain the frame nearly as well ([`LocationAlternative`]).

use super::ForceEstimate;
use crate::inverse::intensity::IntensityEstimate;
use crate::inverse::Candidate;
use crate::math::{dot, norm, sub, unit};
use serde::Serialize;

/// The candidates of one reported force: a seen contact's, or a declared force point's.
pub(super) struct Group {
    /// Where the location came from (`contact`, `force point <name>`).
    pub source: String,
    /// The seen contact's centroid (robot frame, m).
    pub seen_at: Option<[f64; 3]>,
    /// Contact points in the seen group.
    pub points: usize,
    /// The chosen surface node (seen contacts).
    pub node: Option<usize>,
    /// Its candidates (a range of the estimate's).
    pub range: std::ops::Range<usize>,
    /// Other locations that fit nearly as well.
    pub alternatives: Vec<LocationAlternative>,
}

/// Another surface node that explains a frame nearly as well as a contact's chosen one.
#[derive(Clone, Debug, Serialize)]
pub struct LocationAlternative {
    /// The surface node.
    pub node: usize,
    /// Its position where the choice was made (robot frame, m).
    pub location: [f64; 3],
    /// The contact's force were it there (N, robot frame): the estimate moved by what the
    /// swap changes in the choice's QP.
    pub force: [f64; 3],
    /// How much worse the frame fits with the contact there, in units of the noise
    /// ([`crate::inverse::Alternative::misfit`]); at most
    /// [`SenseParams::location_ambiguity`](super::SenseParams::location_ambiguity) reads
    /// "fits within the noise".
    pub misfit: f64,
}

impl LocationAlternative {
    /// Its weight against the chosen location's 1: the likelihood ratio exp(−misfit / 2).
    pub fn weight(&self) -> f64 {
        (-0.5 * self.misfit).exp()
    }
}

/// The force of group `g` in the estimate `e` of `cands` at node positions `positions`:
/// the sum of its candidates' forces, with its magnitude's σ and its covariance.
pub(super) fn force_estimate(
    g: &Group,
    e: &IntensityEstimate,
    cands: &[Candidate],
    positions: &[[f64; 3]],
) -> ForceEstimate {
    let f = force_of(&cands[g.range.clone()], &e.forces[g.range.clone()]);
    let mut var = 0.0;
    let magnitude = norm(f);
    // The components' (co)variance: the sandwich's when the estimate has it, else
    // the independent σ.
    let cov_kl = |k: usize, l: usize| match &e.force_covariance {
        Some(cov) if cov.nrows() == cands.len() => cov[(k, l)],
        _ if k == l => e.force_sigma.get(k).copied().unwrap_or(f64::NAN).powi(2),
        _ => 0.0,
    };
    // Magnitude sigma: that (co)variance projected on the force direction.
    let proj = |k: usize| {
        if magnitude > 0.0 {
            dot(unit(cands[k].direction), f) / magnitude
        } else {
            1.0
        }
    };
    // The same in the robot frame: Σ_kl u_k u_lᵀ cov_kl.
    let mut covariance = [[0.0; 3]; 3];
    for k in g.range.clone() {
        let uk = unit(cands[k].direction);
        for l in g.range.clone() {
            let ul = unit(cands[l].direction);
            let c = cov_kl(k, l);
            var += proj(k) * proj(l) * c;
            for (a, row) in covariance.iter_mut().enumerate() {
                for (b, v) in row.iter_mut().enumerate() {
                    *v += uk[a] * ul[b] * c;
                }
            }
        }
    }
    let var = var.max(0.0);
    let at = cands[g.range.start].at.position(positions);
    let mut out = ForceEstimate {
        source: g.source.clone(),
        seen_at: g.seen_at,
        contact_points: g.points,
        location: at,
        node: g.node,
        force: f,
        magnitude,
        sigma: var.sqrt(),
        sigma_max: largest_sigma(&covariance),
        covariance,
        location_sigma: g.seen_at.map(|_| 0.0),
        alternatives: Vec::new(),
    };
    out.blend(g.alternatives.clone());
    out
}

impl ForceEstimate {
    /// Takes in the locations that explain the frame nearly as well: the answer is then a
    /// mixture over them (weights [`LocationAlternative::weight`], the chosen location's
    /// 1), so the force's mean squared error about the reported force gains
    /// Σ w_k ΔF_k ΔF_kᵀ / Σ w (ΔF_k the force's change were the contact at k), and the
    /// location's the same of the distances.
    pub(super) fn blend(&mut self, alternatives: Vec<LocationAlternative>) {
        if alternatives.is_empty() {
            return;
        }
        let total: f64 = 1.0 + alternatives.iter().map(|a| a.weight()).sum::<f64>();
        let mut spread = 0.0;
        for a in &alternatives {
            let w = a.weight() / total;
            let df = sub(a.force, self.force);
            let dx = sub(a.location, self.location);
            spread += w * dot(dx, dx);
            for (r, row) in self.covariance.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v += w * df[r] * df[c];
                }
            }
        }
        let c = &self.covariance;
        let u = if self.magnitude > 0.0 {
            self.force.map(|v| v / self.magnitude)
        } else {
            [1.0, 0.0, 0.0]
        };
        let var: f64 = (0..3)
            .flat_map(|r| (0..3).map(move |q| (r, q)))
            .map(|(r, q)| u[r] * c[r][q] * u[q])
            .sum();
        self.sigma = var.max(0.0).sqrt();
        self.sigma_max = largest_sigma(c);
        self.location_sigma = Some(spread.sqrt());
        self.alternatives = alternatives;
    }
}

/// The force of candidates `cands` with intensities `forces` (N).
pub(super) fn force_of(cands: &[Candidate], forces: &[f64]) -> [f64; 3] {
    let mut f = [0.0; 3];
    for (c, l) in cands.iter().zip(forces) {
        let d = unit(c.direction);
        for q in 0..3 {
            f[q] += l * d[q];
        }
    }
    f
}

/// The square root of a symmetric 3x3 covariance's largest eigenvalue (0 for a negative
/// one from rounding), NaN when an entry is not finite.
pub fn largest_sigma(covariance: &[[f64; 3]; 3]) -> f64 {
    if covariance.iter().flatten().any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let m = nalgebra::Matrix3::from_fn(|r, c| 0.5 * (covariance[r][c] + covariance[c][r]));
    m.symmetric_eigenvalues().max().max(0.0).sqrt()
}

#[cfg(test)]
pub(super) mod tests {
    use super::{largest_sigma, ForceEstimate, LocationAlternative};

    pub(crate) fn force(seen: bool, magnitude: f64, sigma_max: f64) -> ForceEstimate {
        ForceEstimate {
            source: if seen { "contact" } else { "force point tip" }.into(),
            seen_at: seen.then_some([0.0; 3]),
            contact_points: 10,
            location: [0.0; 3],
            node: None,
            force: [magnitude, 0.0, 0.0],
            magnitude,
            sigma: sigma_max,
            sigma_max,
            covariance: [[sigma_max * sigma_max, 0.0, 0.0], [0.0; 3], [0.0; 3]],
            location_sigma: seen.then_some(0.0),
            alternatives: Vec::new(),
        }
    }

    pub(crate) fn alternative(
        node: usize,
        dx: f64,
        force: [f64; 3],
        misfit: f64,
    ) -> LocationAlternative {
        LocationAlternative {
            node,
            location: [dx, 0.0, 0.0],
            force,
            misfit,
        }
    }

    #[test]
    fn an_equally_good_location_adds_half_its_force_change_squared_to_the_variance() {
        let mut f = force(true, 1.0, 0.01);
        // Misfit 0: weight 1 against the chosen location's 1.
        f.blend(vec![alternative(7, 0.008, [1.2, 0.0, 0.0], 0.0)]);
        let var = 0.01f64.powi(2) + 0.5 * 0.2f64.powi(2);
        assert!((f.covariance[0][0] - var).abs() < 1e-15);
        assert!((f.sigma - var.sqrt()).abs() < 1e-15);
        assert!((f.sigma_max - var.sqrt()).abs() < 1e-15);
        assert!((f.location_sigma.unwrap() - (0.5f64 * 0.008 * 0.008).sqrt()).abs() < 1e-15);
        assert_eq!(f.alternatives.len(), 1);
    }

    #[test]
    fn a_location_that_fits_far_worse_than_the_noise_barely_widens_the_sigma() {
        let mut f = force(true, 1.0, 0.01);
        f.blend(vec![alternative(7, 0.008, [0.0, 1.0, 0.0], 40.0)]);
        assert!(f.sigma_max < 0.01 * (1.0 + 1e-4), "{}", f.sigma_max);
        assert!(f.location_sigma.unwrap() < 1e-6);
    }

    #[test]
    fn the_largest_sigma_of_a_rotated_covariance_is_its_longest_axis() {
        // diag(1, 4, 9) turned 30° about z: the axes keep their lengths.
        let (s, c) = (0.5f64, 3f64.sqrt() / 2.0);
        let r = nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let m = r
            * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 4.0, 9.0))
            * r.transpose();
        let cov = [0, 1, 2].map(|i| [0, 1, 2].map(|j| m[(i, j)]));
        assert!((largest_sigma(&cov) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_covariance_with_a_nan_has_no_largest_sigma() {
        let mut cov = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        cov[1][2] = f64::NAN;
        assert!(largest_sigma(&cov).is_nan());
        assert_eq!(largest_sigma(&[[0.0; 3]; 3]), 0.0);
    }
}

//! From an estimate to a reported force ([`ForceEstimate`]): the sum of its candidates'
//! forces, their covariance in the robot frame and the magnitude's σ, and the blending in
//! of the other locations that explain the frame nearly as well ([`LocationAlternative`]).

use super::ForceEstimate;
use crate::inverse::intensity::IntensityEstimate;
use crate::inverse::{loads_of, total_force, Candidate};
use crate::math::{dot, norm, sub};
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
    let r = g.range.clone();
    let f = force_of(&cands[r.clone()], &e.forces[r.clone()]);
    // The candidates' (co)variance: the sandwich's when the estimate has it, else the
    // independent σ.
    let cov = |k: usize, l: usize| {
        let (k, l) = (r.start + k, r.start + l);
        match &e.force_covariance {
            Some(c) if c.nrows() == cands.len() => c[(k, l)],
            _ if k == l => e.force_sigma.get(k).copied().unwrap_or(f64::NAN).powi(2),
            _ => 0.0,
        }
    };
    let axes: Vec<[f64; 3]> = cands[r.clone()].iter().map(|c| c.direction).collect();
    let covariance = in_robot_frame(&axes, &cov);
    let mut out = ForceEstimate {
        source: g.source.clone(),
        seen_at: g.seen_at,
        contact_points: g.points,
        location: cands[r.start].at.position(positions),
        node: g.node,
        force: f,
        magnitude: norm(f),
        sigma: magnitude_sigma(f, &axes, &cov),
        sigma_max: largest_sigma(&covariance),
        covariance,
        location_sigma: g.seen_at.map(|_| 0.0),
        alternatives: Vec::new(),
    };
    out.blend(g.alternatives.clone());
    out
}

/// The robot frame's axes x, y, z.
const ROBOT_AXES: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The covariance in the robot frame of a force whose components along the unit `axes`
/// have covariance `cov(k, l)`: Σ_kl a_k a_lᵀ cov(k, l).
fn in_robot_frame(axes: &[[f64; 3]], cov: &dyn Fn(usize, usize) -> f64) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (k, ak) in axes.iter().enumerate() {
        for (l, al) in axes.iter().enumerate() {
            let c = cov(k, l);
            for (a, row) in out.iter_mut().enumerate() {
                for (b, v) in row.iter_mut().enumerate() {
                    *v += ak[a] * al[b] * c;
                }
            }
        }
    }
    out
}

/// The one-sigma of the magnitude of `force`, whose components along the unit `axes` (the
/// candidates' directions, or [`ROBOT_AXES`]) have covariance `cov(k, l)`: that covariance
/// projected on the force's direction, Σ_kl p_k p_l cov(k, l) with p_k = a_k·F / |F|. A
/// zero force has no direction, so its magnitude is taken as uncertain as the least
/// certain direction: the largest σ over all of them ([`largest_sigma`]).
pub(super) fn magnitude_sigma(
    force: [f64; 3],
    axes: &[[f64; 3]],
    cov: &dyn Fn(usize, usize) -> f64,
) -> f64 {
    let magnitude = norm(force);
    if magnitude > 0.0 {
        let p: Vec<f64> = axes.iter().map(|a| dot(*a, force) / magnitude).collect();
        let mut var = 0.0;
        for (k, pk) in p.iter().enumerate() {
            for (l, pl) in p.iter().enumerate() {
                var += pk * pl * cov(k, l);
            }
        }
        return var.max(0.0).sqrt();
    }
    largest_sigma(&in_robot_frame(axes, cov))
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
        self.sigma = magnitude_sigma(self.force, &ROBOT_AXES, &|r, q| c[r][q]);
        self.sigma_max = largest_sigma(c);
        self.location_sigma = Some(spread.sqrt());
        self.alternatives = alternatives;
    }
}

impl ForceEstimate {
    /// Takes in a reference's noise and a stiffness known to a relative one-sigma
    /// `relative`: the covariance is scaled by `reference` (1 + 1/N for a reference of N
    /// frames, whose noise enters every frame sensed against it: its share is 1/N of a
    /// frame's, as for the markers' reference), and, as the stiffness scales the whole
    /// force, gains relative² F Fᵀ. `(1, 0)` changes nothing.
    pub(super) fn add_model_error(&mut self, reference: f64, relative: f64) {
        if reference == 1.0 && relative <= 0.0 {
            return;
        }
        let f = self.force;
        for (r, row) in self.covariance.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = reference * *v + relative * relative * f[r] * f[c];
            }
        }
        let c = &self.covariance;
        self.sigma = magnitude_sigma(self.force, &ROBOT_AXES, &|r, q| c[r][q]);
        self.sigma_max = largest_sigma(c);
    }
}

/// The force of candidates `cands` with intensities `forces` (N).
pub(super) fn force_of(cands: &[Candidate], forces: &[f64]) -> [f64; 3] {
    total_force(&loads_of(cands, forces))
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
    use super::{
        in_robot_frame, largest_sigma, magnitude_sigma, ForceEstimate, LocationAlternative,
        ROBOT_AXES,
    };

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
    fn the_magnitude_sigma_is_the_same_from_the_candidates_and_from_the_robot_frame() {
        // A force along two oblique unit axes with correlated components.
        let s = 0.5f64.sqrt();
        let axes = [[s, s, 0.0], [0.0, s, s]];
        let cov = |k: usize, l: usize| [[4e-4, 1e-4], [1e-4, 9e-4]][k][l];
        let force = [0.3 * s, 0.3 * s + 0.1 * s, 0.1 * s];
        let robot = in_robot_frame(&axes, &cov);
        let from_axes = magnitude_sigma(force, &axes, &cov);
        let from_robot = magnitude_sigma(force, &ROBOT_AXES, &|r, q| robot[r][q]);
        assert!(
            (from_axes - from_robot).abs() < 1e-15,
            "{from_axes} {from_robot}"
        );
    }

    #[test]
    fn a_zero_force_has_the_largest_sigma_as_its_magnitude_sigma_in_any_basis() {
        let cov = [[1e-4, 0.0, 0.0], [0.0, 4e-4, 0.0], [0.0, 0.0, 9e-6]];
        let sigma = magnitude_sigma([0.0; 3], &ROBOT_AXES, &|r, q| cov[r][q]);
        assert!((sigma - 0.02).abs() < 1e-15, "{sigma}");
        // The same covariance along the axes taken in another order.
        let axes = [ROBOT_AXES[1], ROBOT_AXES[2], ROBOT_AXES[0]];
        let turned = |k: usize, l: usize| cov[(k + 1) % 3][(l + 1) % 3];
        assert!((magnitude_sigma([0.0; 3], &axes, &turned) - 0.02).abs() < 1e-15);
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

//! Tunables of the sensing chain ([`SenseParams`]).

use crate::contact::ContactParams;
use crate::inverse::FrameParams;
use crate::register::FeatureParams;
use crate::segment::robot_color::RobotColorModel;

/// The 95% quantile of χ² with 3 degrees of freedom (7.8147): how far an equally good
/// location of a 3-D force may fit worse ([`SenseParams::location_ambiguity`]), and the
/// squared Mahalanobis distance inside a 3-D Gaussian's 95% ellipsoid ([`super::score`]).
pub const CHI2_3DOF_95: f64 = 7.815;

/// Parameters of the sensing chain.
#[derive(Clone, Debug)]
pub struct SenseParams {
    /// Which colours are the robot's (default: the scene generator's green, hue within 25°).
    pub color: RobotColorModel,
    /// Margin around the model's bounding box kept by the crop (m, 0.03).
    pub crop_margin: f64,
    /// Points lower than the model's lowest point plus this are the table (m, 0.004).
    pub table_clearance: f64,
    /// Contact detection: more than 3 robot neighbours within 12 mm, groups 5 mm apart of
    /// 10-2000 points.
    // The thesis used 4 mm with its camera closer; see docs/sensing.md for why 12 mm.
    pub contact: ContactParams,
    /// Feature points: 300 on flat patches the camera sees, each at least 5 mm inside its
    /// patch (`flat_radius`, equal to the registration's `d_m`).
    pub features: FeatureParams,
    /// Registration, intensity QP and FE updates.
    pub frame: FrameParams,
    /// Surface nodes within this of a seen contact's centroid are its location options (m,
    /// 0.015).
    // The probe hides the touched point, so the touching points' centroid sits ~8 mm off.
    pub location_radius: f64,
    /// At most this many options per contact, nearest first (16).
    pub location_options: usize,
    /// Another location whose misfit (the fit's loss in units of the noise,
    /// [`LocationAlternative::misfit`](super::LocationAlternative::misfit)) is at most this
    /// "fits within the noise": the force gets a warning ([`CHI2_3DOF_95`], χ² of 3
    /// unknowns at 95%). Up to twice this, alternatives are reported and widen the σ.
    pub location_ambiguity: f64,
    /// FE updates of the preview, the first estimate of an untracked frame with seen
    /// contacts, after which the choice is made again (2; 0 or 1: no preview).
    pub preview_updates: usize,
    /// How many times the choice is made again at an estimated state (2); each time it
    /// picks other locations, they are estimated.
    pub location_checks: usize,
    /// Pool features within this of a seen contact join the frame's features (m, 0.03; 0:
    /// off).
    pub local_features_radius: f64,
    /// Size of the dense feature pool (600).
    pub local_feature_pool: usize,
    /// A tracked frame ([`Sensor::track_frames`](super::Sensor::track_frames)) starts from
    /// the previous one's estimate when each contact is within this of where it was (m,
    /// 0.005).
    pub track_radius: f64,
    /// Largest number of option combinations tried exhaustively (400); beyond, coordinate
    /// descent.
    pub max_combinations: usize,
    /// A frame with more seen contacts than this is not estimated (6):
    /// [`FrameStatus::TooManyContacts`](super::FrameStatus::TooManyContacts).
    // Dozens of contacts come from depth and colour that do not match, not from touches.
    pub max_contacts: usize,
    /// At a seen contact, estimate a 3-D force (inward normal, pushing only, plus two
    /// tangential components) instead of a normal force alone (true).
    pub three_d: bool,
    /// A frame is unreliable when its residual's robust spread exceeds this many times the
    /// expected noise: the dense rows' own, else `frame.intensity.sensor_sigma` (1.5).
    pub poor_fit: f64,
    /// A densely registered frame is unreliable when more than this many surface patches
    /// sit off the model beyond its noise ([`NoiseFit::patches_off`]) (3): noise alone
    /// leaves none, a depth step now and then one, a dent the model misses dozens.
    ///
    /// [`NoiseFit::patches_off`]: crate::inverse::dense::NoiseFit::patches_off
    pub misfit_patches: usize,
    /// Warn that a force's direction (or magnitude) is uncertain when its largest one-sigma
    /// ([`ForceEstimate::sigma_max`](super::ForceEstimate::sigma_max)) exceeds this fraction
    /// of its magnitude (0.025).
    pub direction_warning: f64,
    /// What the FE surface is registered against ([`Registration::Auto`]: every robot
    /// point for a frame with one seen contact, the features otherwise).
    pub registration: Registration,
    /// The dense rows' tunables (their noise model among them).
    pub dense_rows: crate::inverse::DenseParams,
    /// Relative one-sigma of the model's stiffness (0: none): each force's covariance gains
    /// (model_error·F)(model_error·F)ᵀ, as a modulus off by that fraction scales every
    /// force. [`Sensor::calibrate_modulus`](super::Sensor::calibrate_modulus) sets it.
    pub model_error: f64,
}

impl Default for SenseParams {
    fn default() -> Self {
        let mut frame = FrameParams::default();
        // Each matched offset averages the points within 5 mm of the normal line: ~100 at
        // the D415-like 0.8 mm spacing at 0.5 m, of 0.5 mm depth noise and 1 mm depth steps
        // (0.29 mm) each: 0.58 mm / 10 ≈ 0.05 mm.
        let d_m = 0.005;
        frame.register.d_m = d_m;
        frame.intensity.sensor_sigma = 5e-5;
        frame.max_updates = 20;
        // 1 mN: far below the 5% of the lightest load (0.26 N) the estimates are held to.
        frame.force_tol = 1e-3;
        Self {
            color: RobotColorModel::default(),
            crop_margin: 0.03,
            table_clearance: 0.004,
            contact: ContactParams {
                radius_m: 0.012,
                ..ContactParams::default()
            },
            features: FeatureParams {
                count: 300,
                flat_radius: d_m,
                ..FeatureParams::default()
            },
            frame,
            three_d: true,
            poor_fit: 1.5,
            misfit_patches: 3,
            direction_warning: 0.025,
            location_radius: 0.015,
            location_options: 16,
            // 7.81 before it was the constant `score` uses: no bundled recording has an
            // alternative location with a misfit near either threshold (the least is
            // 19.7, beyond twice this), so their answers are the same.
            location_ambiguity: CHI2_3DOF_95,
            preview_updates: 2,
            location_checks: 2,
            max_combinations: 400,
            max_contacts: 6,
            local_features_radius: 0.03,
            local_feature_pool: 600,
            track_radius: 0.005,
            registration: Registration::Auto,
            dense_rows: crate::inverse::DenseParams::default(),
            model_error: 0.0,
        }
    }
}

impl SenseParams {
    /// The defaults with the options `softsense sense` (and `batch`, and the Python
    /// `Sensor`) expose: the registration, the robot's colour, and where given the most
    /// contacts a frame may have and the number of feature points.
    pub fn with_options(
        registration: Registration,
        robot_color: [u8; 3],
        max_contacts: Option<usize>,
        features: Option<usize>,
    ) -> Self {
        let mut params = Self {
            registration,
            color: RobotColorModel::with_reference(robot_color),
            ..Self::default()
        };
        if let Some(n) = max_contacts {
            params.max_contacts = n;
        }
        if let Some(n) = features {
            params.features.count = n;
        }
        params
    }

    /// The defaults with dense registration for every frame ([`Registration::Dense`]).
    pub fn dense() -> Self {
        Self {
            registration: Registration::Dense,
            ..Self::default()
        }
    }

    /// The defaults with the feature registration for every frame
    /// ([`Registration::Features`]).
    pub fn features() -> Self {
        Self {
            registration: Registration::Features,
            ..Self::default()
        }
    }
}

/// What a frame's deformed FE surface is registered against.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Registration {
    /// Dense for a frame with one seen contact, and with several once a reference is
    /// taken; features otherwise. On the development sweeps dense located more single
    /// probes (83-90% against 59-66%) but fewer of two probes; after a reference, dense
    /// put more two-probe loads within 5% (28% against 12% with the body the model, 40%
    /// against 28% with its modulus off, one camera; 58% against 40% with two). The tip
    /// weights (no contact) are held by the features.
    #[default]
    Auto,
    /// The feature points (300-600 flat patches, each the mean of a 5 mm disc of points).
    Features,
    /// Every (subsampled) robot point against the FE surface ([`crate::inverse::dense`]).
    Dense,
}

impl Registration {
    /// Whether a frame with `contacts` seen contacts is registered densely, `referenced`
    /// when the sensor has taken a reference from unloaded frames.
    pub fn is_dense(self, contacts: usize, referenced: bool) -> bool {
        match self {
            Self::Auto => contacts == 1 || (referenced && contacts > 1),
            Self::Features => false,
            Self::Dense => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Registration;

    #[test]
    fn auto_registers_several_contacts_densely_only_after_a_reference() {
        let auto = Registration::Auto;
        assert!(!auto.is_dense(0, false) && !auto.is_dense(0, true));
        assert!(auto.is_dense(1, false) && auto.is_dense(1, true));
        assert!(!auto.is_dense(2, false) && auto.is_dense(2, true));
        assert!(!Registration::Features.is_dense(1, true));
        assert!(Registration::Dense.is_dense(0, false));
    }
}

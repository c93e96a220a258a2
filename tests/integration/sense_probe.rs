//! `sense` on the generated probe scenes (sensor noise on): a probe pushing on the robot's
//! side at 5 random places (clouds/scenes/probe_side), and two probes at once
//! (clouds/scenes/two_probes). The location is chosen by the data among the surface nodes
//! near each seen contact; the force is 3-D (pushing normal + two tangential components).
use softsense::fem::model::Model;
use softsense::scene::camera::CameraSpec;
use softsense::scene::sensor::SensorModel;
use softsense::sense::{
    compare, FrameReport, FrameStatus, LoadError, Recording, SenseParams, Sensor,
};
use std::path::Path;

use crate::common::{bundled, sense_generated};

fn run(scene: &str, params: SenseParams) -> Vec<(usize, LoadError)> {
    let (rec, sensor) = bundled(scene, params);
    let mut out = Vec::new();
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        for e in compare(&report, rec.truth_of(frame).unwrap()) {
            eprintln!(
                "{scene} frame {frame}: {:?}, location error {:.1} mm, 3-D force error {:.1}%",
                report.status,
                1e3 * e.location_error,
                100.0 * e.force_error
            );
            out.push((frame, e));
        }
    }
    out
}

fn within(errors: &[(usize, LoadError)]) -> bool {
    errors
        .iter()
        .all(|(_, e)| e.location_error <= 0.005 && e.force_error <= 0.05)
}

#[test]
fn every_frame_of_the_probe_scenes_gets_a_report_matched_to_its_truth() {
    // Runs the whole chain on 8 frames with 11 loads; errors are printed (see the ignored
    // acceptance tests below for the targets).
    let a = run("probe_side", SenseParams::default());
    let b = run("two_probes", SenseParams::default());
    assert_eq!((a.len(), b.len()), (5, 6));
    let located = a
        .iter()
        .chain(&b)
        .filter(|(_, e)| e.location_error <= 0.005)
        .count();
    eprintln!("{located} of 11 loads located within 5 mm");
    assert!(located > 0, "no load located at all");
}

/// Issue 6's acceptance point, with the feature registration it was met with; the
/// default registers these one-contact frames densely (see the dense test below).
#[test]
fn a_probe_at_five_random_places_is_located_within_five_mm_and_five_percent() {
    assert!(within(&run("probe_side", SenseParams::features())));
}

/// A known miss (docs/accuracy.md, "Known misses"): the target is every load within 5 mm
/// and 5%; measured at 640x480, 5 of 6 (all 6 located within 0.3 mm; frame 0's first
/// probe is 8.7% off, its tangential part). This holds what is reached; the same loads
/// seen at 1280x720 meet the target (the next test).
#[test]
fn two_simultaneous_probes_at_640x480_locate_all_six_loads_and_size_five_within_five_percent() {
    let errors = run("two_probes", SenseParams::default());
    assert_eq!(errors.len(), 6);
    let located = errors.iter().filter(|(_, e)| e.location_error <= 0.005);
    assert_eq!(located.count(), 6, "{errors:?}");
    let sized = errors.iter().filter(|e| within(std::slice::from_ref(e)));
    assert!(sized.count() >= 5, "{errors:?}");
}

/// The bundled two-probe scene's loads and noise draw (`clouds/scenes/two_probes.toml`,
/// seed 12), seen by the same camera at its 1280x720 stream (`CameraSpec::d415_1280x720`:
/// about 2.25 times the pixels on each patch), with that stream's depth noise (the same
/// disparity noise at 1.5 times the focal length, `SensorModel::for_camera`: two thirds of
/// the 640x480 σ) and a 0.1 mm depth unit, generated here. Measured: within 0.1 mm and
/// 0.1-2.1% (the 640x480 frames: 1.0-8.7%, see the ignored test above). Over nine noise
/// draws of the same loads (seeds 12-20): 54 of 54 loads within 5% (max 4.7%); with the
/// default 1 mm depth unit 53 of 54, this draw's worst at 4.996%; at 640x480, 42 of 54.
/// Two-probe frames paired from other places: 64 of 80 loads within 5% (the README's
/// "Camera resolution" has every set and setting).
#[test]
fn two_simultaneous_probes_seen_at_1280x720_are_both_found_within_five_percent() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = std::fs::read_to_string(root.join("clouds/scenes/two_probes.toml")).unwrap();
    // `generated_recording` writes its own (absolute) model path.
    // It also sets the 640x480 stream's depth noise, replaced here.
    let camera = CameraSpec::d415_1280x720();
    let depth_k = SensorModel::for_camera(&camera).depth_k;
    let mut replaced = 0;
    let mut body: String = scene
        .lines()
        .filter(|l| !l.starts_with("model"))
        .map(|l| {
            if l.starts_with("depth_k") {
                replaced += 1;
                format!("depth_k = {depth_k}\ndepth_unit = 0.0001\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert_eq!(replaced, 1, "the scene file sets depth_k once");
    body += "\n[camera]\n";
    body += &toml::to_string(&camera).unwrap();
    let (_dir, rec) = crate::common::generated_recording(&body);
    assert_eq!(rec.camera.intrinsics.width, 1280);
    let model = Model::load(&rec.model_path().unwrap(), None).unwrap();
    let sensor = Sensor::new(
        model,
        rec.robot_from_camera.unwrap(),
        SenseParams::default(),
    );
    let mut errors = Vec::new();
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        assert!(report.reliable, "frame {frame}: {:?}", report.warnings);
        for e in compare(&report, rec.truth_of(frame).unwrap()) {
            eprintln!(
                "1280x720 frame {frame}: location error {:.1} mm, 3-D force error {:.1}%",
                1e3 * e.location_error,
                100.0 * e.force_error
            );
            errors.push((frame, e));
        }
    }
    assert_eq!(errors.len(), 6);
    assert!(within(&errors));
}

#[test]
fn every_frame_of_the_bundled_probe_scenes_passes_the_fit_checks() {
    for scene in ["probe_side", "two_probes"] {
        let (rec, sensor) = bundled(scene, SenseParams::default());
        for &frame in &rec.frames {
            let obs = sensor.observe(&rec, frame).unwrap();
            let r = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
            assert!(
                r.reliable,
                "{scene} frame {frame}: {:?}, warnings {:?}",
                r.status, r.warnings
            );
        }
    }
}

// A held-out probe place (`make_probe_scenes --held-out 303 8`, frame 1): the south leg,
// pushed with 0.77 N. The first intensity QP, linearised at the unloaded state, asks for
// more than that, which the FE model cannot follow in one Newton solve. (Until the location
// choice linearised on Newton's matrix, the place used here was the west leg's tip of
// held-out 404, frame 3; the choice now picks another first node there, whose loop needs
// no halving.)
const LEG_PLACE: [f64; 3] = [0.0132, -0.1012, 0.05833];
const LEG_FORCE: [f64; 3] = [-0.3415, 0.5311, -0.4410];

#[test]
fn a_force_step_the_fe_model_cannot_follow_is_halved_and_the_frame_is_sensed() {
    // The frame gets an estimate, with its fit checks (in the held-out scene this place
    // came out 3.6% off and reliable, in this one-frame scene 4.0%).
    // The feature registration: the dense rows follow this step without halving.
    let (report, errors) = sense_generated(303, LEG_PLACE, LEG_FORCE, SenseParams::features());
    eprintln!(
        "{:?}, reliable {}, {:?}, {errors:?}",
        report.status, report.reliable, report.warnings
    );
    assert!(
        matches!(report.status, FrameStatus::Sensed),
        "{:?}",
        report.status
    );
    assert_eq!(
        report.reliable,
        !report.warnings.iter().any(|w| w.starts_with("unreliable"))
    );
    assert!(report.halvings > 0, "no step was halved");
    // Without halving the estimate at the chosen place fails (the frame then fails, or
    // another location is tried): the test above exercises the halving.
    let mut params = SenseParams::features();
    params.frame.max_halvings = 0;
    let (report, _) = sense_generated(303, LEG_PLACE, LEG_FORCE, params);
    eprintln!(
        "without halving: {:?}, {:?}",
        report.status, report.warnings
    );
    assert!(
        matches!(report.status, FrameStatus::NotSolved(_))
            || report
                .warnings
                .iter()
                .any(|w| w.starts_with("contact location") && w.contains("could not be estimated")),
        "{:?}, {:?}",
        report.status,
        report.warnings
    );
}

#[test]
fn a_frame_the_model_cannot_explain_is_sensed_but_flagged_unreliable() {
    // A probe the contact detector does not see (its radius shrunk to 0.1 mm): the model's
    // declared force points (on the top) cannot explain a dent in the side, and the report
    // must say so. The same frame with the detector on passes the checks (the test above).
    let mut params = SenseParams::default();
    params.contact.radius_m = 1e-4;
    let (rec, sensor) = bundled("probe_side", params);
    let obs = sensor.observe(&rec, 1).unwrap();
    let report = sensor.sense(1, &obs, rec.inputs_of(1).as_ref());
    eprintln!(
        "{:?}, robust residual {:.3} mm, {:?}",
        report.status,
        report.residual_robust * 1e3,
        report.warnings
    );
    assert!(matches!(report.status, FrameStatus::Sensed));
    assert!(!report.reliable);
    assert!(report.warnings.iter().any(|w| w.starts_with("unreliable")));
}

#[test]
fn feature_rows_that_average_shared_points_get_correlated_offsets() {
    use softsense::inverse::SharedPoints;
    use softsense::register::Registrar;
    let (rec, sensor) = bundled("probe_side", SenseParams::default());
    let obs = sensor.observe(&rec, 0).unwrap();
    let reg = Registrar::new(&obs.robot);
    let x = &sensor.model.problem.mesh.nodes_in_rest;
    let params = &sensor.params.frame.register;
    // The first feature twice: two rows of the very same points.
    let mut features = vec![sensor.features[0]];
    features.extend_from_slice(&sensor.features);
    let shared = SharedPoints::of(&reg.match_features(&features, x, params)).unwrap();
    let c = shared.matrix();
    let m = c.nrows();
    assert!(m > 200, "{m} visible rows");
    assert_eq!(c[(0, 1)], c[(0, 0)]);
    let mut sharing = 0;
    for i in 0..m {
        assert!(c[(i, i)] > 0.0);
        for j in 0..m {
            assert_eq!(c[(i, j)], c[(j, i)]);
            assert!(c[(i, j)] >= 0.0);
            assert!(c[(i, j)] <= (c[(i, i)] * c[(j, j)]).sqrt() * (1.0 + 1e-12));
            sharing += usize::from(i < j && c[(i, j)] > 0.0);
        }
    }
    // 300 features with 5 mm discs over the robot overlap somewhere.
    assert!(sharing > m, "{sharing} pairs of rows share points");
    // The sandwich without the matrix is the one with it.
    let b = nalgebra::DMatrix::from_fn(3, m, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
    let direct = &b * &c * b.transpose();
    let fast = shared.sandwich(&b).unwrap();
    assert!((&direct - &fast).amax() <= 1e-12 * fast.amax());
    // Rows scaled (as residuals beyond their noise scale them): B D C D Bᵀ.
    let scale: Vec<f64> = (0..m).map(|i| 1.0 + (i % 5) as f64).collect();
    let d = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale.clone()));
    let direct = &b * &d * &c * &d * b.transpose();
    let fast = shared.sandwich_scaled(&b, &scale).unwrap();
    assert!((&direct - &fast).amax() <= 1e-12 * fast.amax());
    assert!(shared.sandwich_scaled(&b, &scale[1..]).is_none());
    for i in 0..m {
        assert!((shared.row_variance(i) - c[(i, i)]).abs() <= 1e-15 * c[(i, i)]);
    }
    eprintln!("{m} rows, {sharing} pairs sharing points");
}

/// The bundled two-probe scene, and its frame 0 sensed.
fn two_probes_frame_0() -> (Recording, FrameReport) {
    let (rec, sensor) = bundled("two_probes", SenseParams::default());
    let obs = sensor.observe(&rec, 0).unwrap();
    let report = sensor.sense(0, &obs, rec.inputs_of(0).as_ref());
    (rec, report)
}

#[test]
fn each_force_carries_a_covariance_whose_spread_along_it_is_its_sigma() {
    let (_, report) = two_probes_frame_0();
    assert_eq!(report.forces.len(), 2);
    for f in &report.forces {
        let c = nalgebra::Matrix3::from_fn(|i, j| f.covariance[i][j]);
        assert!((c - c.transpose()).amax() <= 1e-15 * c.amax());
        let eig = c.symmetric_eigenvalues();
        assert!(eig.min() >= -1e-12 * eig.max(), "{eig}");
        let d = nalgebra::Vector3::from(f.force) / f.magnitude;
        let along = (d.transpose() * c * d)[0].sqrt();
        assert!(
            (along - f.sigma).abs() <= 1e-9 * f.sigma,
            "{along} vs {}",
            f.sigma
        );
        // Across the force the spread is larger: the tangential components are seen only
        // through the faces they tilt.
        assert!(eig.max().sqrt() > 2.0 * f.sigma, "{eig} vs σ {}", f.sigma);
        assert!((f.sigma_max - eig.max().sqrt()).abs() <= 1e-12 * f.sigma_max);
    }
}

#[test]
fn a_force_is_warned_about_exactly_when_its_largest_sigma_is_over_the_fraction() {
    let params = SenseParams::default();
    let fraction = params.direction_warning;
    let (rec, sensor) = bundled("probe_side", params);
    let (mut warned, mut quiet) = (0, 0);
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        for (i, f) in report.forces.iter().enumerate() {
            let expect = f.magnitude > 2.0 * f.sigma_max && f.sigma_max > fraction * f.magnitude;
            let prefix = format!("force {i}: ");
            let has = report.warnings.iter().any(|w| w.starts_with(&prefix));
            assert_eq!(has, expect, "frame {frame}: {f:?} {:?}", report.warnings);
            if has {
                warned += 1;
            } else {
                quiet += 1;
            }
        }
    }
    // probe_side has both kinds: frames 3 and 4 (7.9% and 4.8% of |F|) and the rest.
    assert!(warned > 0 && quiet > 0, "{warned} warned, {quiet} quiet");
}

#[test]
fn a_preview_whose_locations_stand_goes_on_to_the_forces_of_a_full_first_estimate() {
    // probe_side: on frames 3 and 4 the choice at the preview's state keeps the free
    // state's pick, so the preview's loop goes on (`Start::Onwards`) where a full first
    // estimate (no preview) runs from zero. Both stop at the loop's fixed point, each within
    // its stop rule (`force_tol`, or a quarter of a component's σ). (Frame 0 settles within
    // the preview; on frames 1 and 2 the choice moves at the preview's state, to the node
    // the check at the estimated state moves to without it.)
    let (rec, with) = bundled("probe_side", SenseParams::default());
    let (_, without) = bundled(
        "probe_side",
        SenseParams {
            preview_updates: 0,
            ..SenseParams::default()
        },
    );
    let params = &with.params.frame;
    let mut went_on = 0;
    for &frame in &rec.frames {
        let obs = with.observe(&rec, frame).unwrap();
        let a = with.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        let b = without.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        assert_eq!(a.forces.len(), 1, "frame {frame}");
        assert_eq!(a.forces.len(), b.forces.len(), "frame {frame}");
        let (fa, fb) = (&a.forces[0], &b.forces[0]);
        assert_eq!(fa.node, fb.node, "frame {frame}: another location");
        let tol = 2.0
            * params
                .force_tol
                .max(params.sigma_tol * fa.sigma.max(fb.sigma));
        let d = crate::common::largest_component_gap(fa.force, fb.force);
        eprintln!(
            "frame {frame}: node {:?}, {} / {} FE updates, forces {:.3} mN apart (tolerance {:.3} mN)",
            fa.node,
            a.updates,
            b.updates,
            1e3 * d,
            1e3 * tol
        );
        assert!(d <= tol, "frame {frame}: {d} N apart");
        if d > 0.0 {
            went_on += 1;
        }
    }
    // Not the same path: the frames whose preview went on stop elsewhere within the rule.
    assert!(went_on > 0, "no frame's preview went on");
}

#[test]
fn every_preview_length_and_number_of_checks_senses_a_probe_frame() {
    // probe_side frame 1, where the first choice moves (at the preview's state, or without
    // a preview at the estimated state): each setting, down to no preview and no check,
    // ends with an estimate, at the touched node once any later choice is allowed. (A
    // preview of one FE update is none: that update is at the unloaded state itself.) With
    // the feature registration, for which the first choice moves on this frame.
    let (rec, sensor) = bundled("probe_side", SenseParams::features());
    let obs = sensor.observe(&rec, 1).unwrap();
    let truth = rec.truth_of(1).unwrap();
    for (preview_updates, location_checks) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (3, 2)] {
        let params = SenseParams {
            preview_updates,
            location_checks,
            ..SenseParams::features()
        };
        let sensor = Sensor::new(sensor.model.clone(), rec.robot_from_camera.unwrap(), params);
        let report = sensor.sense(1, &obs, rec.inputs_of(1).as_ref());
        let e = &compare(&report, truth)[0];
        eprintln!(
            "preview {preview_updates}, checks {location_checks}: {:?}, node {:?}, {} FE updates, {:.1} mm, {:.1}%",
            report.status,
            report.forces.first().and_then(|f| f.node),
            report.updates,
            1e3 * e.location_error,
            100.0 * e.force_error
        );
        assert!(matches!(report.status, FrameStatus::Sensed));
        if preview_updates > 1 || location_checks > 0 {
            assert!(e.location_error < 0.005, "{e:?}");
        }
    }
}

/// The default on the bundled probe scene, which registers its one-contact frames densely
/// (every robot point against the FE surface): measured 0.0-0.6 mm and 0.3-6.8%
/// (features: 0.0-0.3 mm, 0.2-3.8%, on the camera direction they were tuned on). On random
/// scenes dense is the better of the two (docs/dense-registration.md).
#[test]
fn the_default_locates_each_bundled_probe_within_five_mm_and_ten_percent() {
    let (rec, sensor) = bundled("probe_side", SenseParams::default());
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref());
        assert_eq!(report.status, FrameStatus::Sensed, "frame {frame}");
        let errors = compare(&report, rec.truth_of(frame).unwrap());
        for e in &errors {
            assert!(e.estimate.is_some(), "frame {frame}: {e:?}");
            assert!(e.location_error <= 0.005, "frame {frame}: {e:?}");
            assert!(e.force_error <= 0.10, "frame {frame}: {e:?}");
        }
    }
}

/// Issue 50: the report carries the loop's own registration, the one its forces and σ came
/// from, so the pictures draw it rather than registering again: the frame's features (the
/// local ones near the contact included), matched at the final state exactly as a fresh
/// registration there matches them; a densely registered frame matches none.
#[test]
fn the_report_carries_the_registration_its_forces_came_from() {
    let (rec, sensor) = bundled("probe_side", SenseParams::features());
    let obs = sensor.observe(&rec, 0).unwrap();
    let report = sensor.sense(0, &obs, rec.inputs_of(0).as_ref());
    assert_eq!(report.status, FrameStatus::Sensed);
    let matches = &report.matches;
    assert_eq!(matches.features.len(), report.features);
    assert!(
        matches.features.len() > sensor.features.len(),
        "local features too"
    );
    let matched = matches.iter().filter(|(_, m)| m.is_some()).count();
    assert_eq!(matched, report.features_visible);
    assert_eq!(matches.points.len(), matched);
    let fresh = softsense::register::Registrar::new(&obs.robot).match_features(
        &matches.features,
        &report.positions,
        &sensor.params.frame.register,
    );
    let key = |m: &softsense::register::LineMatch| (m.offset.to_bits(), m.points);
    for ((_, a), (_, b)) in matches.iter().zip(fresh.iter()) {
        assert_eq!(a.map(key), b.map(key));
    }
    let (rec, sensor) = bundled("probe_side", SenseParams::dense());
    let obs = sensor.observe(&rec, 0).unwrap();
    let report = sensor.sense(0, &obs, rec.inputs_of(0).as_ref());
    assert_eq!(report.status, FrameStatus::Sensed);
    assert_eq!(report.matches.features.len(), report.features);
    assert!(report.matches.iter().all(|(_, m)| m.is_none()));
}

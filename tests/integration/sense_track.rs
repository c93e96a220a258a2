//! `sense --track` ([`Sensor::track_frames`]): a stream's frames starting from the one
//! before. On a press that grows frame by frame (clouds/scenes/probe_press), on two
//! probes, and on hanging weights (declared force points, clouds/scenes/tip_weight) every
//! frame after the first is tracked and agrees with the same frame sensed on its own;
//! where the contact jumps (clouds/scenes/probe_side) nothing is tracked and the answers
//! are the untracked ones, bit for bit.
use softsense::fem::model::Model;
use softsense::sense::{compare, FrameReport, FrameStatus, Recording, SenseParams, Sensor};
use std::path::Path;

fn open(scene: &str) -> (Recording, Sensor) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rec = Recording::open(&root.join("clouds/scenes").join(scene)).unwrap();
    let model = Model::load(&rec.model_path().unwrap(), None).unwrap();
    let sensor = Sensor::new(
        model,
        rec.robot_from_camera.unwrap(),
        SenseParams::default(),
    );
    (rec, sensor)
}

fn tracked(rec: &Recording, sensor: &Sensor) -> Vec<FrameReport> {
    let mut out = Vec::new();
    sensor
        .track_frames(rec, &rec.frames, |_, r| {
            out.push(r);
            Ok::<(), ()>(())
        })
        .unwrap();
    out
}

fn alone(rec: &Recording, sensor: &Sensor, frame: usize) -> FrameReport {
    let obs = sensor.observe(rec, frame).unwrap();
    sensor.sense(frame, &obs, rec.inputs_of(frame).as_ref())
}

#[test]
fn a_growing_press_is_tracked_and_agrees_with_its_frames_sensed_alone() {
    let (rec, sensor) = open("probe_press");
    let reports = tracked(&rec, &sensor);
    assert_eq!(reports.len(), 10);
    assert!(
        !reports[0].tracked,
        "the first frame has nothing to start from"
    );
    let params = &sensor.params.frame;
    for r in &reports {
        assert_eq!(r.status, FrameStatus::Sensed, "frame {}", r.frame);
        assert!(r.reliable, "frame {}: {:?}", r.frame, r.warnings);
        assert_eq!(r.forces.len(), 1);
        let solo = alone(&rec, &sensor, r.frame);
        let (a, b) = (&r.forces[0], &solo.forces[0]);
        assert_eq!(a.node, b.node, "frame {}: another location", r.frame);
        // Both are the loop's fixed point, each to within its stop rule (`force_tol`, or a
        // quarter of a component's σ), so they differ by at most twice that per component.
        let tol = 2.0 * params.force_tol.max(params.sigma_tol * a.sigma);
        let d = crate::common::largest_component_gap(a.force, b.force);
        eprintln!(
            "frame {}: tracked {}, {} FE updates (alone {}), |F| {:.4} N, differs by {:.2} mN (tolerance {:.2} mN)",
            r.frame,
            r.tracked,
            r.updates,
            solo.updates,
            a.magnitude,
            1e3 * d,
            1e3 * tol
        );
        assert!(d <= tol, "frame {}: {d} N apart", r.frame);
        for e in compare(r, rec.truth_of(r.frame).unwrap()) {
            assert!(
                e.location_error <= 0.005 && e.force_error <= 0.05,
                "frame {}: {e:?}",
                r.frame
            );
        }
    }
    let n = reports.iter().filter(|r| r.tracked).count();
    assert_eq!(
        n, 9,
        "every frame after the first starts from the one before"
    );
}

#[test]
fn contacts_that_jump_between_frames_are_sensed_as_untracked_frames_bit_for_bit() {
    // probe_side's probe moves by 8 mm or more between frames: more than `track_radius`.
    let (rec, sensor) = open("probe_side");
    for r in tracked(&rec, &sensor) {
        assert!(!r.tracked, "frame {} was tracked", r.frame);
        let solo = alone(&rec, &sensor, r.frame);
        let forces =
            |r: &FrameReport| -> Vec<[f64; 3]> { r.forces.iter().map(|f| f.force).collect() };
        assert_eq!(forces(&r), forces(&solo), "frame {}", r.frame);
        assert_eq!(r.residual_rms.to_bits(), solo.residual_rms.to_bits());
    }
}

#[test]
fn a_frame_resumed_from_its_own_end_keeps_its_forces() {
    // The previous frame's end is this frame's own: the loop's first QP is its last one
    // (no Newton step), so the forces settle at once, or one update later where the first
    // loop stopped on its predicted error (which needs two updates to measure).
    let (rec, sensor) = open("probe_press");
    let frame = rec.frames[4];
    let obs = sensor.observe(&rec, frame).unwrap();
    let inputs = rec.inputs_of(frame);
    let actuators = inputs.as_ref();
    let (first, track) = sensor.track(frame, &obs, actuators, None);
    let track = track.expect("a reliable frame with a contact leaves a track");
    assert_eq!(track.nodes(), &[first.forces[0].node.unwrap()]);
    let (again, _) = sensor.track(frame, &obs, actuators, Some(&track));
    assert!(again.tracked);
    assert!(again.updates <= 2, "resumed: {} FE updates", again.updates);
    let params = &sensor.params.frame;
    let (a, b) = (&again.forces[0], &first.forces[0]);
    let tol = 2.0 * params.force_tol.max(params.sigma_tol * b.sigma);
    for k in 0..3 {
        assert!(
            (a.force[k] - b.force[k]).abs() <= tol,
            "{:?} vs {:?}",
            a.force,
            b.force
        );
    }
}

#[test]
fn a_hanging_weight_stream_resumes_every_force_point_and_agrees_with_its_frames_alone() {
    // tip_weight's frames have no seen contact: each of the model's declared force points
    // is estimated, and each resumes where its own loop ended in the frame before.
    let (rec, sensor) = open("tip_weight");
    let reports = tracked(&rec, &sensor);
    let params = &sensor.params.frame;
    for (i, r) in reports.iter().enumerate() {
        assert_eq!(r.status, FrameStatus::Sensed);
        assert_eq!(r.tracked, i > 0, "frame {}: {:?}", r.frame, r.warnings);
        let solo = alone(&rec, &sensor, r.frame);
        let (a, b) = (&r.forces[0], &solo.forces[0]);
        assert_eq!(a.source, b.source, "frame {}", r.frame);
        let tol = 2.0 * params.force_tol.max(params.sigma_tol * a.sigma);
        let d = crate::common::largest_component_gap(a.force, b.force);
        assert!(d <= tol, "frame {}: {d} N apart", r.frame);
    }
}

#[test]
fn two_probes_are_tracked_whichever_order_their_contacts_are_listed_in() {
    // Generated here from tests/fixtures/scenes/two_press.toml (4 frames).
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softsense"))
        .args(["scene", "generate"])
        .arg(root.join("tests/fixtures/scenes/two_press.toml"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rec = Recording::open(dir.path()).unwrap();
    let model = Model::load(&root.join("meshes/models/robot.toml"), None).unwrap();
    let sensor = Sensor::new(
        model,
        rec.robot_from_camera.unwrap(),
        SenseParams::default(),
    );
    let reports = tracked(&rec, &sensor);
    assert_eq!(reports.len(), 4);
    let params = &sensor.params.frame;
    let mut swapped = 0;
    for (i, r) in reports.iter().enumerate() {
        assert_eq!(r.status, FrameStatus::Sensed);
        assert_eq!(r.tracked, i > 0, "frame {}: {:?}", r.frame, r.warnings);
        let solo = alone(&rec, &sensor, r.frame);
        assert_eq!(r.forces.len(), 2);
        for (a, b) in r.forces.iter().zip(&solo.forces) {
            assert_eq!(a.node, b.node, "frame {}", r.frame);
            let tol = 2.0
                * params
                    .force_tol
                    .max(params.sigma_tol * a.sigma.min(b.sigma));
            let d = crate::common::largest_component_gap(a.force, b.force);
            eprintln!(
                "frame {}: node {:?} differs by {:.2} mN (tolerance {:.2} mN)",
                r.frame,
                a.node,
                1e3 * d,
                1e3 * tol
            );
            assert!(d <= tol, "frame {}: {d} N apart", r.frame);
        }
        if i > 0 && r.forces[0].node != reports[i - 1].forces[0].node {
            swapped += 1;
        }
    }
    assert!(
        swapped > 0,
        "the contacts kept their order: this test shows nothing"
    );
}

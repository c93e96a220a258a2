//! `sense` on the generated probe scenes (sensor noise on): a probe pushing on the robot's
//! side at 5 random places (clouds/scenes/probe_side), and two probes at once
//! (clouds/scenes/two_probes). The location is chosen by the data among the surface nodes
//! near each seen contact; the force is 3-D (pushing normal + two tangential components).
use softsense::fem::model::Model;
use softsense::sense::{compare, LoadError, Recording, SenseParams, Sensor};
use std::path::Path;

fn run(scene: &str) -> Vec<(usize, LoadError)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rec = Recording::open(&root.join("clouds/scenes").join(scene)).unwrap();
    let model = Model::load(&rec.model_path().unwrap(), None).unwrap();
    let sensor = Sensor::new(model, rec.robot_from_camera, SenseParams::default());
    let mut out = Vec::new();
    for &frame in &rec.frames {
        let obs = sensor.observe(&rec, frame).unwrap();
        let report = sensor.sense(frame, &obs, rec.actuators_of(frame));
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
    let a = run("probe_side");
    let b = run("two_probes");
    assert_eq!((a.len(), b.len()), (5, 6));
    let located = a
        .iter()
        .chain(&b)
        .filter(|(_, e)| e.location_error <= 0.005)
        .count();
    eprintln!("{located} of 11 loads located within 5 mm");
    assert!(located > 0, "no load located at all");
}

#[test]
#[ignore = "acceptance NOT met yet: 2 of 5 probes within 5 mm and 5% (5/5 located within 0.2 mm; magnitudes within 5% in 4/5, 3-D vector errors 0.2-26%: tangential components)"]
fn a_probe_at_five_random_places_is_located_within_five_mm_and_five_percent() {
    assert!(within(&run("probe_side")));
}

#[test]
#[ignore = "acceptance NOT met yet: two probes at once, 4 of 6 loads within 5 mm and 5% (6/6 located within 0.1 mm; 3-D errors 0.8-18.5%, one pass at 4.9% is inside its sigma: in frame 1 the two x errors are equal and opposite, a squeeze of the body between the probes that moves the seen surface very little)"]
fn two_simultaneous_probes_are_both_found_within_five_percent() {
    assert!(within(&run("two_probes")));
}

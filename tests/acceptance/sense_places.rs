//! Sensing at held-out probe places that once failed: a location whose estimate fails
//! gives way, the preview moves off an inverting node, the choice at the preview state.
//! Each generates and senses a noisy scene twice or more (acceptance-sized). These are the
//! location choice's mechanics on the feature registration, where they were shown; the
//! default's dense rows lose these places (89-146 mm off, flagged unreliable), measured
//! in `dense_registration_loses_the_edge_places_and_says_so`.

use crate::common::sense_generated;
use softsense::sense::{FrameStatus, SenseParams};

// A held-out probe place (`make_probe_scenes --held-out 202 8`, frame 5) on the west leg,
// next to a node (655) at the edge of its face. The location choice at the free state picks
// that node first, and the estimated point load there inverts an element however far its
// step is halved. (With the default preview the choice at the preview's state moves to the
// next node before the load gets that far: see the test after this one.)
const WEST_EDGE_PLACE: [f64; 3] = [-0.1012, -0.0132, 0.05];
const WEST_EDGE_FORCE: [f64; 3] = [0.1778, 0.6870, -0.1436];

#[test]
fn a_location_whose_estimate_fails_gives_way_to_the_next_best_one() {
    let params = SenseParams {
        preview_updates: 0,
        ..SenseParams::features()
    };
    let (report, errors) = sense_generated(202, WEST_EDGE_PLACE, WEST_EDGE_FORCE, params);
    eprintln!("{:?}, {:?}, {errors:?}", report.status, report.warnings);
    assert!(
        matches!(report.status, FrameStatus::Sensed),
        "{:?}",
        report.status
    );
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.starts_with("contact location (nodes [655]) could not be estimated")),
        "{:?}",
        report.warnings
    );
    let e = &errors[0];
    assert!(e.estimate.is_some() && e.location_error < 0.005, "{e:?}");
    assert!(
        e.force_error < 0.05,
        "force {:.1}% off",
        e.force_error * 100.0
    );
}

#[test]
fn the_preview_moves_off_a_node_whose_load_would_invert_an_element() {
    // The place of the test above with the default preview: its first two FE updates at
    // node 655 still stand, and the choice made at their state picks node 654.
    let (report, errors) = sense_generated(
        202,
        WEST_EDGE_PLACE,
        WEST_EDGE_FORCE,
        SenseParams::features(),
    );
    eprintln!("{:?}, {:?}, {errors:?}", report.status, report.warnings);
    assert!(matches!(report.status, FrameStatus::Sensed));
    assert!(
        !report
            .warnings
            .iter()
            .any(|w| w.starts_with("contact location")),
        "{:?}",
        report.warnings
    );
    assert_eq!(report.forces[0].node, Some(654));
    let e = &errors[0];
    assert!(e.location_error < 0.005 && e.force_error < 0.05, "{e:?}");
}

// Held out 606, frame 0: a probe near the south-east leg's corner. At the free state the
// choice ranks first a node whose load inverts an element (676), then one 8 mm off the
// probe (549); estimated there, the next choices wander off (node 120, 79 mm away). The
// choice at the preview's state (two FE updates at node 676, before it inverts) picks the
// touched node, 679.
#[test]
fn the_choice_at_the_preview_state_finds_a_node_the_free_state_ranks_low() {
    let place = [0.11, -0.0132, 0.05];
    let force = [-0.1768, 0.6298, -0.243];
    let old = SenseParams {
        preview_updates: 0,
        location_checks: 1,
        ..SenseParams::features()
    };
    let (before, before_errors) = sense_generated(606, place, force, old);
    eprintln!(
        "without: {:?}, {:?}, {before_errors:?}",
        before.status, before.warnings
    );
    let (report, errors) = sense_generated(606, place, force, SenseParams::features());
    eprintln!(
        "with: {:?}, {:?}, {errors:?}",
        report.status, report.warnings
    );
    // Without the preview the frame is lost (flagged, the load far off).
    assert!(
        !before.reliable && before_errors[0].location_error > 0.005,
        "{before_errors:?}"
    );
    assert!(matches!(report.status, FrameStatus::Sensed) && report.reliable);
    assert_eq!(report.forces[0].node, Some(679));
    let e = &errors[0];
    assert!(e.location_error < 0.005, "{e:?}");
    // 5.2% (its 3-D σ is 4.5% of the force): the location is what this test is about.
    assert!(e.force_error < 0.1, "{e:?}");
}

/// The default (dense rows for one contact) at the two edge places above: the first choice's
/// load inverts an element and the estimate ends far off. Known weakness, measured 89 and
/// 146 mm off; what must hold is that it says so.
#[test]
fn dense_registration_loses_the_edge_places_and_says_so() {
    let places = [
        (202, WEST_EDGE_PLACE, WEST_EDGE_FORCE),
        (606, [0.11, -0.0132, 0.05], [-0.1768, 0.6298, -0.243]),
    ];
    for (seed, place, force) in places {
        let (report, errors) = sense_generated(seed, place, force, SenseParams::default());
        let e = &errors[0];
        eprintln!("held out {seed}: {:?}, {e:?}", report.warnings);
        let off = e.location_error > 0.005 || e.force_error > 0.05;
        assert!(!off || !report.reliable, "{seed}: off and reliable: {e:?}");
    }
}

//! Issue 55's closed-loop lines on the bundled catheter scenarios (simulation: the robot is
//! the same catheter with twice the elements, its cables moved by displacement with their
//! own stretch; the tip tracked with 0.1 mm noise through a seven-point calibration). The
//! pass lines are the thesis's (5.5.3, 5.5.4).

use crate::common::project_root;
use softsense::catheter::run::{run, Run, RunStatus};
use softsense::catheter::scenario::{Scenario, Scheme};
use softsense::catheter::statics::static_insertions;

fn full(name: &str) -> Run {
    let s = Scenario::load(&project_root().join("scenarios/catheter").join(name)).unwrap();
    let r = run(&s, &mut |_, _| {}).unwrap();
    assert_eq!(r.status, RunStatus::Completed, "{name}");
    r
}

#[test]
fn bm3_tracking_at_2_4_mm_per_s_stays_within_the_thesis_errors() {
    let r = full("tracking_2.4.toml");
    let s = &r.summary;
    println!("tracking at 2.4 mm/s: {s:?}");
    assert!(s.straight_mean_mm <= 0.3, "{s:?}");
    assert!(s.max_mm <= 4.8, "{s:?}");
    assert_eq!(s.unsettled_steps + s.qpcc_failures, 0, "{s:?}");
}

#[test]
fn bm4_positioning_at_60_mm_ends_within_0_2_mm() {
    let r = full("positioning_60.toml");
    let s = &r.summary;
    println!("positioning at 60 mm: {s:?}");
    assert!(s.final_mm <= 0.2, "{s:?}");
}

/// The soft tube (thesis 5.5.7.2): the contacts scenario's tube with a soft silicone wall;
/// issue 55's line: the run completes at 0.6 mm/s with the tip error at most 2 mm.
#[test]
fn a_soft_tube_is_tracked_at_0_6_mm_per_s_within_2_mm() {
    let r = full("soft_tube.toml");
    let s = &r.summary;
    println!("soft tube at 0.6 mm/s: {s:?}");
    assert!(s.max_mm <= 2.0, "{s:?}");
    assert!(
        s.max_contacts > 0,
        "the catheter never touched the soft wall: {s:?}"
    );
}

/// BM-6 (thesis 5.5.6): ten static passive insertions through a 3-D tube; the model's tip
/// within 3.35 mm of the robot's on average, every settle an equilibrium. A known miss:
/// once the tip reaches the second bend (about 111 mm) every settle of both the model and
/// the robot stops at its round limit (docs/catheter.md).
#[test]
#[ignore = "known miss (issue 55): passive settles stop at their round limit past the second bend"]
fn bm6_ten_static_insertions_in_a_3d_tube_keep_the_model_tip_within_3_35_mm() {
    let s = Scenario::load(&project_root().join("scenarios/catheter/insertions_3d.toml")).unwrap();
    let r = static_insertions(&s, 10, &mut |_, _| {}).unwrap();
    for p in &r.positions {
        println!(
            "{:.1} mm: error {:.3} mm, settled {}",
            1e3 * p.insertion,
            1e3 * p.error,
            p.settled
        );
    }
    assert_eq!(r.unsettled, 0, "settles at their round limit");
    assert!(r.mean_mm <= 3.35, "mean {:.3} mm", r.mean_mm);
}

/// BM-7 in part (thesis 5.3.1, 5.5.7.1): in a 120° bend the coupled baseline's Jacobian,
/// taken from a model that ignores the tube, turns away from the true one once the wall
/// takes over the bending (the margin, 1 on the straight, falls below one half), while the
/// decoupled loop tracks the same insertion within the thesis's largest maximum. Not yet
/// shown: a negative margin and the coupled loop running away (docs/catheter.md).
#[test]
fn bm7_in_a_120_degree_bend_the_coupled_jacobian_turns_away_while_the_decoupled_loop_tracks() {
    let decoupled = full("jacobian_rotation.toml");
    println!("decoupled: {:?}", decoupled.summary);
    assert!(decoupled.summary.max_mm <= 4.8, "{:?}", decoupled.summary);
    let mut s =
        Scenario::load(&project_root().join("scenarios/catheter/jacobian_rotation.toml")).unwrap();
    s.controller.scheme = Scheme::Coupled;
    let coupled = run(&s, &mut |_, _| {}).unwrap();
    let margins: Vec<(f64, f64)> = (coupled.steps.iter())
        .filter_map(|r| Some((r.insertion, r.rotation_margin?)))
        .collect();
    println!("coupled: {:?}; margins {margins:?}", coupled.status);
    let straight = margins.iter().filter(|m| m.0 < 0.03).map(|m| m.1);
    assert!(straight.fold(f64::INFINITY, f64::min) > 0.99, "{margins:?}");
    let least = coupled
        .summary
        .min_rotation_margin
        .expect("margins checked");
    assert!(least < 0.5, "{margins:?}");
}

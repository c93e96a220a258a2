//! Marker-based sensing (`softsense markers`, thesis 4.4) on the SOFA tutorials' cable
//! finger and PneuNet (issue 54 item 5; docs/accuracy.md, "Robots designed by others
//! (SOFA)", "Markers"): 10 markers laid out by `softsense markers layout` for the body's
//! three normal candidates, tracks made by the direct FE model (0.1 mm noise), sensed by
//! `softsense markers --json` (protocol and scoring: `common::markers_sofa`). Synthetic,
//! truth = model: an upper bound. Needs SOFTSENSE_DATA (skipped, saying why, without it).
//!
//! `SOFTSENSE_MARKERS_SWEEP=SEED,COUNT[,YOUNG_FACTOR]` runs another seed and count, the
//! truth's modulus that factor times the model's (the documented sweeps); the floors below are the sweeps' measured results with margin, not targets.

use crate::common;
use crate::common::markers_sofa::{setup, sweep, Robot, Tally, FINGER, PNEUNET};

const MARKERS: usize = 10;

/// The seed and trial count: the fixed test's, or the sweep's from the environment.
/// A third value is the truth's Young's modulus factor (the model's is 1).
fn seed_and_count(seed: u64, count: u64) -> (u64, u64, f64) {
    match std::env::var("SOFTSENSE_MARKERS_SWEEP") {
        Ok(v) => {
            let p: Vec<&str> = v.split(',').map(str::trim).collect();
            let factor = p.get(2).map_or(1.0, |f| f.parse().unwrap());
            (p[0].parse().unwrap(), p[1].parse().unwrap(), factor)
        }
        Err(_) => (seed, count, 1.0),
    }
}

fn run(test: &str, robot: &Robot, seed: u64, count: u64) -> Option<Tally> {
    let data = common::data_dir(test)?;
    let (seed, count, young_factor) = seed_and_count(seed, count);
    let dir = tempfile::tempdir().unwrap();
    let s = setup(robot, MARKERS, young_factor, &data, dir.path());
    let per = sweep(robot, &s, seed, count, &data, dir.path());
    println!(
        "{} (young factor {young_factor}), {MARKERS} markers, I_w {:.0} N/m, seed {seed}:",
        robot.body, s.i_w
    );
    for (name, t) in (s.sensor.locations.iter().map(|c| c.name.as_str()))
        .chain(["all"])
        .zip(&per)
    {
        println!("  {name}: {}", t.line());
    }
    per.last().copied()
}

#[test]
fn the_sofa_finger_locates_marker_forces_with_no_silent_miss() {
    let test = "the_sofa_finger_locates_marker_forces_with_no_silent_miss";
    let Some(all) = run(test, &FINGER, 1, 12) else {
        return;
    };
    assert_eq!(all.silent, 0, "{}", all.line());
}

#[test]
fn the_sofa_pneunet_locates_marker_forces_with_no_silent_miss() {
    let test = "the_sofa_pneunet_locates_marker_forces_with_no_silent_miss";
    let Some(all) = run(test, &PNEUNET, 1, 12) else {
        return;
    };
    assert_eq!(all.silent, 0, "{}", all.line());
}

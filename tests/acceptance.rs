//! Acceptance tier: accuracy sweeps, explain datasets, calibration from many starts and
//! other acceptance-sized runs. Not part of a plain `cargo test` (the target has
//! `test = false`); run it with `cargo test --test acceptance` (`.ci/run` does).
mod common;

#[path = "acceptance/batch.rs"]
mod batch;
#[path = "acceptance/calibrate.rs"]
mod calibrate;
#[path = "acceptance/cameras.rs"]
mod cameras;
#[path = "acceptance/catheter.rs"]
mod catheter;
#[path = "acceptance/catheter_tet.rs"]
mod catheter_tet;
#[path = "acceptance/control.rs"]
mod control;
#[path = "acceptance/explain_any_robot.rs"]
mod explain_any_robot;
#[path = "acceptance/explain_hidden.rs"]
mod explain_hidden;
#[path = "acceptance/explain_truth.rs"]
mod explain_truth;
#[path = "acceptance/markers_layout.rs"]
mod markers_layout;
#[path = "acceptance/markers_locate.rs"]
mod markers_locate;
#[path = "acceptance/markers_sensitivity.rs"]
mod markers_sensitivity;
#[path = "acceptance/membrane.rs"]
mod membrane;
#[path = "acceptance/mutation_fuzz.rs"]
mod mutation_fuzz;
#[path = "acceptance/mutation_fuzz_inputs.rs"]
mod mutation_fuzz_inputs;
#[path = "acceptance/punyo.rs"]
mod punyo;
#[path = "acceptance/readme.rs"]
mod readme;
#[path = "acceptance/recording_folder.rs"]
mod recording_folder;
#[path = "acceptance/sense_places.rs"]
mod sense_places;
#[path = "acceptance/sense_reference.rs"]
mod sense_reference;
#[path = "acceptance/sofa_markers.rs"]
mod sofa_markers;
#[path = "acceptance/sofa_robots.rs"]
mod sofa_robots;

//! Integration tests: whole stages and the CLI on files.
mod common;

#[path = "integration/batch.rs"]
mod batch;
#[path = "integration/calibrate.rs"]
mod calibrate;
#[path = "integration/calibrate_cameras.rs"]
mod calibrate_cameras;
#[path = "integration/calibrate_pso.rs"]
mod calibrate_pso;
#[path = "integration/catheter.rs"]
mod catheter;
#[path = "integration/cli.rs"]
mod cli;
#[path = "integration/cli_own_robot.rs"]
mod cli_own_robot;
#[path = "integration/cli_segment.rs"]
mod cli_segment;
#[path = "integration/cli_sense.rs"]
mod cli_sense;
#[path = "integration/control.rs"]
mod control;
#[path = "integration/doc_commands.rs"]
mod doc_commands;
#[path = "integration/fem_cantilever.rs"]
mod fem_cantilever;
#[path = "integration/fem_diamond.rs"]
mod fem_diamond;
#[path = "integration/fem_shell.rs"]
mod fem_shell;
#[path = "integration/fem_skfem.rs"]
mod fem_skfem;
#[path = "integration/malformed_corpus.rs"]
mod malformed_corpus;
#[path = "integration/markers.rs"]
mod markers;
#[path = "integration/markers_bundled.rs"]
mod markers_bundled;
#[path = "integration/markers_detect.rs"]
mod markers_detect;
#[path = "integration/model_check.rs"]
mod model_check;
#[path = "integration/model_new.rs"]
mod model_new;
#[path = "integration/pictures.rs"]
mod pictures;
#[path = "integration/punyo_reference.rs"]
mod punyo_reference;
#[path = "integration/rgbd_sequence.rs"]
mod rgbd_sequence;
#[path = "integration/scene3d.rs"]
mod scene3d;
#[path = "integration/scene_cameras.rs"]
mod scene_cameras;
#[path = "integration/sense_cameras.rs"]
mod sense_cameras;
#[path = "integration/sense_membrane.rs"]
mod sense_membrane;
#[path = "integration/sense_probe.rs"]
mod sense_probe;
#[path = "integration/sense_tip_weight.rs"]
mod sense_tip_weight;
#[path = "integration/sense_track.rs"]
mod sense_track;
#[path = "integration/sensor_fit.rs"]
mod sensor_fit;
#[path = "integration/sweep.rs"]
mod sweep;

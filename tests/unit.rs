//! Unit tests, one module per library module (mirrors `src/`).
mod common;

#[path = "unit/cloud.rs"]
mod cloud;

#[path = "unit/search.rs"]
mod search;

#[path = "unit/filter.rs"]
mod filter;

#[path = "unit/features.rs"]
mod features;

#[path = "unit/io_pcd.rs"]
mod io_pcd;

#[path = "unit/io_ply.rs"]
mod io_ply;

#[path = "unit/io_malformed.rs"]
mod io_malformed;

#[path = "unit/camera_lens.rs"]
mod camera_lens;
#[path = "unit/fem_base.rs"]
mod fem_base;
#[path = "unit/fem_cavity.rs"]
mod fem_cavity;
#[path = "unit/fem_compliance.rs"]
mod fem_compliance;
#[path = "unit/fem_element.rs"]
mod fem_element;
#[path = "unit/fem_mesh.rs"]
mod fem_mesh;
#[path = "unit/fem_model.rs"]
mod fem_model;
#[path = "unit/fem_neohookean.rs"]
mod fem_neohookean;
#[path = "unit/fem_prestress.rs"]
mod fem_prestress;
#[path = "unit/fem_shell.rs"]
mod fem_shell;
#[path = "unit/inverse_pushes.rs"]
mod inverse_pushes;
#[path = "unit/io_lens.rs"]
mod io_lens;
#[path = "unit/io_rgbd.rs"]
mod io_rgbd;

#[path = "unit/pipeline.rs"]
mod pipeline;

#[path = "unit/filter_golden.rs"]
mod filter_golden;

#[path = "unit/inverse.rs"]
mod inverse;
#[path = "unit/inverse_lsq.rs"]
mod inverse_lsq;
#[path = "unit/inverse_qpcc.rs"]
mod inverse_qpcc;
#[path = "unit/inverse_tare.rs"]
mod inverse_tare;
#[path = "unit/markers.rs"]
mod markers;
#[path = "unit/markers_calib.rs"]
mod markers_calib;
#[path = "unit/markers_detect.rs"]
mod markers_detect;
#[path = "unit/markers_layout.rs"]
mod markers_layout;
#[path = "unit/markers_reference.rs"]
mod markers_reference;
#[path = "unit/register.rs"]
mod register;
#[path = "unit/scene.rs"]
mod scene;
#[path = "unit/scene_cameras.rs"]
mod scene_cameras;
#[path = "unit/scene_sensor.rs"]
mod scene_sensor;
#[path = "unit/scene_truth.rs"]
mod scene_truth;
#[path = "unit/segment.rs"]
mod segment;
#[path = "unit/segment_geometric.rs"]
mod segment_geometric;
#[path = "unit/sense_hold.rs"]
mod sense_hold;

#[path = "unit/calibrate.rs"]
mod calibrate;
#[path = "unit/calibrate_pso.rs"]
mod calibrate_pso;
#[path = "unit/contact.rs"]
mod contact;
#[path = "unit/discrepancy.rs"]
mod discrepancy;
#[path = "unit/discrepancy_body.rs"]
mod discrepancy_body;
#[path = "unit/discrepancy_truth.rs"]
mod discrepancy_truth;

#[path = "unit/render.rs"]
mod render;

#[path = "unit/flann_order.rs"]
mod flann_order;

#[path = "unit/recording.rs"]
mod recording;
#[path = "unit/recording_import.rs"]
mod recording_import;
#[path = "unit/recording_rig.rs"]
mod recording_rig;

#[path = "unit/score.rs"]
mod score;

#[path = "unit/control.rs"]
mod control;

#[path = "unit/catheter.rs"]
mod catheter;
#[path = "unit/catheter_rig.rs"]
mod catheter_rig;
#[path = "unit/catheter_soft.rs"]
mod catheter_soft;
#[path = "unit/catheter_tet.rs"]
mod catheter_tet;
#[path = "unit/layers.rs"]
mod layers;

#[path = "unit/batch.rs"]
mod batch;
#[path = "unit/fem_beam.rs"]
mod fem_beam;
#[path = "unit/scene3d.rs"]
mod scene3d;

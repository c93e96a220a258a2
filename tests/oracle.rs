//! Live comparisons against PCL and Open3D (programs in `tools/oracle/`).
mod common;

#[path = "oracle/filter.rs"]
mod filter;
#[path = "oracle/harness.rs"]
mod harness;
#[path = "oracle/io.rs"]
mod io;
#[path = "oracle/rgbd.rs"]
mod rgbd;
#[path = "oracle/segment.rs"]
mod segment;
#[path = "oracle/segment_color.rs"]
mod segment_color;
#[path = "oracle/segment_mosd.rs"]
mod segment_mosd;

//! Live comparisons against PCL and Open3D (programs in `tools/oracle/`).
mod common;

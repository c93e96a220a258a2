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

#[path = "unit/io_rgbd.rs"]
mod io_rgbd;

#[path = "unit/segment.rs"]
mod segment;

#[path = "unit/contact.rs"]
mod contact;

//! Unit tests, one module per library module (mirrors `src/`).
mod common;

#[path = "unit/cloud.rs"]
mod cloud;

#[path = "unit/fem_compliance.rs"]
mod fem_compliance;
#[path = "unit/fem_element.rs"]
mod fem_element;
#[path = "unit/fem_mesh.rs"]
mod fem_mesh;
#[path = "unit/fem_model.rs"]
mod fem_model;
#[path = "unit/inverse.rs"]
mod inverse;
#[path = "unit/register.rs"]
mod register;
#[path = "unit/scene.rs"]
mod scene;

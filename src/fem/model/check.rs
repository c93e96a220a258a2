//! What a model file holds, checked before it is used (`softsense model check`): the mesh
//! and its quality, mass, fixed nodes, cables, cavities, effectors and force points, and
//! the sag under gravity alone. Stricter than the loader, which accepts what a model may
//! hold on purpose: [`check`] refuses a cable point outside the body (the loader maps one
//! up to 5% of the mesh's diagonal outside), an open cavity (the loader takes one as a
//! membrane) and a model that fixes no node (the loader builds it; a solve refuses it).
//! Each refusal is a [`FemError::Model`] naming the model file's key.

use super::super::cavity::CavityControl;
use super::super::mesh::{norm, sub, QualityReport};
use super::super::solve::CableControl;
use super::super::{FemError, FemResult};
use super::{Effector, Model, ModelSpec};
use crate::geometry::triangle::point_triangle_distance2;
use crate::io::InFile;
use serde::Serialize;
use std::path::Path;

/// How far (fraction of the mesh's bounding-box diagonal) a cable point may lie outside
/// the tetrahedra and still count as in the body: rounding only.
pub const INSIDE_TOLERANCE: f64 = 1e-6;

/// What a model holds (SI).
#[derive(Debug, Clone, Serialize)]
pub struct ModelReport {
    /// The model file.
    pub file: String,
    /// The file's unit system (`"SI"` or `"mm-kg-s"`); the report itself is SI.
    pub units: String,
    /// The element law (`"corotational"`, `"small-strain"` or `"neo-hookean"`).
    pub formulation: String,
    /// Mesh quality: counts, volume (m^3), dihedral angles (deg), radius-edge ratio,
    /// bounding box (m).
    pub quality: QualityReport,
    /// The largest side of the bounding box (m): the body length the sag is compared to.
    pub body_length: f64,
    /// Young's modulus (Pa; regions may differ) and Poisson's ratio.
    pub young: f64,
    /// Poisson's ratio.
    pub poisson: f64,
    /// Total mass (kg).
    pub mass: f64,
    /// Mass density (kg/m^3).
    pub density: f64,
    /// Gravity acceleration (m/s^2).
    pub gravity: [f64; 3],
    /// Fixed nodes.
    pub fixed_nodes: usize,
    /// The compliant base's total stiffness (N/m), or `None` for a clamped base.
    pub base_stiffness: Option<f64>,
    /// The cables, in the file's order.
    pub cables: Vec<CableReport>,
    /// The pressure cavities, in the file's order.
    pub cavities: Vec<CavityReport>,
    /// The effectors (feature points).
    pub effectors: Vec<PointReport>,
    /// The candidate force points.
    pub force_points: Vec<PointReport>,
    /// Point loads in the file (left out of the sag).
    pub loads: usize,
    /// The sag under gravity alone; `None` without mass or gravity.
    pub sag: Option<Sag>,
}

/// A cable as loaded.
#[derive(Debug, Clone, Serialize)]
pub struct CableReport {
    /// Name.
    pub name: String,
    /// Attach points.
    pub points: usize,
    /// Rest length from the pull point through the attach points (m).
    pub length: f64,
    /// Its control in the file (m of shortening, or N of tension).
    pub control: CableControl,
}

/// A pressure cavity as loaded.
#[derive(Debug, Clone, Serialize)]
pub struct CavityReport {
    /// Name.
    pub name: String,
    /// Triangles.
    pub faces: usize,
    /// Whether the faces close (always true in a report: open ones are refused).
    pub closed: bool,
    /// Enclosed volume at rest (m^3).
    pub rest_volume: f64,
    /// Its control in the file (Pa, or m^3 of volume change).
    pub control: CavityControl,
}

/// An effector or force point as loaded.
#[derive(Debug, Clone, Serialize)]
pub struct PointReport {
    /// Name.
    pub name: String,
    /// Rest position (m).
    pub position: [f64; 3],
    /// Constraint rows: 3 (x, y, z) or 1 (along a direction or the surface normal).
    pub rows: usize,
}

/// The largest node displacement under gravity alone.
#[derive(Debug, Clone, Serialize)]
pub struct Sag {
    /// Its length (m).
    pub displacement: f64,
    /// As a fraction of [`ModelReport::body_length`].
    pub fraction_of_length: f64,
    /// The node where it happens.
    pub node: usize,
    /// That node's rest position (m).
    pub at: [f64; 3],
    /// Its displacement vector (m).
    pub vector: [f64; 3],
    /// Newton iterations of the solve.
    pub iterations: usize,
    /// Small strain's validity warning ([`Model::validity_warning`]), if it speaks.
    pub warning: Option<String>,
}

/// Loads and checks the model file `path`: its model and report, or a refusal naming
/// the key and the file.
pub fn check_file(path: &Path) -> FemResult<(Model, ModelReport)> {
    let spec = Model::spec_of(path)?;
    let model = Model::load(path, None)?;
    let mut report = check(&model, &spec).map_err(|e| e.in_file(path))?;
    report.file = path.display().to_string();
    Ok((model, report))
}

/// Checks `model` loaded from `spec` (see the module docs) and solves for its sag;
/// `file` of the report is left empty ([`check_file`] fills it).
pub fn check(model: &Model, spec: &ModelSpec) -> FemResult<ModelReport> {
    let p = &model.problem;
    let quality = p.mesh.quality()?;
    refuse_unfixed(model)?;
    refuse_cable_points_outside(model, spec, &quality)?;
    refuse_open_cavities(model, spec)?;
    let [lo, hi] = quality.bbox;
    let body_length = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let x = &p.mesh.nodes_in_rest;
    let cables = (p.cables.iter())
        .map(|c| CableReport {
            name: c.name.clone(),
            points: c.attach.len(),
            length: c.length(x),
            control: c.control,
        })
        .collect();
    let cavities = (p.cavities.iter())
        .map(|c| CavityReport {
            name: c.name.clone(),
            faces: c.faces.len(),
            closed: c.is_closed(),
            rest_volume: c.rest_volume,
            control: c.control,
        })
        .collect();
    let points = |list: &[Effector]| {
        (list.iter())
            .map(|e| PointReport {
                name: e.name.clone(),
                position: e.point.position(x),
                rows: e.rows.len(),
            })
            .collect()
    };
    let sag = gravity_sag(model, body_length)?;
    Ok(ModelReport {
        file: String::new(),
        units: spec.units.clone(),
        formulation: p.formulation.name().to_string(),
        body_length,
        young: p.material.young(),
        poisson: p.material.poisson(),
        mass: p.density * quality.volume,
        density: p.density,
        gravity: p.gravity,
        fixed_nodes: p.fixed.len(),
        base_stiffness: p.base_stiffness,
        cables,
        cavities,
        effectors: points(&model.effectors),
        force_points: points(&model.force_points),
        loads: p.loads.len(),
        sag,
        quality,
    })
}

/// A model that fixes no node floats: refused by key (the loader builds it, for tests
/// that never solve; a solve refuses it as singular, which does not say which key).
fn refuse_unfixed(model: &Model) -> FemResult<()> {
    if model.problem.fixed.is_empty() && model.problem.prescribed.is_empty() {
        return Err(FemError::Model(
            "fixed: the model fixes no node, so the body is free to float: give a \
             [[fixed]] box (or nodes, or marked = true) where it is held"
                .into(),
        ));
    }
    Ok(())
}

/// A cable attach point more than [`INSIDE_TOLERANCE`] of the diagonal outside every
/// tetrahedron is refused, with how far outside it lies in the file's length unit.
fn refuse_cable_points_outside(
    model: &Model,
    spec: &ModelSpec,
    quality: &QualityReport,
) -> FemResult<()> {
    let u = &model.units;
    let unit = length_unit(spec);
    let diag = norm(sub(quality.bbox[1], quality.bbox[0]));
    let mesh = &model.problem.mesh;
    let mut surface = None;
    for (i, c) in spec.cables.iter().enumerate() {
        for (j, a) in c.attach.iter().enumerate() {
            let p = a.map(|v| v * u.length);
            match mesh.locate(p, INSIDE_TOLERANCE * diag) {
                Ok(_) => {}
                Err(FemError::PointOutside { .. }) => {
                    // `locate`'s distance is to a clamped barycentric point, up to half
                    // again too far; the surface's nearest triangle says how far it is.
                    let s = surface.get_or_insert_with(|| mesh.surface());
                    let x = &mesh.nodes_in_rest;
                    let distance = (s.triangles.iter())
                        .map(|t| point_triangle_distance2(p, x[t[0]], x[t[1]], x[t[2]]))
                        .fold(f64::INFINITY, f64::min)
                        .sqrt();
                    return Err(FemError::Model(format!(
                        "cables[{i}].attach[{j}] = {a:?} (cable {:?}) lies {:.3} {unit} \
                         outside the body: a cable runs through the material, so each \
                         attach point must be inside it",
                        c.name,
                        distance / u.length
                    )));
                }
                Err(e) => return Err(e),
            }
        }
    }
    Ok(())
}

/// An open cavity (rim edges: edges with one face) is refused: its "volume" is a swept
/// one, which a closed chamber's pressure does not act on.
fn refuse_open_cavities(model: &Model, spec: &ModelSpec) -> FemResult<()> {
    for (i, (c, s)) in model
        .problem
        .cavities
        .iter()
        .zip(&spec.cavities)
        .enumerate()
    {
        if c.is_closed() {
            continue;
        }
        let (key, from) = match &s.surface {
            Some(f) => ("surface", format!("the surface {f}")),
            None => ("box", "the mesh faces in the box".to_string()),
        };
        let at = c.rim[0].rest[0].map(|v| v / model.units.length);
        return Err(FemError::Model(format!(
            "cavities[{i}].{key} (cavity {:?}): {from} is not closed: {} rim edges (edges \
             with one face), the first at {at:?} {}; a chamber's surface must close",
            c.name,
            c.rim.len(),
            length_unit(spec)
        )));
    }
    Ok(())
}

/// The file's length unit, for messages.
fn length_unit(spec: &ModelSpec) -> &'static str {
    match spec.units.as_str() {
        "mm-kg-s" | "mm" => "mm",
        _ => "m",
    }
}

/// The largest node displacement under gravity alone: cables and cavities at zero input
/// (no tension, no pressure), no point loads.
fn gravity_sag(model: &Model, body_length: f64) -> FemResult<Option<Sag>> {
    let p = &model.problem;
    if p.density == 0.0 || p.gravity == [0.0; 3] {
        return Ok(None);
    }
    // A clone keeps the mesh, fixed nodes and cable attachments, and so the solver setup.
    let mut q = p.clone();
    q.loads.clear();
    for c in &mut q.cables {
        c.control = CableControl::Force(0.0);
    }
    for c in &mut q.cavities {
        c.control = CavityControl::Pressure(0.0);
    }
    let sol = q.solve_static(&model.newton)?;
    let (node, d) = (sol.displacement.iter().enumerate())
        .map(|(i, d)| (i, norm(*d)))
        .fold((0, 0.0), |best, e| if e.1 > best.1 { e } else { best });
    let warning = model.validity_warning(&sol.displacement);
    Ok(Some(Sag {
        displacement: d,
        fraction_of_length: d / body_length,
        node,
        at: p.mesh.nodes_in_rest[node],
        vector: sol.displacement[node],
        iterations: sol.iterations,
        warning,
    }))
}

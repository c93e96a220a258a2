//! The model file as written ([`ModelSpec`] and its tables), the unit systems it may be
//! written in ([`Units`]), and the check that every number in it is finite.

use super::super::mesh::Placement;
use super::super::shell::ShellParams;
use super::super::{FemError, FemResult};
use serde::{Deserialize, Serialize};

/// The model file as written.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// `"SI"` (default) or `"mm-kg-s"`.
    #[serde(default = "default_units")]
    pub units: String,
    /// `"corotational"` (default), `"small-strain"` or `"neo-hookean"` (compressible
    /// Neo-Hookean, for large strains; the same E and ν).
    #[serde(default)]
    pub formulation: Option<String>,
    /// The mesh file.
    pub mesh: MeshSpec,
    /// Placement of the mesh (in file units, applied before unit conversion).
    #[serde(default)]
    pub placement: Placement,
    /// Material (Young's modulus in the file's pressure unit).
    pub material: MaterialSpec,
    /// Mass (total or density) for gravity.
    #[serde(default)]
    pub mass: Option<MassSpec>,
    /// Gravity acceleration (file units).
    #[serde(default)]
    pub gravity: Option<[f64; 3]>,
    /// Fixed-node selections.
    #[serde(default)]
    pub fixed: Vec<FixedSpec>,
    /// Total stiffness of a compliant base (force unit per length unit: N/m in both unit
    /// systems, each axis), shared equally by all fixed nodes as springs to their rest
    /// positions; absent (default), the fixed nodes are clamped.
    #[serde(default)]
    pub base_stiffness: Option<f64>,
    /// Cable actuators.
    #[serde(default)]
    pub cables: Vec<CableSpec>,
    /// Regions of another Young's modulus (e.g. PneuNet's strain-limiting layer).
    #[serde(default)]
    pub regions: Vec<RegionSpec>,
    /// Pressure cavities (actuators after the cables).
    #[serde(default)]
    pub cavities: Vec<CavitySpec>,
    /// Point loads.
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Effectors (feature points).
    #[serde(default)]
    pub effectors: Vec<PointSpec>,
    /// Candidate external-force points (compliance rows).
    #[serde(default)]
    pub force_points: Vec<PointSpec>,
    /// Newton settings.
    #[serde(default)]
    pub newton: Option<NewtonSpec>,
}

fn default_units() -> String {
    "SI".into()
}

/// Mesh file reference.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Path, relative to the model file; `${VAR}` expands environment variables.
    pub path: String,
    /// A triangle surface file made a thin body: extruded into layers of tetrahedra
    /// ([`crate::fem::shell`]; thickness in the file's length unit, after placement).
    #[serde(default)]
    pub shell: Option<ShellParams>,
}

/// Material in file units.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Young's modulus (Pa for SI, kPa for mm-kg-s).
    pub young: f64,
    /// Poisson ratio.
    pub poisson: f64,
}

/// Mass: total (kg, uniform) or density (kg per file unit volume).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MassSpec {
    /// Total mass in kg, spread uniformly by volume.
    pub total: Option<f64>,
    /// Density (kg/m^3 for SI, kg/mm^3 for mm-kg-s).
    pub density: Option<f64>,
}

/// A fixed-node selection.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FixedSpec {
    /// Axis-aligned box [min, max] (after placement, file units).
    pub r#box: Option<[[f64; 3]; 2]>,
    /// Explicit node indices.
    pub nodes: Option<Vec<usize>>,
    /// The nodes the mesh file marks (vertex cells; every layer copy in a shell).
    #[serde(default)]
    pub marked: bool,
}

/// A cable actuator.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CableSpec {
    /// Name.
    pub name: String,
    /// Pull point (fixed in space).
    pub pull: [f64; 3],
    /// Attach points, from the pull point outward (mapped barycentrically).
    pub attach: Vec<[f64; 3]>,
    /// Displacement control: shortening (length unit).
    pub shorten: Option<f64>,
    /// Force control: tension (force unit).
    pub force: Option<f64>,
}

/// A region of another Young's modulus: the tetrahedra whose centroid is in the box.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Axis-aligned box [min, max] (after placement, file units).
    pub r#box: [[f64; 3]; 2],
    /// Young's modulus there (the file's pressure unit, as `material.young`).
    pub young: f64,
}

/// A pressure cavity: its faces from a surface file or the mesh's boundary faces in a box.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CavitySpec {
    /// Name.
    pub name: String,
    /// Surface file (STL binary or ASCII, OBJ), in the mesh's file units and placed with
    /// it; relative to the model file, `${VAR}` expands. Corners on mesh nodes are those
    /// nodes, others are mapped barycentrically into the volume mesh.
    pub surface: Option<String>,
    /// Axis-aligned box [min, max] (after placement, file units): the mesh boundary faces
    /// with all three nodes inside.
    pub r#box: Option<[[f64; 3]; 2]>,
    /// Pressure control: pressure (pressure unit: Pa for SI, kPa for mm-kg-s; default 0).
    pub pressure: Option<f64>,
    /// Volume control: volume change from rest (length unit cubed).
    pub volume: Option<f64>,
}

/// A point load.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Location (mapped barycentrically), or
    pub at: Option<[f64; 3]>,
    /// a node index.
    pub node: Option<usize>,
    /// Force vector (force unit).
    pub force: [f64; 3],
}

/// An effector or force point.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointSpec {
    /// Name.
    #[serde(default)]
    pub name: String,
    /// Location.
    pub at: [f64; 3],
    /// One row along this direction (else three rows x, y, z).
    pub direction: Option<[f64; 3]>,
    /// One row along the interpolated outward surface normal.
    #[serde(default)]
    pub normal: bool,
}

/// Newton settings.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct NewtonSpec {
    /// Maximum iterations per load step (1 to [`crate::fem::solve::MAX_ITERATIONS`]).
    pub max_iterations: Option<usize>,
    /// Load steps (1 to [`crate::fem::solve::MAX_LOAD_STEPS`]).
    pub load_steps: Option<usize>,
    /// Relative residual tolerance, strictly between 0 and 1.
    pub rel_tol: Option<f64>,
}

/// Unit scale factors from file units to SI.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Units {
    /// Length.
    pub length: f64,
    /// Force.
    pub force: f64,
    /// Pressure.
    pub pressure: f64,
    /// Density.
    pub density: f64,
}

impl Units {
    /// Parses a unit system name.
    pub fn parse(name: &str) -> FemResult<Self> {
        match name {
            "SI" | "si" | "m-kg-s" => Ok(Self {
                length: 1.0,
                force: 1.0,
                pressure: 1.0,
                density: 1.0,
            }),
            "mm-kg-s" | "mm" => Ok(Self {
                length: 1e-3,
                force: 1e-3,
                pressure: 1e3,
                density: 1e9,
            }),
            _ => Err(FemError::Model(format!(
                "unknown units {name:?} (SI or mm-kg-s)"
            ))),
        }
    }
}

/// Refuses a NaN or infinite number anywhere in the spec, naming the field: such a
/// value passed through to a compliance of all nulls or an effector that "converged".
pub(super) fn check_finite(spec: &ModelSpec) -> FemResult<()> {
    let mut fields: Vec<(String, f64)> = Vec::new();
    let mut add = |name: String, values: &[f64]| {
        for (k, &v) in values.iter().enumerate() {
            let at = if values.len() > 1 {
                format!("{name}[{k}]")
            } else {
                name.clone()
            };
            fields.push((at, v));
        }
    };
    let pl = &spec.placement;
    add("placement.scale".into(), pl.scale.as_slice());
    add(
        "placement.rotate_deg".into(),
        pl.rotate_deg.as_ref().map_or(&[], |v| v),
    );
    add(
        "placement.translate".into(),
        pl.translate.as_ref().map_or(&[], |v| v),
    );
    add("material.young".into(), &[spec.material.young]);
    add("material.poisson".into(), &[spec.material.poisson]);
    if let Some(m) = &spec.mass {
        add("mass.total".into(), m.total.as_slice());
        add("mass.density".into(), m.density.as_slice());
    }
    add("gravity".into(), spec.gravity.as_ref().map_or(&[], |v| v));
    add("base_stiffness".into(), spec.base_stiffness.as_slice());
    let shell = spec.mesh.shell.as_ref().map(|s| s.thickness);
    add("mesh.shell.thickness".into(), shell.as_slice());
    for (i, f) in spec.fixed.iter().enumerate() {
        if let Some([lo, hi]) = &f.r#box {
            add(format!("fixed[{i}].box[0]"), lo);
            add(format!("fixed[{i}].box[1]"), hi);
        }
    }
    for (i, c) in spec.cables.iter().enumerate() {
        add(format!("cables[{i}].pull"), &c.pull);
        for (j, a) in c.attach.iter().enumerate() {
            add(format!("cables[{i}].attach[{j}]"), a);
        }
        add(format!("cables[{i}].shorten"), c.shorten.as_slice());
        add(format!("cables[{i}].force"), c.force.as_slice());
    }
    for (i, c) in spec.cavities.iter().enumerate() {
        if let Some([lo, hi]) = &c.r#box {
            add(format!("cavities[{i}].box[0]"), lo);
            add(format!("cavities[{i}].box[1]"), hi);
        }
        add(format!("cavities[{i}].pressure"), c.pressure.as_slice());
        add(format!("cavities[{i}].volume"), c.volume.as_slice());
    }
    for (i, l) in spec.loads.iter().enumerate() {
        add(format!("loads[{i}].at"), l.at.as_ref().map_or(&[], |v| v));
        add(format!("loads[{i}].force"), &l.force);
    }
    for (list, points) in [
        ("effectors", &spec.effectors),
        ("force_points", &spec.force_points),
    ] {
        for (i, e) in points.iter().enumerate() {
            add(format!("{list}[{i}].at"), &e.at);
            add(
                format!("{list}[{i}].direction"),
                e.direction.as_ref().map_or(&[], |v| v),
            );
        }
    }
    match fields.into_iter().find(|(_, v)| !v.is_finite()) {
        Some((name, v)) => Err(FemError::Model(format!("{name} must be finite, got {v}"))),
        None => Ok(()),
    }
}

//! Model files (TOML): mesh, placement, units, material, mass, gravity, fixed nodes (clamped,
//! or on springs: `base_stiffness`), cables, pressure cavities, loads, effectors and force
//! points. Values are
//! written in the file's units (`units = "SI"` or `"mm-kg-s"` as SOFA scenes: mm, kg, s,
//! hence mN and kPa) and converted to SI on load.
//!
//! ```
//! let text = r#"
//! units = "mm-kg-s"
//! [mesh]
//! path = "robot.vtu"
//! [material]
//! young = 180.0
//! poisson = 0.45
//! "#;
//! let spec: softsense::fem::model::ModelSpec = toml::from_str(text).unwrap();
//! assert_eq!(spec.material.young, 180.0);
//! ```

pub mod check;
mod spec;
pub mod template;

use super::constraint::{ConstraintRow, RowKind};
use super::material::Material;
use super::mesh::{Placement, TetMesh};
use super::meshio::read_mesh;
use super::shell::{read_body, shell_prestress, MarkedMesh};
use super::solve::{
    Cable, CableControl, Formulation, MappedPoint, NewtonParams, PointLoad, Problem,
};
use super::{FemError, FemResult};
use crate::io::InFile;
use serde::Serialize;
use spec::check_finite;
pub use spec::*;
use std::path::{Path, PathBuf};

/// A named effector or force point with its constraint rows.
#[derive(Debug, Clone, Serialize)]
pub struct Effector {
    /// Name.
    pub name: String,
    /// The mapped point.
    pub point: MappedPoint,
    /// Its rows (1 or 3).
    pub rows: Vec<ConstraintRow>,
}

/// A loaded model, SI inside.
#[derive(Debug, Clone)]
pub struct Model {
    /// The static problem.
    pub problem: Problem,
    /// Effectors.
    pub effectors: Vec<Effector>,
    /// Force-point rows (all force points' rows, in order).
    pub force_rows: Vec<ConstraintRow>,
    /// Force points: candidate locations of external forces, with their rows.
    pub force_points: Vec<Effector>,
    /// Newton settings.
    pub newton: NewtonParams,
    /// Units of the file.
    pub units: Units,
}

/// Reads and parses a model file.
fn read_spec(path: &Path) -> FemResult<ModelSpec> {
    // Said before reading, where the OS's "Is a directory" or a UTF-8 error would not say
    // what was given instead of a model file.
    if path.is_dir() {
        return Err(FemError::NotAModel {
            path: path.to_path_buf(),
            problem: "is a folder, not a model file (a TOML such as \
                      meshes/models/robot.toml): if it is the recording, the arguments may \
                      be in the wrong order (see --help)"
                .into(),
        });
    }
    let text = std::fs::read(path).map_err(|source| FemError::File {
        path: path.display().to_string(),
        source,
    })?;
    let text = String::from_utf8(text).map_err(|_| FemError::NotAModel {
        path: path.to_path_buf(),
        problem: "is not a model file: a model file is TOML text (as \
                  meshes/models/robot.toml), and this file is binary (a cloud or a mesh? \
                  a mesh is named by the model file's `mesh.path`)"
            .into(),
    })?;
    let mut spec: ModelSpec =
        toml::from_str(&text).map_err(|e| FemError::Model(format!("{}: {e}", path.display())))?;
    // Resolved here, where the model file's folder is known, as the mesh path is.
    for c in &mut spec.cavities {
        if let Some(s) = &mut c.surface {
            let p = PathBuf::from(expand_env(s).map_err(|e| e.in_file(path))?);
            let p = match p.is_relative() {
                true => path.parent().unwrap_or(Path::new(".")).join(p),
                false => p,
            };
            *s = p.display().to_string();
        }
    }
    Ok(spec)
}

/// The mesh path of `spec`, relative paths taken from the folder of the model file `path`.
fn mesh_path_of(path: &Path, spec: &ModelSpec) -> FemResult<PathBuf> {
    let p = PathBuf::from(expand_env(&spec.mesh.path).map_err(|e| e.in_file(path))?);
    Ok(match p.is_relative() {
        true => path.parent().unwrap_or(Path::new(".")).join(p),
        false => p,
    })
}

/// Expands `${VAR}` from the environment; an unset variable is an error.
pub fn expand_env(s: &str) -> FemResult<String> {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find("${") {
        out.push_str(&rest[..i]);
        let end = rest[i..]
            .find('}')
            .ok_or_else(|| FemError::Model(format!("unclosed ${{ in {s:?}")))?;
        let var = &rest[i + 2..i + end];
        let val = std::env::var(var).map_err(|_| {
            FemError::Model(format!(
                "environment variable {var} is not set (needed by {s:?})"
            ))
        })?;
        out.push_str(&val);
        rest = &rest[i + end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

impl Model {
    /// Loads a model file; `mesh_override` replaces the mesh path.
    pub fn load(path: &Path, mesh_override: Option<&Path>) -> FemResult<Self> {
        let spec = read_spec(path)?;
        // Checked before the mesh is read, where the file can be named.
        newton_params(spec.newton.as_ref()).map_err(|e| match e {
            FemError::Model(m) => FemError::Model(format!("{}: {m}", path.display())),
            other => other,
        })?;
        let mesh_path = match mesh_override {
            Some(p) => p.to_path_buf(),
            None => mesh_path_of(path, &spec)?,
        };
        let body = read_body(&mesh_path, spec.mesh.shell.as_ref(), placement_scale(&spec))?;
        Self::from_body(&spec, body).map_err(|e| e.in_file(path))
    }

    /// Loads a model file on another mesh of the same body, `mesh_path` (in the model
    /// file's units, placed by its `placement`), as the truth of a scene that is not its
    /// model. What the file gives by position is located in the new mesh as in its own
    /// (fixed boxes, cable attachments, loads' `at`); what it gives by node
    /// index (`fixed.nodes`, `loads.node`) moves to the new mesh's node nearest to that
    /// node's rest position in the file's own mesh. The body has no effectors or force
    /// points: those are what an estimator measures, not part of the body, and a point
    /// given for one mesh's surface may fall off another's (a surface normal then has no
    /// direction).
    pub fn load_on_mesh(path: &Path, mesh_path: &Path) -> FemResult<Self> {
        let mut spec = read_spec(path)?;
        spec.effectors.clear();
        spec.force_points.clear();
        newton_params(spec.newton.as_ref()).map_err(|e| e.in_file(path))?;
        let mesh = read_mesh(mesh_path)?;
        if spec.fixed.iter().any(|f| f.marked) {
            // The own mesh's marks, given by index: moved below like `fixed.nodes`.
            let own = read_body(
                &mesh_path_of(path, &spec)?,
                spec.mesh.shell.as_ref(),
                placement_scale(&spec),
            )?;
            for f in spec.fixed.iter_mut().filter(|f| f.marked) {
                f.marked = false;
                f.nodes.get_or_insert_with(Vec::new).extend(&own.marked);
            }
        }
        let by_index = spec.fixed.iter().any(|f| f.nodes.is_some())
            || spec.loads.iter().any(|l| l.node.is_some());
        if by_index {
            let own = read_body(
                &mesh_path_of(path, &spec)?,
                spec.mesh.shell.as_ref(),
                placement_scale(&spec),
            )?
            .mesh;
            let placed = |m: &TetMesh| {
                let mut m = m.clone();
                m.place(&spec.placement);
                m.nodes_in_rest
            };
            let (from, to) = (placed(&own), placed(&mesh));
            let moved = |i: usize| -> FemResult<usize> {
                let p = from.get(i).ok_or_else(|| {
                    FemError::Model(format!(
                        "{}: node {i} is not in its mesh ({} nodes)",
                        path.display(),
                        from.len()
                    ))
                })?;
                Ok(nearest_node(&to, *p))
            };
            for f in &mut spec.fixed {
                if let Some(nodes) = &mut f.nodes {
                    *nodes = nodes.iter().map(|&i| moved(i)).collect::<FemResult<_>>()?;
                }
            }
            for l in &mut spec.loads {
                if let Some(n) = &mut l.node {
                    *n = moved(*n)?;
                }
            }
        }
        Self::from_spec(&spec, mesh).map_err(|e| e.in_file(path))
    }

    /// The model file as written (cavity surface paths resolved against its folder), for
    /// what a loaded [`Model`] no longer says by key: [`check::check`] names the keys.
    pub fn spec_of(path: &Path) -> FemResult<ModelSpec> {
        read_spec(path)
    }

    /// The mesh file a model file names (resolved against the model's folder, `${VAR}`s
    /// expanded), without loading either: to refuse an output that would overwrite it.
    pub fn mesh_file(path: &Path) -> FemResult<PathBuf> {
        let spec = read_spec(path)?;
        mesh_path_of(path, &spec)
    }

    /// Builds a model from a spec and its (unplaced, file-unit) mesh, which marks no nodes.
    pub fn from_spec(spec: &ModelSpec, mesh: TetMesh) -> FemResult<Self> {
        let marked = Vec::new();
        Self::from_body(spec, MarkedMesh { mesh, marked })
    }

    /// Builds a model from a spec and its (unplaced, file-unit) mesh with marked nodes.
    pub fn from_body(spec: &ModelSpec, body: MarkedMesh) -> FemResult<Self> {
        let MarkedMesh { mut mesh, marked } = body;
        check_finite(spec)?;
        let u = Units::parse(&spec.units)?;
        mesh.place(&spec.placement);
        mesh.orient_positive();
        mesh.place(&Placement {
            scale: Some(u.length),
            rotate_deg: None,
            translate: None,
        });
        let quality = mesh.quality()?;
        let diag = super::mesh::norm(super::mesh::sub(quality.bbox[1], quality.bbox[0]));
        // Points given in the file may lie this far outside the mesh.
        let tol = 0.05 * diag;
        let formulation = parse_formulation(spec.formulation.as_deref())?;
        let material = Material::new(spec.material.young * u.pressure, spec.material.poisson)?;
        let mut p = Problem::new(mesh, material, formulation);
        p.fixed = fixed_nodes(&spec.fixed, &p.mesh, &marked, &u)?;
        p.base_stiffness = base_stiffness(spec.base_stiffness, &u)?;
        if let Some(m) = &spec.mass {
            p.density = density(m, quality.volume, &u)?;
        }
        if let Some(g) = spec.gravity {
            p.gravity = u.point(g);
        }
        p.cables = (spec.cables.iter())
            .map(|c| cable(c, &p.mesh, &u, tol))
            .collect::<FemResult<_>>()?;
        p.young_scale = young_scale(spec, &p.mesh, &u)?;
        if let Some(shell) = spec.mesh.shell.as_ref().filter(|s| s.tension != 0.0) {
            let tension = shell.tension * u.force / u.length;
            let thickness = shell.thickness * u.length;
            p.prestress = shell_prestress(&p.mesh, shell.layers, tension, thickness)?;
        }
        p.shell = spec.mesh.shell.map(|s| super::shell::ShellParams {
            thickness: s.thickness * u.length,
            tension: s.tension * u.force / u.length,
            ..s
        });
        p.cavities = (spec.cavities.iter())
            .map(|c| super::cavity::from_spec(c, &p.mesh, &spec.placement, &u, tol))
            .collect::<FemResult<_>>()?;
        p.loads = (spec.loads.iter())
            .map(|ld| load(ld, &p.mesh, &u, tol))
            .collect::<FemResult<_>>()?;
        let points = PointRows::new(spec, &p.mesh, &u, tol);
        let effectors = (spec.effectors.iter())
            .map(|e| points.effector(RowKind::Effector, e))
            .collect::<FemResult<Vec<_>>>()?;
        let force_points = (spec.force_points.iter())
            .map(|e| points.effector(RowKind::Force, e))
            .collect::<FemResult<Vec<_>>>()?;
        let force_rows = (force_points.iter())
            .flat_map(|e| e.rows.iter().cloned())
            .collect();
        Ok(Self {
            problem: p,
            effectors,
            force_rows,
            force_points,
            newton: newton_params(spec.newton.as_ref())?,
            units: u,
        })
    }

    /// A warning when a small-strain solution's largest nodal displacement exceeds
    /// [`SMALL_STRAIN_LIMIT`] of the mesh's bounding-box diagonal: linear elasticity
    /// about the rest shape is then outside its validity (a 10 kN load on a 125 mm robot
    /// "converged" to a 225 m tip displacement). `None` for corotational models.
    pub fn validity_warning(&self, displacement: &[[f64; 3]]) -> Option<String> {
        if self.problem.formulation != Formulation::SmallStrain {
            return None;
        }
        let nodes = &self.problem.mesh.nodes_in_rest;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in nodes {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let size = super::mesh::norm(super::mesh::sub(hi, lo));
        let max = displacement
            .iter()
            .map(|d| super::mesh::norm(*d))
            .fold(0.0, f64::max);
        (max > SMALL_STRAIN_LIMIT * size).then(|| {
            format!(
                "small-strain displacement of {max:.3e} m is over {:.0}% of the mesh's \
                 {size:.3e} m size: the result is outside small strain's validity; try \
                 formulation = \"corotational\"",
                100.0 * SMALL_STRAIN_LIMIT
            )
        })
    }

    /// All constraint rows at positions `x`: effectors, then actuators (cables, then
    /// cavities), then forces.
    pub fn rows(&self, x: &[[f64; 3]]) -> Vec<ConstraintRow> {
        let mut rows: Vec<ConstraintRow> = self
            .effectors
            .iter()
            .flat_map(|e| e.rows.iter().cloned())
            .collect();
        rows.extend(
            self.problem
                .cables
                .iter()
                .map(|c| ConstraintRow::cable(c, x)),
        );
        rows.extend((self.problem.cavities.iter()).map(|c| ConstraintRow::cavity(c, x)));
        rows.extend(self.force_rows.iter().cloned());
        rows
    }
}

impl Units {
    /// A point or vector in file units, in SI.
    fn point(&self, p: [f64; 3]) -> [f64; 3] {
        p.map(|c| c * self.length)
    }
}

/// The largest small-strain displacement, as a fraction of the mesh's bounding-box
/// diagonal, before [`Model::validity_warning`] speaks.
pub const SMALL_STRAIN_LIMIT: f64 = 0.1;

/// The formulation a model file names (default corotational).
fn parse_formulation(name: Option<&str>) -> FemResult<Formulation> {
    match name {
        None => Ok(Formulation::Corotational),
        Some(f) => Formulation::from_name(f).ok_or_else(|| {
            FemError::Model(format!(
                "unknown formulation {f:?}: use \"corotational\", \"small-strain\" or \"neo-hookean\""
            ))
        }),
    }
}

/// The fixed nodes of the selections, sorted, without repeats.
fn fixed_nodes(
    specs: &[FixedSpec],
    mesh: &TetMesh,
    marked: &[usize],
    u: &Units,
) -> FemResult<Vec<usize>> {
    let mut fixed = Vec::new();
    for (i, f) in specs.iter().enumerate() {
        if f.marked && marked.is_empty() {
            return Err(FemError::Model(
                "fixed marked = true, but the mesh file marks no nodes (no vertex cells)".into(),
            ));
        }
        if f.marked {
            fixed.extend_from_slice(marked);
        }
        if let Some([lo, hi]) = f.r#box {
            let nodes = mesh.nodes_in_box(u.point(lo), u.point(hi));
            // An empty box fixed nothing and said nothing: the body then floated, or hung
            // by the other boxes alone, until a solve called it singular, or never did.
            if nodes.is_empty() {
                let [a, b] = mesh.bbox().map(|p| p.map(|c| c / u.length));
                return Err(FemError::Model(format!(
                    "fixed[{i}].box = {lo:?} - {hi:?} selects no node: the mesh's nodes span \
                     {a:?} - {b:?} (file units, after placement)"
                )));
            }
            fixed.extend(nodes);
        }
        if let Some(n) = &f.nodes {
            fixed.extend(n.iter().copied());
        }
    }
    fixed.sort_unstable();
    fixed.dedup();
    Ok(fixed)
}

/// The placement's length scale (1 if absent).
fn placement_scale(spec: &ModelSpec) -> f64 {
    spec.placement.scale.unwrap_or(1.0)
}

/// The base stiffness in N/m from file units, refused unless positive.
fn base_stiffness(k: Option<f64>, u: &Units) -> FemResult<Option<f64>> {
    match k {
        Some(k) if !(k > 0.0) => Err(FemError::Model(format!(
            "base_stiffness = {k}: must be positive (leave it out for a clamped base)"
        ))),
        k => Ok(k.map(|k| k * u.force / u.length)),
    }
}

/// The node of `nodes` nearest to `p` (the first of equals; 0 for no nodes).
fn nearest_node(nodes: &[[f64; 3]], p: [f64; 3]) -> usize {
    let d2 = |q: &[f64; 3]| (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>();
    (0..nodes.len())
        .min_by(|&a, &b| d2(&nodes[a]).total_cmp(&d2(&nodes[b])))
        .unwrap_or(0)
}

/// The mass density (kg/m^3) from a total mass over the mesh's `volume` or a density.
fn density(m: &MassSpec, volume: f64, u: &Units) -> FemResult<f64> {
    let density = match (m.total, m.density) {
        (Some(t), None) => t / volume,
        (None, Some(d)) => d * u.density,
        _ => {
            return Err(FemError::Model(
                "mass needs exactly one of total or density".into(),
            ))
        }
    };
    if !(density >= 0.0 && density.is_finite()) {
        return Err(FemError::Model(format!(
            "mass density {density} is invalid"
        )));
    }
    Ok(density)
}

/// A cable, its attach points located in `mesh` (within `tol`).
fn cable(c: &CableSpec, mesh: &TetMesh, u: &Units, tol: f64) -> FemResult<Cable> {
    let control = match (c.shorten, c.force) {
        (Some(d), None) => CableControl::Displacement(d * u.length),
        (None, Some(f)) => CableControl::Force(f * u.force),
        (None, None) => CableControl::Force(0.0),
        _ => {
            return Err(FemError::Model(format!(
                "cable {}: give shorten or force, not both",
                c.name
            )))
        }
    };
    if c.attach.is_empty() {
        return Err(FemError::Model(format!(
            "cable {} has no attach point",
            c.name
        )));
    }
    let attach = (c.attach.iter())
        .map(|a| MappedPoint::locate(mesh, u.point(*a), tol))
        .collect::<FemResult<Vec<_>>>()?;
    Ok(Cable {
        name: c.name.clone(),
        pull: u.point(c.pull),
        attach,
        control,
    })
}

/// Each tetrahedron's factor on `material.young` from the regions (the last region that
/// holds its centroid wins); empty without regions.
fn young_scale(spec: &ModelSpec, mesh: &TetMesh, u: &Units) -> FemResult<Vec<f64>> {
    if spec.regions.is_empty() {
        return Ok(Vec::new());
    }
    if let Some(r) = spec
        .regions
        .iter()
        .find(|r| !(r.young > 0.0 && r.young.is_finite()))
    {
        return Err(FemError::Model(format!(
            "region young = {}: must be positive",
            r.young
        )));
    }
    let centroid = |t: &[usize; 4]| {
        let c = (0..3).map(|k| t.iter().map(|&v| mesh.nodes_in_rest[v][k]).sum::<f64>() / 4.0);
        let c: Vec<f64> = c.collect();
        [c[0], c[1], c[2]]
    };
    Ok((mesh.tets.iter())
        .map(|t| {
            let c = centroid(t);
            let inside = |r: &&RegionSpec| {
                let (lo, hi) = (u.point(r.r#box[0]), u.point(r.r#box[1]));
                (0..3).all(|k| c[k] >= lo[k] && c[k] <= hi[k])
            };
            spec.regions
                .iter()
                .rev()
                .find(inside)
                .map_or(1.0, |r| r.young / spec.material.young)
        })
        .collect())
}

/// A point load, at a located point or a node.
fn load(ld: &LoadSpec, mesh: &TetMesh, u: &Units, tol: f64) -> FemResult<PointLoad> {
    let at = match (ld.at, ld.node) {
        (Some(a), None) => MappedPoint::locate(mesh, u.point(a), tol)?,
        (None, Some(n)) if n < mesh.num_nodes() => MappedPoint::node(n),
        _ => {
            return Err(FemError::Model(
                "a load needs `at` or a valid `node`".into(),
            ))
        }
    };
    Ok(PointLoad {
        at,
        force: ld.force.map(|f| f * u.force),
    })
}

/// Newton options: the defaults with the file's overrides, checked.
fn newton_params(spec: Option<&NewtonSpec>) -> FemResult<NewtonParams> {
    let mut newton = NewtonParams::default();
    if let Some(n) = spec {
        newton.max_iterations = n.max_iterations.unwrap_or(newton.max_iterations);
        newton.load_steps = n.load_steps.unwrap_or(newton.load_steps);
        newton.rel_tol = n.rel_tol.unwrap_or(newton.rel_tol);
    }
    newton.validate()?;
    Ok(newton)
}

/// Locates effectors and force points and builds their rows.
struct PointRows<'m> {
    mesh: &'m TetMesh,
    units: &'m Units,
    tol: f64,
    /// The mesh surface, if any point is measured along the surface normal.
    surface: Option<super::mesh::Surface>,
}

impl<'m> PointRows<'m> {
    fn new(spec: &ModelSpec, mesh: &'m TetMesh, units: &'m Units, tol: f64) -> Self {
        let normal = (spec.effectors.iter())
            .chain(&spec.force_points)
            .any(|e| e.normal);
        Self {
            mesh,
            units,
            tol,
            surface: normal.then(|| mesh.surface()),
        }
    }

    /// The located point of `e` with its rows of `kind`: along the surface normal, along
    /// its direction, or x, y and z.
    fn effector(&self, kind: RowKind, e: &PointSpec) -> FemResult<Effector> {
        let at = MappedPoint::locate(self.mesh, self.units.point(e.at), self.tol)?;
        let rows = if e.normal {
            let s = (self.surface.as_ref()).ok_or_else(|| FemError::Model("no surface".into()))?;
            let mut n = [0.0; 3];
            for (v, w) in at.nodes.iter().zip(at.weights) {
                for (nk, sk) in n.iter_mut().zip(s.vertex_normals[*v]) {
                    *nk += w * sk;
                }
            }
            vec![ConstraintRow::along(kind, &at, n)?]
        } else if let Some(d) = e.direction {
            vec![ConstraintRow::along(kind, &at, d)?]
        } else {
            ConstraintRow::point3(kind, &at)
        };
        Ok(Effector {
            name: e.name.clone(),
            point: at,
            rows,
        })
    }
}

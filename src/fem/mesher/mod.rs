//! Tetrahedra inside a closed surface, made by gmsh (a maintained mesher, GPL-2.0-or-later
//! with a linking exception; run as a separate Python process, so nothing of it is linked
//! into softsense). `pip install gmsh` (or the Python package's `mesh` extra) provides it.
//!
//! The surface is checked first ([`crate::geometry::closed`]): gmsh given a hole or a
//! crossing fails deep inside, or meshes the wrong region.

use super::mesh::{QualityReport, TetMesh};
use super::{FemError, FemResult};
use crate::geometry::closed::ClosedSurface;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The script handed to the interpreter (kept in its own file for reading and linting).
const SCRIPT: &str = include_str!("gmsh_tets.py");

/// How to mesh.
#[derive(Debug, Clone, Serialize)]
pub struct MesherParams {
    /// Target tetrahedron edge length (the surface's length unit). Default: 1/20 of the
    /// bounding-box diagonal.
    pub size: Option<f64>,
    /// Smallest dihedral angle a tetrahedron should have (degrees); fewer are counted and
    /// reported. Default 5.
    pub min_dihedral_deg: f64,
    /// Largest circumradius-to-shortest-edge ratio a tetrahedron should have; more are
    /// counted and reported. Default 3 (TetGen's `-q` uses 2; a regular one has 0.61).
    pub max_radius_edge: f64,
    /// Keep the surface's triangles as the mesh's boundary instead of remeshing it to the
    /// size. Default false.
    pub keep_surface: bool,
    /// The Python interpreter that has gmsh. Default: `$SOFTSENSE_PYTHON`, else `python3`.
    pub python: String,
}

impl Default for MesherParams {
    fn default() -> Self {
        Self {
            size: None,
            min_dihedral_deg: 5.0,
            max_radius_edge: 3.0,
            keep_surface: false,
            python: std::env::var("SOFTSENSE_PYTHON").unwrap_or_else(|_| "python3".into()),
        }
    }
}

/// A tetrahedral mesh and how it came out.
#[derive(Debug, Clone)]
pub struct Meshed {
    /// The mesh (the surface's length unit).
    pub mesh: TetMesh,
    /// Its quality.
    pub quality: QualityReport,
    /// The size used (length unit).
    pub size: f64,
    /// Tetrahedra with a dihedral angle below the limit.
    pub below_min_dihedral: usize,
    /// Tetrahedra with a radius-edge ratio above the limit.
    pub above_max_radius_edge: usize,
    /// Whether the surface was remeshed to the size (false: its triangles were kept).
    pub surface_remeshed: bool,
    /// gmsh's version.
    pub gmsh_version: String,
    /// Seconds gmsh took.
    pub seconds: f64,
}

#[derive(Deserialize)]
struct ScriptResult {
    gmsh: String,
    surface_remeshed: bool,
    seconds: f64,
}

/// Meshes the solid inside `surface` (its first shell the outer skin, any others cavities),
/// using `work_dir` for gmsh's input and output files.
pub fn tetrahedralise(
    surface: &ClosedSurface,
    params: &MesherParams,
    work_dir: &Path,
) -> FemResult<Meshed> {
    let (lo, hi) = bounds(&surface.vertices);
    let diagonal = crate::math::norm(crate::math::sub(hi, lo));
    let size = params.size.unwrap_or(diagonal / 20.0);
    if !(size > 0.0 && size.is_finite()) {
        return Err(FemError::Mesher(format!(
            "element size {size} must be positive"
        )));
    }
    if size < diagonal / 400.0 {
        return Err(FemError::Mesher(format!(
            "element size {size:.4} is under 1/400 of the body's {diagonal:.4} diagonal: \
             some 10^8 tetrahedra; is it in the surface's unit?"
        )));
    }
    let file = |name: &str| -> PathBuf { work_dir.join(name) };
    let write = |path: &Path, bytes: &[u8]| {
        std::fs::write(path, bytes).map_err(|source| FemError::File {
            path: path.display().to_string(),
            source,
        })
    };
    let mut shells = Vec::new();
    for (k, shell) in surface.shells.iter().enumerate() {
        let tris: Vec<[usize; 3]> = shell
            .triangles
            .iter()
            .map(|&f| surface.triangles[f])
            .collect();
        let path = file(&format!("shell_{k}.stl"));
        write(
            &path,
            &super::surfaceio::stl_bytes(&surface.vertices, &tris),
        )?;
        shells.push(path.display().to_string());
    }
    let (script, out, result) = (
        file("gmsh_tets.py"),
        file("mesh.msh"),
        file("gmsh_result.json"),
    );
    write(&script, SCRIPT.as_bytes())?;
    let job = serde_json::json!({
        "shells": shells,
        "size": size,
        "keep_surface": params.keep_surface,
        "out": out.display().to_string(),
        "result": result.display().to_string(),
    });
    let job_path = file("gmsh_job.json");
    write(&job_path, job.to_string().as_bytes())?;
    run_script(&params.python, &script, &job_path)?;
    let text = std::fs::read_to_string(&result).map_err(|source| FemError::File {
        path: result.display().to_string(),
        source,
    })?;
    let r: ScriptResult = serde_json::from_str(&text)
        .map_err(|e| FemError::Mesher(format!("gmsh's result file: {e}")))?;
    let mut mesh = super::meshio::read_mesh(&out)?;
    mesh.orient_positive();
    let quality = mesh.quality()?;
    let (mut below, mut above) = (0, 0);
    for t in 0..mesh.tets.len() {
        let c = mesh.corners(t);
        below +=
            usize::from(super::tet_quality::dihedral_range_deg(&c)[0] < params.min_dihedral_deg);
        above += usize::from(super::tet_quality::radius_edge(&c) > params.max_radius_edge);
    }
    Ok(Meshed {
        mesh,
        quality,
        size,
        below_min_dihedral: below,
        above_max_radius_edge: above,
        surface_remeshed: r.surface_remeshed,
        gmsh_version: r.gmsh,
        seconds: r.seconds,
    })
}

/// Runs the script, turning a missing interpreter or gmsh into the install line.
fn run_script(python: &str, script: &Path, job: &Path) -> FemResult<()> {
    let install = "install it with `pip install gmsh` (or `pip install 'softsense[mesh]'`), \
                   or name an interpreter that has it with --python or SOFTSENSE_PYTHON";
    let output = Command::new(python)
        .arg(script)
        .arg(job)
        .output()
        .map_err(|e| {
            FemError::Mesher(format!(
                "cannot run {python:?} ({e}): meshing needs Python with gmsh; {install}"
            ))
        })?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    let last = stderr
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .trim();
    match output.status.code() {
        Some(0) => Ok(()),
        Some(3) => Err(FemError::Mesher(format!("{last}: {install}"))),
        _ => Err(FemError::Mesher(format!(
            "{python} {}: {last}",
            script.display()
        ))),
    }
}

fn bounds(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

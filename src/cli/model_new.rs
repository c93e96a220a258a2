//! `softsense model new SURFACE --out DIR`: a model folder from a CAD surface.

use super::{CliError, CliResult};
use clap::Args;
use softsense::fem::mesh::TetMesh;
use softsense::fem::mesher::{tetrahedralise, MesherParams};
use softsense::fem::model::template::ModelTemplate;
use softsense::fem::model::{CableSpec, Model};
use softsense::fem::surfaceio::{read_triangles, stl_bytes, Triangle};
use softsense::geometry::closed::{close_surface, ClosedSurface};
use softsense::io::InFile;
use std::path::{Path, PathBuf};

/// Meshes a closed surface into tetrahedra and writes a commented model file.
#[derive(Args, Debug)]
#[command(after_long_help = "Examples:\n  \
softsense model new finger.stl --out finger --young 18000 --fixed-box=-5,0,0,10,15,20 --cable cable.json\n  \
softsense model new pneunet.stl --out pneunet --young 500 --poisson 0.3 --fixed-above x=-10 --cavity cavity.stl \
--region=-100,22.5,-8,-19,28,8=1500\n\n\
Writes DIR/model.toml (every key commented), DIR/mesh.vtu, DIR/cavity_NAME.stl for each \
cavity and DIR/report.json (mesh quality, gmsh's version and time). Meshing needs Python \
with gmsh: `pip install gmsh`.")]
pub struct NewArgs {
    /// The robot's closed surface (STL binary or ASCII, OBJ, PLY), or a volume mesh
    /// (VTK, VTU, Gmsh MSH) taken as it is.
    pub surface: PathBuf,
    /// The folder to write; it must be new or empty.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Young's modulus, in the model's pressure unit: kPa for mm-kg-s, Pa for SI.
    #[arg(long)]
    pub young: f64,
    /// Poisson ratio (silicones: 0.45-0.49; linear tetrahedra stiffen near 0.5).
    #[arg(long, default_value_t = 0.45)]
    pub poisson: f64,
    /// Density in kg/m^3, whatever the units (silicones: 1070-1240).
    #[arg(long, default_value_t = 1070.0)]
    pub density: f64,
    /// The body's total mass in kg (weighed), spread by volume, instead of --density.
    #[arg(long, conflicts_with = "density")]
    pub mass: Option<f64>,
    /// The surface's unit system: mm-kg-s (CAD's millimetres) or SI (metres).
    #[arg(long, default_value = "mm-kg-s", value_parser = ["mm-kg-s", "SI"])]
    pub units: String,
    /// Gravity as X,Y,Z in the length unit per s^2 (default: 9.81 m/s^2 along -z).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub gravity: Option<[f64; 3]>,
    /// Clamp the nodes in a box X0,Y0,Z0,X1,Y1,Z1 (length unit); repeatable.
    #[arg(long, value_parser = parse_box, allow_hyphen_values = true)]
    pub fixed_box: Vec<[[f64; 3]; 2]>,
    /// Clamp the nodes at or below a coordinate, as AXIS=VALUE (e.g. z=2); repeatable.
    #[arg(long, value_parser = parse_axis_value, allow_hyphen_values = true)]
    pub fixed_below: Vec<(usize, f64)>,
    /// Clamp the nodes at or above a coordinate, as AXIS=VALUE (e.g. x=-10); repeatable.
    #[arg(long, value_parser = parse_axis_value, allow_hyphen_values = true)]
    pub fixed_above: Vec<(usize, f64)>,
    /// A cable: a JSON list of points [[x,y,z], ...] (the first is the pull point), or
    /// {"name", "pull", "attach"}; repeatable.
    #[arg(long, value_name = "PATH.json")]
    pub cable: Vec<PathBuf>,
    /// A pressure cavity's closed surface (STL, OBJ, PLY); a hole in the body if the robot's
    /// surface does not already hold it; repeatable.
    #[arg(long, value_name = "SURFACE")]
    pub cavity: Vec<PathBuf>,
    /// An effector NAME=X,Y,Z (length unit); default: "tip", the node farthest from the
    /// fixed nodes.
    #[arg(long, value_parser = parse_effector, allow_hyphen_values = true)]
    pub effector: Vec<(String, [f64; 3])>,
    /// A part of another Young's modulus, X0,Y0,Z0,X1,Y1,Z1=YOUNG: the tetrahedra whose
    /// centroid is in the box (e.g. a strain-limiting layer); repeatable.
    #[arg(long, value_parser = parse_region, allow_hyphen_values = true)]
    pub region: Vec<([[f64; 3]; 2], f64)>,
    /// Target tetrahedron edge length (length unit); default 1/20 of the diagonal.
    #[arg(long)]
    pub size: Option<f64>,
    /// Tetrahedra with a dihedral angle below this (degrees) are counted and reported.
    #[arg(long, default_value_t = 5.0)]
    pub min_dihedral: f64,
    /// Tetrahedra with a radius-edge ratio above this are counted and reported.
    #[arg(long, default_value_t = 3.0)]
    pub max_radius_edge: f64,
    /// Keep the surface's triangles as the mesh boundary (no remeshing to --size).
    #[arg(long)]
    pub keep_surface: bool,
    /// The Python interpreter with gmsh (default: $SOFTSENSE_PYTHON, else python3).
    #[arg(long)]
    pub python: Option<String>,
}

fn parse_numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let v: Vec<f64> = (s.split(','))
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("{x:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let v: [f64; N] = v
        .try_into()
        .map_err(|v: Vec<f64>| format!("{} numbers given, {N} expected", v.len()))?;
    match v.iter().all(|x| x.is_finite()) {
        true => Ok(v),
        false => Err("numbers must be finite".into()),
    }
}

/// X,Y,Z as three finite numbers (also `softsense pose`'s points).
pub(super) fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    parse_numbers::<3>(s)
}

fn parse_box(s: &str) -> Result<[[f64; 3]; 2], String> {
    let v = parse_numbers::<6>(s)?;
    let b = [[v[0], v[1], v[2]], [v[3], v[4], v[5]]];
    match (0..3).all(|k| b[0][k] <= b[1][k]) {
        true => Ok(b),
        false => Err("the first corner must be the smaller one on every axis".into()),
    }
}

fn parse_axis_value(s: &str) -> Result<(usize, f64), String> {
    let (axis, value) = s.split_once('=').ok_or("give AXIS=VALUE, e.g. z=2")?;
    let axis = ["x", "y", "z"]
        .iter()
        .position(|a| a.eq_ignore_ascii_case(axis.trim()))
        .ok_or(format!("axis {axis:?} is not x, y or z"))?;
    let v: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("{value:?} is not a number"))?;
    Ok((axis, v))
}

fn parse_region(s: &str) -> Result<([[f64; 3]; 2], f64), String> {
    let (b, young) = s.split_once('=').ok_or("give X0,Y0,Z0,X1,Y1,Z1=YOUNG")?;
    let young: f64 = young
        .trim()
        .parse()
        .map_err(|_| format!("{young:?} is not a number"))?;
    match young > 0.0 && young.is_finite() {
        true => Ok((parse_box(b)?, young)),
        false => Err("the region's modulus must be positive".into()),
    }
}

fn parse_effector(s: &str) -> Result<(String, [f64; 3]), String> {
    let (name, at) = s
        .split_once('=')
        .ok_or("give NAME=X,Y,Z, e.g. tip=0,0,90")?;
    Ok((name.trim().to_string(), parse_vec3(at)?))
}

/// Runs `softsense model new`.
pub fn run(args: &NewArgs) -> CliResult {
    let mut inputs: Vec<&Path> = vec![&args.surface];
    inputs.extend(args.cable.iter().map(PathBuf::as_path));
    inputs.extend(args.cavity.iter().map(PathBuf::as_path));
    let staged = super::staged_output_dir(&args.out, &inputs, false)?;
    let dir = staged.path().to_path_buf();
    let ext = (args.surface.extension().and_then(|e| e.to_str()))
        .unwrap_or("")
        .to_ascii_lowercase();
    let volume_mesh = matches!(ext.as_str(), "vtk" | "vtu" | "msh");
    let cavities = read_cavities(&args.cavity)?;
    let (mesh, report) = match volume_mesh {
        true => (softsense::fem::meshio::read_mesh(&args.surface)?, None),
        false => {
            let (mesh, report) = mesh_surface(args, &cavities, &dir)?;
            (mesh, Some(report))
        }
    };
    warn_units(args, &mesh);
    let mut template = template(args, &mesh, &ext)?;
    for (name, surface) in &cavities {
        let file = format!("cavity_{name}.stl");
        write(
            &dir.join(&file),
            &stl_bytes(&surface.vertices, &surface.triangles),
        )?;
        template.cavities.push((name.clone(), file));
    }
    softsense::fem::meshio::write_vtu(
        &dir.join("mesh.vtu"),
        &mesh.nodes_in_rest,
        &mesh.tets,
        &[],
        &[],
    )?;
    let model_path = dir.join("model.toml");
    write(&model_path, template.to_toml().as_bytes())?;
    // What was written must load: a key the loader refuses is found here, not later.
    let model = Model::load(&model_path, None)
        .map_err(|e| CliError::Result(format!("the written model does not load: {e}")))?;
    if let Some(r) = &report {
        write(
            &dir.join("report.json"),
            serde_json::to_string_pretty(r)
                .unwrap_or_default()
                .as_bytes(),
        )?;
    }
    for f in [
        "shell_0.stl",
        "gmsh_tets.py",
        "gmsh_job.json",
        "gmsh_result.json",
        "mesh.msh",
    ] {
        let _ = std::fs::remove_file(dir.join(f));
    }
    for k in 1..64 {
        let _ = std::fs::remove_file(dir.join(format!("shell_{k}.stl")));
    }
    staged.commit().map_err(super::output_error)?;
    print_summary(args, &model, report.as_ref())
}

/// Each cavity's closed surface with its name (the file stem), refused with the reason.
fn read_cavities(paths: &[PathBuf]) -> Result<Vec<(String, ClosedSurface)>, CliError> {
    let mut out: Vec<(String, ClosedSurface)> = Vec::new();
    for p in paths {
        let soup = read_triangles(p)?;
        let closed = close_surface(&soup, 0.0)
            .map_err(|e| CliError::Result(format!("--cavity {}: {e}", p.display())))?;
        let stem = (p.file_stem()).map_or("cavity".into(), |s| s.to_string_lossy().into_owned());
        let mut name: String = stem
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        while out.iter().any(|(n, _)| *n == name) {
            name.push('_');
        }
        out.push((name, closed));
    }
    Ok(out)
}

/// What meshing reports (report.json).
#[derive(Debug, serde::Serialize)]
struct MeshReport {
    source: String,
    size: f64,
    nodes: usize,
    tetrahedra: usize,
    min_dihedral_deg: f64,
    max_dihedral_deg: f64,
    max_radius_edge: f64,
    min_dihedral_limit_deg: f64,
    max_radius_edge_limit: f64,
    below_min_dihedral: usize,
    above_max_radius_edge: usize,
    shells: usize,
    collapsed_triangles_dropped: usize,
    triangles_reoriented: usize,
    surface_remeshed: bool,
    gmsh_version: String,
    gmsh_seconds: f64,
}

/// The surface checked (holes, crossings; with any cavity not already in it), then meshed.
fn mesh_surface(
    args: &NewArgs,
    cavities: &[(String, ClosedSurface)],
    dir: &Path,
) -> Result<(TetMesh, MeshReport), CliError> {
    let mut soup: Vec<Triangle> = read_triangles(&args.surface)?;
    let own = close_surface(&soup, 0.0)
        .map_err(|e| CliError::Result(format!("{}: {e}", args.surface.display())))?;
    for (name, c) in cavities {
        if !already_holds(&own, c) {
            soup.extend(c.triangles.iter().map(|t| t.map(|i| c.vertices[i])));
            eprintln!(
                "model new: cavity {name} is not in {}: it is cut out of the body as a hole",
                args.surface.display()
            );
        }
    }
    let surface = close_surface(&soup, 0.0).map_err(|e| {
        CliError::Result(format!("{} with its cavities: {e}", args.surface.display()))
    })?;
    let params = MesherParams {
        size: args.size,
        min_dihedral_deg: args.min_dihedral,
        max_radius_edge: args.max_radius_edge,
        keep_surface: args.keep_surface,
        python: args
            .python
            .clone()
            .unwrap_or_else(|| MesherParams::default().python),
    };
    eprintln!(
        "model new: meshing {} ({} triangles, {} shell(s)) with gmsh ...",
        args.surface.display(),
        surface.triangles.len(),
        surface.shells.len()
    );
    // gmsh's input and output files, removed once read.
    let work = dir.join("gmsh");
    std::fs::create_dir_all(&work)
        .map_err(|e| CliError::Result(format!("{}: {e}", work.display())))?;
    let m = tetrahedralise(&surface, &params, &work).map_err(|e| e.in_file(&args.surface))?;
    let _ = std::fs::remove_dir_all(&work);
    let q = &m.quality;
    let report = MeshReport {
        source: args.surface.display().to_string(),
        size: m.size,
        nodes: q.nodes,
        tetrahedra: q.tets,
        min_dihedral_deg: q.min_dihedral_deg,
        max_dihedral_deg: q.max_dihedral_deg,
        max_radius_edge: q.max_radius_edge,
        min_dihedral_limit_deg: args.min_dihedral,
        max_radius_edge_limit: args.max_radius_edge,
        below_min_dihedral: m.below_min_dihedral,
        above_max_radius_edge: m.above_max_radius_edge,
        shells: surface.shells.len(),
        collapsed_triangles_dropped: surface.collapsed,
        triangles_reoriented: surface.flipped,
        surface_remeshed: m.surface_remeshed,
        gmsh_version: m.gmsh_version,
        gmsh_seconds: m.seconds,
    };
    Ok((m.mesh, report))
}

/// Whether every corner of `cavity` is a corner of `surface` (it is one of its shells).
fn already_holds(surface: &ClosedSurface, cavity: &ClosedSurface) -> bool {
    let tol = 1e-6 * diagonal(&surface.vertices);
    let key = |p: &[f64; 3]| p.map(|c| (c / tol).round() as i64);
    let corners: std::collections::HashSet<[i64; 3]> = surface.vertices.iter().map(key).collect();
    cavity.vertices.iter().all(|p| corners.contains(&key(p)))
}

fn diagonal(points: &[[f64; 3]]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    softsense::math::norm(softsense::math::sub(hi, lo)).max(f64::MIN_POSITIVE)
}

/// Warns when the mesh's size or the modulus does not fit the unit system.
fn warn_units(args: &NewArgs, mesh: &TetMesh) {
    let d = diagonal(&mesh.nodes_in_rest);
    let si = args.units == "SI";
    if !si && d < 2.0 {
        eprintln!("warning: the mesh is {d:.3} mm across: if the surface is in metres, give --units SI (or scale it by 1000)");
    }
    if si && d > 5.0 {
        eprintln!("warning: the mesh is {d:.1} m across: if the surface is in millimetres, give --units mm-kg-s");
    }
    if si && args.young < 1e3 {
        eprintln!("warning: --young {} Pa is softer than any silicone: with --units SI the modulus is in Pa (a kPa value needs x1000)", args.young);
    }
    if !si && args.young > 1e5 {
        eprintln!("warning: --young {} kPa is 100 MPa or more: with mm-kg-s the modulus is in kPa (a Pa value needs /1000)", args.young);
    }
}

fn write(path: &Path, bytes: &[u8]) -> CliResult {
    softsense::io::atomic::write(path, bytes).map_err(|e| CliError::Result(e.to_string()))
}

/// The model file's content: material, mass, gravity, fixed boxes, cables, effectors.
fn template(args: &NewArgs, mesh: &TetMesh, ext: &str) -> Result<ModelTemplate, CliError> {
    let [lo, hi] = mesh.bbox();
    let margin = 1e-6 * diagonal(&mesh.nodes_in_rest);
    let mut fixed: Vec<([[f64; 3]; 2], String)> = Vec::new();
    for (k, b) in args.fixed_box.iter().enumerate() {
        fixed.push((*b, format!("--fixed-box {}", k + 1)));
    }
    for (flag, list, side) in [
        ("below", &args.fixed_below, 1),
        ("above", &args.fixed_above, 0),
    ] {
        for &(axis, v) in list {
            let mut b = [lo.map(|c| c - margin), hi.map(|c| c + margin)];
            b[side][axis] = if side == 1 { v + margin } else { v - margin };
            fixed.push((b, format!("--fixed-{flag} {}={v}", ["x", "y", "z"][axis])));
        }
    }
    if fixed.is_empty() {
        return Err(CliError::Usage("no fixed nodes: give --fixed-box, --fixed-below or --fixed-above (where the robot is clamped); a body held by nothing cannot be solved".into()));
    }
    let mut fixed_nodes = Vec::new();
    for (b, why) in &fixed {
        let nodes = mesh.nodes_in_box(b[0], b[1]);
        if nodes.is_empty() {
            return Err(CliError::Usage(format!(
                "{why} selects no node: the mesh spans x {:.3} to {:.3}, y {:.3} to {:.3}, z {:.3} to {:.3}",
                lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
            )));
        }
        if nodes.len() == mesh.num_nodes() {
            return Err(CliError::Usage(format!(
                "{why} selects every node: nothing would move (the mesh spans x {:.3} to {:.3}, y {:.3} to {:.3}, z {:.3} to {:.3})",
                lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
            )));
        }
        fixed_nodes.extend(nodes);
    }
    let cables = (args.cable.iter().enumerate())
        .map(|(k, p)| read_cable(p, k, mesh))
        .collect::<Result<Vec<_>, _>>()?;
    let mut effectors = args.effector.clone();
    if effectors.is_empty() {
        effectors.push(("tip".into(), farthest_node(mesh, &fixed_nodes)));
    }
    let length = if args.units == "SI" { 1.0 } else { 1e3 };
    Ok(ModelTemplate {
        units: args.units.clone(),
        mesh: "mesh.vtu".into(),
        source: match ext {
            "vtk" | "vtu" | "msh" => format!("the volume mesh {}", args.surface.display()),
            _ => format!("the surface {}, meshed by gmsh", args.surface.display()),
        },
        young: args.young,
        poisson: args.poisson,
        density_si: args.density,
        total_mass: args.mass,
        gravity: args.gravity.unwrap_or([0.0, 0.0, -9.81 * length]),
        fixed,
        cables,
        cavities: Vec::new(),
        effectors,
        regions: args.region.clone(),
    })
}

/// The free end of a finger: the centroid of the nodes farthest from the fixed nodes'
/// centroid (within 2% of the diagonal of the farthest).
fn farthest_node(mesh: &TetMesh, fixed: &[usize]) -> [f64; 3] {
    let c = centroid(fixed.iter().map(|&v| &mesh.nodes_in_rest[v]));
    let d = |p: &[f64; 3]| softsense::math::norm(softsense::math::sub(*p, c));
    let far = mesh.nodes_in_rest.iter().map(d).fold(0.0, f64::max);
    let band = far - 0.02 * diagonal(&mesh.nodes_in_rest);
    centroid(mesh.nodes_in_rest.iter().filter(|p| d(p) >= band))
}

fn centroid<'a>(points: impl Iterator<Item = &'a [f64; 3]>) -> [f64; 3] {
    let (mut sum, mut n) = ([0.0; 3], 0.0);
    for p in points {
        sum = [sum[0] + p[0], sum[1] + p[1], sum[2] + p[2]];
        n += 1.0;
    }
    sum.map(|s| s / f64::max(n, 1.0))
}

/// A cable file: a list of points (the first the pull point) or {name, pull, attach};
/// every attach point must lie inside the body.
fn read_cable(path: &Path, k: usize, mesh: &TetMesh) -> Result<CableSpec, CliError> {
    #[derive(serde::Deserialize)]
    #[serde(untagged)]
    enum CableFile {
        Points(Vec<[f64; 3]>),
        Full {
            name: Option<String>,
            pull: [f64; 3],
            attach: Vec<[f64; 3]>,
        },
    }
    let bad = |m: String| CliError::Result(format!("--cable {}: {m}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let file: CableFile = serde_json::from_str(&text).map_err(|e| {
        bad(format!("{e} (give a list of points [[x, y, z], ...] or {{\"pull\": [x, y, z], \"attach\": [[x, y, z], ...]}})"))
    })?;
    let stem = (path.file_stem()).map_or(format!("cable{k}"), |s| s.to_string_lossy().into_owned());
    let (name, pull, attach) = match file {
        CableFile::Points(p) if p.len() >= 2 => (stem, p[0], p[1..].to_vec()),
        CableFile::Points(p) => {
            return Err(bad(format!(
                "{} point(s): a cable needs a pull point and one more",
                p.len()
            )))
        }
        CableFile::Full { name, pull, attach } => (name.unwrap_or(stem), pull, attach),
    };
    if attach.is_empty() || attach.iter().flatten().chain(&pull).any(|c| !c.is_finite()) {
        return Err(bad(
            "no attach point, or a coordinate that is not finite".into()
        ));
    }
    let tol = 1e-6 * diagonal(&mesh.nodes_in_rest);
    for (i, a) in attach.iter().enumerate() {
        if let Err(e) = mesh.locate(*a, tol) {
            return Err(bad(format!(
                "point {} ({}, {}, {}) is outside the body: {e}",
                i + 1,
                a[0],
                a[1],
                a[2]
            )));
        }
    }
    Ok(CableSpec {
        name,
        pull,
        attach,
        shorten: None,
        force: None,
    })
}

/// What was written, with the mesh's quality against the limits.
fn print_summary(args: &NewArgs, model: &Model, report: Option<&MeshReport>) -> CliResult {
    let p = &model.problem;
    let q = p.mesh.quality()?;
    super::out(format_args!(
        "{}: {} nodes, {} tetrahedra; {} fixed nodes, {} cable(s), {} cavity(ies), {} effector(s)\n",
        args.out.join("model.toml").display(),
        q.nodes,
        q.tets,
        p.fixed.len(),
        p.cables.len(),
        p.cavities.len(),
        model.effectors.len()
    ))?;
    if let Some(r) = report {
        super::out(format_args!(
            "mesh: size {:.3}, dihedral angles {:.1} to {:.1} deg ({} below {} deg), radius-edge ratio at most {:.2} ({} above {}); gmsh {}, {:.1} s{}\n",
            r.size, r.min_dihedral_deg, r.max_dihedral_deg, r.below_min_dihedral, r.min_dihedral_limit_deg,
            r.max_radius_edge, r.above_max_radius_edge, r.max_radius_edge_limit, r.gmsh_version, r.gmsh_seconds,
            if r.surface_remeshed { "" } else { " (surface triangles kept)" }
        ))?;
        if r.below_min_dihedral + r.above_max_radius_edge > 0 {
            eprintln!("warning: {} tetrahedra break the quality limits: a smaller --size or a cleaner surface helps", r.below_min_dihedral.max(r.above_max_radius_edge));
        }
    }
    super::out(format_args!(
        "next: softsense model check {}\n",
        args.out.join("model.toml").display()
    ))
}

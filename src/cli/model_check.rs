//! `softsense model check MODEL.toml`: what a model file holds, before it is used.

use super::CliError;
use clap::Args;
use softsense::fem::cavity::CavityControl;
use softsense::fem::model::check::{check_file, ModelReport};
use softsense::fem::model::Units;
use softsense::fem::solve::CableControl;
use softsense::render::model::{model_picture, ModelPicture};
use std::path::PathBuf;

/// The picture's size (pixels).
const PICTURE_SIZE: u32 = 960;

/// Prints a model's mesh quality, mass, fixed nodes, cables, cavities and gravity sag.
#[derive(Args, Debug)]
#[command(
    long_about = "Prints what a model file holds, and refuses what would make it \
wrong without an error later.\n\n\
Lines printed (lengths, forces and pressures in the file's units; `--json` gives the same \
in SI):\n\
  mesh       nodes, tetrahedra, volume and the bounding box's sides.\n\
  quality    the smallest and largest dihedral angle (a sliver has angles near 0 and 180 \
deg), the largest radius-edge ratio (2 or less is what quality meshers guarantee), the \
smallest shape measure (1 for a regular tetrahedron).\n\
  material   Young's modulus and Poisson's ratio.\n\
  mass       the total mass (kg), its density (kg/m^3) and gravity.\n\
  fixed      how many nodes the [[fixed]] selections hold, clamped or on springs \
(base_stiffness).\n\
  cable      each cable: its attach points, its rest length from the pull point, its \
control in the file.\n\
  cavity     each pressure cavity: its faces, its rest volume, its control.\n\
  effector, force point   each point and its rows (3: x, y, z; 1: along a direction).\n\
  sag        the largest node displacement under gravity alone (cables slack, cavities \
unpressurised, point loads left out), where it happens and as a share of the body's \
longest side: a soft body that sags by a tenth of its length wants a \
corotational or Neo-Hookean formulation, and a sag far from the real body's says the \
modulus or the mass is off.\n\n\
Refused, naming the key and the file: a fixed box that selects no node (every command \
refuses this), a model that fixes no node, a cable attach point outside the body \
(other commands accept one up to 5% of the mesh's diagonal outside), a cavity whose \
surface is not closed (others take an open one as a membrane).\n\n\
--picture OUT.png draws the body from the top, front and side at one scale: its outline \
in grey, fixed nodes, cable paths (o pull point, * attach points), cavities shaded, \
effectors (x) and force points (o), a legend of what is drawn and a scale bar. Without \
it, no picture is written."
)]
pub struct CheckArgs {
    /// Model file (TOML).
    pub model: PathBuf,
    /// Write a picture of the model (PNG, 960 x 960 pixels): top, front and side views.
    #[arg(long, value_name = "OUT.png")]
    pub picture: Option<PathBuf>,
    /// Print the report as JSON on stdout (SI units).
    #[arg(long)]
    pub json: bool,
}

/// Runs `softsense model check`.
pub fn run(args: &CheckArgs) -> Result<(), CliError> {
    if let Some(out) = &args.picture {
        super::refuse_output_over_input(&args.model, out)?;
    }
    let (model, report) = check_file(&args.model)?;
    if let Some(out) = &args.picture {
        let title = format!("model check: {}", args.model.display());
        let mut pic = ModelPicture::of(&model, &title);
        pic.notes = summary(&report, &model.units)
            .into_iter()
            .filter(|l| {
                ["mesh", "mass", "fixed", "sag"]
                    .iter()
                    .any(|k| l.starts_with(k))
            })
            .collect();
        (model_picture(&pic, PICTURE_SIZE, PICTURE_SIZE).and_then(|c| c.save_png(out)))
            .map_err(|e| CliError::Lib(e.into()))?;
    }
    if args.json {
        let text = serde_json::to_string(&report).map_err(|e| CliError::Other(Box::new(e)))?;
        return super::out(format_args!("{text}\n"));
    }
    for line in summary(&report, &model.units) {
        super::out(format_args!("{line}\n"))?;
    }
    let picture = match &args.picture {
        Some(p) => format!("written to {}", p.display()),
        None => "none (give --picture OUT.png)".to_string(),
    };
    super::out(format_args!("picture:    {picture}\n"))
}

/// The report as lines of text, in the file's units `u`.
fn summary(r: &ModelReport, u: &Units) -> Vec<String> {
    let mm = r.units == "mm-kg-s" || r.units == "mm";
    let (len, force, pressure) = match mm {
        true => ("mm", "mN", "kPa"),
        false => ("m", "N", "Pa"),
    };
    let l = |v: f64| v / u.length;
    let p3 = |p: [f64; 3]| format!("[{}, {}, {}]", num(l(p[0])), num(l(p[1])), num(l(p[2])));
    let q = &r.quality;
    let side = (0..3).map(|k| num(l(q.bbox[1][k] - q.bbox[0][k])));
    let mut out = vec![
        format!("model:      {} ({}, {})", r.file, r.units, r.formulation),
        format!(
            "mesh:       {} nodes, {} tetrahedra, volume {} {len}^3, {} {len}",
            q.nodes,
            q.tets,
            num(q.volume / u.length.powi(3)),
            side.collect::<Vec<_>>().join(" x ")
        ),
        format!(
            "quality:    dihedral angles {:.1}-{:.1} deg, radius-edge ratio <= {:.2}, \
             shape >= {:.3}",
            q.min_dihedral_deg, q.max_dihedral_deg, q.max_radius_edge, q.min_shape
        ),
        format!(
            "material:   E {} {pressure}, nu {}",
            num(r.young / u.pressure),
            r.poisson
        ),
        format!(
            "mass:       {} kg (density {} kg/m^3), gravity {} {len}/s^2",
            num(r.mass),
            num(r.density),
            p3(r.gravity)
        ),
        format!(
            "fixed:      {} nodes, {}",
            r.fixed_nodes,
            match r.base_stiffness {
                None => "clamped".to_string(),
                Some(k) => format!("on springs of {} N/m in all", num(k)),
            }
        ),
    ];
    for c in &r.cables {
        let control = match c.control {
            CableControl::Displacement(d) => format!("shortened {} {len}", num(l(d))),
            CableControl::Force(f) => format!("tension {} {force}", num(f / u.force)),
        };
        out.push(format!(
            "cable:      {}: {} attach point{}, rest length {} {len}, {control}",
            c.name,
            c.points,
            if c.points == 1 { "" } else { "s" },
            num(l(c.length))
        ));
    }
    for c in &r.cavities {
        let control = match c.control {
            CavityControl::Pressure(p) => format!("pressure {} {pressure}", num(p / u.pressure)),
            CavityControl::Volume(v) => {
                format!("volume change {} {len}^3", num(v / u.length.powi(3)))
            }
        };
        out.push(format!(
            "cavity:     {}: {} faces, closed, rest volume {} {len}^3, {control}",
            c.name,
            c.faces,
            num(c.rest_volume / u.length.powi(3))
        ));
    }
    for (kind, list) in [("effector", &r.effectors), ("force point", &r.force_points)] {
        for e in list {
            out.push(format!(
                "{:<11} {} at {} {len}, {} row{}",
                format!("{kind}:"),
                e.name,
                p3(e.position),
                e.rows,
                if e.rows == 1 { "" } else { "s" },
            ));
        }
    }
    if r.loads > 0 {
        out.push(format!("loads:      {} (left out of the sag)", r.loads));
    }
    out.push(match &r.sag {
        None => "sag:        none (the model has no mass or no gravity)".to_string(),
        Some(s) => format!(
            "sag:        {} {len} ({:.2}% of the body's {} {len}) at node {} {} {len}, \
             under gravity alone",
            num(l(s.displacement)),
            100.0 * s.fraction_of_length,
            num(l(r.body_length)),
            s.node,
            p3(s.at)
        ),
    });
    if let Some(w) = r.sag.as_ref().and_then(|s| s.warning.as_ref()) {
        out.push(format!("warning:    {w}"));
    }
    out
}

/// `v` to 4 significant digits without trailing zeros, 0 below 1e-9, in exponent form
/// outside 1e-3 to 1e6.
fn num(v: f64) -> String {
    let a = v.abs();
    // Below 1e-9 of the file's unit is rounding (a node at -1e-17 mm).
    if a < 1e-9 || !v.is_finite() {
        return format!("{}", if v.is_finite() { 0.0 } else { v });
    }
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i64).clamp(0, 6) as usize;
    let s = format!("{v:.decimals$}");
    let s = match s.contains('.') {
        true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        false => s,
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

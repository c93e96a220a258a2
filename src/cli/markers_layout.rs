//! `softsense markers layout`: a marker layout minimising I_w (thesis 4.6.1, Table 4.1).

use super::markers::load_candidates;
use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::fem::model::Model;
use softsense::markers::layout::{propose_layout, LayoutParams};
use softsense::markers::tracks::{write_tracks, MarkerTracks, TrackFrame};
use std::path::PathBuf;

/// Propose where to put N markers so the forces at the candidates are least sensitive to
/// marker noise.
#[derive(Args, Debug)]
#[command(
    long_about = "Propose a marker layout minimising I_w = 1/sigma_min(W_ef) (thesis 4.6.1): \
W_ef is computed once at the model's free equilibrium for every pool node (surface nodes, \
not fixed, at least --clearance-mm from a candidate), then greedy forward selection adds the \
node that lowers I_w most and exchange passes swap a chosen node for an unchosen one while \
I_w drops. Candidates come from --candidates (CSV name,x,y,z,directions in m) or else the \
model's [[force_points]].\n\n\
--csv writes the layout as a softsense track file (frame 0, the free equilibrium, metres): \
the first frame `softsense markers` binds its markers from.",
    after_help = "Examples:\n  \
softsense markers layout meshes/models/robot.toml --markers 8 \
--candidates meshes/models/robot_candidates.csv --csv layout.csv"
)]
pub struct LayoutArgs {
    /// Model file (TOML).
    model: PathBuf,
    /// Markers to place.
    #[arg(long)]
    markers: usize,
    /// Candidate force locations (CSV name,x,y,z,directions in m); default: the model's force points.
    #[arg(long)]
    candidates: Option<PathBuf>,
    /// Most exchange passes.
    #[arg(long, default_value_t = 5)]
    max_exchange_passes: usize,
    /// Keep every n-th pool node (a coarser, faster search).
    #[arg(long, default_value_t = 1)]
    pool_stride: usize,
    /// Pool nodes nearer than this to a candidate are left out (mm).
    #[arg(long, default_value_t = 5.0)]
    clearance_mm: f64,
    /// Write the layout as a track file (frame 0, free equilibrium, m); never one of the
    /// input files.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Print a JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `softsense markers layout`.
pub fn run(args: &LayoutArgs) -> CliResult {
    if args.markers == 0
        || args.pool_stride == 0
        || args.clearance_mm.is_nan()
        || args.clearance_mm < 0.0
    {
        return Err(CliError::Usage(
            "--markers and --pool-stride must be positive, --clearance-mm not negative".into(),
        ));
    }
    if let Some(out) = &args.csv {
        let inputs: Vec<&std::path::Path> = std::iter::once(args.model.as_path())
            .chain(args.candidates.as_deref())
            .collect();
        super::check_output_file(out, &inputs)?;
    }
    let model = Model::load(&args.model, None).map_err(|e| CliError::Lib(e.into()))?;
    let candidates = load_candidates(&model, &args.model, args.candidates.as_deref(), &[])?;
    let params = LayoutParams {
        markers: args.markers,
        max_exchange_passes: args.max_exchange_passes,
        pool_stride: args.pool_stride,
        clearance: args.clearance_mm * 1e-3,
        ..Default::default()
    };
    let layout = propose_layout(&model.problem, &model.newton, &candidates, None, &params)
        .map_err(|e| CliError::Lib(e.into()))?;
    let names: Vec<String> = layout.nodes.iter().map(|v| format!("n{v}")).collect();
    if let Some(path) = &args.csv {
        let tracks = MarkerTracks {
            names: names.clone(),
            frames: vec![TrackFrame {
                frame: 0,
                positions: layout.positions.iter().map(|p| Some(*p)).collect(),
            }],
        };
        write_tracks(path, &tracks).map_err(|e| CliError::Lib(e.into()))?;
    }
    if args.json {
        let v = serde_json::json!({
            "markers": names, "nodes": layout.nodes, "positions_m": layout.positions,
            "i_w_greedy_n_per_m": layout.i_w_greedy, "i_w_n_per_m": layout.i_w,
            "pool": layout.pool, "unknowns": candidates.iter().map(|c| c.unknowns()).sum::<usize>(),
        });
        return print_json(&v);
    }
    outln!(
        "{} markers from a pool of {} nodes: I_w {:.2} N/m after greedy, {:.2} N/m after exchanges",
        layout.nodes.len(),
        layout.pool,
        layout.i_w_greedy,
        layout.i_w
    )?;
    for (name, p) in names.iter().zip(&layout.positions) {
        outln!("  {name}: ({:.5}, {:.5}, {:.5}) m", p[0], p[1], p[2])?;
    }
    Ok(())
}

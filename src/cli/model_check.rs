//! `softsense model check MODEL.toml`: what a model file holds, before it is used.

use super::CliError;
use clap::Args;
use softsense::fem::model::Model;
use std::path::PathBuf;

/// Prints a model's mesh quality, mass, fixed nodes, cables and cavities.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Model file (TOML).
    pub model: PathBuf,
}

/// Runs `softsense model check`.
pub fn run(args: &CheckArgs) -> Result<(), CliError> {
    let m = Model::load(&args.model, None)?;
    let q = m.problem.mesh.quality()?;
    println!(
        "{}: {} nodes, {} tetrahedra, dihedral angles {:.1}-{:.1} deg, radius-edge ratio <= {:.2}",
        args.model.display(),
        q.nodes,
        q.tets,
        q.min_dihedral_deg,
        q.max_dihedral_deg,
        q.max_radius_edge
    );
    Ok(())
}

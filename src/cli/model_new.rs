//! `softsense model new SURFACE --out DIR`: a model folder from a CAD surface.

use super::CliError;
use clap::Args;
use std::path::PathBuf;

/// Meshes a closed surface into tetrahedra and writes a commented model file.
#[derive(Args, Debug)]
pub struct NewArgs {
    /// The robot's closed surface (STL, OBJ, PLY) or a volume mesh (VTK, VTU, Gmsh).
    pub surface: PathBuf,
    /// The folder to write (model.toml, mesh.vtu, report.json).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `softsense model new`.
pub fn run(_args: &NewArgs) -> Result<(), CliError> {
    Err(CliError::Usage("model new: being built".into()))
}

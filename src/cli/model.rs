//! `softsense model`: a model from a user's own robot (`new`) and its check (`check`).

use clap::{Args, Subcommand};

/// Your own robot: mesh a CAD surface into a model file, and check a model file.
#[derive(Args, Debug)]
#[command(long_about = "Your own robot.\n\n\
`model new SURFACE --out DIR` meshes a closed CAD surface (STL, OBJ or PLY) into \
tetrahedra with gmsh and writes DIR/model.toml with every key commented; a volume mesh \
(VTK, VTU, Gmsh) is taken as it is.\n\
`model check MODEL.toml` prints what a model holds (mesh quality, mass, fixed nodes, \
cables, cavities, the sag under gravity) and draws it.\n\n\
The walkthrough from an STL to forces is docs/your-robot.md; every key is in \
docs/model-format.md.")]
pub struct ModelArgs {
    #[command(subcommand)]
    command: ModelCommand,
}

#[derive(Subcommand, Debug)]
enum ModelCommand {
    New(Box<super::model_new::NewArgs>),
    Check(super::model_check::CheckArgs),
}

/// Runs `softsense model ...`.
pub fn run(args: &ModelArgs) -> Result<(), super::CliError> {
    match &args.command {
        ModelCommand::New(a) => super::model_new::run(a),
        ModelCommand::Check(a) => super::model_check::run(a),
    }
}

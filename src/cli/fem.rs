//! `softsense fem`: static solves and constraint-space compliance of a model file.

use clap::{Args, Subcommand};
use softsense::fem::meshio::{write_vtu, Field};
use softsense::fem::model::Model;
use std::path::PathBuf;

/// Finite-element model: static solve or compliance.
#[derive(Args, Debug)]
pub struct FemArgs {
    #[command(subcommand)]
    command: FemCommand,
}

#[derive(Subcommand, Debug)]
enum FemCommand {
    /// Static equilibrium under the model's loads and cable actuation.
    Solve {
        /// Model file (TOML).
        model: PathBuf,
        /// Write the deformed result as VTU (displacement, force, von Mises).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Use this mesh file instead of the model's.
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Print JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Compliance W and free motion for the model's effectors, actuators and force points.
    Compliance {
        /// Model file (TOML).
        model: PathBuf,
        /// Use this mesh file instead of the model's.
        #[arg(long)]
        mesh: Option<PathBuf>,
        /// Print JSON on stdout.
        #[arg(long)]
        json: bool,
    },
}

/// Runs `softsense fem ...`.
pub fn run(args: FemArgs) -> Result<(), Box<dyn std::error::Error>> {
    match args.command {
        FemCommand::Solve {
            model,
            out,
            mesh,
            json,
        } => {
            let m = Model::load(&model, mesh.as_deref())?;
            // Solve failures come from the model's content: name its file.
            let sol = (m.problem.solve_static(&m.newton)).map_err(|e| e.in_file(&model))?;
            let warning = m.validity_warning(&sol.displacement);
            if let Some(w) = &warning {
                eprintln!("warning: {}: {w}", model.display());
            }
            if let Some(out) = out {
                let disp: Vec<f64> = sol.displacement.iter().flatten().copied().collect();
                let force: Vec<f64> = sol.external_force.iter().flatten().copied().collect();
                write_vtu(
                    &out,
                    &m.problem.mesh.nodes_in_rest,
                    &m.problem.mesh.tets,
                    &[
                        Field {
                            name: "displacement",
                            components: 3,
                            values: &disp,
                        },
                        Field {
                            name: "force",
                            components: 3,
                            values: &force,
                        },
                    ],
                    &[Field {
                        name: "von_mises",
                        components: 1,
                        values: &sol.von_mises,
                    }],
                )?;
            }
            let effectors: Vec<serde_json::Value> = m
                .effectors
                .iter()
                .map(|e| {
                    let p = e.point.position(&sol.positions);
                    let r = e.point.position(&m.problem.mesh.nodes_in_rest);
                    serde_json::json!({"name": e.name, "position": p,
                        "displacement": [p[0]-r[0], p[1]-r[1], p[2]-r[2]]})
                })
                .collect();
            let cables: Vec<serde_json::Value> = m
                .problem
                .cables
                .iter()
                .enumerate()
                .map(|(i, c)| serde_json::json!({"name": c.name, "tension": sol.cable_tension[i], "shortening": sol.cable_shortening[i], "slack": sol.cable_slack[i]}))
                .collect();
            if json {
                let v = serde_json::json!({
                    "units": "SI", "converged": sol.converged, "iterations": sol.iterations,
                    "residuals": sol.residuals, "effectors": effectors, "cables": cables,
                    "node_displacements": sol.displacement, "warning": warning,
                });
                outln!("{}", serde_json::to_string(&v)?)?;
            } else {
                outln!(
                    "converged: {} in {} iterations (residuals {:?})",
                    sol.converged,
                    sol.iterations,
                    sol.residuals
                )?;
                for e in &effectors {
                    outln!("effector {e}")?;
                }
                for c in &cables {
                    outln!("cable {c}")?;
                }
            }
        }
        FemCommand::Compliance { model, mesh, json } => {
            let m = Model::load(&model, mesh.as_deref())?;
            let x = m.problem.mesh.nodes_in_rest.clone();
            let rows = m.rows(&x);
            let mut solver = m.problem.solver().map_err(|e| e.in_file(&model))?;
            let c = (solver.compliance_at(&x, &rows)).map_err(|e| e.in_file(&model))?;
            let w: Vec<Vec<f64>> = (0..c.w.nrows())
                .map(|i| c.w.row(i).iter().copied().collect())
                .collect();
            if json {
                let v = serde_json::json!({"units": "SI", "kinds": c.kinds, "w": w, "delta_free": c.delta_free});
                outln!("{}", serde_json::to_string(&v)?)?;
            } else {
                outln!("{} rows: {:?}", c.kinds.len(), c.kinds)?;
                outln!("W (m/N) =\n{}", c.w)?;
                outln!("delta_free (m) = {:?}", c.delta_free)?;
            }
        }
    }
    Ok(())
}

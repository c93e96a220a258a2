//! `softsense fem`: static solves and constraint-space compliance of a model file.

use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use softsense::fem::meshio::{write_vtu, Field};
use softsense::fem::model::Model;
use softsense::io::InFile;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

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
            if let Some(out) = &out {
                super::refuse_output_over_input(&model, out)?;
                // The mesh the VTU would replace: --mesh, else the one the model names.
                let mesh_file = mesh.clone().map_or_else(|| Model::mesh_file(&model), Ok);
                if let Ok(mesh_file) = mesh_file {
                    super::refuse_output_over_input(&mesh_file, out)?;
                }
            }
            let m = Model::load(&model, mesh.as_deref())?;
            let mut progress = StepProgress::new();
            // Solve failures come from the model's content: name its file.
            let sol = m
                .problem
                .solve_static_observed(&m.newton, &mut |k, n| progress.step(k, n))
                .map_err(|e| e.in_file(&model))?;
            progress.finish();
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
            let cavities: Vec<serde_json::Value> = (m.problem.cavities.iter())
                .enumerate()
                .map(|(i, c)| serde_json::json!({"name": c.name, "closed": c.is_closed(), "pressure": sol.cavity_pressure[i], "volume_change": sol.cavity_volume_change[i]}))
                .collect();
            if json {
                let mut v = serde_json::json!({
                    "units": "SI", "converged": sol.converged, "iterations": sol.iterations,
                    "residuals": sol.residuals, "effectors": effectors, "cables": cables,
                    "node_displacements": sol.displacement,
                });
                // Only with cavities, so the output of cable-only models reads as before.
                if !cavities.is_empty() {
                    v["cavities"] = serde_json::json!(cavities);
                }
                // Only outside small strain's validity, so valid results read as before.
                if let Some(w) = &warning {
                    v["warning"] = serde_json::json!(w);
                }
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
                for c in &cavities {
                    outln!("cavity {c}")?;
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
            // Each row's free motion is a displacement along the row's direction.
            let along: Vec<[f64; 3]> = c.delta_free.iter().map(|&d| [d, 0.0, 0.0]).collect();
            if let Some(w) = m.validity_warning(&along) {
                eprintln!("warning: {}: {w}", model.display());
            }
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

/// Load-step progress on stderr for solves that take a while: a bar on a terminal, a
/// line now and then otherwise (logs), nothing for the first seconds or a single step.
struct StepProgress {
    started: Instant,
    last_line: Option<Instant>,
    bar: Option<ProgressBar>,
    terminal: bool,
}

impl StepProgress {
    /// Quiet before this: most solves end sooner and need no progress.
    const AFTER: Duration = Duration::from_secs(2);
    /// Between two progress lines when stderr is not a terminal.
    const LINE_EVERY: Duration = Duration::from_secs(10);

    fn new() -> Self {
        Self {
            started: Instant::now(),
            last_line: None,
            bar: None,
            terminal: std::io::stderr().is_terminal(),
        }
    }

    fn step(&mut self, step: usize, steps: usize) {
        if steps < 2 || self.started.elapsed() < Self::AFTER {
            return;
        }
        if self.terminal {
            let bar = self.bar.get_or_insert_with(|| {
                let b = ProgressBar::new(steps as u64);
                b.set_style(
                    ProgressStyle::with_template("{bar:40} {pos}/{len} load steps {elapsed}")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                b
            });
            bar.set_position(step as u64);
        } else if self
            .last_line
            .is_none_or(|t| t.elapsed() >= Self::LINE_EVERY)
        {
            self.last_line = Some(Instant::now());
            eprintln!(
                "softsense: load step {step} of {steps} ({:.0} s)",
                self.started.elapsed().as_secs_f64()
            );
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

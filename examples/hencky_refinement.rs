//! Issue 53 item 2: Hencky's clamped circular membrane built from thin tetrahedral layers,
//! at several mesh densities and 1 or 2 layers, for both large-deformation formulations:
//! the centre deflection against Hencky's w0 = 0.662 a (p a / (E t))^(1/3), and the run
//! time. Prints the markdown table of docs/membrane.md. The case is
//! `tests/common/membrane.rs`, shared with `cargo test --test acceptance membrane`. Run
//! from the repository root:
//!
//! ```text
//! cargo run --release --example hencky_refinement
//! ```

#[allow(dead_code)]
#[path = "../tests/common/membrane.rs"]
mod membrane;

use membrane::{solve_membrane, MembraneCase};
use softsense::fem::solve::Formulation;

fn main() -> Result<(), softsense::fem::FemError> {
    let case = MembraneCase::acceptance(8, 1, Formulation::Corotational);
    println!(
        "a = {} m, t = {} m (t/a = {}), E = {} Pa, nu = 0.3, p = {:.3} Pa (p a / (E t) = {:.5}); \
         Hencky's w0 = {:.3} mm ({:.0} t)\n",
        case.radius,
        case.thickness,
        case.thickness / case.radius,
        case.young,
        case.pressure,
        case.pressure * case.radius / (case.young * case.thickness),
        1e3 * case.hencky_w0(),
        case.hencky_w0() / case.thickness
    );
    println!("| formulation | rings | layers | nodes | tets | w0 (mm) | error | Newton iterations | time (s) |");
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for formulation in [Formulation::Corotational, Formulation::NeoHookean] {
        for (rings, layers) in [(4, 1), (8, 1), (16, 1), (32, 1), (8, 2), (16, 2)] {
            let case = MembraneCase::acceptance(rings, layers, formulation);
            match solve_membrane(&case) {
                Ok(r) => println!(
                    "| {} | {rings} | {layers} | {} | {} | {:.3} | {:+.2}% | {} | {:.2} |",
                    formulation.name(),
                    r.nodes,
                    r.tets,
                    1e3 * r.w0,
                    100.0 * r.error,
                    r.iterations,
                    r.seconds
                ),
                Err(e) => println!(
                    "| {} | {rings} | {layers} | | | failed: {e} | | | |",
                    formulation.name()
                ),
            }
        }
    }
    Ok(())
}

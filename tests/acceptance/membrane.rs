//! Issue 53 item 2: Hencky's clamped circular membrane, built from one layer of thin
//! tetrahedra over a 32-ring disk (6,338 nodes), within 5% of Hencky's centre deflection
//! for both large-deformation formulations. The case is `tests/common/membrane.rs`; the
//! refinement table is `cargo run --release --example hencky_refinement`
//! (docs/membrane.md).

use crate::common::membrane::{solve_membrane, MembraneCase};
use softsense::fem::solve::Formulation;

#[test]
fn a_clamped_membrane_of_thin_tetrahedra_deflects_as_hencky_says_within_5_percent() {
    for formulation in [Formulation::Corotational, Formulation::NeoHookean] {
        let case = MembraneCase::acceptance(32, 1, formulation);
        let r = solve_membrane(&case).unwrap();
        println!(
            "{}: w0 = {:.3} mm, Hencky {:.3} mm, error {:+.2}%, {:.1} s",
            formulation.name(),
            1e3 * r.w0,
            1e3 * case.hencky_w0(),
            100.0 * r.error,
            r.seconds
        );
        assert!(
            r.error.abs() < 0.05,
            "{}: {:+.2}%",
            formulation.name(),
            100.0 * r.error
        );
    }
}

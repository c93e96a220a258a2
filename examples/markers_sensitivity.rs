//! Issue 36, thesis Tables 4.2 and 4.3: the sensitivity of marker-based force sensing to
//! an imprecise Young's modulus, imprecise marker z and imprecise actuator inputs, on the
//! bundled sheet and robot. The direct FE model at the bundled modulus makes the truth; the
//! inverse model recovers the forces with one error at a time. Prints the tables (I_e in
//! mN, a column per layout of markers and candidates) and the bound ‖Δf‖ ≤ I_w ‖Δδ_e‖ for
//! the marker offsets, as markdown. The study is `tests/common/markers_sensitivity.rs`,
//! shared with `cargo test --test acceptance markers_sensitivity`. Run from the repository
//! root:
//!
//! ```text
//! cargo run --release --example markers_sensitivity
//! ```

#[allow(dead_code)]
#[path = "../tests/common/markers.rs"]
mod markers;
#[allow(dead_code)]
#[path = "../tests/common/markers_sensitivity.rs"]
mod markers_sensitivity;

use markers_sensitivity::{bound_table, linearity, run, table, Column};

fn print_body(title: &str, columns: &[Column]) {
    println!("### {title}\n");
    for c in columns {
        println!("- {}: {}", c.name, c.about);
    }
    println!("\n{}", table(columns));
    for c in columns {
        for (source, cells) in &c.rows {
            let (worst, monotonic) = linearity(*source, cells);
            println!(
                "- {} {}: grows with the source: {monotonic}; worst deviation from proportional {:.1}%",
                c.name,
                source.label(),
                100.0 * worst
            );
        }
    }
    println!("\n{}", bound_table(columns));
}

fn main() {
    let start = std::time::Instant::now();
    let (sheet, robot) = run();
    print_body("Sheet (Table 4.2)", &sheet);
    print_body("Robot (Table 4.3)", &robot);
    println!("({:.1} s)", start.elapsed().as_secs_f64());
}

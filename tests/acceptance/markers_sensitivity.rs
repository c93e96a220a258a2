//! Tables 4.2 and 4.3 (issue 36): the sensitivity of marker-based sensing to an imprecise
//! Young's modulus (280/260/240 against 300), marker z (0.05/0.10/0.15 mm) and actuator
//! inputs (0.10/0.15/0.20 N, robot), study in `tests/common/markers_sensitivity.rs`.
//!
//! The thesis's trend: each error grows with its source, about linearly. The rule held
//! here, fixed before measuring: the errors grow strictly with the source, and the ratio of
//! each level's I_e to the first level's is within 20% of the ratio of the sources' sizes
//! (the thesis's own tables deviate by up to 18%, r_4's marker rows). And the thesis's bound
//! for the marker rows: ‖Δf‖ ≤ I_w ‖Δδ_e‖.
use crate::common::markers_sensitivity::{
    robot_layouts, sheet_layouts, study, table, Column, Source,
};
use std::sync::OnceLock;

const BAND: f64 = 0.2;

fn sheet() -> &'static [Column] {
    static COLUMNS: OnceLock<Vec<Column>> = OnceLock::new();
    COLUMNS.get_or_init(|| {
        let cols: Vec<Column> = (sheet_layouts().iter())
            .map(|l| study(l, &[Source::Young, Source::MarkerZ]))
            .collect();
        eprintln!("sheet:\n{}", table(&cols));
        cols
    })
}

fn robot() -> &'static [Column] {
    static COLUMNS: OnceLock<Vec<Column>> = OnceLock::new();
    COLUMNS.get_or_init(|| {
        let sources = [Source::Young, Source::MarkerZ, Source::Actuator];
        let cols: Vec<Column> = robot_layouts().iter().map(|l| study(l, &sources)).collect();
        eprintln!("robot:\n{}", table(&cols));
        cols
    })
}

/// Every column's rows of `source` grow strictly and about linearly with it.
fn check_linear(body: &str, columns: &[Column], source: Source) {
    for c in columns {
        let (_, cells) = c.rows.iter().find(|r| r.0 == source).expect("source row");
        let (worst, monotonic) = crate::common::markers_sensitivity::linearity(source, cells);
        let i_e: Vec<f64> = cells.iter().map(|x| 1e3 * x.i_e).collect();
        eprintln!(
            "{body} {} {source:?}: I_e {i_e:.2?} mN, worst deviation {:.1}%",
            c.name,
            100.0 * worst
        );
        assert!(monotonic, "{body} {} {source:?}: I_e {i_e:?} mN", c.name);
        assert!(
            worst <= BAND,
            "{body} {} {source:?}: {:.1}% from proportional",
            c.name,
            100.0 * worst
        );
    }
}

/// ‖Δf‖ ≤ I_w ‖Δδ_e‖ in every marker-offset cell.
fn check_bound(body: &str, columns: &[Column]) {
    for c in columns {
        let (_, cells) = (c.rows.iter())
            .find(|r| r.0 == Source::MarkerZ)
            .expect("marker rows");
        for cell in cells {
            let bound = cell.bound.expect("a bound");
            eprintln!(
                "{body} {} z +{} mm: |df| {:.3} mN <= I_w |dd| {:.3} mN",
                c.name,
                cell.level,
                1e3 * cell.delta_f,
                1e3 * bound
            );
            assert!(cell.delta_f <= bound, "{body} {}: {cell:?}", c.name);
        }
    }
}

#[test]
fn sheet_errors_grow_about_linearly_with_the_young_modulus_error() {
    check_linear("sheet", sheet(), Source::Young);
}

#[test]
fn sheet_errors_grow_about_linearly_with_the_marker_offset() {
    check_linear("sheet", sheet(), Source::MarkerZ);
}

#[test]
fn sheet_marker_offsets_stay_within_the_i_w_bound() {
    check_bound("sheet", sheet());
}

#[test]
fn robot_errors_grow_about_linearly_with_the_young_modulus_error() {
    check_linear("robot", robot(), Source::Young);
}

#[test]
fn robot_errors_grow_about_linearly_with_the_marker_offset() {
    check_linear("robot", robot(), Source::MarkerZ);
}

#[test]
fn robot_errors_grow_about_linearly_with_the_actuator_input_error() {
    check_linear("robot", robot(), Source::Actuator);
}

#[test]
fn robot_marker_offsets_stay_within_the_i_w_bound() {
    check_bound("robot", robot());
}

//! The sensitivity study of thesis Tables 4.2 and 4.3 (issue 36) on softsense's bodies,
//! shared by `examples/markers_sensitivity.rs` (prints the tables) and the acceptance test.
//!
//! The direct FE model at the bundled modulus makes the truth (no noise: each row isolates
//! one source); the inverse model recovers the forces with one error at a time:
//!
//! - Young's modulus: the inverse model's at 280/300, 260/300, 240/300 of the direct one's
//!   (our models' modulus plays the thesis's 300 kPa);
//! - marker z: every marker's measured z offset by +0.05, +0.10, +0.15 mm;
//! - actuator input (robot): each force-driven cable held at +0.10, +0.15, +0.20 N above
//!   the truth's (the bundled robot's west, south and east cables, 0 N; the north cable is
//!   displacement-held, an input in mm, and is left exact).
//!
//! Columns are layouts of markers and candidates, as the thesis's s_2…s_7 and r_2…r_7: two
//! with the same markers and different candidates, one with other markers.
use super::markers::{grid, model, robot_tip_sensor, sensor, sheet_markers};
use softsense::fem::material::Material;
use softsense::fem::solve::{CableControl, PointLoad};
use softsense::markers::{CandidateLocation, Directions, MarkerSensor};

/// An error source and its three levels, in the unit its row is labelled with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The inverse model's Young's modulus, as the thesis's kPa against 300.
    Young,
    /// The markers' z offset (mm).
    MarkerZ,
    /// The force-driven cables' input error (N).
    Actuator,
}

impl Source {
    /// The three levels of the source (row labels).
    pub fn levels(self) -> [f64; 3] {
        match self {
            Source::Young => [280.0, 260.0, 240.0],
            Source::MarkerZ => [0.05, 0.10, 0.15],
            Source::Actuator => [0.10, 0.15, 0.20],
        }
    }

    /// The size of the error of a level, for the linearity check: the modulus's relative
    /// error, the offset, the input error.
    pub fn size(self, level: f64) -> f64 {
        match self {
            Source::Young => (300.0 - level) / 300.0,
            _ => level,
        }
    }

    /// The row group's label.
    pub fn label(self) -> &'static str {
        match self {
            Source::Young => "Imprecise Young's modulus (kPa, against 300)",
            Source::MarkerZ => "Imprecise marker z (mm)",
            Source::Actuator => "Imprecise actuator input (N)",
        }
    }
}

/// One inverse model (a table column): markers, candidates and the truth.
pub struct Layout {
    /// Column name.
    pub name: String,
    /// What the layout is.
    pub about: String,
    /// The inverse sensor at the nominal parameters.
    pub sensor: MarkerSensor,
    /// The applied force vector at each candidate (N).
    pub truth: Vec<[f64; 3]>,
}

/// One table cell.
#[derive(Debug, Clone)]
pub struct Cell {
    /// The source's level.
    pub level: f64,
    /// I_e = ‖f_computed − f_applied‖₂ (N); infinite when the inverse failed.
    pub i_e: f64,
    /// ‖f − f_reference‖₂ (N): the change the error made against the error-free inverse.
    pub delta_f: f64,
    /// I_w ‖Δδ_e‖₂ (N), for marker-offset cells: the thesis's bound on `delta_f`.
    pub bound: Option<f64>,
}

/// A column's results.
pub struct Column {
    /// Column name.
    pub name: String,
    /// What the layout is.
    pub about: String,
    /// Markers and force unknowns.
    pub markers: usize,
    /// Force unknowns.
    pub unknowns: usize,
    /// I_w of the error-free inverse (N/m).
    pub i_w: f64,
    /// I_e of the error-free inverse (N).
    pub reference: f64,
    /// Per source, its three cells.
    pub rows: Vec<(Source, Vec<Cell>)>,
}

/// The forces of `s` from `measured`, or `None` when the inverse failed or did not converge.
fn solve(s: &MarkerSensor, measured: &[Option<[f64; 3]>]) -> Option<Vec<[f64; 3]>> {
    match s.solve_frame(0, measured, None) {
        Ok(est) if est.status == softsense::markers::MarkersStatus::Converged => Some(est.forces),
        Ok(est) => {
            eprintln!("inverse {:?}: {:?}", est.status, est.warnings);
            None
        }
        Err(e) => {
            eprintln!("inverse failed: {e}");
            None
        }
    }
}

fn distance(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    (a.iter().zip(b))
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).powi(2)))
        .sum::<f64>()
        .sqrt()
}

/// The study of one column for `sources`.
pub fn study(layout: &Layout, sources: &[Source]) -> Column {
    let s = &layout.sensor;
    let mut direct = s.problem.clone();
    direct.loads = (s.locations.iter().zip(&layout.truth))
        .map(|(c, f)| PointLoad {
            at: c.at(),
            force: *f,
        })
        .collect();
    let sol = direct.solve_static(&s.newton).expect("direct FE model");
    let exact: Vec<Option<[f64; 3]>> = (s.markers.iter())
        .map(|m| Some(m.at.position(&sol.positions)))
        .collect();
    let est = s.solve_frame(0, &exact, None).expect("error-free inverse");
    let f_ref = est.forces.clone();
    let i_w = est.i_w;
    let reference = distance(&f_ref, &layout.truth);
    let cell = |level: f64, forces: Option<Vec<[f64; 3]>>, bound: Option<f64>| match forces {
        Some(f) => Cell {
            level,
            i_e: distance(&f, &layout.truth),
            delta_f: distance(&f, &f_ref),
            bound,
        },
        None => Cell {
            level,
            i_e: f64::INFINITY,
            delta_f: f64::INFINITY,
            bound,
        },
    };
    let mut rows = Vec::new();
    for &source in sources {
        let cells = (source.levels().into_iter())
            .map(|level| match source {
                Source::Young => {
                    let mut inv = s.clone();
                    let m = inv.problem.material;
                    inv.problem.material =
                        Material::new(m.young() * level / 300.0, m.poisson()).expect("modulus");
                    cell(level, solve(&inv, &exact), None)
                }
                Source::MarkerZ => {
                    let dz = level * 1e-3;
                    let measured: Vec<_> = (exact.iter())
                        .map(|p| p.map(|q| [q[0], q[1], q[2] + dz]))
                        .collect();
                    // ‖Δδ_e‖₂ of a uniform z offset on every marker.
                    let bound = i_w * dz * (exact.len() as f64).sqrt();
                    cell(level, solve(s, &measured), Some(bound))
                }
                Source::Actuator => {
                    let mut inv = s.clone();
                    for c in &mut inv.problem.cables {
                        if let CableControl::Force(f) = c.control {
                            c.control = CableControl::Force(f + level);
                        }
                    }
                    cell(level, solve(&inv, &exact), None)
                }
            })
            .collect();
        rows.push((source, cells));
    }
    Column {
        name: layout.name.clone(),
        about: layout.about.clone(),
        markers: s.markers.len(),
        unknowns: s.unknowns(),
        i_w,
        reference,
        rows,
    }
}

/// The sheet's columns: two 0.4 N forces down at (±20, 0) mm; s-a 25 markers (40 mm grid)
/// and the two candidates there, s-b the same markers and the 12-candidate grid, s-c 9
/// markers (60 mm grid) and the two candidates.
pub fn sheet_layouts() -> Vec<Layout> {
    let m = model("sheet.toml");
    let two = [[-20.0, 0.0, 4.0], [20.0, 0.0, 4.0]];
    let twelve = grid(&[-60.0, -20.0, 20.0, 60.0], &[-40.0, 0.0, 40.0], 4.0);
    let nine = grid(&[-60.0, 0.0, 60.0], &[-60.0, 0.0, 60.0], 4.0);
    let truth_at = |cands: &[[f64; 3]]| -> Vec<[f64; 3]> {
        (cands.iter())
            .map(|c| {
                let on = two.iter().any(|t| t == c);
                [0.0, 0.0, if on { -0.4 } else { 0.0 }]
            })
            .collect()
    };
    let make = |name: &str, about: &str, markers: &[[f64; 3]], cands: &[[f64; 3]]| Layout {
        name: name.into(),
        about: about.into(),
        sensor: sensor(&m, markers, cands, Directions::Normal),
        truth: truth_at(cands),
    };
    vec![
        make(
            "s-a",
            "25 markers (40 mm grid), 2 normal candidates at (±20, 0) mm",
            &sheet_markers(),
            &two,
        ),
        make(
            "s-b",
            "the same 25 markers, the 12 normal candidates (4 × 3, 40 mm)",
            &sheet_markers(),
            &twelve,
        ),
        make(
            "s-c",
            "9 markers (60 mm grid), the 2 candidates of s-a",
            &nine,
            &two,
        ),
    ]
}

/// The robot's columns: a 0.4 N weight on the tip hook; r-a 16 markers near the tip and
/// the hook, r-b the same markers, the hook and the normal candidate "top-east", r-c 16
/// markers around the east knee and the hook.
pub fn robot_layouts() -> Vec<Layout> {
    let m = model("robot.toml");
    let near = robot_tip_sensor([0.0, 0.0, 0.125]);
    let far = robot_tip_sensor([0.097, 0.0, 0.045]);
    let top_east = (m.force_points.iter())
        .find(|e| e.name == "top-east")
        .expect("robot.toml's top-east force point");
    let mut two = near.locations.clone();
    two.push(CandidateLocation::from_force_point(
        top_east,
        &m.problem.mesh,
    ));
    let with_two = near.with_locations(two).expect("robot sensor");
    let hook = [0.0, 0.0, -0.4];
    vec![
        Layout {
            name: "r-a".into(),
            about: "16 markers near the tip, the tip hook (along -z)".into(),
            sensor: near,
            truth: vec![hook],
        },
        Layout {
            name: "r-b".into(),
            about: "the same markers, the hook and the normal candidate top-east".into(),
            sensor: with_two,
            truth: vec![hook, [0.0; 3]],
        },
        Layout {
            name: "r-c".into(),
            about: "16 markers around the east knee (97, 0, 45) mm, the hook".into(),
            sensor: far,
            truth: vec![hook],
        },
    ]
}

/// The sheet's and the robot's tables, computed on two threads.
pub fn run() -> (Vec<Column>, Vec<Column>) {
    let sheet_sources = [Source::Young, Source::MarkerZ];
    let robot_sources = [Source::Young, Source::MarkerZ, Source::Actuator];
    std::thread::scope(|scope| {
        let sheet = scope.spawn(move || {
            (sheet_layouts().iter())
                .map(|l| study(l, &sheet_sources))
                .collect::<Vec<_>>()
        });
        let robot: Vec<Column> = (robot_layouts().iter())
            .map(|l| study(l, &robot_sources))
            .collect();
        (sheet.join().expect("sheet study"), robot)
    })
}

/// A markdown table of I_e (mN) in the thesis's layout: a row per source level, a column
/// per layout, with I_w and the error-free I_e on top.
pub fn table(columns: &[Column]) -> String {
    let mut out = String::from("| | |");
    columns
        .iter()
        .for_each(|c| out += &format!(" {} |", c.name));
    out += "\n| --- | --- |";
    columns.iter().for_each(|_| out += " --- |");
    out += "\n| markers / unknowns | |";
    (columns.iter()).for_each(|c| out += &format!(" {} / {} |", c.markers, c.unknowns));
    out += "\n| I_w (N/m) | |";
    columns
        .iter()
        .for_each(|c| out += &format!(" {:.1} |", c.i_w));
    out += "\n| I_e without error (mN) | |";
    (columns.iter()).for_each(|c| out += &format!(" {:.4} |", 1e3 * c.reference));
    for (r, (source, cells)) in columns[0].rows.iter().enumerate() {
        for (k, cell) in cells.iter().enumerate() {
            let label = if k == 0 { source.label() } else { "" };
            out += &format!("\n| {label} | {} |", cell.level);
            for c in columns {
                out += &format!(" {:.1} |", 1e3 * c.rows[r].1[k].i_e);
            }
        }
    }
    out.push('\n');
    out
}

/// A markdown table of the bound check: ‖Δf‖ against I_w ‖Δδ_e‖ (mN) per marker offset.
pub fn bound_table(columns: &[Column]) -> String {
    let mut out =
        String::from("| layout | z offset (mm) | ‖Δf‖ (mN) | I_w ‖Δδ_e‖ (mN) | ratio |\n");
    out += "| --- | --- | --- | --- | --- |\n";
    for c in columns {
        for (_, cells) in c.rows.iter().filter(|r| r.0 == Source::MarkerZ) {
            for cell in cells {
                let b = cell.bound.unwrap_or(f64::NAN);
                out += &format!(
                    "| {} | {} | {:.2} | {:.2} | {:.3} |\n",
                    c.name,
                    cell.level,
                    1e3 * cell.delta_f,
                    1e3 * b,
                    cell.delta_f / b
                );
            }
        }
    }
    out
}

/// The worst deviation of a source's errors from proportionality to the source's size:
/// max over the second and third level of |(e_k / e_1) / (s_k / s_1) − 1|, and whether the
/// errors grow strictly with the source.
pub fn linearity(source: Source, cells: &[Cell]) -> (f64, bool) {
    let e: Vec<f64> = cells.iter().map(|c| c.i_e).collect();
    let s: Vec<f64> = cells.iter().map(|c| source.size(c.level)).collect();
    let monotonic = e.windows(2).all(|w| w[0] < w[1]) && e.iter().all(|v| v.is_finite());
    let worst = (1..e.len())
        .map(|k| ((e[k] / e[0]) / (s[k] / s[0]) - 1.0).abs())
        .fold(0.0, f64::max);
    (worst, monotonic)
}

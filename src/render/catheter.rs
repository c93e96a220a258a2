//! The pictures of a catheter run ([`crate::catheter`]): the path and tube walls with the
//! robot's catheter at its last step, the obstacles' outlines, its contact forces as
//! arrows and the tip's track,
//! seen from above and from the side; and the tracking errors over time.

use super::canvas::{Canvas, Rgb, WHITE};
use super::plot::{line_chart, Series};
use super::RenderError;
use crate::catheter::run::{Run, StepRecord};
use std::path::Path;

const PATH: Rgb = [120, 120, 120];
const WALL: Rgb = [190, 190, 190];
const ROBOT: Rgb = [40, 90, 180];
const MODEL: Rgb = [215, 95, 30];
const FORCE: Rgb = [200, 40, 40];
const TRACK: Rgb = [60, 150, 60];
const OBSTACLE: Rgb = [90, 60, 40];

/// Length of a force arrow per newton (mm/N).
const ARROW_MM_PER_N: f64 = 5.0;

/// A NaN point: breaks a series' line, so one series can hold many segments.
const BREAK: [f64; 2] = [f64::NAN, f64::NAN];

/// The pictures of a run: `path.png` (above and side views) and `errors.png`.
pub fn pictures(run: &Run) -> Result<Vec<(&'static str, Canvas)>, RenderError> {
    let path = run.scenario.centreline()?;
    let radius = 0.5e-3 * run.scenario.tube.diameter_mm;
    let last = run.steps.last();
    let obstacles = run.scenario.obstacles();
    let view = |axes: [usize; 2], title: &str| {
        let mm = |p: [f64; 3]| [1e3 * p[axes[0]], 1e3 * p[axes[1]]];
        let centre: Vec<[f64; 2]> = path.points().iter().map(|&p| mm(p)).collect();
        let walls = wall_lines(&centre, 1e3 * radius);
        let obstacles: Vec<[f64; 2]> = (obstacles.iter())
            .flat_map(|o| obstacle_outline(mm(o.a), mm(o.b), 1e3 * o.radius))
            .collect();
        let track: Vec<[f64; 2]> = run.steps.iter().map(|r| mm(r.robot)).collect();
        let nodes = |x: &[[f64; 3]]| -> Vec<[f64; 2]> { x.iter().map(|&p| mm(p)).collect() };
        let mut arrows = Vec::new();
        if let Some(r) = last {
            for c in &r.robot_contacts {
                let at = run.robot_nodes[c.node];
                let tail: [f64; 3] =
                    std::array::from_fn(|k| at[k] - 1e-3 * ARROW_MM_PER_N * c.force * c.normal[k]);
                arrows.extend([mm(tail), mm(at), BREAK]);
            }
        }
        let names = ["x (mm)", "y (mm)", "z (mm)"];
        let force_label = format!("robot's contact forces ({ARROW_MM_PER_N} mm/N)");
        line_chart(
            title,
            [names[axes[0]], names[axes[1]]],
            &[
                Series {
                    label: "tube wall",
                    color: WALL,
                    points: walls,
                },
                Series {
                    label: "path",
                    color: PATH,
                    points: centre,
                },
                Series {
                    label: "obstacles",
                    color: OBSTACLE,
                    points: obstacles,
                },
                Series {
                    label: "tip track",
                    color: TRACK,
                    points: track,
                },
                Series {
                    label: "robot (last step)",
                    color: ROBOT,
                    points: nodes(&run.robot_nodes),
                },
                Series {
                    label: "model (last step)",
                    color: MODEL,
                    points: nodes(&run.model_nodes),
                },
                Series {
                    label: &force_label,
                    color: FORCE,
                    points: arrows,
                },
            ],
            &[],
            600,
            520,
        )
    };
    let mut picture = Canvas::new(1200, 520, WHITE)?;
    picture.blit(
        &view([0, 1], &format!("{}: from above (x, y)", run.name))?,
        0,
        0,
    );
    picture.blit(&view([0, 2], "from the side (x, z)")?, 600, 0);
    let rate = run.scenario.rate_hz;
    let series = |label, color, f: &dyn Fn(&StepRecord) -> f64| Series {
        label,
        color,
        points: run
            .steps
            .iter()
            .map(|r| [r.step as f64 / rate, f(r)])
            .collect(),
    };
    let bends: Vec<[f64; 2]> = bend_times(run);
    let errors = line_chart(
        &format!("{}: tracking error (bends shaded)", run.name),
        ["time (s)", "mm"],
        &[
            series("robot tip to path", ROBOT, &|r| 1e3 * r.error),
            series("model tip to path", MODEL, &|r| 1e3 * r.model_error),
        ],
        &bends,
        1000,
        380,
    )?;
    Ok(vec![("path.png", picture), ("errors.png", errors)])
}

/// The two walls of a tube of `radius` round a projected centreline: offsets along the
/// in-plane normal (the projection of the tube's silhouette), one series broken between.
fn wall_lines(centre: &[[f64; 2]], radius: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::with_capacity(2 * centre.len() + 1);
    for side in [1.0, -1.0] {
        for (i, p) in centre.iter().enumerate() {
            let (a, b) = (
                centre[i.saturating_sub(1)],
                centre[(i + 1).min(centre.len() - 1)],
            );
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let l = (dx * dx + dy * dy).sqrt();
            if l > 1e-9 {
                out.push([p[0] - side * radius * dy / l, p[1] + side * radius * dx / l]);
            }
        }
        out.push(BREAK);
    }
    out
}

/// The outline of a capsule of `radius` round the projected segment `a`-`b`: a circle
/// round each end and, between them, the two sides; at least 0.5 wide, so that a point
/// obstacle shows.
fn obstacle_outline(a: [f64; 2], b: [f64; 2], radius: f64) -> Vec<[f64; 2]> {
    let r = radius.max(0.5);
    let mut out = Vec::new();
    for c in [a, b] {
        out.extend((0..=24).map(|i| {
            let t = std::f64::consts::TAU * f64::from(i) / 24.0;
            [c[0] + r * t.cos(), c[1] + r * t.sin()]
        }));
        out.push(BREAK);
    }
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l = (dx * dx + dy * dy).sqrt();
    if l > 1e-9 {
        for side in [1.0, -1.0] {
            let (nx, ny) = (-side * r * dy / l, side * r * dx / l);
            out.extend([[a[0] + nx, a[1] + ny], [b[0] + nx, b[1] + ny], BREAK]);
        }
    }
    out
}

/// Time ranges where the robot's desired point is on a bend (s).
fn bend_times(run: &Run) -> Vec<[f64; 2]> {
    let rate = run.scenario.rate_hz;
    let mut out: Vec<[f64; 2]> = Vec::new();
    let mut open: Option<f64> = None;
    for r in &run.steps {
        let t = r.step as f64 / rate;
        match (r.straight, open) {
            (false, None) => open = Some(t),
            (true, Some(t0)) => {
                out.push([t0, t]);
                open = None;
            }
            _ => {}
        }
    }
    if let (Some(t0), Some(r)) = (open, run.steps.last()) {
        out.push([t0, r.step as f64 / rate]);
    }
    out
}

/// Writes [`pictures`] into `dir` (which must exist) as PNG files.
pub fn write_pictures(run: &Run, dir: &Path) -> Result<(), RenderError> {
    for (name, canvas) in pictures(run)? {
        canvas.save_png(dir.join(name))?;
    }
    Ok(())
}

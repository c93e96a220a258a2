//! The pictures of a control run ([`crate::control`]): the effector error against step,
//! the path of target, robot and model seen from above and from the side, and each
//! cable's input against step.

use super::canvas::{Canvas, Rgb, WHITE};
use super::plot::{line_chart, Series};
use super::RenderError;
use crate::control::run::{Run, StepRecord};
use crate::control::scenario::Actuation;
use crate::math::dist;
use std::path::Path;

const TARGET: Rgb = [120, 120, 120];
const ROBOT: Rgb = [40, 90, 180];
const MODEL: Rgb = [215, 95, 30];
// Blue and orange mean robot and model in every picture of a run, so the cables take
// other colours.
const CABLES: [Rgb; 6] = [
    [60, 150, 60],
    [170, 50, 150],
    [30, 160, 170],
    [150, 120, 40],
    [200, 60, 80],
    [110, 80, 200],
];

/// The pictures of a run: `error.png` (robot error and model gap against step, lost
/// steps shaded), `path.png` (target, robot and model seen from above and from the side),
/// `inputs.png` (each cable's input against step).
pub fn pictures(run: &Run) -> Result<Vec<(&'static str, Canvas)>, RenderError> {
    let steps = &run.steps;
    let series = |label, color, f: &dyn Fn(&StepRecord) -> f64| Series {
        label,
        color,
        points: steps.iter().map(|r| [r.step as f64, f(r)]).collect(),
    };
    let shade: Vec<[f64; 2]> = (run.scenario.sensor.lost.iter())
        .map(|r| [r[0] as f64, r[1] as f64])
        .collect();
    let gap = |r: &StepRecord| 1e3 * dist(r.model, r.robot);
    let error = line_chart(
        &format!("{}: effector error", run.name),
        ["step", "mm"],
        &[
            series("robot - target", ROBOT, &|r| 1e3 * r.error),
            series("model - robot", MODEL, &gap),
        ],
        &shade,
        900,
        360,
    )?;
    let view = |axes: [usize; 2], title: &str| {
        let pts = |f: &dyn Fn(&StepRecord) -> [f64; 3]| {
            steps
                .iter()
                .map(|r| {
                    let p = f(r);
                    [1e3 * p[axes[0]], 1e3 * p[axes[1]]]
                })
                .collect()
        };
        let names = ["x (mm)", "y (mm)", "z (mm)"];
        line_chart(
            title,
            [names[axes[0]], names[axes[1]]],
            &[
                Series {
                    label: "target",
                    color: TARGET,
                    points: pts(&|r| r.target),
                },
                Series {
                    label: "robot",
                    color: ROBOT,
                    points: pts(&|r| r.robot),
                },
                Series {
                    label: "model",
                    color: MODEL,
                    points: pts(&|r| r.model),
                },
            ],
            &[],
            450,
            420,
        )
    };
    let mut path = Canvas::new(900, 420, WHITE)?;
    path.blit(&view([0, 1], "path from above (x, y)")?, 0, 0);
    path.blit(&view([0, 2], "path from the side (x, z)")?, 450, 0);
    let scale = run.scenario.input_scale();
    let unit = match run.scenario.controller.actuation {
        Actuation::Displacement => "mm",
        Actuation::Force => "N",
        Actuation::Pressure => "kPa",
    };
    let n = steps.first().map_or(0, |r| r.inputs.len());
    let what = match run.scenario.controller.actuation {
        Actuation::Pressure => "cavity",
        _ => "cable",
    };
    let labels: Vec<String> = (0..n).map(|i| format!("{what} {i}")).collect();
    let cables: Vec<Series> = (0..n)
        .map(|i| {
            series(&labels[i], CABLES[i % CABLES.len()], &move |r| {
                r.inputs[i] / scale
            })
        })
        .collect();
    let inputs = line_chart(
        &format!("{}: robot inputs", run.name),
        ["step", unit],
        &cables,
        &shade,
        900,
        360,
    )?;
    Ok(vec![
        ("error.png", error),
        ("path.png", path),
        ("inputs.png", inputs),
    ])
}

/// Writes [`pictures`] into `dir` (which must exist) as PNG files.
pub fn write_pictures(run: &Run, dir: &Path) -> Result<(), RenderError> {
    for (name, canvas) in pictures(run)? {
        canvas.save_png(dir.join(name))?;
    }
    Ok(())
}

//! A run's files: the trajectory as CSV and JSON, and pictures a person reads (error
//! against step, the 3-D path of target, robot and model, inputs against step).

use super::run::{dist, Run};
use super::{ControlError, ControlResult};
use crate::render::{line_chart, Canvas, Rgb, Series};
use std::fmt::Write as _;
use std::path::Path;

/// The trajectory as CSV: one row per step, positions in mm, inputs in the scenario's
/// unit (mm of shortening or N), `measured_*` empty where nothing was seen.
pub fn trajectory_csv(run: &Run) -> String {
    let n = run.steps.first().map_or(0, |r| r.inputs.len());
    let scale = run.scenario.input_scale();
    let mut s = String::from(
        "step,target_x,target_y,target_z,measured_x,measured_y,measured_z,robot_x,robot_y,robot_z,\
         model_x,model_y,model_z,error_mm",
    );
    for i in 0..n {
        let _ = write!(s, ",input_{i}");
    }
    for i in 0..n {
        let _ = write!(s, ",model_input_{i}");
    }
    s.push_str(",switch,bounded\n");
    let mm = |p: [f64; 3]| format!("{:.6},{:.6},{:.6}", 1e3 * p[0], 1e3 * p[1], 1e3 * p[2]);
    for r in &run.steps {
        let measured = r.measured.map_or(",,".to_string(), mm);
        let _ = write!(
            s,
            "{},{},{},{},{},{:.6}",
            r.step,
            mm(r.target),
            measured,
            mm(r.robot),
            mm(r.model),
            1e3 * r.error
        );
        for v in r.inputs.iter().chain(&r.model_inputs) {
            let _ = write!(s, ",{:.6}", v / scale);
        }
        let switch = serde_json::to_value(r.switch)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        let _ = writeln!(s, ",{switch},{}", r.bounded);
    }
    s
}

/// Writes `trajectory.csv`, `run.json` and the pictures into `dir` (created if needed).
pub fn write_run(run: &Run, dir: &Path) -> ControlResult<()> {
    let file_err = |p: &Path| {
        let path = p.display().to_string();
        move |source| ControlError::File { path, source }
    };
    std::fs::create_dir_all(dir).map_err(file_err(dir))?;
    let csv = dir.join("trajectory.csv");
    std::fs::write(&csv, trajectory_csv(run)).map_err(file_err(&csv))?;
    let json = dir.join("run.json");
    let text = serde_json::to_string_pretty(run)
        .map_err(|e| ControlError::Scenario(format!("cannot write JSON: {e}")))?;
    std::fs::write(&json, text).map_err(file_err(&json))?;
    for (name, canvas) in pictures(run)? {
        canvas.save_png(dir.join(name))?;
    }
    Ok(())
}

const TARGET: Rgb = [120, 120, 120];
const ROBOT: Rgb = [40, 90, 180];
const MODEL: Rgb = [215, 95, 30];
const CABLES: [Rgb; 6] = [
    [40, 90, 180],
    [215, 95, 30],
    [60, 150, 60],
    [170, 50, 150],
    [30, 160, 170],
    [150, 120, 40],
];

/// The pictures of a run: `error.png` (robot error and model gap against step, lost
/// steps shaded), `path.png` (target, robot and model seen from above and from the side),
/// `inputs.png` (each cable's input against step).
pub fn pictures(run: &Run) -> ControlResult<Vec<(&'static str, Canvas)>> {
    let steps = &run.steps;
    let series = |label, color, f: &dyn Fn(&super::run::StepRecord) -> f64| Series {
        label,
        color,
        points: steps.iter().map(|r| [r.step as f64, f(r)]).collect(),
    };
    let shade: Vec<[f64; 2]> = (run.scenario.sensor.lost.iter())
        .map(|r| [r[0] as f64, r[1] as f64])
        .collect();
    let gap = |r: &super::run::StepRecord| 1e3 * dist(r.model, r.robot);
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
        let pts = |f: &dyn Fn(&super::run::StepRecord) -> [f64; 3]| {
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
    let mut path = Canvas::new(900, 420, crate::render::WHITE)?;
    path.blit(&view([0, 1], "path from above (x, y)")?, 0, 0);
    path.blit(&view([0, 2], "path from the side (x, z)")?, 450, 0);
    let scale = run.scenario.input_scale();
    let unit = match run.scenario.controller.actuation {
        super::scenario::Actuation::Displacement => "mm",
        super::scenario::Actuation::Force => "N",
    };
    let n = steps.first().map_or(0, |r| r.inputs.len());
    let labels: Vec<String> = (0..n).map(|i| format!("cable {i}")).collect();
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

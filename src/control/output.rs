//! A run's files: the trajectory as CSV and JSON. Its pictures are drawn by
//! [`crate::render::control`], which the command line writes beside these.

use super::run::Run;
use super::{ControlError, ControlResult};
use crate::io::atomic;
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

/// Writes `trajectory.csv` and `run.json` into `dir` (created if needed), each all or
/// nothing ([`atomic::write`]).
pub fn write_run(run: &Run, dir: &Path) -> ControlResult<()> {
    std::fs::create_dir_all(dir).map_err(|source| ControlError::File {
        path: dir.display().to_string(),
        source,
    })?;
    atomic::write(&dir.join("trajectory.csv"), trajectory_csv(run).as_bytes())?;
    let text = serde_json::to_string_pretty(run).map_err(ControlError::Json)?;
    atomic::write(&dir.join("run.json"), text.as_bytes())?;
    Ok(())
}

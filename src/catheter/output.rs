//! A run's files: the steps as CSV and the whole run as JSON. Its pictures are drawn by
//! `render::catheter`, which the command line writes beside these.

use super::run::Run;
use super::{CatheterError, CatheterResult};
use crate::io::atomic;
use std::fmt::Write as _;
use std::path::Path;

/// The steps as CSV: positions and errors in mm, pulls in mm, tensions and forces in N.
pub fn steps_csv(run: &Run) -> String {
    let n = run.steps.first().map_or(0, |r| r.pulls.len());
    let mut s = String::from(
        "step,time_s,insertion_mm,s_mm,straight,error_mm,model_error_mm,robot_x,robot_y,robot_z,\
         measured_x,measured_y,measured_z,model_x,model_y,model_z",
    );
    for i in 0..n {
        let _ = write!(s, ",pull_{i}_mm,robot_tension_{i}_n,model_tension_{i}_n");
    }
    s.push_str(
        ",robot_contacts,robot_force_sum_n,model_contacts,model_force_sum_n,rotation_margin\n",
    );
    let mm = |p: [f64; 3]| format!("{:.4},{:.4},{:.4}", 1e3 * p[0], 1e3 * p[1], 1e3 * p[2]);
    for r in &run.steps {
        let _ = write!(
            s,
            "{},{:.3},{:.4},{:.4},{},{:.4},{:.4},{},{},{}",
            r.step,
            r.step as f64 / run.scenario.rate_hz,
            1e3 * r.insertion,
            1e3 * r.s,
            r.straight,
            1e3 * r.error,
            1e3 * r.model_error,
            mm(r.robot),
            mm(r.measured),
            mm(r.model)
        );
        for i in 0..n {
            let _ = write!(
                s,
                ",{:.5},{:.5},{:.5}",
                1e3 * r.pulls[i],
                r.robot_tensions[i],
                r.model_tensions[i]
            );
        }
        let sum = |c: &[super::rig::ContactForce]| c.iter().map(|c| c.force).sum::<f64>();
        let margin = r
            .rotation_margin
            .map_or(String::new(), |m| format!("{m:.5}"));
        let _ = writeln!(
            s,
            ",{},{:.5},{},{:.5},{margin}",
            r.robot_contacts.len(),
            sum(&r.robot_contacts),
            r.model_contacts.len(),
            sum(&r.model_contacts)
        );
    }
    s
}

/// Writes `steps.csv` and `run.json` into `dir` (created if needed), each all or nothing.
pub fn write_run(run: &Run, dir: &Path) -> CatheterResult<()> {
    std::fs::create_dir_all(dir).map_err(|source| CatheterError::File {
        path: dir.display().to_string(),
        source,
    })?;
    atomic::write(&dir.join("steps.csv"), steps_csv(run).as_bytes())?;
    let text = serde_json::to_string_pretty(run)
        .map_err(|e| CatheterError::Shape(format!("cannot write the run as JSON: {e}")))?;
    atomic::write(&dir.join("run.json"), text.as_bytes())?;
    Ok(())
}

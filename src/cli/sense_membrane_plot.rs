//! The membrane mode's timeline picture: estimated |F| with its 2-sigma band, and the
//! measured |F| when given.

use super::{CliError, CliResult};
use softsense::render::{line_chart, Series};
use softsense::sense::membrane::{MembraneEstimate, MembraneStatus};
use std::collections::BTreeMap;
use std::path::Path;

pub fn timeline(
    path: &Path,
    frames: &[usize],
    estimates: &[(MembraneEstimate, Option<String>)],
    measured: &BTreeMap<usize, f64>,
) -> CliResult {
    let at = |f: &dyn Fn(&MembraneEstimate) -> f64| -> Vec<[f64; 2]> {
        (frames.iter().zip(estimates))
            .map(|(&k, (e, _))| match e.status {
                MembraneStatus::Ok => [k as f64, f(e)],
                _ => [k as f64, f64::NAN],
            })
            .collect()
    };
    let mut series = vec![
        Series {
            label: "estimate + 2 sigma",
            color: [150, 180, 225],
            points: at(&|e| e.magnitude + 2.0 * e.sigma),
        },
        Series {
            label: "estimate - 2 sigma",
            color: [150, 180, 225],
            points: at(&|e| (e.magnitude - 2.0 * e.sigma).max(0.0)),
        },
        Series {
            label: "estimated |F|",
            color: [40, 80, 170],
            points: at(&|e| e.magnitude),
        },
    ];
    if !measured.is_empty() {
        series.push(Series {
            label: "measured |F|",
            color: [215, 95, 30],
            points: measured.iter().map(|(&k, &m)| [k as f64, m]).collect(),
        });
    }
    // Frames without an estimate are shaded.
    let shade: Vec<[f64; 2]> = (frames.iter().zip(estimates))
        .filter(|(_, (e, _))| e.status != MembraneStatus::Ok)
        .map(|(&k, _)| [k as f64 - 0.5, k as f64 + 0.5])
        .collect();
    let chart = line_chart(
        "Contact force on the membrane",
        ["frame", "|F| (N)"],
        &series,
        &shade,
        900,
        420,
    )
    .map_err(|e| CliError::Result(format!("{}: {e}", path.display())))?;
    chart
        .save_png(path)
        .map_err(|e| CliError::Result(format!("{}: {e}", path.display())))
}

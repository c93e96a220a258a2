//! Diagnostic of one generated dataset (issue 7): the residual statistics with no effect,
//! with the true effects and with each true effect alone, read from the truth file (a
//! diagnostic for the developer; the workflow itself never reads it).
//!
//! Usage: cargo run --example explain_diag -- DATASET_DIR (as written by explain_acceptance)
use softsense::discrepancy::data::load_frames;
use softsense::discrepancy::effects::Effect;
use softsense::discrepancy::generate::{layout, DatasetTruth};
use softsense::discrepancy::{evaluate, DiscrepancyParams};
use softsense::fem::model::Model;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).ok_or("usage: explain_diag DIR")?);
    let (frames, truth_path) = layout(&dir);
    let truth: DatasetTruth = serde_json::from_str(&std::fs::read_to_string(truth_path)?)?;
    let model = Model::load(&truth.spec.model, None)?;
    let rec = load_frames(&frames, &Default::default())?;
    let params = DiscrepancyParams::default();
    let lib: Vec<Effect> = truth.library_effects();
    let mut sets: Vec<(String, Vec<Effect>)> =
        vec![("none".into(), vec![]), ("truth".into(), lib.clone())];
    for e in &lib {
        sets.push((e.kind.name(), vec![e.clone()]));
    }
    for (name, effects) in sets {
        let [train, hold] = evaluate(&model, &rec, &params, &effects)?;
        let (t, h) = (
            train.last().ok_or("no stats")?,
            hold.last().ok_or("no stats")?,
        );
        println!(
            "{name:40} train chi2 {:10.1} n {:5} z {:8.1} | hold chi2 {:10.1} n {:5} z {:8.1} rms {:.3} mm noise {:.3} mm",
            t.chi2, t.n, t.z, h.chi2, h.n, h.z, h.rms * 1e3, h.noise_rms * 1e3
        );
    }
    Ok(())
}

//! Diagnostic: residual statistics of a hidden-effect dataset at nominal and at the truth.
//! Usage: cargo run --example explain_probe -- DATASET_DIR [MODEL]
use softsense::discrepancy::data::load_frames;
use softsense::discrepancy::generate::{layout, DatasetTruth};
use softsense::discrepancy::{evaluate, DiscrepancyParams};
use softsense::fem::model::Model;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(&args[1]);
    let model_path = args
        .get(2)
        .cloned()
        .unwrap_or("meshes/models/robot.toml".into());
    let model = Model::load(std::path::Path::new(&model_path), None)?;
    let (frames, truth) = layout(&dir);
    let rec = load_frames(&frames, &Default::default())?;
    let truth: DatasetTruth = serde_json::from_str(&std::fs::read_to_string(truth)?)?;
    let effects = truth.library_effects();
    let p = DiscrepancyParams::default();
    let mut cases = vec![
        ("nominal".to_string(), vec![]),
        ("truth".to_string(), effects),
    ];
    for v in args.iter().skip(3) {
        // extra: kind=value, e.g. young=-0.1
        let (k, x) = v.split_once('=').unwrap();
        let e: softsense::discrepancy::effects::Effect =
            serde_json::from_str(&format!("{{\"kind\": \"{k}\", \"params\": [{x}]}}"))?;
        cases.push((v.clone(), vec![e]));
    }
    for (name, eff) in cases {
        let [tr, ho] = evaluate(&model, &rec, &p, &eff)?;
        for (set, s) in [("train", tr), ("hold", ho)] {
            let a = s.last().unwrap();
            println!(
                "{name:12} {set:5} n {:4} rms {:.3} mm noise {:.3} mm chi2/n {:.2} z {:.1}",
                a.n,
                a.rms * 1e3,
                a.noise_rms * 1e3,
                a.chi2 / a.n.max(1) as f64,
                a.z
            );
        }
    }
    Ok(())
}

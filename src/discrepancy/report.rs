//! Writing the results: the updated model file and the report folder.

use super::effects::EffectKind;
use super::{DiscrepancyError, DiscrepancyResult, Explanation, FittedEffect, Outcome, RegionStats};
use crate::fem::model::Units;
use std::fmt::Write as _;
use std::path::Path;

fn file_err(path: &Path, e: impl std::fmt::Display) -> DiscrepancyError {
    DiscrepancyError::File {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// One line per effect: name, parameters ± 1σ.
pub fn describe(e: &FittedEffect) -> String {
    let names: Vec<&str> = match e.effect.kind {
        EffectKind::Gravity | EffectKind::Young | EffectKind::LegStiffness { .. } => {
            vec!["relative change"]
        }
        EffectKind::Poisson => vec!["change of Poisson ratio"],
        EffectKind::PointLoad { .. } => vec!["Fx (N)", "Fy (N)", "Fz (N)"],
        EffectKind::ActuatorOffset => vec!["offset (N, m, Pa or m^3)"; e.effect.params.len()],
        EffectKind::CameraPose => vec![
            "wx (rad)", "wy (rad)", "wz (rad)", "tx (m)", "ty (m)", "tz (m)",
        ],
        EffectKind::Depth => vec!["scale - 1", "offset (m)"],
    };
    let parts: Vec<String> = e
        .effect
        .params
        .iter()
        .zip(&e.sigma)
        .zip(names)
        .map(|((p, s), n)| format!("{n} {p:.4e} ± {s:.1e}"))
        .collect();
    format!("{}: {}", e.name, parts.join(", "))
}

/// The model file text with the effects added: material and mass effects edit their
/// fields, a point load becomes a `[[loads]]` entry; effects the model file cannot hold
/// (leg stiffness, actuator offsets, camera pose, depth) are written as comments.
pub fn updated_model(
    original: &str,
    units: &Units,
    effects: &[FittedEffect],
) -> DiscrepancyResult<String> {
    let mut v: toml::Value =
        toml::from_str(original).map_err(|e| DiscrepancyError::Data(format!("model file: {e}")))?;
    let t = v
        .as_table_mut()
        .ok_or_else(|| DiscrepancyError::Data("model file is not a table".into()))?;
    let mut notes = String::from(
        "# Updated by `softsense explain`: effects found and fitted (value ± 1 sigma):\n",
    );
    for e in effects {
        let _ = writeln!(notes, "#   {}", describe(e));
        let p0 = e.effect.params.first().copied().unwrap_or(0.0);
        let get = |t: &toml::value::Table, k: &str| {
            t.get(k)
                .and_then(|x| x.as_float().or(x.as_integer().map(|i| i as f64)))
        };
        match e.effect.kind {
            EffectKind::Young | EffectKind::Poisson => {
                if let Some(m) = t.get_mut("material").and_then(|m| m.as_table_mut()) {
                    let (key, val) = if e.effect.kind == EffectKind::Young {
                        ("young", get(m, "young").map(|y| y / (1.0 + p0)))
                    } else {
                        ("poisson", get(m, "poisson").map(|y| y + p0))
                    };
                    if let Some(val) = val {
                        m.insert(key.into(), toml::Value::Float(val));
                    }
                }
            }
            EffectKind::Gravity => {
                if let Some(m) = t.get_mut("mass").and_then(|m| m.as_table_mut()) {
                    for key in ["total", "density"] {
                        if let Some(val) = get(m, key) {
                            m.insert(key.into(), toml::Value::Float(val * (1.0 + p0)));
                        }
                    }
                }
            }
            EffectKind::PointLoad { node } => {
                let mut l = toml::value::Table::new();
                l.insert("node".into(), toml::Value::Integer(node as i64));
                l.insert(
                    "force".into(),
                    toml::Value::Array(
                        e.effect
                            .params
                            .iter()
                            .map(|f| toml::Value::Float(f / units.force))
                            .collect(),
                    ),
                );
                let loads = t
                    .entry("loads")
                    .or_insert_with(|| toml::Value::Array(Vec::new()));
                if let Some(a) = loads.as_array_mut() {
                    a.push(toml::Value::Table(l));
                }
            }
            _ => {
                let _ = writeln!(
                    notes,
                    "#     (not representable in the model file; see effects.json)"
                );
            }
        }
    }
    let body =
        toml::to_string(&v).map_err(|e| DiscrepancyError::Data(format!("model file: {e}")))?;
    Ok(format!("{notes}{body}"))
}

fn stats_table(out: &mut String, before: &[RegionStats], after: &[RegionStats]) {
    let _ = writeln!(
        out,
        "| region | rows | RMS before (mm) | RMS after (mm) | noise floor (mm) | z before | z after |\n| --- | --- | --- | --- | --- | --- | --- |"
    );
    for (b, a) in before.iter().zip(after) {
        let _ = writeln!(
            out,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.1} | {:.1} |",
            b.region,
            b.n,
            b.rms * 1e3,
            a.rms * 1e3,
            b.noise_rms * 1e3,
            b.z,
            a.z
        );
    }
}

/// A Markdown summary of an explanation.
pub fn markdown(x: &Explanation) -> String {
    let mut s = String::from("# softsense explain: report\n\n");
    match &x.outcome {
        Outcome::NoMissingEffect => {
            s.push_str("**No missing effect**: the residual is at the sensor noise floor.\n\n")
        }
        Outcome::Explained { effects } => {
            s.push_str("**Explained** by:\n\n");
            for e in effects {
                let _ = writeln!(s, "- {}", describe(e));
            }
            s.push('\n');
        }
        Outcome::UnexplainedResidual { regions, partial } => {
            let _ = writeln!(
                s,
                "**Unexplained residual remains** in: {}\n",
                regions.join(", ")
            );
            for e in partial {
                let _ = writeln!(s, "- kept on the way (not claimed): {}", describe(e));
            }
            s.push('\n');
        }
    }
    let _ = writeln!(
        s,
        "Frames: training {:?}, held out {:?}. Feature points: {}.\n\n## Held-out residual per region\n",
        x.split[0],
        x.split[1],
        x.features.len()
    );
    stats_table(&mut s, &x.before, &x.after);
    s.push_str("\n## Selection steps (candidates by BIC, best first)\n\n");
    for (i, st) in x.steps.iter().enumerate() {
        let _ = writeln!(
            s,
            "Step {} ({}): BIC with the effects kept so far {:.1}; held-out χ² {:.1} → {:.1}; {}\n\n| candidate | k | χ² | BIC | exact |\n| --- | --- | --- | --- | --- |",
            i + 1,
            st.action,
            st.bic_current,
            st.holdout_chi2[0],
            st.holdout_chi2[1],
            if st.accepted { "kept" } else { "rejected" }
        );
        for c in st.candidates.iter().take(12) {
            let _ = writeln!(
                s,
                "| {} | {} | {:.1} | {:.1} | {} |",
                c.name,
                c.k,
                c.chi2,
                c.bic,
                if c.refined { "yes" } else { "linear" }
            );
        }
        s.push('\n');
    }
    s
}

/// Writes `index.md`, `explanation.json` and `effects.json` into `dir`, and the updated
/// model as `model_updated.toml` from the original model text.
pub fn write_report(
    dir: &Path,
    x: &Explanation,
    model_text: &str,
    units: &Units,
) -> DiscrepancyResult<()> {
    std::fs::create_dir_all(dir).map_err(|e| file_err(dir, e))?;
    let w = |name: &str, text: String| -> DiscrepancyResult<()> {
        let p = dir.join(name);
        Ok(crate::io::atomic::write(&p, text.as_bytes())?)
    };
    let mut md = markdown(x);
    for pic in ["residual_before_after.png", "criterion.png"] {
        if dir.join(pic).exists() {
            let _ = writeln!(md, "![{pic}]({pic})\n");
        }
    }
    md.push_str("Files: `model_updated.toml` (the model with the effects), `effects.json`, `explanation.json`.\n");
    w("index.md", md)?;
    w(
        "explanation.json",
        serde_json::to_string_pretty(x).map_err(|e| DiscrepancyError::Data(e.to_string()))?,
    )?;
    w(
        "effects.json",
        serde_json::to_string_pretty(&x.kept).map_err(|e| DiscrepancyError::Data(e.to_string()))?,
    )?;
    w(
        "model_updated.toml",
        updated_model(model_text, units, &x.kept)?,
    )
}

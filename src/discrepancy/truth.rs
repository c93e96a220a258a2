//! `hidden --truth`: a hidden-effect dataset rendered from a body that is not the model.
//! The body is the scene generator's `[truth]` ([`crate::scene::truth`]): the same keys,
//! the same checks, the same body; this file only reads the option and puts the hidden
//! effects on that body.
//!
//! The option is a preset (`modulus`, `neo-hookean`), the keys inline (`young_factor =
//! 1.1, formulation = "neo-hookean"`, a TOML inline table without its braces) or a TOML
//! file with them (at its top or in a `[truth]` table, so a scene file serves). Numbers
//! may be ranges `[lo, hi]`, drawn from the dataset's seed as a sweep draws them.
//!
//! ```
//! use softsense::discrepancy::truth::parse_truth;
//! let t = parse_truth("young_factor = 1.1").unwrap();
//! assert_eq!(t.draw(1, 0, None).young_factor, 1.1);
//! assert!(parse_truth("young_factor = 0").is_err());
//! ```

use super::effects::{Effect, EffectKind};
use super::{DiscrepancyError, DiscrepancyResult};
use crate::fem::model::Model;
use crate::scene::truth::{on_mesh, TruthRanges, TruthSpec};
use std::path::Path;

/// The presets of `--truth`: name, the keys they stand for, what they are.
pub const TRUTH_PRESETS: [(&str, &str, &str); 2] = [
    (
        "modulus",
        "young_factor = [0.85, 1.15]",
        "the modulus off, drawn within ±15% from the seed",
    ),
    (
        "neo-hookean",
        "formulation = \"neo-hookean\"",
        "a compressible Neo-Hookean body, the model's E and ν",
    ),
];

fn bad(arg: &str, problem: impl Into<String>) -> DiscrepancyError {
    DiscrepancyError::Truth {
        arg: arg.into(),
        problem: problem.into(),
    }
}

/// Reads `--truth`'s value (a preset, inline keys or a file: see the module's help); a
/// `mesh` is resolved against the file's folder (the current folder for inline keys) and
/// must exist. Every key is checked as the scene generator checks it.
pub fn parse_truth(arg: &str) -> DiscrepancyResult<TruthRanges> {
    let text = arg.trim();
    if text.is_empty() {
        return Err(bad(arg, "is empty: give a preset, KEY = VALUE or a file"));
    }
    let (table, base) = if let Some((_, keys, _)) = TRUTH_PRESETS.iter().find(|p| p.0 == text) {
        (parse_keys(arg, keys)?, Path::new(".").to_path_buf())
    } else if text.contains('=') {
        (parse_keys(arg, text)?, Path::new(".").to_path_buf())
    } else {
        let path = Path::new(text);
        let body = std::fs::read_to_string(path).map_err(|e| {
            let presets: Vec<&str> = TRUTH_PRESETS.iter().map(|p| p.0).collect();
            bad(
                arg,
                format!(
                    "is not a preset ({}), not KEY = VALUE, and not a readable file: {e}",
                    presets.join(", ")
                ),
            )
        })?;
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        (parse_file(arg, &body)?, dir)
    };
    table.check().map_err(|e| bad(arg, e.to_string()))?;
    resolve_mesh(arg, table, &base)
}

/// Inline keys: a TOML inline table without its braces.
fn parse_keys(arg: &str, keys: &str) -> DiscrepancyResult<TruthRanges> {
    #[derive(serde::Deserialize)]
    struct Wrap {
        truth: TruthRanges,
    }
    let w: Wrap = toml::from_str(&format!("truth = {{ {keys} }}"))
        .map_err(|e| bad(arg, format!("not [truth] keys: {}", e.message())))?;
    Ok(w.truth)
}

/// A file: the keys at its top, or in its `[truth]` table.
fn parse_file(arg: &str, body: &str) -> DiscrepancyResult<TruthRanges> {
    let v: toml::Table = toml::from_str(body).map_err(|e| bad(arg, e.to_string()))?;
    let table = match v.get("truth") {
        Some(toml::Value::Table(t)) => t.clone(),
        _ => v,
    };
    toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| bad(arg, format!("not [truth] keys: {}", e.message())))
}

fn resolve_mesh(arg: &str, mut t: TruthRanges, base: &Path) -> DiscrepancyResult<TruthRanges> {
    if let Some(m) = &t.mesh {
        let p = base.join(m);
        if !p.is_file() {
            return Err(bad(
                arg,
                format!(
                    "mesh {}: no such file (a 2x finer robot: python3 tools/mesh/gen_meshes.py \
                     /tmp/fine --robot-h 4.4 --only robot)",
                    p.display()
                ),
            ));
        }
        t.mesh = Some(std::path::absolute(&p).unwrap_or(p).display().to_string());
    }
    Ok(t)
}

/// The body the frames are rendered from: `nominal` (loaded from `model_path`) as `truth`
/// changes it, on the truth's mesh when it has one.
pub fn truth_body(
    model_path: &Path,
    nominal: &Model,
    truth: &TruthSpec,
) -> DiscrepancyResult<Model> {
    let on = match &truth.mesh {
        Some(m) => on_mesh(model_path, Path::new(m), nominal)?,
        None => nominal.clone(),
    };
    Ok(truth.body(&on, &nominal.problem.material)?)
}

/// A hidden effect moved onto the body: a point load at a model node goes to the body's
/// node nearest to that node's rest position (the same node when the mesh is the model's).
pub fn onto_body(e: &Effect, nominal: &Model, body: &Model) -> Effect {
    let EffectKind::PointLoad { node } = e.kind else {
        return e.clone();
    };
    let (from, to) = (&nominal.problem.mesh, &body.problem.mesh);
    if from.nodes_in_rest == to.nodes_in_rest {
        return e.clone();
    }
    let at = from.nodes_in_rest[node];
    let d2 = |p: &[f64; 3]| (0..3).map(|k| (p[k] - at[k]).powi(2)).sum::<f64>();
    let nearest = (to.nodes_in_rest.iter().enumerate())
        .min_by(|a, b| d2(a.1).total_cmp(&d2(b.1)))
        .map_or(node, |(i, _)| i);
    Effect {
        kind: EffectKind::PointLoad { node: nearest },
        params: e.params.clone(),
    }
}

//! `[truth]`: the body a scene's frames are rendered from, when it is not the model. Without
//! it, the frames come from the very FE model that later inverts them (the "inverse
//! crime"). With it, the robot is rendered with another modulus, Poisson ratio, element law,
//! mesh of the same shape or a compliant base, while the recording still names the model:
//! `truth.json`'s `model_path` and `material` are the model's, and its `truth_model` says
//! what the body was, for reports only (the estimator never reads it).
//!
//! One table, [`Truth`], over its numbers: a scene file's `[truth]` is a [`TruthSpec`]
//! (numbers); a sweep file's is a [`TruthRanges`] (numbers or ranges), drawn per scene on a
//! stream of its own, so that adding `[truth]` to a sweep keeps every scene's camera and
//! probes.
//!
//! ```
//! use softsense::scene::truth::{TruthRanges, TruthSpec};
//! let t: TruthSpec = toml::from_str("young_factor = 1.15\nformulation = \"neo-hookean\"").unwrap();
//! assert!(t.check().is_ok());
//! let r: TruthRanges = toml::from_str("young_factor = [0.85, 1.15]").unwrap();
//! let drawn = r.draw(7, 0, None);
//! assert!((0.85..=1.15).contains(&drawn.young_factor));
//! ```

use super::{SceneError, SceneResult};
use crate::fem::material::Material;
use crate::fem::model::Model;
use crate::fem::solve::Formulation;
use crate::math::rand::uniform;
use crate::math::{norm, sub};
use crate::recording::schema::TruthModel;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A `[truth]` table: how the rendered body differs from the model, each number a `V`
/// ([`TruthValue`]: a number in a scene file, a number or a range in a sweep file). Every
/// field left out is the model's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(deserialize = "V: TruthValue + Deserialize<'de>")
)]
pub struct Truth<V> {
    /// The body's Young's modulus over the model's (1; within 0-10, exclusive of 0).
    #[serde(default = "one")]
    pub young_factor: V,
    /// The body's Poisson ratio (in (-1, 0.5)); default the model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson: Option<V>,
    /// The body's element law, "corotational" or "neo-hookean"; default the model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formulation: Option<String>,
    /// Another volume mesh of the same body (relative to the file it is written in; in the
    /// model file's units and placement); default the model's mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<String>,
    /// A compliant base: its total stiffness (N/m, each axis), shared by the model's fixed
    /// nodes as springs to their rest positions; default the model's base (clamped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_stiffness: Option<V>,
}

/// A scene file's `[truth]`.
pub type TruthSpec = Truth<f64>;

/// A sweep file's `[truth]`: `young_factor`, `poisson` and `base_stiffness` as a number or
/// a range drawn per scene; `formulation` and `mesh` the same for every scene.
pub type TruthRanges = Truth<Ranged>;

/// A number of a [`Truth`]: one value ([`f64`]) or what a sweep draws one from ([`Ranged`]).
pub trait TruthValue: Copy {
    /// The value 1 (`young_factor`'s default).
    fn one() -> Self;
    /// Checks the value (each end of a range, and their order) with `check`.
    fn check_with(self, field: &str, check: fn(&str, f64) -> SceneResult<()>) -> SceneResult<()>;
}

impl TruthValue for f64 {
    fn one() -> Self {
        1.0
    }

    fn check_with(self, field: &str, check: fn(&str, f64) -> SceneResult<()>) -> SceneResult<()> {
        check(field, self)
    }
}

fn one<V: TruthValue>() -> V {
    V::one()
}

/// The largest accepted `young_factor`.
pub const MAX_YOUNG_FACTOR: f64 = 10.0;

/// How far the truth mesh's bounding box may lie from the model's, as a share of the
/// model's bounding-box diagonal: farther is another body, or a unit slip.
pub const MAX_SHAPE_OFFSET: f64 = 0.05;

fn bad(field: &str, value: impl std::fmt::Display, problem: impl Into<String>) -> SceneError {
    SceneError::BadTruth {
        field: field.into(),
        value: value.to_string(),
        problem: problem.into(),
    }
}

fn check_factor(field: &str, f: f64) -> SceneResult<()> {
    match f > 0.0 && f <= MAX_YOUNG_FACTOR {
        true => Ok(()),
        false => Err(bad(
            field,
            f,
            format!("must be > 0 and <= {MAX_YOUNG_FACTOR}"),
        )),
    }
}

fn check_poisson(field: &str, nu: f64) -> SceneResult<()> {
    match nu > -1.0 && nu < 0.5 {
        true => Ok(()),
        false => Err(bad(field, nu, "must be in (-1, 0.5)")),
    }
}

/// The element law a `[truth]` names: corotational or Neo-Hookean (small strain is not a
/// body, only a model's simplification).
fn formulation(name: &str) -> SceneResult<Formulation> {
    match Formulation::from_name(name) {
        Some(f) if f != Formulation::SmallStrain && name == f.name() => Ok(f),
        _ => Err(bad(
            "truth.formulation",
            format!("{name:?}"),
            "must be \"corotational\" or \"neo-hookean\"",
        )),
    }
}

fn check_stiffness(field: &str, k: f64) -> SceneResult<()> {
    match k > 0.0 && k.is_finite() {
        true => Ok(()),
        false => Err(bad(field, k, "must be > 0 and finite (N/m)")),
    }
}

impl<V: TruthValue> Truth<V> {
    /// Checks every field; the error names the first bad one.
    pub fn check(&self) -> SceneResult<()> {
        (self.young_factor).check_with("truth.young_factor", check_factor)?;
        if let Some(nu) = self.poisson {
            nu.check_with("truth.poisson", check_poisson)?;
        }
        if let Some(f) = &self.formulation {
            formulation(f)?;
        }
        if let Some(m) = &self.mesh {
            if m.trim().is_empty() {
                return Err(bad("truth.mesh", "\"\"", "must name a file"));
            }
        }
        if let Some(k) = self.base_stiffness {
            k.check_with("truth.base_stiffness", check_stiffness)?;
        }
        Ok(())
    }
}

impl TruthSpec {
    /// The body: `on_mesh` (the model, or the model on the truth's mesh: [`on_mesh`]) with
    /// this truth's modulus, Poisson ratio, element law and base; `nominal` is the model's
    /// material.
    pub fn body(&self, on_mesh: &Model, nominal: &Material) -> SceneResult<Model> {
        self.check()?;
        let mut body = on_mesh.clone();
        let nu = self.poisson.unwrap_or(nominal.poisson());
        body.problem.material = Material::new(nominal.young() * self.young_factor, nu)?;
        if let Some(f) = &self.formulation {
            body.problem.formulation = formulation(f)?;
        }
        if let Some(k) = self.base_stiffness {
            body.problem.base_stiffness = Some(k);
        }
        Ok(body)
    }

    /// What `truth.json` says of the body (`mesh`: its mesh file as written there).
    pub fn record(&self, body: &Model, mesh: String) -> TruthModel {
        let m = &body.problem.material;
        TruthModel {
            young_factor: self.young_factor,
            young: m.young(),
            poisson: m.poisson(),
            formulation: body.problem.formulation.name().into(),
            mesh,
            base_stiffness: body.problem.base_stiffness,
        }
    }
}

/// The model file `model_path` loaded on the mesh `mesh_path` ([`Model::load_on_mesh`]),
/// refused as `truth.mesh` when it does not load or is not the shape of `model` (its
/// bounding box off by more than [`MAX_SHAPE_OFFSET`] of the model's diagonal).
pub fn on_mesh(model_path: &Path, mesh_path: &Path, model: &Model) -> SceneResult<Model> {
    let shown = mesh_path.display();
    let body = Model::load_on_mesh(model_path, mesh_path)
        .map_err(|e| bad("truth.mesh", &shown, e.to_string()))?;
    let [lo, hi] = model.problem.mesh.bbox();
    let [tlo, thi] = body.problem.mesh.bbox();
    let diag = norm(sub(hi, lo));
    let off = norm(sub(tlo, lo)).max(norm(sub(thi, hi)));
    if off > MAX_SHAPE_OFFSET * diag {
        return Err(bad(
            "truth.mesh",
            &shown,
            format!(
                "is not the model's shape: its bounding box is {:.1} mm from the model's \
                 (at most {:.1} mm, {:.0}% of the diagonal)",
                off * 1e3,
                MAX_SHAPE_OFFSET * diag * 1e3,
                MAX_SHAPE_OFFSET * 100.0
            ),
        ));
    }
    Ok(body)
}

/// A value a sweep draws per scene: one number, or uniform over `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Ranged {
    /// Always this value.
    Fixed(f64),
    /// Uniform over [lo, hi].
    Range([f64; 2]),
}

impl Ranged {
    fn bounds(self) -> [f64; 2] {
        match self {
            Ranged::Fixed(v) => [v, v],
            Ranged::Range(r) => r,
        }
    }

    /// The value at `u` in (0, 1).
    fn at(self, u: f64) -> f64 {
        let [lo, hi] = self.bounds();
        lo + (hi - lo) * u
    }
}

impl TruthValue for Ranged {
    fn one() -> Self {
        Ranged::Fixed(1.0)
    }

    fn check_with(self, field: &str, check: fn(&str, f64) -> SceneResult<()>) -> SceneResult<()> {
        let [lo, hi] = self.bounds();
        check(field, lo)?;
        check(field, hi)?;
        match lo <= hi {
            true => Ok(()),
            false => Err(bad(
                field,
                format!("[{lo}, {hi}]"),
                "must be [lo, hi], lo <= hi",
            )),
        }
    }
}

/// The attempt key of the truth's draws: no attempt of a scene uses it, so the camera,
/// probes and occluder of a scene do not depend on whether its sweep has a `[truth]`.
const TRUTH_STREAM: u64 = u64::MAX;

impl TruthRanges {
    /// Scene `index`'s truth in a sweep of seed `seed` (`mesh`: the mesh path to write in
    /// it, resolved; default this file's as written).
    pub fn draw(&self, seed: u64, index: usize, mesh: Option<&Path>) -> TruthSpec {
        let u = |n: u64| uniform(seed, index as u64, TRUTH_STREAM, n);
        TruthSpec {
            young_factor: self.young_factor.at(u(1)),
            poisson: self.poisson.map(|p| p.at(u(2))),
            formulation: self.formulation.clone(),
            mesh: (mesh.map(|m| m.display().to_string())).or_else(|| self.mesh.clone()),
            base_stiffness: self.base_stiffness.map(|k| k.at(u(3))),
        }
    }
}

//! The batch manifest (TOML): which recordings, scene files and sweeps to sense, and
//! with which options. Paths are taken from the manifest's folder.

use super::{BatchError, BatchResult};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Sense options of an item: each `None` takes `[defaults]`, then `softsense sense`'s own
/// default. The same names as `sense`'s options.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SenseOptions {
    /// FE model file; default the one the recording (or scene file) names.
    pub model: Option<PathBuf>,
    /// Camera pose file ({"robot_from_camera": 4x4}); default the recording's own.
    pub pose: Option<PathBuf>,
    /// Number of surface feature points (default 51, as `sense`).
    pub features: Option<usize>,
    /// Robot colour, sRGB (default [40, 200, 60]).
    pub robot_color: Option<[u8; 3]>,
    /// Frames with more seen contacts are not estimated (default as `sense`).
    pub max_contacts: Option<usize>,
    /// "auto", "features" or "dense" (default "auto").
    pub registration: Option<RegistrationName>,
}

impl SenseOptions {
    /// These options, each unset one taken from `defaults`.
    fn or(&self, defaults: &SenseOptions) -> SenseOptions {
        SenseOptions {
            model: self.model.clone().or_else(|| defaults.model.clone()),
            pose: self.pose.clone().or_else(|| defaults.pose.clone()),
            features: self.features.or(defaults.features),
            robot_color: self.robot_color.or(defaults.robot_color),
            max_contacts: self.max_contacts.or(defaults.max_contacts),
            registration: self.registration.or(defaults.registration),
        }
    }

    /// The paths made relative to `base` (the manifest's folder) unless absolute.
    fn resolved(mut self, base: &Path) -> SenseOptions {
        self.model = self.model.map(|p| base.join(p));
        self.pose = self.pose.map(|p| base.join(p));
        self
    }
}

/// `registration` in a manifest ([`crate::sense::Registration`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RegistrationName {
    /// Dense for a frame with one seen contact, features otherwise.
    Auto,
    /// The feature points.
    Features,
    /// Every robot point.
    Dense,
}

impl From<RegistrationName> for crate::sense::Registration {
    fn from(r: RegistrationName) -> Self {
        match r {
            RegistrationName::Auto => Self::Auto,
            RegistrationName::Features => Self::Features,
            RegistrationName::Dense => Self::Dense,
        }
    }
}

/// A `[[recording]]` entry: a recording folder to sense.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordingEntry {
    path: PathBuf,
    id: Option<String>,
    #[serde(flatten)]
    options: SenseOptions,
}

/// A `[[scene]]` entry: a scene file to generate, then sense.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneEntry {
    spec: PathBuf,
    id: Option<String>,
    #[serde(flatten)]
    options: SenseOptions,
}

/// A `[[sweep]]` entry: `count` scenes drawn from a sweep file, each generated and sensed.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepEntry {
    spec: PathBuf,
    count: usize,
    seed: u64,
    id: Option<String>,
    #[serde(flatten)]
    options: SenseOptions,
}

/// The manifest file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    #[serde(default)]
    defaults: SenseOptions,
    #[serde(default)]
    recording: Vec<RecordingEntry>,
    #[serde(default)]
    scene: Vec<SceneEntry>,
    #[serde(default)]
    sweep: Vec<SweepEntry>,
}

/// Where an item's frames come from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Source {
    /// A recording folder.
    Recording {
        /// The folder.
        path: PathBuf,
    },
    /// A scene file, generated into the output folder first.
    Scene {
        /// The scene file.
        spec: PathBuf,
    },
    /// Scene `index` of a sweep, drawn and generated into the output folder first.
    SweepScene {
        /// The sweep file.
        spec: PathBuf,
        /// The sweep's seed.
        seed: u64,
        /// The scene's index (scene `index` depends only on the file, the seed and it).
        index: usize,
    },
}

/// One unit of work: one result file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Item {
    /// Unique name; the result is `results/ID.json`.
    pub id: String,
    /// What is sensed.
    #[serde(flatten)]
    pub source: Source,
    /// Sense options (`[defaults]` applied, paths resolved).
    pub options: SenseOptions,
}

/// A parsed manifest: its items in file order (recordings, scenes, then sweeps).
#[derive(Clone, Debug)]
pub struct Manifest {
    /// The manifest file.
    pub path: PathBuf,
    /// Every item, sweeps expanded.
    pub items: Vec<Item>,
}

impl Manifest {
    /// Reads and checks a manifest file.
    pub fn load(path: &Path) -> BatchResult<Manifest> {
        let text = std::fs::read_to_string(path).map_err(|e| BatchError::Manifest {
            path: path.to_path_buf(),
            message: format!("cannot read it: {e}"),
        })?;
        Self::parse(&text, path)
    }

    /// Parses manifest `text`; `path` names the file in errors and is the base of its
    /// relative paths.
    pub fn parse(text: &str, path: &Path) -> BatchResult<Manifest> {
        let bad = |message: String| BatchError::Manifest {
            path: path.to_path_buf(),
            message,
        };
        let file: ManifestFile = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut items = Vec::new();
        for r in file.recording {
            let id = r.id.unwrap_or_else(|| name_of(&r.path));
            items.push(item(
                id,
                Source::Recording {
                    path: base.join(&r.path),
                },
                &r.options,
            ));
        }
        for s in file.scene {
            let id = s.id.unwrap_or_else(|| name_of(&s.spec));
            items.push(item(
                id,
                Source::Scene {
                    spec: base.join(&s.spec),
                },
                &s.options,
            ));
        }
        for s in file.sweep {
            if s.count == 0 {
                return Err(bad(format!(
                    "[[sweep]] {}: count must be at least 1",
                    s.spec.display()
                )));
            }
            let prefix = s.id.unwrap_or_else(|| name_of(&s.spec));
            for index in 0..s.count {
                let source = Source::SweepScene {
                    spec: base.join(&s.spec),
                    seed: s.seed,
                    index,
                };
                items.push(item(format!("{prefix}_{index:04}"), source, &s.options));
            }
        }
        let items: Vec<Item> = items
            .into_iter()
            .map(|mut i| {
                i.options = i.options.or(&file.defaults).resolved(base);
                i
            })
            .collect();
        check_ids(&items).map_err(bad)?;
        if items.is_empty() {
            return Err(bad(
                "no items: add a [[recording]], [[scene]] or [[sweep]] table".into(),
            ));
        }
        Ok(Manifest {
            path: path.to_path_buf(),
            items,
        })
    }
}

fn item(id: String, source: Source, options: &SenseOptions) -> Item {
    Item {
        id,
        source,
        options: options.clone(),
    }
}

/// A file's or folder's name without its extension: the default id.
fn name_of(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Ids name files: letters, digits, `_`, `-` and `.` (not first), each used once.
fn check_ids(items: &[Item]) -> Result<(), String> {
    let mut seen: BTreeMap<&str, &Source> = BTreeMap::new();
    for i in items {
        let fine = !i.id.is_empty()
            && !i.id.starts_with('.')
            && i.id
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !fine {
            return Err(format!(
                "item id {:?} cannot name a file: use letters, digits, '_', '-' and '.' \
                 (not first); set `id = \"...\"` on the entry",
                i.id
            ));
        }
        if let Some(first) = seen.insert(&i.id, &i.source) {
            return Err(format!(
                "two items are called {:?} ({} and {}): give one of them `id = \"...\"`",
                i.id,
                describe(first),
                describe(&i.source)
            ));
        }
    }
    Ok(())
}

/// The source in a few words, for messages.
pub fn describe(source: &Source) -> String {
    match source {
        Source::Recording { path } => format!("recording {}", path.display()),
        Source::Scene { spec } => format!("scene {}", spec.display()),
        Source::SweepScene { spec, seed, index } => {
            format!("scene {index} of sweep {} (seed {seed})", spec.display())
        }
    }
}

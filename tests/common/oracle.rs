//! Running the PCL and Open3D oracles (`tools/oracle/`) from tests.
//!
//! [`run`] writes a job file, runs `tools/oracle/build/pcl_oracle` (built once per test
//! process by `tools/oracle/build.sh`) or `tools/oracle/open3d_oracle.py`, and returns the
//! parsed `result.json` plus the path of `cloud.pcd`. Skip policy: when an oracle is not
//! installed, `run` prints a SKIPPED line and returns `None`, unless `SOFTSENSE_ORACLES=1`
//! (set by `.ci/run`), in which case the missing oracle is a test failure.
//!
//! [`RawPcd`] reads the oracles' binary PCD outputs independently of `softsense::io`, so a
//! comparison never checks our reader against itself.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use serde_json::Value;

/// Which oracle library.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lib {
    /// PCL 1.13 (`tools/oracle/pcl_oracle.cpp`).
    Pcl,
    /// Open3D 0.20 (`tools/oracle/open3d_oracle.py`).
    Open3d,
}

impl Lib {
    /// Lower-case name as used in `result.json`.
    pub fn name(self) -> &'static str {
        match self {
            Lib::Pcl => "pcl",
            Lib::Open3d => "open3d",
        }
    }
}

/// One oracle run's output.
pub struct OracleResult {
    /// The parsed `result.json`.
    pub json: Value,
    /// `cloud.pcd`, when the stage wrote one.
    pub cloud: Option<PathBuf>,
    /// The output directory (deleted when this value is dropped).
    pub dir: tempfile::TempDir,
}

impl OracleResult {
    /// `json["clusters"]` as lists of input indices; panics if absent (not a clustering stage).
    pub fn clusters(&self) -> Vec<Vec<usize>> {
        self.json["clusters"]
            .as_array()
            .expect("result.json has no `clusters`")
            .iter()
            .map(|c| {
                c.as_array()
                    .expect("a cluster is a list of indices")
                    .iter()
                    .map(|v| v.as_u64().expect("an index") as usize)
                    .collect()
            })
            .collect()
    }

    /// `json["indices"]` as `usize`s; panics if absent (the stage selects no points).
    pub fn indices(&self) -> Vec<usize> {
        self.json["indices"]
            .as_array()
            .expect("result.json has no `indices`")
            .iter()
            .map(|v| v.as_u64().expect("index is a non-negative integer") as usize)
            .collect()
    }

    /// `json["timings_ms"]`.
    pub fn timings_ms(&self) -> Vec<f64> {
        self.json["timings_ms"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_f64).collect())
            .unwrap_or_default()
    }

    /// `json[key]` as an integer; panics if absent.
    pub fn int(&self, key: &str) -> u64 {
        self.json[key]
            .as_u64()
            .unwrap_or_else(|| panic!("result.json has no integer `{key}`"))
    }

    /// `json["fields"]` as strings.
    pub fn fields(&self) -> Vec<String> {
        self.json["fields"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The output cloud, parsed; panics if the stage wrote none.
    pub fn raw_cloud(&self) -> RawPcd {
        let path = self.cloud.as_ref().expect("the oracle wrote no cloud.pcd");
        RawPcd::read(path)
    }
}

fn oracle_dir() -> PathBuf {
    super::project_root().join("tools").join("oracle")
}

fn oracles_required() -> bool {
    std::env::var_os("SOFTSENSE_ORACLES").is_some_and(|v| v == "1")
}

/// The Python interpreter for the Open3D oracle (`SOFTSENSE_PYTHON`, default `python3`).
pub fn python() -> String {
    std::env::var("SOFTSENSE_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// The PCL oracle binary, built once per process; `Err(reason)` when PCL is not installed.
/// Panics when PCL is installed but the program does not compile: that is a bug, not a
/// missing oracle.
fn pcl_binary() -> Result<PathBuf, String> {
    static BIN: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    BIN.get_or_init(|| {
        let probe = Command::new("pkg-config")
            .args(["--modversion", "pcl_common"])
            .output();
        match probe {
            Ok(o) if o.status.success() => {}
            Ok(_) => return Err("PCL is not installed (pkg-config pcl_common failed)".into()),
            Err(e) => return Err(format!("pkg-config is not runnable: {e}")),
        }
        let out = Command::new("bash")
            .arg(oracle_dir().join("build.sh"))
            .output()
            .expect("bash runs tools/oracle/build.sh");
        assert!(
            out.status.success(),
            "tools/oracle/build.sh failed although PCL is installed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let path = String::from_utf8_lossy(&out.stdout).trim().to_string();
        Ok(PathBuf::from(path))
    })
    .clone()
}

/// `Ok(())` when `python3 -c "import open3d"` works; `Err(reason)` otherwise.
fn open3d_available() -> Result<(), String> {
    static OK: OnceLock<Result<(), String>> = OnceLock::new();
    OK.get_or_init(|| {
        match Command::new(python())
            .args(["-c", "import open3d"])
            .output()
        {
            Ok(o) if o.status.success() => Ok(()),
            Ok(o) => Err(format!(
                "Open3D is not importable by {}: {}",
                python(),
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            )),
            Err(e) => Err(format!("{} is not runnable: {e}", python())),
        }
    })
    .clone()
}

/// True when `lib` can run here. When it cannot: prints `SKIPPED <test>: <why>` and
/// returns false, or panics if `SOFTSENSE_ORACLES=1`.
pub fn available(lib: Lib, test: &str) -> bool {
    let status = match lib {
        Lib::Pcl => pcl_binary().map(|_| ()),
        Lib::Open3d => open3d_available(),
    };
    match status {
        Ok(()) => true,
        Err(why) if oracles_required() => {
            panic!(
                "{test}: SOFTSENSE_ORACLES=1 but the {} oracle is missing: {why}",
                lib.name()
            )
        }
        Err(why) => {
            super::skipped(
                test,
                &format!(
                    "{} oracle unavailable ({why}); run tools/oracle/install.sh",
                    lib.name()
                ),
            );
            false
        }
    }
}

/// Runs `stage` of `lib` on `input` once. `None` (with a SKIPPED line) when the oracle is
/// missing and not required. Panics when the oracle fails or reports `ok: false`.
pub fn run(lib: Lib, stage: &str, input: &Path, params: Value) -> Option<OracleResult> {
    let r = run_job(lib, stage, input, params, 1)?;
    assert!(
        r.json["ok"].as_bool() == Some(true),
        "{} oracle stage `{stage}` on {} failed: {}",
        lib.name(),
        input.display(),
        r.json["error"]
    );
    Some(r)
}

/// Like [`run`] with `repeat` timed repetitions, and returning results with `ok: false`
/// too (for tests of error behaviour).
pub fn run_job(
    lib: Lib,
    stage: &str,
    input: &Path,
    params: Value,
    repeat: u32,
) -> Option<OracleResult> {
    let test = format!("{} oracle `{stage}`", lib.name());
    if !available(lib, &test) {
        return None;
    }
    let dir = tempfile::tempdir().expect("temp dir for the oracle");
    let input = std::fs::canonicalize(input)
        .unwrap_or_else(|e| panic!("oracle input {}: {e}", input.display()));
    let job = serde_json::json!({
        "stage": stage,
        "input": input,
        "output_dir": dir.path(),
        "params": params,
        "repeat": repeat,
    });
    let job_path = dir.path().join("job.json");
    std::fs::write(&job_path, job.to_string()).expect("write job.json");
    let mut cmd = match lib {
        Lib::Pcl => Command::new(pcl_binary().expect("checked by available()")),
        Lib::Open3d => {
            let mut c = Command::new(python());
            c.arg(oracle_dir().join("open3d_oracle.py"));
            c
        }
    };
    let out = cmd.arg(&job_path).output().expect("run the oracle");
    let result_path = dir.path().join("result.json");
    let text = std::fs::read_to_string(&result_path).unwrap_or_else(|e| {
        panic!(
            "{test} wrote no result.json ({e}); exit {:?}; stderr:\n{}",
            out.status.code(),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    let json: Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("{test}: result.json is not JSON ({e}):\n{text}"));
    let cloud = dir.path().join("cloud.pcd");
    let cloud = cloud.exists().then_some(cloud);
    Some(OracleResult { json, cloud, dir })
}

/// A PCD field of a [`RawPcd`].
#[derive(Debug, Clone, PartialEq)]
pub struct RawField {
    /// Name (`x`, `rgba`, ...).
    pub name: String,
    /// Bytes per element.
    pub size: usize,
    /// `F`, `U` or `I`.
    pub kind: char,
    /// Elements per point.
    pub count: usize,
    /// Byte offset within a point record.
    pub offset: usize,
}

/// A binary PCD as the oracles write it (header + array-of-structs records), read without
/// `softsense::io`.
#[derive(Debug, Clone)]
pub struct RawPcd {
    /// Fields in file order (including PCL's `_` padding fields).
    pub fields: Vec<RawField>,
    /// WIDTH.
    pub width: usize,
    /// HEIGHT.
    pub height: usize,
    /// Bytes per point.
    pub stride: usize,
    /// The records, `points * stride` bytes.
    pub data: Vec<u8>,
}

impl RawPcd {
    /// Reads a `DATA binary` PCD; panics on anything else (oracle outputs only).
    pub fn read(path: &Path) -> RawPcd {
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut pos = 0;
        let mut header: std::collections::HashMap<String, Vec<String>> = Default::default();
        loop {
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .unwrap_or_else(|| panic!("{}: header has no DATA line", path.display()));
            let line = String::from_utf8_lossy(&bytes[pos..pos + end]).to_string();
            pos += end + 1;
            let mut words = line.split_whitespace();
            let Some(key) = words.next() else { continue };
            if key.starts_with('#') {
                continue;
            }
            header.insert(key.to_string(), words.map(String::from).collect());
            if key == "DATA" {
                break;
            }
        }
        assert_eq!(
            header["DATA"],
            ["binary"],
            "{}: oracle clouds are binary",
            path.display()
        );
        let get = |k: &str| {
            header
                .get(k)
                .unwrap_or_else(|| panic!("{}: no {k}", path.display()))
        };
        let names = get("FIELDS");
        let mut fields = Vec::new();
        let mut offset = 0;
        for (i, name) in names.iter().enumerate() {
            let size: usize = get("SIZE")[i].parse().expect("SIZE");
            let count: usize = header
                .get("COUNT")
                .map_or(1, |c| c[i].parse().expect("COUNT"));
            let kind = get("TYPE")[i].chars().next().expect("TYPE");
            fields.push(RawField {
                name: name.clone(),
                size,
                kind,
                count,
                offset,
            });
            offset += size * count;
        }
        let width: usize = get("WIDTH")[0].parse().expect("WIDTH");
        let height: usize = header
            .get("HEIGHT")
            .map_or(1, |h| h[0].parse().expect("HEIGHT"));
        let points: usize = get("POINTS")[0].parse().expect("POINTS");
        assert_eq!(
            width * height,
            points,
            "{}: WIDTH*HEIGHT != POINTS",
            path.display()
        );
        // PCL's binary writer pads the file with zeros to a page boundary (it writes
        // through mmap), so the body may be longer than the records.
        let need = points * offset;
        assert!(
            bytes.len() - pos >= need,
            "{}: body shorter than POINTS records",
            path.display()
        );
        let data = bytes[pos..pos + need].to_vec();
        RawPcd {
            fields,
            width,
            height,
            stride: offset,
            data,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    /// True when the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Field names without PCL's `_` padding.
    pub fn field_names(&self) -> Vec<String> {
        self.fields
            .iter()
            .filter(|f| f.name != "_")
            .map(|f| f.name.clone())
            .collect()
    }

    /// The field called `name`, if present.
    pub fn field(&self, name: &str) -> Option<&RawField> {
        self.fields.iter().find(|f| f.name == name)
    }

    fn column4(&self, name: &str) -> Option<Vec<[u8; 4]>> {
        let f = self.field(name)?;
        assert_eq!(f.size, 4, "field {name} is not 4 bytes");
        Some(
            (0..self.len())
                .map(|i| {
                    let at = i * self.stride + f.offset;
                    [
                        self.data[at],
                        self.data[at + 1],
                        self.data[at + 2],
                        self.data[at + 3],
                    ]
                })
                .collect(),
        )
    }

    /// A 4-byte field as `f32` (whatever its TYPE says).
    pub fn f32s(&self, name: &str) -> Option<Vec<f32>> {
        Some(
            self.column4(name)?
                .into_iter()
                .map(f32::from_le_bytes)
                .collect(),
        )
    }

    /// A 4-byte field as `u32` (whatever its TYPE says).
    pub fn u32s(&self, name: &str) -> Option<Vec<u32>> {
        Some(
            self.column4(name)?
                .into_iter()
                .map(u32::from_le_bytes)
                .collect(),
        )
    }

    /// `x y z` per point.
    pub fn positions(&self) -> Vec<[f32; 3]> {
        let (x, y, z) = (
            self.f32s("x").expect("x"),
            self.f32s("y").expect("y"),
            self.f32s("z").expect("z"),
        );
        (0..self.len()).map(|i| [x[i], y[i], z[i]]).collect()
    }

    /// Packed `rgb`/`rgba` as `(r, g, b, a)` per point, if the cloud has colour.
    pub fn rgba(&self) -> Option<Vec<[u8; 4]>> {
        let packed = self.u32s("rgba").or_else(|| self.u32s("rgb"))?;
        Some(
            packed
                .into_iter()
                .map(|v| [(v >> 16) as u8, (v >> 8) as u8, v as u8, (v >> 24) as u8])
                .collect(),
        )
    }

    /// `normal_x normal_y normal_z` per point, if present.
    pub fn normals(&self) -> Option<Vec<[f32; 3]>> {
        let (x, y, z) = (
            self.f32s("normal_x")?,
            self.f32s("normal_y")?,
            self.f32s("normal_z")?,
        );
        Some((0..self.len()).map(|i| [x[i], y[i], z[i]]).collect())
    }
}

/// The Python interpreter with gmsh (the mesher of `softsense model new`), or `None` with a
/// SKIPPED line; required (a failure when missing) under `SOFTSENSE_ORACLES=1`.
pub fn gmsh_python(test: &str) -> Option<String> {
    let py = python();
    let ok = Command::new(&py)
        .args(["-c", "import gmsh"])
        .output()
        .is_ok_and(|o| o.status.success());
    match (ok, oracles_required()) {
        (true, _) => Some(py),
        (false, true) => panic!("{test}: SOFTSENSE_ORACLES=1 but {py} cannot import gmsh (tools/oracle/install.sh installs it)"),
        (false, false) => {
            super::skipped(
                test,
                &format!("{py} cannot import gmsh (pip install gmsh; see docs/testing.md)"),
            );
            None
        }
    }
}

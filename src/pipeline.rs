//! The filter chain as a value: crop → voxel → outlier removal → normals, per frame.
//!
//! [`ChainParams`] holds every stage's parameters (each stage optional) and reads from
//! TOML; [`Pipeline::step`] runs one frame and reports per-stage timings;
//! [`run_sequence`] streams a directory or glob of PCD/PLY files through the chain with
//! a reader thread and a bounded queue, writing one output file per frame atomically.
//!
//! ```
//! use softsense::cloud::PointCloud;
//! use softsense::pipeline::{ChainParams, Pipeline};
//! # fn main() -> Result<(), softsense::pipeline::PipelineError> {
//! let params: ChainParams = ChainParams::from_toml_str(r#"
//!     [[crop]]
//!     field = "z"
//!     min = 0.0
//!     max = 2.0
//!     [voxel]
//!     leaf_size = [0.01, 0.01, 0.01]
//! "#)?;
//! assert!(params.radius_outlier.is_some()); // unspecified stages keep their defaults
//! let mut chain = Pipeline::new(ChainParams { radius_outlier: None, ..params });
//! let frame = PointCloud::from_positions(vec![[0.0, 0.0, 1.0], [0.001, 0.0, 1.0], [0.0, 0.0, 5.0]]);
//! let out = chain.step(&frame)?;
//! assert_eq!(out.cloud.len(), 1);
//! assert_eq!(out.timings.iter().map(|t| t.stage).collect::<Vec<_>>(), ["crop", "voxel"]);
//! # Ok(()) }
//! ```

use crate::cloud::{remap, PointCloud};
use crate::features::{estimate_normals, FeatureError, NormalParams};
use crate::filter::{
    pass_through, pass_through_indices_into, radius_outlier_removal, statistical_outlier_removal,
    voxel_grid, voxel_grid_of, Field, FilterError, FilterOutput, PassThroughParams,
    RadiusOutlierParams, StatisticalOutlierParams, VoxelGridParams,
};
use crate::io::{read_cloud, write_cloud, Encoding, IoError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use thiserror::Error;

/// Errors of the chain.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// The TOML configuration could not be parsed.
    #[error("chain configuration: {0}")]
    Config(String),
    /// The sequence names no PCD/PLY file.
    #[error("{path}: no .pcd or .ply frames found")]
    NoFrames {
        /// The directory or pattern.
        path: PathBuf,
    },
    /// A stage was given bad parameters.
    #[error(transparent)]
    Filter(#[from] FilterError),
    /// Normal estimation was given bad parameters.
    #[error(transparent)]
    Features(#[from] FeatureError),
    /// An RGB-D depth image has no camera file (per-frame `.xml` or a shared
    /// `intrinsics.json`/`intrinsics.xml`) next to it.
    #[error("{depth}: no camera file (STEM.xml or intrinsics.json) for this depth image")]
    NoCamera {
        /// The depth image.
        depth: PathBuf,
    },
    /// Reading or writing a frame failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A recording folder is malformed.
    #[error(transparent)]
    Recording(crate::recording::RecordingError),
}

/// Parameters of the whole chain. Stages run in field order; `None` skips a stage.
///
/// Defaults: no crop, a 5 mm PCL voxel grid, PCL radius outlier removal (5 mm, 5
/// neighbours), no statistical outlier removal, no normals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChainParams {
    /// Pass-through filters, applied in order (PCL `PassThrough`).
    pub crop: Vec<PassThroughParams>,
    /// Voxel-grid down-sampling.
    pub voxel: Option<VoxelGridParams>,
    /// Radius outlier removal.
    pub radius_outlier: Option<RadiusOutlierParams>,
    /// Statistical outlier removal.
    pub statistical_outlier: Option<StatisticalOutlierParams>,
    /// Normal estimation on the final cloud.
    pub normals: Option<NormalParams>,
}

impl Default for ChainParams {
    fn default() -> Self {
        ChainParams {
            crop: Vec::new(),
            voxel: Some(VoxelGridParams::new(0.005)),
            radius_outlier: Some(RadiusOutlierParams::default()),
            statistical_outlier: None,
            normals: None,
        }
    }
}

impl ChainParams {
    /// The thesis' chain: x, y in [-0.13, 0.13] m, z in [0, 0.54] m, a 1.1 mm voxel
    /// grid, and radius outlier removal with 20 neighbours within 5 mm.
    pub fn thesis() -> Self {
        ChainParams {
            crop: vec![
                PassThroughParams::new(Field::X, -0.13, 0.13),
                PassThroughParams::new(Field::Y, -0.13, 0.13),
                PassThroughParams::new(Field::Z, 0.0, 0.54),
            ],
            voxel: Some(VoxelGridParams::new(0.0011)),
            radius_outlier: Some(RadiusOutlierParams {
                radius: 0.005,
                min_neighbors: 20,
                ..Default::default()
            }),
            statistical_outlier: None,
            normals: None,
        }
    }

    /// Parses a TOML document; missing stages keep their defaults.
    pub fn from_toml_str(text: &str) -> Result<Self, PipelineError> {
        toml::from_str(text).map_err(|e| PipelineError::Config(e.to_string()))
    }

    /// Reads a TOML file.
    pub fn from_toml_file(path: &Path) -> Result<Self, PipelineError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::Config(format!("{}: {e}", path.display())))?;
        Self::from_toml_str(&text)
            .map_err(|e| PipelineError::Config(format!("{}: {e}", path.display())))
    }

    /// The parameters as TOML.
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }
}

/// Wall time of one stage of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StageTiming {
    /// Stage name: `crop`, `voxel`, `radius_outlier`, `statistical_outlier`, `normals`.
    pub stage: &'static str,
    /// Points leaving the stage.
    pub points_out: usize,
    /// Wall time.
    pub elapsed: Duration,
}

/// The result of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameResult {
    /// The filtered cloud.
    pub cloud: PointCloud,
    /// For each output point, the input index it came from (for voxels, the smallest
    /// input index of the voxel).
    pub indices: Vec<usize>,
    /// Per-stage timings, in chain order.
    pub timings: Vec<StageTiming>,
}

impl FrameResult {
    /// Total wall time of the chain.
    pub fn total(&self) -> Duration {
        self.timings.iter().map(|t| t.elapsed).sum()
    }
}

/// The chain, reused across frames (its index buffers are kept between frames).
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// The chain's parameters.
    pub params: ChainParams,
    /// The kept crop indices of the last frame (buffer reused).
    crop_kept: Vec<usize>,
    /// One crop's kept indices when there are several (buffer reused).
    crop_one: Vec<usize>,
}

impl Pipeline {
    /// A chain with the given parameters.
    pub fn new(params: ChainParams) -> Self {
        Pipeline {
            params,
            crop_kept: Vec::new(),
            crop_one: Vec::new(),
        }
    }

    /// Crop then voxel without building the cropped cloud: the crops' kept indices of
    /// `frame` (each crop tests the frame's own values, as it would test the cropped
    /// cloud's), then the voxel grid of those points. Same output as the two stages run
    /// one after the other (the cropped cloud is only ever read by the voxel grid).
    fn crop_then_voxel(
        &mut self,
        frame: &PointCloud,
        voxel: &VoxelGridParams,
        timings: &mut Vec<StageTiming>,
    ) -> Result<FilterOutput, PipelineError> {
        let t = Instant::now();
        let (kept, one) = (&mut self.crop_kept, &mut self.crop_one);
        for (k, crop) in self.params.crop.iter().enumerate() {
            if k == 0 {
                pass_through_indices_into(frame, crop, kept)?;
            } else {
                pass_through_indices_into(frame, crop, one)?;
                intersect_sorted(kept, one);
            }
        }
        timings.push(StageTiming {
            stage: "crop",
            points_out: kept.len(),
            elapsed: t.elapsed(),
        });
        let t = Instant::now();
        let out = voxel_grid_of(frame, Some(kept), voxel)?;
        timings.push(StageTiming {
            stage: "voxel",
            points_out: out.cloud.len(),
            elapsed: t.elapsed(),
        });
        Ok(out)
    }

    /// Runs every configured stage on one frame.
    pub fn step(&mut self, frame: &PointCloud) -> Result<FrameResult, PipelineError> {
        // PERF: no copy of the frame and no identity index list: `cloud` is `None` and
        // `indices` `None` until a stage has run.
        let mut cloud: Option<PointCloud> = None;
        let mut indices: Option<Vec<usize>> = None;
        let mut timings = Vec::new();
        let fuse = !self.params.crop.is_empty()
            && self.params.crop.iter().all(|c| !c.keep_organized)
            && self.params.voxel.is_some();
        if let (true, Some(v)) = (fuse, self.params.voxel) {
            let out = self.crop_then_voxel(frame, &v, &mut timings)?;
            cloud = Some(out.cloud);
            indices = Some(out.indices);
        }
        let mut apply = |stage: &'static str,
                         cloud: &mut Option<PointCloud>,
                         f: &dyn Fn(&PointCloud) -> Result<FilterOutput, FilterError>|
         -> Result<(), PipelineError> {
            let t = Instant::now();
            let out = f(cloud.as_ref().unwrap_or(frame))?;
            indices = Some(match &indices {
                None => out.indices,
                Some(prev) => remap(prev, &out.indices),
            });
            timings.push(StageTiming {
                stage,
                points_out: out.cloud.len(),
                elapsed: t.elapsed(),
            });
            *cloud = Some(out.cloud);
            Ok(())
        };
        let p = &self.params;
        if !p.crop.is_empty() && !fuse {
            apply("crop", &mut cloud, &|c| {
                let mut acc: Option<FilterOutput> = None;
                for crop in &p.crop {
                    let src = acc.as_ref().map_or(c, |a| &a.cloud);
                    let out = pass_through(src, crop)?;
                    acc = Some(match acc {
                        None => out,
                        Some(a) => FilterOutput {
                            indices: remap(&a.indices, &out.indices),
                            cloud: out.cloud,
                        },
                    });
                }
                // Only reached with a non-empty crop list: acc was set by the loop.
                Ok(acc.expect("at least one crop"))
            })?;
        }
        if let (false, Some(v)) = (fuse, &p.voxel) {
            apply("voxel", &mut cloud, &|c| voxel_grid(c, v))?;
        }
        if let Some(r) = &p.radius_outlier {
            apply("radius_outlier", &mut cloud, &|c| {
                radius_outlier_removal(c, r)
            })?;
        }
        if let Some(s) = &p.statistical_outlier {
            apply("statistical_outlier", &mut cloud, &|c| {
                statistical_outlier_removal(c, s)
            })?;
        }
        let mut cloud = cloud.unwrap_or_else(|| frame.clone());
        if let Some(n) = &p.normals {
            let t = Instant::now();
            estimate_normals(&cloud, n)?.apply_to(&mut cloud);
            timings.push(StageTiming {
                stage: "normals",
                points_out: cloud.len(),
                elapsed: t.elapsed(),
            });
        }
        Ok(FrameResult {
            cloud,
            indices: indices.unwrap_or_else(|| (0..frame.len()).collect()),
            timings,
        })
    }
}

/// Keeps in `a` (ascending) only the values also in `b` (ascending).
fn intersect_sorted(a: &mut Vec<usize>, b: &[usize]) {
    let mut j = 0;
    a.retain(|&v| {
        while j < b.len() && b[j] < v {
            j += 1;
        }
        j < b.len() && b[j] == v
    });
}

/// One frame of a sequence: a cloud file, or an RGB-D image pair with its camera.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameSource {
    /// A `.pcd` or `.ply` file.
    Cloud(PathBuf),
    /// A 16-bit depth image, an optional colour image of the same size, and the camera
    /// file (Open3D `.json` or PCL grabber `.xml`, see [`crate::io::intrinsics`]).
    Rgbd {
        /// Depth image (PNG or TIFF).
        depth: PathBuf,
        /// Colour image (PNG or TIFF).
        color: Option<PathBuf>,
        /// Intrinsics file.
        intrinsics: PathBuf,
    },
}

impl From<PathBuf> for FrameSource {
    fn from(p: PathBuf) -> Self {
        FrameSource::Cloud(p)
    }
}

impl FrameSource {
    /// The file that names the frame (the cloud, or the depth image).
    pub fn path(&self) -> &Path {
        match self {
            FrameSource::Cloud(p) => p,
            FrameSource::Rgbd { depth, .. } => depth,
        }
    }

    /// The output file name: the cloud's own name, or for an RGB-D pair
    /// `frame_NNNN.pcd` (from `depth_NNNN.png`) or `STEM.pcd` (from `STEM_depth.tiff`).
    pub fn output_name(&self) -> PathBuf {
        match self {
            FrameSource::Cloud(p) => p
                .file_name()
                .map(PathBuf::from)
                .unwrap_or_else(|| "frame.pcd".into()),
            FrameSource::Rgbd { depth, .. } => {
                let stem = depth
                    .file_stem()
                    .and_then(|s| s.to_str())
                    .unwrap_or("frame");
                let id = match (stem.strip_prefix("depth_"), stem.strip_suffix("_depth")) {
                    (Some(n), _) => format!("frame_{n}"),
                    (None, Some(s)) => s.to_string(),
                    (None, None) => stem.to_string(),
                };
                PathBuf::from(format!("{id}.pcd"))
            }
        }
    }

    /// Reads the frame as a cloud (RGB-D pairs in PCL's arithmetic, depth in the camera
    /// file's units, millimetres by default).
    pub fn read(&self) -> Result<PointCloud, IoError> {
        match self {
            FrameSource::Cloud(p) => read_cloud(p),
            FrameSource::Rgbd {
                depth,
                color,
                intrinsics,
            } => {
                let (camera, lens) = crate::io::intrinsics::read_camera_file(intrinsics)?;
                crate::io::rgbd::read_frame_through(depth, color.as_deref(), &camera, &lens)
            }
        }
    }
}

/// The frames of a sequence: every `.pcd`/`.ply` file of a directory, or the files whose
/// name matches a pattern with `*` wildcards (`dir/frame_*.pcd`), sorted by name. A
/// directory without cloud files is read as RGB-D pairs ([`list_rgbd_frames`]).
pub fn list_frames(spec: &Path) -> Result<Vec<FrameSource>, PipelineError> {
    match list_cloud_files(spec) {
        Err(PipelineError::NoFrames { .. }) if spec.is_dir() => list_rgbd_frames(spec),
        other => Ok(other?.into_iter().map(FrameSource::Cloud).collect()),
    }
}

/// The RGB-D frames of a directory in any recording layout ([`crate::recording::Layout`]:
/// `depth_NNNN.png` + `color_NNNN.png` + `intrinsics.json`, PCL grabber
/// `STEM_depth.tiff` + `STEM_rgb.tiff` + `STEM.xml`, or Open3D `depth/` + `color/`).
///
/// A depth image without a colour image gives an uncoloured cloud; one without any
/// camera file is an error ([`PipelineError::NoCamera`]).
pub fn list_rgbd_frames(dir: &Path) -> Result<Vec<FrameSource>, PipelineError> {
    use crate::recording::RecordingError;
    let (_, files) = crate::recording::list_frames(dir).map_err(|e| match e {
        RecordingError::NoFrames { path } => PipelineError::NoFrames { path },
        RecordingError::NoCamera { depth } => PipelineError::NoCamera { depth },
        RecordingError::Io(e) => PipelineError::Io(e),
        other => PipelineError::Recording(other),
    })?;
    Ok(files
        .into_iter()
        .map(|f| FrameSource::Rgbd {
            depth: f.depth,
            color: f.color,
            intrinsics: f.camera,
        })
        .collect())
}

/// The cloud files of a sequence (see [`list_frames`]).
fn list_cloud_files(spec: &Path) -> Result<Vec<PathBuf>, PipelineError> {
    let no_frames = || PipelineError::NoFrames {
        path: spec.to_path_buf(),
    };
    let is_cloud = |p: &Path| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("pcd") || e.eq_ignore_ascii_case("ply"))
    };
    let (dir, pattern) = if spec.is_dir() {
        (spec.to_path_buf(), None)
    } else {
        let name = spec
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(no_frames)?;
        let dir = spec
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        (dir.to_path_buf(), Some(name.to_string()))
    };
    let entries = std::fs::read_dir(&dir).map_err(|source| IoError::Os {
        path: dir.clone(),
        source,
    })?;
    let mut out: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_cloud(p))
        .filter(|p| match &pattern {
            None => true,
            Some(pat) => p
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| wildcard_match(pat, n)),
        })
        .collect();
    out.sort();
    if out.is_empty() {
        return Err(no_frames());
    }
    Ok(out)
}

/// `*` matches any run of characters, `?` one character; everything else literally.
fn wildcard_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let (mut pi, mut ni, mut star, mut mark) = (0, 0, None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            mark = ni;
            pi += 1;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    p[pi..].iter().all(|&c| c == '*')
}

/// Per-frame record of a sequence run.
#[derive(Debug, Clone, Serialize)]
pub struct FrameSummary {
    /// Input file.
    pub input: PathBuf,
    /// Output file.
    pub output: PathBuf,
    /// Points read.
    pub points_in: usize,
    /// Points written.
    pub points_out: usize,
    /// Per-stage wall time, milliseconds, in chain order.
    pub stage_ms: Vec<(&'static str, f64)>,
    /// Why the frame could not be read or filtered (then nothing was written for it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Streams `frames` through `pipeline`: a reader thread loads frames into a queue of at
/// most `queue` frames while this thread filters and writes `out_dir/<input file name>`
/// atomically ([`FrameSource::output_name`]: binary PCD, or PLY for a PLY input). A
/// progress bar goes to stderr when `progress`. A frame that cannot be read or filtered
/// gets its [`FrameSummary::error`] and the run goes on; a write error stops it (the
/// output folder is at fault, not the frame).
pub fn run_sequence(
    pipeline: &mut Pipeline,
    frames: &[FrameSource],
    out_dir: &Path,
    queue: usize,
    progress: bool,
) -> Result<Vec<FrameSummary>, PipelineError> {
    std::fs::create_dir_all(out_dir).map_err(|source| IoError::Os {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let bar = if progress {
        let b = indicatif::ProgressBar::new(frames.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {pos}/{len} frames {per_sec} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let (tx, rx) =
        std::sync::mpsc::sync_channel::<(FrameSource, Result<PointCloud, IoError>)>(queue.max(1));
    let list = frames.to_vec();
    let reader = std::thread::spawn(move || {
        for frame in list {
            let cloud = frame.read();
            if tx.send((frame, cloud)).is_err() {
                break; // the consumer stopped
            }
        }
    });
    let mut summary = Vec::with_capacity(frames.len());
    let mut result = Ok(());
    for (frame, cloud) in rx.iter() {
        let output = out_dir.join(frame.output_name());
        let filtered = cloud
            .map_err(PipelineError::from)
            .and_then(|c| pipeline.step(&c).map(|out| (c.len(), out)));
        let record = match filtered {
            Ok((points_in, out)) => {
                if let Err(e) = write_cloud(&output, &out.cloud, Encoding::Binary) {
                    result = Err(e.into());
                    break;
                }
                FrameSummary {
                    input: frame.path().to_path_buf(),
                    output,
                    points_in,
                    points_out: out.cloud.len(),
                    stage_ms: out
                        .timings
                        .iter()
                        .map(|t| (t.stage, t.elapsed.as_secs_f64() * 1e3))
                        .collect(),
                    error: None,
                }
            }
            Err(e) => FrameSummary {
                input: frame.path().to_path_buf(),
                output,
                points_in: 0,
                points_out: 0,
                stage_ms: Vec::new(),
                error: Some(e.to_string()),
            },
        };
        match &record.error {
            None => bar.set_message(format!(
                "{} -> {} points",
                record.points_in, record.points_out
            )),
            Some(e) => bar.println(format!("skipped {}: {e}", record.input.display())),
        }
        bar.inc(1);
        summary.push(record);
    }
    drop(rx);
    let _ = reader.join();
    bar.finish_and_clear();
    result.map(|_| summary)
}

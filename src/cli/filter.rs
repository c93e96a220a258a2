//! `softsense filter`: crop, voxel, outlier removal and normals on one cloud or a sequence.

use super::{print_json, CliError, CliResult};
use clap::{Args, ValueEnum};
use softsense::features::{Neighbourhood, NormalParams};
use softsense::filter::{
    Field, OutlierMode, PassThroughParams, RadiusOutlierParams, StatisticalOutlierParams,
    VoxelGridParams, VoxelMode,
};
use softsense::io::{read_cloud, write_cloud, Encoding};
use softsense::pipeline::{
    list_frames, list_rgbd_frames, run_sequence, ChainParams, Pipeline, StageTiming,
};
use std::io::IsTerminal;
use std::path::PathBuf;

/// Library conventions for a stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    /// PCL 1.13 semantics.
    Pcl,
    /// Open3D 0.20 semantics.
    Open3d,
}

/// Filter a point cloud (PCD/PLY) or a sequence of them: pass-through crops, voxel grid,
/// radius / statistical outlier removal and normals, in PCL's or Open3D's semantics.
///
/// Stages run in the order crop, voxel, radius outlier, statistical outlier, normals.
/// Without --config only the stages given on the command line run; with --config the
/// file's chain runs and command-line stages override it.
///
/// Examples:
///
///   softsense filter scan.pcd out.pcd --crop z:0:0.54 --voxel 0.005 --radius-outlier 0.005:5
///
///   softsense filter frames/ filtered/ --config chain.toml --json
///
///   softsense filter 'frames/frame_*.pcd' filtered/ --voxel 0.01 --voxel-mode open3d
///
///   softsense filter scene_dir/ filtered/ --voxel 0.005   (depth_NNNN.png + color_NNNN.png)
#[derive(Debug, Args)]
#[command(
    about = "Crop, voxel-filter, remove outliers and estimate normals (PCL/Open3D semantics)",
    verbatim_doc_comment
)]
pub struct FilterArgs {
    /// Input cloud (.pcd/.ply), a directory of them (or of RGB-D image pairs), or a
    /// pattern like 'dir/frame_*.pcd'.
    pub input: PathBuf,
    /// Output cloud, or an output directory when the input is a sequence.
    pub output: PathBuf,
    /// Keep MIN <= FIELD <= MAX (PCL PassThrough); FIELD is x, y, z, normal_x..z,
    /// curvature, label, r, g or b; repeatable, e.g. --crop z:0:0.54 --crop x:-0.13:0.13.
    #[arg(long, value_name = "FIELD:MIN:MAX", value_parser = parse_crop)]
    pub crop: Vec<PassThroughParams>,
    /// Voxel-grid leaf size in metres, e.g. 0.005 (5 mm).
    #[arg(long, value_name = "LEAF", allow_negative_numbers = true, value_parser = parse_leaf)]
    pub voxel: Option<f64>,
    /// Voxel grid of PCL (origin-anchored, truncated colours) or Open3D (min-anchored).
    #[arg(long, value_enum, default_value = "pcl")]
    pub voxel_mode: Mode,
    /// Radius outlier removal: keep points with at least MIN_NEIGHBORS other points
    /// within RADIUS metres, e.g. 0.005:5.
    #[arg(long, value_name = "RADIUS:MIN_NEIGHBORS", value_parser = parse_radius_outlier)]
    pub radius_outlier: Option<(f64, usize)>,
    /// Neighbour counting of the outlier filters: PCL or Open3D.
    #[arg(long, value_enum, default_value = "pcl")]
    pub outlier_mode: Mode,
    /// Statistical outlier removal with K neighbours (PCL meanK; Open3D nb_neighbors
    /// counts the point itself) and threshold mean + STDDEV * sigma, e.g. 20:2.
    #[arg(long, value_name = "K:STDDEV", value_parser = parse_statistical)]
    pub statistical_outlier: Option<(usize, f64)>,
    /// Estimate normals and curvature from the K nearest points (PCL semantics, oriented
    /// towards the cloud's viewpoint).
    #[arg(long, value_name = "K")]
    pub normals: Option<usize>,
    /// Chain parameters as TOML (see `ChainParams`); flags override its stages.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Print a JSON summary (points and per-stage milliseconds per frame) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Read the input directory's RGB-D image pairs (depth_NNNN.png + color_NNNN.png +
    /// intrinsics.json, or STEM_depth.tiff + STEM_rgb.tiff + STEM.xml) even if it also
    /// holds .pcd/.ply files; a directory without cloud files is read this way anyway.
    #[arg(long)]
    pub rgbd: bool,
}

/// A voxel leaf: a positive, finite length in metres.
fn parse_leaf(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        Ok(v) => Err(format!(
            "the leaf is a positive length in metres, e.g. 0.005 for 5 mm (got {v})"
        )),
        Err(e) => Err(format!("{e}: give a length in metres, e.g. 0.005")),
    }
}

fn parse_crop(s: &str) -> Result<PassThroughParams, String> {
    let parts: Vec<&str> = s.split(':').collect();
    let [field, min, max] = parts[..] else {
        return Err(format!("expected FIELD:MIN:MAX (e.g. z:0:0.54), got `{s}`"));
    };
    let field: Field = field.parse().map_err(|e| format!("{e}"))?;
    let num = |v: &str| {
        v.parse::<f32>()
            .map_err(|_| format!("`{v}` is not a number in `{s}`"))
    };
    let (min, max) = (num(min)?, num(max)?);
    if min.is_nan() || max.is_nan() || min > max {
        return Err(format!("need MIN <= MAX in `{s}`"));
    }
    Ok(PassThroughParams::new(field, min, max))
}

fn parse_radius_outlier(s: &str) -> Result<(f64, usize), String> {
    let (r, n) = s
        .split_once(':')
        .ok_or_else(|| format!("expected RADIUS:MIN_NEIGHBORS (e.g. 0.005:5), got `{s}`"))?;
    let r: f64 = r
        .parse()
        .map_err(|_| format!("radius `{r}` is not a number"))?;
    if !(r.is_finite() && r > 0.0) {
        return Err(format!("radius must be > 0, got {r}"));
    }
    let n: usize = n
        .parse()
        .map_err(|_| format!("MIN_NEIGHBORS `{n}` is not a non-negative integer"))?;
    Ok((r, n))
}

fn parse_statistical(s: &str) -> Result<(usize, f64), String> {
    let (k, m) = s
        .split_once(':')
        .ok_or_else(|| format!("expected K:STDDEV (e.g. 20:2), got `{s}`"))?;
    let k: usize = k
        .parse()
        .map_err(|_| format!("K `{k}` is not a positive integer"))?;
    let m: f64 = m
        .parse()
        .map_err(|_| format!("STDDEV `{m}` is not a number"))?;
    if k == 0 || !m.is_finite() {
        return Err(format!("need K >= 1 and a finite STDDEV in `{s}`"));
    }
    Ok((k, m))
}

/// The chain the arguments describe.
fn chain(args: &FilterArgs) -> Result<ChainParams, CliError> {
    let mut p = match &args.config {
        Some(path) => ChainParams::from_toml_file(path)?,
        None => ChainParams {
            voxel: None,
            radius_outlier: None,
            ..ChainParams::default()
        },
    };
    let outlier_mode = match args.outlier_mode {
        Mode::Pcl => OutlierMode::Pcl,
        Mode::Open3d => OutlierMode::Open3d,
    };
    if !args.crop.is_empty() {
        p.crop = args.crop.clone();
    }
    if let Some(leaf) = args.voxel {
        p.voxel = Some(VoxelGridParams {
            mode: match args.voxel_mode {
                Mode::Pcl => VoxelMode::Pcl,
                Mode::Open3d => VoxelMode::Open3d,
            },
            ..VoxelGridParams::new(leaf)
        });
    }
    if let Some((radius, min_neighbors)) = args.radius_outlier {
        p.radius_outlier = Some(RadiusOutlierParams {
            radius,
            min_neighbors,
            mode: outlier_mode,
            ..Default::default()
        });
    }
    if let Some((k, std_ratio)) = args.statistical_outlier {
        p.statistical_outlier = Some(StatisticalOutlierParams {
            k,
            std_ratio,
            mode: outlier_mode,
            ..Default::default()
        });
    }
    if let Some(k) = args.normals {
        p.normals = Some(NormalParams {
            neighbourhood: Neighbourhood::Knn(k),
            ..NormalParams::knn(k)
        });
    }
    Ok(p)
}

/// Runs `softsense filter`.
pub fn run(args: &FilterArgs) -> CliResult {
    super::refuse_output_over_input(&args.input, &args.output)?;
    let params = chain(args)?;
    let mut pipeline = Pipeline::new(params);
    let input_str = args.input.to_string_lossy();
    let is_sequence = args.input.is_dir() || input_str.contains('*') || input_str.contains('?');
    if is_sequence {
        let frames = if args.rgbd {
            list_rgbd_frames(&args.input)?
        } else {
            list_frames(&args.input)?
        };
        let progress = std::io::stderr().is_terminal();
        let summary = run_sequence(&mut pipeline, &frames, &args.output, 4, progress)?;
        let failed: Vec<_> = summary.iter().filter(|f| f.error.is_some()).collect();
        if args.json {
            print_json(&serde_json::to_value(&summary).unwrap_or_default())?;
        } else {
            let done = summary.len() - failed.len();
            let total_ms: f64 = summary
                .iter()
                .flat_map(|f| f.stage_ms.iter().map(|s| s.1))
                .sum();
            eprintln!(
                "filtered {done} of {} frames into {} ({:.2} ms per frame in the chain)",
                summary.len(),
                args.output.display(),
                total_ms / done.max(1) as f64
            );
            for f in &failed {
                eprintln!("  not filtered: {}", f.error.as_deref().unwrap_or_default());
            }
        }
        if !failed.is_empty() {
            return Err(CliError::Result(format!(
                "{} of {} frames could not be filtered (each is named above); the others \
                 were written",
                failed.len(),
                summary.len()
            )));
        }
        return Ok(());
    }
    let cloud = read_cloud(&args.input)?;
    let out = pipeline
        .step(&cloud)
        .map_err(|e| CliError::Result(format!("{}: {e}", args.input.display())))?;
    write_cloud(&args.output, &out.cloud, Encoding::Binary)?;
    let stages: Vec<_> = out
        .timings
        .iter()
        .map(|t| {
            serde_json::json!({"stage": t.stage, "points_out": t.points_out,
                "ms": t.elapsed.as_secs_f64() * 1e3})
        })
        .collect();
    if args.json {
        let j = serde_json::json!({"input": args.input, "output": args.output,
            "points_in": cloud.len(), "points_out": out.cloud.len(), "stages": stages});
        print_json(&j)?;
    } else {
        for t in &out.timings {
            eprintln!(
                "{:>20}: {:>8} points {:>9.3} ms",
                t.stage,
                t.points_out,
                t.elapsed.as_secs_f64() * 1e3
            );
        }
        eprintln!(
            "{} -> {} points, written to {}",
            cloud.len(),
            out.cloud.len(),
            args.output.display()
        );
    }
    warn_coarse_voxel(args, cloud.len(), &out.timings);
    Ok(())
}

/// Warns when the voxel grid kept under 1% of the points it was given: a leaf meant in
/// millimetres but read in metres (`--voxel 5`) leaves a handful of points, silently.
fn warn_coarse_voxel(args: &FilterArgs, points_in: usize, timings: &[StageTiming]) {
    let Some(leaf) = args.voxel else { return };
    let Some(at) = timings.iter().position(|t| t.stage == "voxel") else {
        return;
    };
    let before = match at {
        0 => points_in,
        _ => timings[at - 1].points_out,
    };
    let after = timings[at].points_out;
    if before >= 1000 && after * 100 < before {
        eprintln!(
            "warning: --voxel {leaf} kept {after} of {before} points: the leaf is in metres \
             (0.005 is 5 mm); give a smaller leaf if this was not meant"
        );
    }
}

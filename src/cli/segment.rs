//! `softsense segment`: PCL-compatible colour region growing or our geometric mode;
//! writes every input point with a `label` field.

use super::{print_json, CliError, CliResult};
use clap::{Args, ValueEnum};
use softsense::io::{read_cloud, write_cloud, Encoding};
use softsense::segment::{segment, GeometricParams, RegionGrowingParams, SegmentMode, UNSEGMENTED};
use softsense::PointCloud;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Segment a cloud and write it with a `label` field.
///
/// --mode pcl (default): colour region growing with PCL 1.13 RegionGrowingRGB semantics,
/// exact; defaults are PCL's; the thesis code used --distance 0.01 --point-color 6
/// --region-color 4 --min-cluster 100.
///
/// --mode geometric: our own mode for objects on a table: the dominant plane (the
/// support) is removed, the rest grown into smooth surfaces by normals and curvature and
/// merged across convex junctions (and flat ones of similar colour). Its parameters are
/// fixed (see softsense::segment::geometric); the PCL flags do not apply to it. Support
/// parts are segments too; --json flags them with "support": true.
///
/// OUT holds every input point in input order; `label` is 1 + the segment's index for
/// points in a segment, and 0 for points in none (non-finite points and points of
/// clusters removed by the size limits).
///
/// Examples:
///
///   softsense segment scene.pcd labelled.pcd --distance 0.01 --point-color 6 --region-color 4 --min-cluster 100
///
///   softsense segment scene.pcd labelled.pcd --mode geometric --json
#[derive(Debug, Args)]
#[command(
    about = "Colour region growing (PCL RegionGrowingRGB, exact); writes a `label` field",
    verbatim_doc_comment
)]
pub struct SegmentArgs {
    /// Input cloud (.pcd/.ply); PCL mode needs colours.
    pub input: PathBuf,
    /// Output cloud (.pcd/.ply) with a `label` field.
    pub output: PathBuf,
    /// Segmentation mode.
    #[arg(long, value_enum, default_value_t = Mode::Pcl)]
    pub mode: Mode,
    /// Segments closer than this many metres may merge by colour (PCL default √0.05).
    #[arg(long, value_name = "M")]
    pub distance: Option<f64>,
    /// Largest RGB distance (0-255 units, inclusive) between neighbouring points grown
    /// into one segment (default 35).
    #[arg(long, value_name = "T")]
    pub point_color: Option<f64>,
    /// Segments whose mean colours differ by less than this merge (default √10).
    #[arg(long, value_name = "T")]
    pub region_color: Option<f64>,
    /// Smallest segment in points; smaller ones merge into their nearest neighbour unless
    /// --no-merge (default 10).
    #[arg(long, value_name = "N")]
    pub min_cluster: Option<usize>,
    /// Do not merge small segments into their neighbours; drop them instead.
    #[arg(long)]
    pub no_merge: bool,
    /// Print a JSON summary (segments with size, mean colour, bounding box) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The segmentation modes of the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    /// PCL RegionGrowingRGB, exact.
    Pcl,
    /// Support plane + smooth growing + convexity merge (our own).
    Geometric,
}

/// Writes `cloud` with `label` = 1 + `labels[i]`, or 0 for `unassigned`.
pub fn write_labelled(
    path: &Path,
    cloud: &PointCloud,
    labels: &[u32],
    unassigned: u32,
) -> CliResult {
    let mut out = cloud.clone();
    out.labels = Some(
        labels
            .iter()
            .map(|&l| {
                if l == unassigned {
                    0
                } else {
                    l.saturating_add(1)
                }
            })
            .collect(),
    );
    write_cloud(path, &out, Encoding::Binary)?;
    Ok(())
}

/// Runs the subcommand.
pub fn run(args: &SegmentArgs) -> CliResult {
    super::refuse_output_over_input(&args.input, &args.output)?;
    let mut params = RegionGrowingParams::default();
    if let Some(d) = args.distance {
        params.distance_m = d;
    }
    if let Some(t) = args.point_color {
        params.point_color = t;
    }
    if let Some(t) = args.region_color {
        params.region_color = t;
    }
    if let Some(n) = args.min_cluster {
        params.min_cluster_size = n;
    }
    params.merge_small = !args.no_merge;
    let mode = match args.mode {
        Mode::Pcl => SegmentMode::Pcl(params),
        Mode::Geometric => {
            if args.distance.is_some()
                || args.point_color.is_some()
                || args.region_color.is_some()
                || args.min_cluster.is_some()
                || args.no_merge
            {
                return Err(CliError::Usage(
                    "--distance, --point-color, --region-color, --min-cluster and --no-merge \
                     apply to --mode pcl only"
                        .into(),
                ));
            }
            SegmentMode::Geometric(GeometricParams::default())
        }
    };
    let cloud = read_cloud(&args.input)?;
    let t0 = Instant::now();
    let (seg, support) = segment(&cloud, &mode)
        .map_err(|e| CliError::Result(format!("{}: {e}", args.input.display())))?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    write_labelled(&args.output, &cloud, &seg.labels, UNSEGMENTED)?;
    let unsegmented = seg.labels.iter().filter(|&&l| l == UNSEGMENTED).count();
    if args.json {
        let segments: Vec<serde_json::Value> = seg
            .segments
            .iter()
            .enumerate()
            .map(|(i, s)| {
                serde_json::json!({"label": i + 1, "points": s.len(), "mean_color": s.mean_color,
                    "min": s.min, "max": s.max, "support": support.contains(&i)})
            })
            .collect();
        print_json(&serde_json::json!({
            "input": args.input, "output": args.output, "points": cloud.len(),
            "unsegmented": unsegmented, "grown_segments": seg.grown_segments,
            "colour_regions": seg.colour_regions, "params": mode, "segments": segments,
            "ms": ms}))?;
    } else {
        eprintln!(
            "{} points: {} segments, {unsegmented} unsegmented (label 0), {ms:.1} ms -> {}",
            cloud.len(),
            seg.segments.len(),
            args.output.display()
        );
    }
    Ok(())
}

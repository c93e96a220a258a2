//! `softsense cluster`: PCL-compatible Euclidean cluster extraction.

use super::segment::write_labelled;
use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::io::read_cloud;
use softsense::segment::euclidean::{euclidean_clusters, labels_from_clusters, EuclideanParams};
use std::path::PathBuf;
use std::time::Instant;

/// Split a cloud into Euclidean clusters (PCL 1.13 EuclideanClusterExtraction: points
/// strictly closer than the tolerance connect; clusters outside --min..--max points are
/// dropped whole) and write it with a `label` field.
///
/// OUT holds every input point in input order; `label` is 1 + the cluster's index
/// (clusters by size, largest first) or 0 for points in no kept cluster.
///
/// Example:
///
///   softsense cluster contacts.pcd groups.pcd --tolerance 0.005 --min 10 --max 2000
#[derive(Debug, Args)]
#[command(
    about = "Euclidean cluster extraction (PCL semantics); writes a `label` field",
    verbatim_doc_comment
)]
pub struct ClusterArgs {
    /// Input cloud (.pcd/.ply).
    pub input: PathBuf,
    /// Output cloud with a `label` field.
    pub output: PathBuf,
    /// Cluster tolerance in metres.
    #[arg(long, value_name = "M")]
    pub tolerance: f64,
    /// Smallest cluster kept, points.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub min: usize,
    /// Largest cluster kept, points (default: no limit).
    #[arg(long, value_name = "N")]
    pub max: Option<usize>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand.
pub fn run(args: &ClusterArgs) -> CliResult {
    super::refuse_output_over_input(&args.input, &args.output)?;
    let cloud = read_cloud(&args.input)?;
    let params = EuclideanParams {
        tolerance: args.tolerance,
        min_size: args.min,
        max_size: args.max.unwrap_or(usize::MAX),
        ..Default::default()
    };
    let t0 = Instant::now();
    let clusters =
        euclidean_clusters(&cloud.positions, &params).map_err(|e| CliError::Lib(e.into()))?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let labels = labels_from_clusters(cloud.len(), &clusters, u32::MAX);
    write_labelled(&args.output, &cloud, &labels, u32::MAX)?;
    let sizes: Vec<usize> = clusters.iter().map(|c| c.len()).collect();
    if args.json {
        print_json(
            &serde_json::json!({"input": args.input, "output": args.output,
            "points": cloud.len(), "clusters": sizes, "ms": ms}),
        )?;
    } else {
        eprintln!(
            "{} points: {} clusters {}, {ms:.1} ms -> {}",
            cloud.len(),
            clusters.len(),
            largest_sizes(&sizes),
            args.output.display()
        );
    }
    Ok(())
}

/// How many cluster sizes the human summary lists.
const SIZES_SHOWN: usize = 20;

/// The largest sizes (`sizes` is largest first) as `[a, b, ...]`, the rest counted: a
/// fine tolerance on millions of points gives a million clusters, a 3.5 MB line.
fn largest_sizes(sizes: &[usize]) -> String {
    let shown = &sizes[..sizes.len().min(SIZES_SHOWN)];
    match sizes.len() - shown.len() {
        0 => format!("{shown:?}"),
        more => format!("{shown:?} and {more} more"),
    }
}

//! `softsense batch`: many recordings, scene files and sweep scenes, one result file each,
//! resumable.

use super::{CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use softsense::batch::{plan, result_path, run, Manifest, Source};
use std::path::PathBuf;

/// Sense many recordings in one resumable run: one result file per item.
///
/// MANIFEST (TOML) lists the items; paths in it are relative to the manifest's folder:
///
///   [defaults]                 # optional: `sense` options for every item
///   features = 51              # also: model, pose, robot_color = [40, 200, 60],
///   registration = "auto"      #   max_contacts; an item's own value wins
///
///   [[recording]]              # a recording folder, sensed as `softsense sense`
///   path = "../../clouds/scenes/tip_weight"
///   # id = "tip_weight"        # default: the folder's name
///   # model = "../../meshes/models/robot.toml"   # or any other `sense` option
///
///   [[scene]]                  # a scene file: generated, then sensed
///   spec = "../../clouds/scenes/probe_side.toml"
///   id = "probe_side_regenerated"
///
///   [[sweep]]                  # COUNT scenes drawn as `softsense scene sweep` draws
///   spec = "../../tools/sweeps/robot_one_probe.toml"   # them, each generated and
///   count = 20                 # sensed: items ID_0000 .. ID_0019 (ID: `id`, default
///   seed = 7                   # the file's name)
///
/// Each item writes OUT/results/ID.json, atomically (a killed run leaves whole result
/// files only): {"id", "item" (what was sensed, with which options), "status" ("done", or
/// "failed" with "error"), "sensed" (frames sensed), "frames" (one object per frame, as
/// `sense --json` prints it), "seconds"}. Scene and sweep items write their generated
/// recording to OUT/recordings/ID/: generated beside it and moved in when whole, with
/// the list of its files (OUT/recordings/ID/.softsense-written). Generating an item again
/// replaces only the files on that list: batch never deletes a file it did not write, and
/// an item whose new file would replace one of yours fails, naming it.
///
/// Run the same command again to resume: items with a complete result file of the same
/// item are skipped (their count is printed), the rest run. Items that failed keep their
/// error in their result file and are not run again unless --retry-failed. An item's
/// results do not depend on --jobs.
#[derive(Debug, Args)]
#[command(
    about = "Sense many recordings, scene files and sweep scenes: one result file each, resumable",
    verbatim_doc_comment,
    after_help = "Examples:\n  \
softsense batch scenarios/batch/bundled.toml --out /tmp/bundled --jobs 2\n  \
softsense batch scenarios/batch/bundled.toml --out /tmp/bundled      # again: resumes\n  \
softsense batch scenarios/batch/bundled.toml --out /tmp/bundled --retry-failed\n\n\
More in docs/scale-out.md."
)]
pub struct BatchArgs {
    /// Manifest file (TOML; see above).
    pub manifest: PathBuf,
    /// Output folder (created): results/ID.json per item, recordings/ID/ for generated
    /// ones. Default: MANIFEST's name without extension, plus ".out", in the working
    /// directory.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Items run at the same time. With 1, each item's frames are sensed side by side
    /// instead; on two cores both take about the same time.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = super::parse_positive)]
    pub jobs: usize,
    /// Run the items that failed in an earlier run again.
    #[arg(long)]
    pub retry_failed: bool,
}

pub fn run_batch(args: &BatchArgs) -> CliResult {
    let manifest = Manifest::load(&args.manifest).map_err(softsense::Error::from)?;
    let out = args.out.clone().unwrap_or_else(|| {
        let stem = args.manifest.file_stem().unwrap_or_default();
        PathBuf::from(format!("{}.out", stem.to_string_lossy()))
    });
    let clock = std::time::Instant::now();
    let planned = plan(&manifest.items, &out, args.retry_failed);
    eprintln!(
        "{}: {} items ({}); results in {}",
        args.manifest.display(),
        manifest.items.len(),
        kinds(&manifest),
        out.join("results").display()
    );
    if planned.done + planned.failed.len() > 0 {
        eprintln!(
            "skipped {} items with a result from an earlier run ({} done, {} failed{})",
            planned.done + planned.failed.len(),
            planned.done,
            planned.failed.len(),
            if planned.failed.is_empty() {
                ""
            } else {
                ": --retry-failed runs them again"
            }
        );
    }
    if planned.replaced > 0 {
        eprintln!(
            "{} result files were unreadable or of another item (the manifest changed): \
             those items run again",
            planned.replaced
        );
    }
    let bar = ProgressBar::new(planned.todo.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} items {elapsed} (eta {eta}) {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let outcomes = run(&planned.todo, &out, args.jobs, |o| {
        bar.inc(1);
        bar.set_message(o.id.clone());
        if let Err(e) = &o.result {
            bar.suspend(|| eprintln!("{}: failed: {e}", o.id));
        }
    })
    .map_err(softsense::Error::from)?;
    bar.finish_and_clear();
    let failed_now: Vec<_> = outcomes.iter().filter(|o| o.result.is_err()).collect();
    let frames: usize = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().ok())
        .map(|r| r.0)
        .sum();
    eprintln!(
        "{} run ({} done, {} failed; {frames} frames), {} skipped, {} failed before: {:.1} s",
        outcomes.len(),
        outcomes.len() - failed_now.len(),
        failed_now.len(),
        planned.done + planned.failed.len(),
        planned.failed.len(),
        clock.elapsed().as_secs_f64()
    );
    for (id, e) in &planned.failed {
        eprintln!("{id}: failed in an earlier run: {e}");
    }
    let failed = failed_now.len() + planned.failed.len();
    if failed > 0 {
        let first = failed_now
            .first()
            .map(|o| o.id.clone())
            .or_else(|| planned.failed.first().map(|f| f.0.clone()))
            .unwrap_or_default();
        return Err(CliError::Result(format!(
            "{failed} of {} items failed; each one's error is in its result file, e.g. {}",
            manifest.items.len(),
            result_path(&out, &first).display()
        )));
    }
    Ok(())
}

/// "5 recordings, 20 sweep scenes" for the items of `manifest`.
fn kinds(manifest: &Manifest) -> String {
    let count = |f: fn(&Source) -> bool| manifest.items.iter().filter(|i| f(&i.source)).count();
    let parts = [
        (
            count(|s| matches!(s, Source::Recording { .. })),
            "recordings",
        ),
        (count(|s| matches!(s, Source::Scene { .. })), "scene files"),
        (
            count(|s| matches!(s, Source::SweepScene { .. })),
            "sweep scenes",
        ),
    ];
    parts
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, what)| format!("{n} {what}"))
        .collect::<Vec<_>>()
        .join(", ")
}

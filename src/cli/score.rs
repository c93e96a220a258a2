//! `softsense score`: sense results against the truth, over many recordings.

use super::{CliError, CliResult};
use clap::Args;
use softsense::sense::score::{score, Score, SensedFrame, Summary, LOCATED, WITHIN};
use std::path::{Path, PathBuf};

/// Score `sense --json` results against each recording's truth.json: located and within-5%
/// rates, silent misses, sigma coverage, time per frame.
#[derive(Args, Debug)]
#[command(long_about = LONG)]
pub struct ScoreArgs {
    /// Recording folders (each with truth.json and the sense output), or sweep folders
    /// (their scene_* recordings are scored).
    #[arg(required = true)]
    recordings: Vec<PathBuf>,
    /// Name of the sense output inside each recording (`sense DIR --json > DIR/NAME`).
    #[arg(long, value_name = "NAME", default_value = "sense.json")]
    sense_file: String,
    /// Print the score as one JSON object (every load and phantom listed) on stdout.
    #[arg(long)]
    json: bool,
    /// Score only each recording's last frame, by the forces fused over the frames its
    /// load was held (sensed with `sense --hold`; a sweep with `held_frames`).
    #[arg(long)]
    held: bool,
}

const LONG: &str = "\
Score `softsense sense --json` results against each recording's truth.json (made by
`scene generate` or `scene sweep`), over any number of recordings.

Each RECORDING is a recording folder holding truth.json and the sense output (sense.json
by default: `softsense sense DIR --json > DIR/sense.json`), or a sweep folder, whose
scene_* recordings are all scored.

Rules:
  located       the estimate `sense` matched to a true load is within 5 mm of it
  within 5%     located, and |F_est - F_true| <= 5% of |F_true| (3-D force)
  flagged       the frame was not sensed, is marked unreliable, or has a warning
  silent miss   a load of an unflagged frame that is not located or whose 3-D error
                exceeds max(5%, 2 sigma along the error); or an estimate of an unflagged
                frame matched to no true load (a phantom)
  sigma         over located loads: the magnitude error within 1/2/3 sigma (Gaussian:
                68.3/95.4/99.7%), and the squared Mahalanobis distance e' C^-1 e of the
                3-D error (Gaussian: median 2.37, 95% below 7.815)
  reference     a frame sense took as its reference (--reference-frames; \"reference\":
                true) is not scored
  unloaded      a frame whose truth has no load: \"force above 2 sigma\" when some
                estimate's magnitude exceeds twice its sigma (its estimates are phantoms)
  --held        only each recording's last frame is scored, by its forces fused over
                the frames the load was held (`sense --hold`); a last frame that ended
                the hold (failed or unreliable) is scored as it is, flagged

Every silent miss is listed with its recording and frame. Recordings of a sweep (its
draws.json beside them) are also scored by how far the camera's azimuth is from the
bundled scenes' direction (its first camera's): 0-30, 30-90 and 90-180 degrees. Frames of
recordings of several cameras are also scored by how many cameras each was sensed from
(a camera without the frame, or with an unreadable one, does not count). Exit code 1 when a recording
has no truth.json or its sense output lacks frames the truth has.

Examples:
  softsense scene sweep tools/sweeps/robot_one_probe.toml /tmp/sw --count 100 --seed 7
  for d in /tmp/sw/scene_*/; do softsense sense \"$d\" --json > \"$d/sense.json\"; done
  softsense score /tmp/sw
  softsense score /tmp/sw --json | jq '.all'
  # a load held over 10 frames (held_frames = 10 in the sweep file):
  for d in /tmp/sh/scene_*/; do softsense sense \"$d\" --hold --json > \"$d/sense.json\"; done
  softsense score /tmp/sh --held";

/// The recordings named on the command line, sweep folders expanded.
fn expand(paths: &[PathBuf]) -> Result<Vec<PathBuf>, CliError> {
    let mut out = Vec::new();
    for p in paths {
        if p.join("truth.json").is_file() {
            out.push(p.clone());
            continue;
        }
        let mut scenes: Vec<PathBuf> = std::fs::read_dir(p)
            .map_err(|e| CliError::Result(format!("{}: {e}", p.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|d| {
                d.is_dir()
                    && d.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with("scene_"))
            })
            .collect();
        if scenes.is_empty() {
            return Err(CliError::Result(format!(
                "{}: neither a recording with truth.json nor a sweep folder with scene_* recordings",
                p.display()
            )));
        }
        scenes.sort();
        out.extend(scenes);
    }
    Ok(out)
}

/// Reads one recording's sense lines and checks them against its truth's frame count.
fn read_recording(dir: &Path, sense_file: &str) -> Result<Vec<SensedFrame>, CliError> {
    let truth_path = dir.join("truth.json");
    let truth: serde_json::Value = std::fs::read_to_string(&truth_path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
        .map_err(|e| CliError::Result(format!("{}: {e}", truth_path.display())))?;
    let frames = truth["frames"].as_array().map_or(0, |f| f.len());
    let path = dir.join(sense_file);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        CliError::Result(format!(
            "{}: {e} (make it with `softsense sense {} --json > {}`)",
            path.display(),
            dir.display(),
            path.display()
        ))
    })?;
    let mut lines = Vec::new();
    for (k, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let f: SensedFrame = serde_json::from_str(line)
            .map_err(|e| CliError::Result(format!("{} line {}: {e}", path.display(), k + 1)))?;
        if f.errors.is_none() {
            return Err(CliError::Result(format!(
                "{} line {}: frame {} has no errors against the truth (was it sensed without truth.json?)",
                path.display(),
                k + 1,
                f.frame
            )));
        }
        lines.push(f);
    }
    if lines.len() < frames {
        return Err(CliError::Result(format!(
            "{}: {} frames, but truth.json has {frames}: sense every frame (was it interrupted?)",
            path.display(),
            lines.len()
        )));
    }
    Ok(lines)
}

/// Runs the subcommand.
pub fn run(args: &ScoreArgs) -> CliResult {
    let dirs = expand(&args.recordings)?;
    let mut recordings = Vec::new();
    for d in &dirs {
        recordings.push((
            d.display().to_string(),
            read_recording(d, &args.sense_file)?,
        ));
    }
    let mut fused = Vec::new();
    if args.held {
        for (name, lines) in &mut recordings {
            let last = softsense::sense::score::held_last(lines)
                .ok_or_else(|| CliError::Result(format!("{name}: no frame to score for --held")))?;
            fused.push(last.1 as f64);
            *lines = vec![last.0];
        }
    }
    let s = score(&recordings);
    let by_azimuth = azimuth_groups(&dirs, &recordings);
    let by_cameras = camera_groups(&recordings);
    if args.json {
        let mut v = serde_json::to_value(&s).map_err(|e| CliError::Result(e.to_string()))?;
        let groups: Vec<serde_json::Value> = by_azimuth
            .iter()
            .map(|(name, g)| serde_json::json!({"azimuth": name, "summary": g}))
            .collect();
        v["by_azimuth"] = serde_json::Value::Array(groups);
        let groups: Vec<serde_json::Value> = (by_cameras.iter())
            .map(|(n, g)| serde_json::json!({"cameras": n, "summary": g}))
            .collect();
        v["by_cameras"] = serde_json::Value::Array(groups);
        if args.held {
            // Per recording, frames its last frame's forces fused (0: it ended the hold).
            v["held_frames_fused"] = serde_json::json!(fused);
        }
        return super::print_json(&v);
    }
    print_text(&s, dirs.len())?;
    if args.held {
        let ended = fused.iter().filter(|&&n| n == 0.0).count();
        outln!(
            "held: last frames scored by their fused forces; frames fused median {} (min {}); {ended} of {} ended the hold (scored unfused, flagged)",
            softsense::math::median(&mut fused.clone()),
            fused.iter().cloned().fold(f64::INFINITY, f64::min),
            fused.len()
        )?;
    }
    for (n, g) in &by_cameras {
        outln!("frames sensed from {n} camera(s):")?;
        for l in summary_lines(g) {
            outln!("  {l}")?;
        }
    }
    for (name, g) in &by_azimuth {
        outln!("camera {name} from the bundled direction:")?;
        for l in summary_lines(g) {
            outln!("  {l}")?;
        }
    }
    Ok(())
}

/// Bins of the camera's azimuth away from the bundled scenes' direction (degrees).
const AZIMUTH_BINS: [(f64, f64, &str); 3] = [
    (0.0, 30.0, "0-30 degrees"),
    (30.0, 90.0, "30-90 degrees"),
    (90.0, 180.1, "90-180 degrees"),
];

/// The azimuth `scene sweep` drew for `dir` (from its sweep's `draws.json`), if any.
fn drawn_azimuth(dir: &Path) -> Option<f64> {
    let name = dir.file_name()?.to_str()?;
    let index: usize = name.strip_prefix("scene_")?.parse().ok()?;
    let text = std::fs::read_to_string(dir.parent()?.join("draws.json")).ok()?;
    let draws: serde_json::Value = serde_json::from_str(&text).ok()?;
    let az = draws.as_array()?.get(index)?["azimuth_deg"].as_f64()?;
    // Folded to 0-180 degrees either side of the bundled direction.
    Some(((az + 180.0).rem_euclid(360.0) - 180.0).abs())
}

/// Scores per azimuth bin, when every recording comes from a sweep (else none).
fn azimuth_groups(
    dirs: &[PathBuf],
    recordings: &[(String, Vec<SensedFrame>)],
) -> Vec<(&'static str, Summary)> {
    let Some(az): Option<Vec<f64>> = dirs.iter().map(|d| drawn_azimuth(d)).collect() else {
        return Vec::new();
    };
    AZIMUTH_BINS
        .iter()
        .filter_map(|&(lo, hi, name)| {
            let group: Vec<_> = recordings
                .iter()
                .zip(&az)
                .filter(|(_, a)| (lo..hi).contains(*a))
                .map(|(r, _)| r.clone())
                .collect();
            (!group.is_empty()).then(|| (name, score(&group).all))
        })
        .collect()
}

/// Scores per number of cameras a frame was sensed from, when some recording has several
/// cameras (else none).
fn camera_groups(recordings: &[(String, Vec<SensedFrame>)]) -> Vec<(usize, Summary)> {
    let frames = recordings.iter().flat_map(|(_, f)| f);
    if frames.clone().all(|f| f.cameras.is_empty()) {
        return Vec::new();
    }
    let mut counts: Vec<usize> = frames.map(|f| f.cameras_seen()).collect();
    counts.sort_unstable();
    counts.dedup();
    counts
        .into_iter()
        .map(|n| {
            let group: Vec<(String, Vec<SensedFrame>)> = (recordings.iter())
                .map(|(name, f)| {
                    let kept = f.iter().filter(|f| f.cameras_seen() == n).cloned();
                    (name.clone(), kept.collect())
                })
                .filter(|(_, f): &(String, Vec<SensedFrame>)| !f.is_empty())
                .collect();
            (n, score(&group).all)
        })
        .collect()
}

fn pct(n: usize, of: usize) -> String {
    if of == 0 {
        "-".into()
    } else {
        format!("{n}/{of} ({:.1}%)", 100.0 * n as f64 / of as f64)
    }
}

/// A share as a percentage, "-" when there was nothing to share.
fn pc(share: f64) -> String {
    if share.is_nan() {
        "-".into()
    } else {
        format!("{:.1}%", 100.0 * share)
    }
}

fn summary_lines(s: &Summary) -> Vec<String> {
    let cover = s.sigma_coverage.map(pc);
    let mut lines = vec![
        format!("frames                       {} ({} sensed, {} flagged)", s.frames, s.sensed, s.flagged_frames),
        format!("located within {:.0} mm         {}", LOCATED * 1e3, pct(s.located, s.loads)),
        format!("3-D force within {:.0}%         {}", WITHIN * 100.0, pct(s.within, s.loads)),
        format!("frames: all loads located    {}", pct(s.frames_all_located, s.frames)),
        format!("frames: all loads within 5%  {}", pct(s.frames_all_within, s.frames)),
        format!("silent misses                {} (phantom estimates: {})", s.silent, s.phantoms),
        format!(
            "magnitude within 1/2/3 sigma {} / {} / {} (Gaussian 68.3 / 95.4 / 99.7)",
            cover[0], cover[1], cover[2]
        ),
        format!(
            "squared Mahalanobis, 3-D     median {:.2} (Gaussian 2.37); {} inside the 95% ellipsoid",
            s.median_mahalanobis2,
            pc(s.within_ellipsoid95)
        ),
        format!("time per frame               median {:.0} ms", s.median_ms),
    ];
    if s.unloaded_frames > 0 {
        lines.push(format!(
            "unloaded frames: force above 2 sigma {}",
            pct(s.unloaded_above_2sigma, s.unloaded_frames)
        ));
    }
    lines
}

fn print_text(s: &Score, recordings: usize) -> CliResult {
    outln!("{recordings} recordings, {} loads", s.all.loads)?;
    for l in summary_lines(&s.all) {
        outln!("  {l}")?;
    }
    if s.by_loads.len() > 1 {
        for (k, g) in &s.by_loads {
            outln!("frames with {k} load(s):")?;
            for l in summary_lines(g) {
                outln!("  {l}")?;
            }
        }
    }
    let silent: Vec<_> = s.loads.iter().filter(|l| l.silent).collect();
    if !silent.is_empty() {
        outln!("silent misses:")?;
        for l in silent {
            let loc = l
                .location_error
                .map_or("no estimate".into(), |d| format!("{:.1} mm", d * 1e3));
            outln!(
                "  {} frame {}: {:.3} N load, location {loc}, force {:.1}% off",
                l.recording,
                l.frame,
                l.magnitude,
                100.0 * l.force_error
            )?;
        }
    }
    for p in s.phantoms.iter().filter(|p| !p.flagged) {
        outln!(
            "  {} frame {}: phantom estimate of {:.3} N (no true load near it)",
            p.recording,
            p.frame,
            p.magnitude
        )?;
    }
    Ok(())
}

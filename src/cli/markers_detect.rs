//! `softsense markers detect`: coloured markers found in an RGB-D recording, written as a
//! marker track file.

use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::markers::detect::{detect_recording, errors_against, DetectParams};
use softsense::markers::tracks::{read_tracks, write_tracks, write_tracks_string};
use softsense::recording::Recording;
use std::path::PathBuf;

/// Find coloured markers in an RGB-D recording and write their tracks.
#[derive(Args, Debug)]
#[command(
    long_about = "Find coloured markers in every frame of an RGB-D recording and write their \
tracks (softsense CSV frame,marker,x,y,z, metres, robot frame) for `softsense markers TRACKS \
MODEL`.\n\n\
A pixel is paint when the angle between its RGB vector and --colour is below --max-angle-deg \
(shading keeps a colour's direction) and its brightest channel is at least 40. 8-connected \
blobs of at least --min-pixels are markers: a plane is fitted to the blob's depth points and \
the mean of its pixels' rays cut with that plane is the centre on the surface, put in the \
robot frame with the recording's camera pose (calibration.json or camera_pose.json). A blob \
whose area on the surface is not 0.6 to 1.6 times pi r^2 (--radius-mm) is partly hidden or \
two markers merged, and is left out.\n\n\
Identities: each detection takes the marker whose last position is nearest (within \
--max-jump-mm). With --reference (a track file, e.g. from `softsense markers layout --csv`) \
the markers are the reference's; else the first frame's detections are the markers m0, m1, \
... in image order. A marker not found in a frame is written as a missing entry.\n\n\
When the recording has markers_truth.csv (from `scene generate` with [markers]), the \
distance of every detection to its nearest true marker is reported.",
    after_help = "Examples:\n  \
softsense scene generate painted.toml /tmp/painted\n  \
softsense markers detect /tmp/painted --colour 30,60,230 --out /tmp/painted/tracks.csv\n  \
softsense markers /tmp/painted/tracks.csv meshes/models/sheet.toml --candidates candidates.csv"
)]
pub struct DetectArgs {
    /// Recording folder (depth and colour images, intrinsics, camera pose).
    recording: PathBuf,
    /// Paint colour R,G,B (0-255).
    #[arg(long, value_parser = parse_colour, default_value = "30,60,230")]
    colour: [u8; 3],
    /// Marker disc radius (mm).
    #[arg(long, default_value_t = 3.0)]
    radius_mm: f64,
    /// Largest angle between a pixel's RGB vector and the colour's (degrees).
    #[arg(long, default_value_t = 12.0)]
    max_angle_deg: f64,
    /// Fewest pixels of a marker blob.
    #[arg(long, default_value_t = 8)]
    min_pixels: usize,
    /// A detection farther than this from where a marker is expected (its last position
    /// moved by its nearest matched neighbours' displacement) is another marker (mm).
    #[arg(long, default_value_t = 10.0)]
    max_jump_mm: f64,
    /// Reference layout (softsense track file): the marker names and starting positions.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Write the tracks here (else they are printed on stdout); never a file the command
    /// reads (a frame, the camera or truth files, --reference).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print a JSON summary on stdout (with --out).
    #[arg(long, requires = "out")]
    json: bool,
}

fn parse_colour(s: &str) -> Result<[u8; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || format!("{s:?}: expected R,G,B with each 0-255, e.g. 30,60,230");
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut c = [0u8; 3];
    for (ck, p) in c.iter_mut().zip(parts) {
        *ck = p.parse().map_err(|_| bad())?;
    }
    Ok(c)
}

/// Runs `softsense markers detect`.
pub fn run(args: &DetectArgs) -> CliResult {
    let params = DetectParams {
        colour: args.colour,
        max_angle_deg: args.max_angle_deg,
        min_pixels: args.min_pixels.max(3),
        radius: args.radius_mm * 1e-3,
        max_jump: args.max_jump_mm * 1e-3,
        ..Default::default()
    };
    params
        .validate()
        .map_err(|e| CliError::Usage(e.to_string()))?;
    if let Some(out) = &args.out {
        let mut inputs = super::recording_files(&args.recording);
        inputs.extend(args.reference.clone());
        let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
        super::check_output_file(out, &inputs)?;
    }
    let rec = Recording::open(&args.recording).map_err(|e| CliError::Lib(e.into()))?;
    let reference = (args.reference.as_deref())
        .map(read_tracks)
        .transpose()
        .map_err(|e| CliError::Lib(e.into()))?;
    let (tracks, detections, dropped) =
        detect_recording(&rec, &params, reference.as_ref()).map_err(|e| CliError::Lib(e.into()))?;
    if tracks.names.is_empty() {
        // The tracks hold only their header, which `markers` refuses: say why here.
        eprintln!(
            "warning: {}: no marker found in any frame: check --colour and --max-angle-deg",
            args.recording.display()
        );
    }
    let truth_path = rec.dir.join(softsense::scene::MARKERS_TRUTH);
    let errors = match truth_path.exists() {
        true => {
            let truth = read_tracks(&truth_path).map_err(|e| CliError::Lib(e.into()))?;
            Some(errors_against(&tracks, &truth))
        }
        false => None,
    };
    let Some(out) = &args.out else {
        print!("{}", write_tracks_string(&tracks));
        return Ok(());
    };
    write_tracks(out, &tracks).map_err(|e| CliError::Lib(e.into()))?;
    let stats = errors.as_ref().map(|e| error_stats(e));
    if args.json {
        let per_frame: Vec<usize> = detections.iter().map(Vec::len).collect();
        let v = serde_json::json!({
            "markers": tracks.names, "detected_per_frame": per_frame, "unassigned": dropped,
            "truth_error_mm": stats.map(|[max, median, n]| serde_json::json!({
                "max": max, "median": median, "detections": n })),
        });
        return print_json(&v);
    }
    for (f, d) in tracks.frames.iter().zip(&detections) {
        let hidden = f.positions.iter().filter(|p| p.is_none()).count();
        outln!(
            "frame {}: {} blobs, {} of {} markers located",
            f.frame,
            d.len(),
            tracks.names.len() - hidden,
            tracks.names.len()
        )?;
    }
    if dropped > 0 {
        outln!("{dropped} detections matched no reference marker")?;
    }
    if let Some([max, median, n]) = stats {
        outln!(
            "against {}: {n} detections, error max {max:.3} mm, median {median:.3} mm",
            truth_path.display()
        )?;
    }
    outln!("tracks written to {}", out.display())?;
    Ok(())
}

/// Max and median of `errors` (mm) and their count.
fn error_stats(errors: &[f64]) -> [f64; 3] {
    let mut mm: Vec<f64> = errors.iter().map(|e| e * 1e3).collect();
    let max = mm.iter().copied().fold(0.0, f64::max);
    let median = softsense::math::median(&mut mm);
    [max, median, mm.len() as f64]
}

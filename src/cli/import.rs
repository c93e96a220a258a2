//! `softsense import`: a RealSense `.bag` or a ROS 2 bag into a recording folder.

use super::{print_json, CliError, CliResult};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use softsense::recording::import::{import, ImportParams};
use std::path::PathBuf;

/// Arguments of `softsense import`.
#[derive(Debug, Args)]
#[command(
    about = "Import a RealSense .bag or a ROS 2 bag (MCAP or sqlite3) into a recording folder",
    long_about = "Import a camera recording into a recording folder (softsense layout: \
depth_NNNN.png, color_NNNN.png, intrinsics.json) that `sense`, `calibrate` and `explain` read.\n\n\
BAG is a RealSense .bag (rosbag v1, as the RealSense Viewer records it), a ROS 2 bag folder \
(metadata.yaml + .mcap or .db3 files) or one .mcap or .db3 file. MCAP chunks may be \
uncompressed, lz4 or zstd (ROS 2's writer's usual choice), rosbag chunks uncompressed or lz4; \
sqlite3 bags are opened read-only.\n\n\
Topics: depth is the one sensor_msgs/Image topic with encoding 16UC1, mono16 or 32FC1, \
colour the one with rgb8, bgr8, rgba8, bgra8 or mono8 (RealSense: /device_0/sensor_0/Depth_0/image/data \
and /device_0/sensor_1/Color_0/image/data); each camera's sensor_msgs/CameraInfo is the one \
whose topic shares the longest prefix with the image topic. Of several candidates, mono8 \
loses to colour encodings, then the one whose name says depth (color, colour, rgb) wins. The --*-topic options choose when \
the guess is wrong or ambiguous; a missing topic is an error listing the bag's topics.\n\n\
Pairing: each depth frame takes the colour frame nearest in header stamp within \
--pair-tolerance (default half the median depth frame period); a colour frame goes to one \
depth frame only, the nearer. A depth frame without colour is not written (reported as \
dropped); frame numbers are the depth frames' places in stamp order, so a dropped frame leaves \
a gap. A bag without colour gives a depth-only recording: `sense` finds the robot by its \
colour, so it reports such frames no_robot.\n\n\
Depth: 16-bit values are kept as they are, in metres per unit from --depth-unit, else the \
RealSense `Depth Units` option, else 0.001; 32FC1 metres are rounded to --float-depth-unit. \
When the colour camera's intrinsics or size differ from the depth camera's, or the bag's \
depth-to-colour extrinsic is not the identity, depth is reprojected into the colour camera. \
The extrinsic is a RealSense bag's <stream>/tf/<reference> transforms \
(/device_0/sensor_0/Depth_0/tf/0, /device_0/sensor_1/Color_0/tf/0); without them it is the \
identity, with a warning.\n\n\
The bag carries no robot pose, model or cable inputs: add camera_pose.json (or calibrate), \
and inputs.json or actuators.json, as for any recording (docs/recording-format.md).",
    after_help = "Examples:\n  \
softsense import walk.bag /tmp/walk\n  \
softsense import rosbag2_2026_01_01 /tmp/run --depth-topic /camera/aligned_depth_to_color/image_raw \\\n      \
--colour-topic /camera/color/image_raw\n  \
softsense import walk.bag /tmp/walk --json"
)]
pub struct ImportArgs {
    /// The bag: a .bag file, a ROS 2 bag folder, or an .mcap or .db3 file.
    #[arg(value_name = "BAG")]
    pub bag: PathBuf,
    /// The recording folder to write: new or empty (written beside it and renamed into
    /// place when done, so a failed import leaves nothing).
    #[arg(value_name = "OUT_DIR")]
    pub out: PathBuf,
    #[arg(long, help = super::FORCE_HELP)]
    pub force: bool,
    /// Depth image topic [default: the one with a depth encoding].
    #[arg(long, value_name = "TOPIC")]
    pub depth_topic: Option<String>,
    /// Colour image topic [default: the one with a colour encoding, else depth only].
    #[arg(long, value_name = "TOPIC", alias = "color-topic")]
    pub colour_topic: Option<String>,
    /// CameraInfo topic of the depth camera [default: nearest the depth topic's name].
    #[arg(long, value_name = "TOPIC", alias = "info-topic")]
    pub depth_info_topic: Option<String>,
    /// CameraInfo topic of the colour camera [default: nearest the colour topic's name].
    #[arg(long, value_name = "TOPIC", alias = "color-info-topic")]
    pub colour_info_topic: Option<String>,
    /// Largest depth-colour stamp difference of a pair, seconds [default: half the median
    /// depth frame period].
    #[arg(long, value_name = "S")]
    pub pair_tolerance: Option<f64>,
    /// Metres per unit of 16-bit depth [default: the bag's Depth Units, else 0.001].
    #[arg(long, value_name = "M")]
    pub depth_unit: Option<f64>,
    /// Metres per written unit for 32FC1 depth [default: 0.0001].
    #[arg(long, value_name = "M")]
    pub float_depth_unit: Option<f64>,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `softsense import`.
pub fn run(args: &ImportArgs) -> CliResult {
    let positive = |v: Option<f64>, name: &str| match v {
        Some(x) if !(x > 0.0 && x.is_finite()) => {
            Err(CliError::Usage(format!("{name} {x}: must be positive")))
        }
        _ => Ok(()),
    };
    positive(args.pair_tolerance, "--pair-tolerance")?;
    positive(args.depth_unit, "--depth-unit")?;
    positive(args.float_depth_unit, "--float-depth-unit")?;
    let staged = super::staged_output_dir(&args.out, &[&args.bag], args.force)?;
    let params = ImportParams {
        depth_topic: args.depth_topic.clone(),
        colour_topic: args.colour_topic.clone(),
        depth_info_topic: args.depth_info_topic.clone(),
        colour_info_topic: args.colour_info_topic.clone(),
        pair_tolerance: args.pair_tolerance,
        depth_unit: args.depth_unit,
        float_depth_unit: args.float_depth_unit,
    };
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} depth frames {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let summary = import(&args.bag, staged.path(), &params, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(softsense::Error::from)?;
    bar.finish_and_clear();
    // No frame: the folder is not made (`staged` is dropped, its folder removed).
    if summary.frames_written > 0 {
        staged.commit().map_err(super::output_error)?;
    }
    if args.json {
        let v = serde_json::to_value(&summary).map_err(|e| CliError::Result(e.to_string()))?;
        print_json(&v)?;
    }
    let colour = summary.colour_topic.as_deref().unwrap_or("none");
    eprintln!(
        "wrote {}: {} frames ({} with colour) from {} depth and {} colour images; depth {}, colour {}",
        args.out.display(),
        summary.frames_written,
        summary.paired,
        summary.depth_frames,
        summary.colour_frames,
        summary.depth_topic,
        colour,
    );
    if !summary.dropped_depth.is_empty() {
        let n: Vec<String> = summary
            .dropped_depth
            .iter()
            .map(|n| n.to_string())
            .collect();
        eprintln!(
            "dropped {} depth frames without a colour frame within {:.4} s: frames {}",
            n.len(),
            summary.pair_tolerance,
            n.join(", ")
        );
    }
    if summary.unused_colour > 0 {
        eprintln!(
            "{} colour frames were paired with no depth frame",
            summary.unused_colour
        );
    }
    for w in &summary.warnings {
        eprintln!("warning: {w}");
    }
    if summary.frames_written == 0 {
        return Err(CliError::Result(format!(
            "{}: no frame written",
            args.bag.display()
        )));
    }
    Ok(())
}

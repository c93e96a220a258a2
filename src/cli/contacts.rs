//! `softsense contacts`: segmentation, robot choice and KD-tree contact detection.

use super::segment::Mode;
use super::{print_json, CliError, CliResult};
use clap::Args;
use softsense::contact::{detect_contacts, ContactParams};
use softsense::io::read_cloud;
use softsense::segment::robot::{select_robot, ChosenBy, RobotRule};
use softsense::segment::robot_color::RobotColorModel;
use softsense::segment::{segment, GeometricParams, RegionGrowingParams, SegmentMode};
use std::path::PathBuf;
use std::time::Instant;

/// Find where objects touch the robot in a coloured scene (raw or filtered): segmentation
/// (--mode pcl: colour region growing with the thesis code's parameters, 0.01 m, point
/// colour 6, region colour 4, min 100 points; --mode geometric: our geometric mode, whose
/// support-plane parts are never the robot but are objects it can touch), the robot
/// segment (by colour, or the largest), then object points with more than
/// --min-neighbors robot points within --radius, grouped by Euclidean clustering (5 mm,
/// 10-2000 points). Prints one line (or JSON object) per contact: centroid (m), points,
/// extent (m).
///
/// Examples:
///
///   softsense contacts scene.pcd
///
///   softsense contacts scene.pcd --robot-color 30,60,200:25 --radius 0.004 --min-neighbors 3 --json
#[derive(Debug, Args)]
#[command(
    about = "Segment, pick the robot and detect where objects touch it",
    verbatim_doc_comment
)]
pub struct ContactsArgs {
    /// Input cloud with colours (.pcd/.ply).
    pub input: PathBuf,
    /// Segmentation mode.
    #[arg(long, value_enum, default_value_t = Mode::Pcl)]
    pub mode: Mode,
    /// The robot is the largest segment whose mean colour is within TOL degrees of CIELAB
    /// hue (default 25, with chroma at least 12: the colour model `sense` uses) of this sRGB
    /// colour; without it, the largest segment.
    #[arg(long, value_name = "R,G,B[:TOL]", value_parser = parse_robot_color)]
    pub robot_color: Option<([u8; 3], f64)>,
    /// Contact search radius in metres.
    #[arg(long, value_name = "M", default_value_t = 0.004)]
    pub radius: f64,
    /// An object point is in contact with more than this many robot points in range.
    #[arg(long, value_name = "N", default_value_t = 3)]
    pub min_neighbors: usize,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_robot_color(s: &str) -> Result<([u8; 3], f64), String> {
    let (rgb, tol) = match s.split_once(':') {
        Some((c, t)) => (c, t.parse::<f64>().map_err(|e| format!("tolerance: {e}"))?),
        None => (s, RobotColorModel::default().hue_tolerance_deg),
    };
    if !(tol.is_finite() && (0.0..=180.0).contains(&tol)) {
        return Err("tolerance must be a hue angle in degrees, 0 to 180".into());
    }
    Ok((super::parse_rgb(rgb)?, tol))
}

/// Runs the subcommand.
pub fn run(args: &ContactsArgs) -> CliResult {
    // Name the input: a failure here is about that cloud.
    let lib = |e: softsense::segment::SegmentError| {
        CliError::Result(format!("{}: {e}", args.input.display()))
    };
    let cloud = read_cloud(&args.input)?;
    let t0 = Instant::now();
    let mode = match args.mode {
        Mode::Pcl => SegmentMode::Pcl(RegionGrowingParams::thesis()),
        Mode::Geometric => SegmentMode::Geometric(GeometricParams::default()),
    };
    let (seg, support) =
        segment(&cloud, &mode).map_err(|e| super::segment_error(&args.input, e))?;
    let rule = match args.robot_color {
        Some((rgb, hue_tolerance_deg)) => RobotRule::Color(RobotColorModel {
            hue_tolerance_deg,
            ..RobotColorModel::with_reference(rgb)
        }),
        None => RobotRule::Largest,
    };
    // Support parts (geometric mode) are not robot candidates.
    let candidates: Vec<usize> = (0..seg.segments.len())
        .filter(|k| !support.contains(k))
        .collect();
    let candidate_segments: Vec<_> = candidates
        .iter()
        .map(|&k| seg.segments[k].clone())
        .collect();
    let mut robot = select_robot(&candidate_segments, &rule).map_err(lib)?;
    robot.segment = candidates[robot.segment];
    let robot_pts: Vec<[f32; 3]> = seg.segments[robot.segment]
        .indices
        .iter()
        .map(|&i| cloud.positions[i])
        .collect();
    let object_idx: Vec<usize> = seg
        .segments
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != robot.segment)
        .flat_map(|(_, s)| s.indices.iter().copied())
        .collect();
    let object_pts: Vec<[f32; 3]> = object_idx.iter().map(|&i| cloud.positions[i]).collect();
    let cparams = ContactParams {
        radius_m: args.radius,
        min_neighbors: args.min_neighbors,
        ..Default::default()
    };
    let contacts = detect_contacts(&robot_pts, &object_pts, &cparams).map_err(lib)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if args.json {
        let list: Vec<serde_json::Value> = contacts
            .iter()
            .map(|c| {
                serde_json::json!({"centroid": c.centroid, "points": c.points,
                    "extent": c.extent(), "min": c.min, "max": c.max})
            })
            .collect();
        print_json(
            &serde_json::json!({"input": args.input, "segments": seg.segments.len(),
            "robot": {"segment": robot.segment, "points": robot_pts.len(), "chosen_by": robot.chosen_by,
                      "mean_color": seg.segments[robot.segment].mean_color},
            "contacts": list, "ms": ms}),
        )?;
    } else {
        let chosen_by = match robot.chosen_by {
            ChosenBy::Color { hue_difference_deg } => {
                format!("its colour, hue {hue_difference_deg:.1}° from the robot's")
            }
            ChosenBy::Largest => "its size, the largest".to_string(),
        };
        eprintln!(
            "{} segments; robot = segment {} ({} points, chosen by {chosen_by}); {} contacts; {ms:.1} ms",
            seg.segments.len(),
            robot.segment,
            robot_pts.len(),
            contacts.len()
        );
        for c in &contacts {
            outln!(
                "{:.4} {:.4} {:.4}  points {}  extent {:.4} m",
                c.centroid[0],
                c.centroid[1],
                c.centroid[2],
                c.points,
                c.extent()
            )?;
        }
    }
    Ok(())
}

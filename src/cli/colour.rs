//! `softsense colour FRAME --at U,V`: the robot's colour sampled from a frame, and how well
//! it would segment.

use super::{CliError, CliResult};
use clap::Args;
use softsense::io::rgbd::read_color_image;
use softsense::segment::color::rgb_to_lab;
use softsense::segment::robot_color::RobotColorModel;
use std::path::PathBuf;

/// Arguments of `softsense colour`.
#[derive(Debug, Args)]
#[command(
    about = "Sample the robot's colour from a frame (for --robot-color) and check it segments",
    long_about = "Sample the robot's colour at a pixel of a colour frame: the median sRGB of a \
window around it, its CIELAB lightness, chroma and hue, and the share of the whole frame that \
the colour model (`sense --robot-color`) would take for robot.\n\n\
What segments well: a saturated colour (CIELAB chroma well above 12, the model's floor) whose \
hue no background shares: green, blue, orange or magenta silicone against a grey or white \
table. White, grey, black and skin-toned bodies do not: their chroma is too low or their hue is \
everywhere. Pick U,V on the robot in an image viewer (column, row from the top left), away from \
highlights and shadows.",
    after_help = "Example:\n  softsense colour clouds/scenes/tip_weight/color_0000.png --at 320,240"
)]
pub struct ColourArgs {
    /// A colour frame (PNG, JPEG, TIFF), e.g. RECORDING/color_0000.png.
    #[arg(value_name = "FRAME")]
    pub frame: PathBuf,
    /// The pixel on the robot, as U,V (column, row; from the top left).
    #[arg(long, value_name = "U,V")]
    pub at: String,
    /// Side of the square window whose median is taken (pixels, odd).
    #[arg(long, default_value_t = 7)]
    pub window: u32,
    /// Print JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `softsense colour`.
pub fn run(args: &ColourArgs) -> CliResult {
    let (u, v) = parse_pixel(&args.at)?;
    let image = read_color_image(&args.frame)?;
    if u >= image.width || v >= image.height {
        return Err(CliError::Usage(format!(
            "--at {u},{v} is outside the {}x{} frame",
            image.width, image.height
        )));
    }
    let half = args.window.max(1) / 2;
    let mut window: Vec<[u8; 3]> = Vec::new();
    for y in v.saturating_sub(half)..=(v + half).min(image.height - 1) {
        for x in u.saturating_sub(half)..=(u + half).min(image.width - 1) {
            window.push(image.data[(y * image.width + x) as usize]);
        }
    }
    let median = [0, 1, 2].map(|k| {
        let mut c: Vec<u8> = window.iter().map(|p| p[k]).collect();
        c.sort_unstable();
        c[c.len() / 2]
    });
    let lab = rgb_to_lab(median);
    let chroma = lab[1].hypot(lab[2]);
    let hue = lab[2].atan2(lab[1]).to_degrees().rem_euclid(360.0);
    let model = RobotColorModel::with_reference(median);
    let mut classifier = model.classifier();
    let share = (image.data.iter())
        .filter(|&&p| classifier.is_robot(p))
        .count() as f64
        / image.data.len() as f64;
    let verdict = if chroma < 2.0 * model.min_chroma {
        "segments poorly: too little colour (a grey, white or black body); paint or dye it"
    } else if share > 0.5 {
        "segments poorly: more than half the frame has this hue; change the background"
    } else {
        "segments well"
    };
    if args.json {
        let j = serde_json::json!({
            "rgb": median, "lab": lab, "chroma": chroma, "hue_deg": hue,
            "share_of_frame": share, "verdict": verdict,
        });
        return super::out(format_args!("{j}\n"));
    }
    super::out(format_args!(
        "at ({u}, {v}), median of {} pixels: sRGB {},{},{}; CIELAB L {:.0}, chroma {:.0}, hue {:.0} deg\n\
         {:.1}% of the frame has this colour (hue within {} deg, chroma above {}): {verdict}\n\
         use: --robot-color {},{},{}\n",
        window.len(),
        median[0], median[1], median[2],
        lab[0], chroma, hue,
        100.0 * share, model.hue_tolerance_deg, model.min_chroma,
        median[0], median[1], median[2]
    ))
}

fn parse_pixel(s: &str) -> Result<(u32, u32), CliError> {
    let bad = || {
        CliError::Usage(format!(
            "--at {s:?}: give U,V as two whole pixel numbers, e.g. 320,240"
        ))
    };
    let (u, v) = s.split_once(',').ok_or_else(bad)?;
    Ok((
        u.trim().parse().map_err(|_| bad())?,
        v.trim().parse().map_err(|_| bad())?,
    ))
}

//! `softsense convert`: cloud to cloud (PCD/PLY/XYZ), or RGB-D images to a cloud.

use super::{print_json, CliError, CliResult};
use clap::{Args, ValueEnum};
use serde_json::json;
use softsense::io::intrinsics::{read_camera_file, Arithmetic};
use softsense::io::{self, rgbd, CloudFormat, Encoding};
use softsense::PointCloud;
use std::path::PathBuf;

/// Output encoding names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EncodingArg {
    /// Text (PCD ascii, PLY ascii).
    Ascii,
    /// Raw binary (PCD binary, PLY binary_little_endian).
    Binary,
    /// PCD binary_compressed (LZF); PLY writes binary.
    #[value(name = "binary_compressed", alias = "binary-compressed")]
    BinaryCompressed,
}

impl From<EncodingArg> for Encoding {
    fn from(e: EncodingArg) -> Self {
        match e {
            EncodingArg::Ascii => Encoding::Ascii,
            EncodingArg::Binary => Encoding::Binary,
            EncodingArg::BinaryCompressed => Encoding::BinaryCompressed,
        }
    }
}

/// Whose arithmetic the RGB-D back-projection reproduces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ArithmeticArg {
    /// PCL's grabber (f32 throughout); bit-identical to PCL's PCD of the same frames.
    Pcl,
    /// Open3D's create_from_rgbd_image (f32 depth, f64 back-projection).
    Open3d,
}

/// Arguments of `softsense convert`.
#[derive(Debug, Args)]
#[command(
    about = "Convert PCD/PLY/XYZ, or RGB-D images (+ intrinsics) to a cloud",
    long_about = "Convert a cloud between formats, or turn an RGB-D image pair into an organized cloud.\n\n\
Cloud to cloud: `convert IN OUT`. Formats are chosen by extension (.pcd, .ply, .xyz/.txt). \
All fields that both formats can hold are kept; XYZ keeps positions only.\n\n\
RGB-D to cloud: `convert --depth D [--color C] --intrinsics I OUT`. D is a 16-bit \
single-channel PNG or TIFF (raw units, 0 = no measurement), C an 8-bit RGB or RGBA PNG or \
TIFF of the same size (RGBA: alpha is dropped), I either Open3D's PinholeCameraIntrinsic \
JSON ({\"width\", \"height\", \"intrinsic_matrix\": [9 numbers, column-major]}) or PCL's \
grabber XML (<depth><focal_length_x>... <z_multiplication_factor>). The cloud is organized \
(width x height of the image); pixels without depth, or with depth >= --depth-trunc, are NaN \
points, never (0,0,0). Coordinates: x right, y down, z forward, metres.",
    after_help = "Examples:\n  \
softsense convert clouds/demo_scene.pcd /tmp/demo.ply\n  \
softsense convert clouds/demo_scene.pcd /tmp/demo_ascii.pcd --encoding ascii\n  \
softsense convert --depth tests/fixtures/rgbd/depth.png --color tests/fixtures/rgbd/color.png \\\n      \
--intrinsics tests/fixtures/rgbd/intrinsics.json /tmp/frame.pcd\n  \
softsense convert --depth frame_depth.tiff --color frame_rgb.tiff --intrinsics frame.xml \\\n      \
--depth-trunc 3.0 --arithmetic open3d /tmp/frame.pcd"
)]
pub struct ConvertArgs {
    /// IN OUT for a cloud; only OUT with --depth.
    #[arg(value_name = "FILE", num_args = 1..=2, required = true)]
    pub files: Vec<PathBuf>,
    /// Output encoding (PCD and PLY; ignored for XYZ).
    #[arg(long, value_enum, default_value = "binary")]
    pub encoding: EncodingArg,
    /// RGB-D mode: the 16-bit depth image (PNG or TIFF).
    #[arg(long, value_name = "D", requires = "intrinsics")]
    pub depth: Option<PathBuf>,
    /// RGB-D mode: the 8-bit colour image (PNG or TIFF), same size as the depth image.
    #[arg(long, value_name = "C", requires = "depth")]
    pub color: Option<PathBuf>,
    /// RGB-D mode: the intrinsics, Open3D JSON (.json) or PCL grabber XML (.xml).
    #[arg(long, value_name = "I", requires = "depth")]
    pub intrinsics: Option<PathBuf>,
    /// Raw depth units per metre [default: the JSON's depth_scale, 1/z_multiplication_factor
    /// from PCL XML, else 1000].
    #[arg(long, value_name = "S", requires = "depth")]
    pub depth_scale: Option<f64>,
    /// Depths at or beyond T metres become NaN [default: no truncation; Open3D uses 3.0].
    #[arg(long, value_name = "T", requires = "depth")]
    pub depth_trunc: Option<f64>,
    /// Whose floating-point order to reproduce in the back-projection.
    #[arg(long, value_enum, default_value = "pcl", requires = "depth")]
    pub arithmetic: ArithmeticArg,
    /// Print a JSON summary of the written cloud on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `softsense convert`.
pub fn run(args: &ConvertArgs) -> CliResult {
    let (cloud, output) = match (&args.depth, args.files.as_slice()) {
        (Some(depth), [out]) => {
            super::refuse_output_over_input(depth, out)?;
            (rgbd_cloud(args, depth)?, out)
        }
        (Some(_), _) => {
            return Err(CliError::Usage(
                "with --depth give only the output file (convert --depth D --color C --intrinsics I OUT)".into(),
            ))
        }
        (None, [input, out]) => {
            check_output(out)?;
            super::refuse_output_over_input(input, out)?;
            (io::read_cloud(input)?, out)
        }
        (None, _) => {
            return Err(CliError::Usage(
                "give an input and an output file (convert IN OUT), or use --depth".into(),
            ))
        }
    };
    io::write_cloud(output, &cloud, args.encoding.into())?;
    let finite = cloud.count_finite();
    if args.json {
        print_json(&json!({
            "output": output.display().to_string(),
            "points": cloud.len(),
            "finite_points": finite,
            "width": cloud.width,
            "height": cloud.height,
            "fields": cloud.field_names(),
        }))?;
    }
    eprintln!(
        "wrote {}: {} points ({} finite), {} x {}",
        output.display(),
        cloud.len(),
        finite,
        cloud.width,
        cloud.height
    );
    let format = CloudFormat::from_path(output);
    if format == Some(CloudFormat::Xyz) && cloud.field_names().len() > 3 {
        eprintln!("note: XYZ keeps positions only; other fields were dropped");
    }
    if format != Some(CloudFormat::Pcd) && cloud.is_organized() {
        eprintln!("note: only PCD stores the organized shape; the file holds a flat list");
    }
    Ok(())
}

/// Fails early (before reading anything) when the output extension is unknown.
fn check_output(out: &std::path::Path) -> CliResult {
    match CloudFormat::from_path(out) {
        Some(_) => Ok(()),
        None => Err(io::IoError::UnknownFormat {
            path: out.to_path_buf(),
        }
        .into()),
    }
}

fn rgbd_cloud(args: &ConvertArgs, depth: &std::path::Path) -> Result<PointCloud, CliError> {
    let out = &args.files[0];
    check_output(out)?;
    let intrinsics = args
        .intrinsics
        .as_ref()
        .ok_or_else(|| CliError::Usage("--depth needs --intrinsics".into()))?;
    let (mut camera, lens) = read_camera_file(intrinsics)?;
    if let Some(s) = args.depth_scale {
        camera.params.depth_scale = s;
    }
    if let Some(t) = args.depth_trunc {
        camera.params.depth_trunc = t;
    }
    camera.params.arithmetic = match args.arithmetic {
        ArithmeticArg::Pcl => Arithmetic::Pcl,
        ArithmeticArg::Open3d => Arithmetic::Open3d,
    };
    camera
        .params
        .validate()
        .map_err(|e| CliError::Usage(format!("--depth-scale/--depth-trunc: {e}")))?;
    let cloud = rgbd::read_frame_through(depth, args.color.as_deref(), &camera, &lens)?;
    if cloud.count_finite() == 0 {
        // Almost always a unit mistake; refuse rather than write an all-NaN cloud.
        return Err(CliError::Result(format!(
            "{}: no pixel gives a valid point (depth_scale {} units/m, depth_trunc {} m); \
             check --depth-scale and --depth-trunc",
            depth.display(),
            camera.params.depth_scale,
            camera.params.depth_trunc
        )));
    }
    Ok(cloud)
}

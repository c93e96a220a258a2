//! `softsense info FILE [--json]`: what a cloud file holds.

use super::{print_json, CliResult};
use clap::Args;
use serde_json::json;
use softsense::io::{self, CloudFormat};
use std::path::{Path, PathBuf};

/// Arguments of `softsense info`.
#[derive(Debug, Args)]
#[command(
    long_about = "Print what a cloud file holds: number of points and of finite points, \
organized size (width x height), the file's fields, its encoding, the bounding box of the \
finite points and the sensor viewpoint.\n\n\
The format is chosen by extension: .pcd, .ply, .xyz/.txt. For PCD the field list is the \
file's own header (including fields softsense skips); for PLY and XYZ it is what was read.",
    after_help = "Examples:\n  \
softsense info clouds/demo_scene.pcd\n  \
softsense info clouds/demo_scene.pcd --json | jq .finite_points"
)]
pub struct InfoArgs {
    /// The cloud file (.pcd, .ply, .xyz).
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Print the summary as one JSON object on stdout instead of text on stderr.
    #[arg(long)]
    pub json: bool,
}

/// The file's own description: fields and encoding, from its header.
struct HeaderFacts {
    fields: Vec<String>,
    encoding: String,
}

/// Reads the header facts that a loaded `PointCloud` no longer carries.
fn header_facts(path: &Path, cloud: &softsense::PointCloud) -> Result<HeaderFacts, io::IoError> {
    let from_cloud = || cloud.field_names().iter().map(|f| f.to_string()).collect();
    Ok(match CloudFormat::from_path(path) {
        Some(CloudFormat::Pcd) => {
            // TODO(merge io): io::pcd::read_pcd_header(path)? -> fields, encoding.keyword()
            HeaderFacts {
                fields: from_cloud(),
                encoding: "unknown".into(),
            }
        }
        Some(CloudFormat::Ply) => HeaderFacts {
            fields: from_cloud(),
            encoding: ply_format(path)?.unwrap_or_else(|| "unknown".into()),
        },
        _ => HeaderFacts {
            fields: from_cloud(),
            encoding: "ascii".into(),
        },
    })
}

/// The `format` line of a PLY header (`ascii`, `binary_little_endian`, ...).
fn ply_format(path: &Path) -> Result<Option<String>, io::IoError> {
    use std::io::{BufRead, BufReader, Read};
    let file = std::fs::File::open(path).map_err(|source| io::IoError::Os {
        path: path.to_path_buf(),
        source,
    })?;
    // A header line is short; never read more than 64 KiB looking for it.
    let reader = BufReader::new(file.take(1 << 16));
    for line in reader.lines().map_while(Result::ok) {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("format") => return Ok(words.next().map(str::to_string)),
            Some("end_header") => break,
            _ => {}
        }
    }
    Ok(None)
}

/// Runs `softsense info`.
pub fn run(args: &InfoArgs) -> CliResult {
    let cloud = io::read_cloud(&args.file)?;
    let facts = header_facts(&args.file, &cloud)?;
    let finite = cloud.count_finite();
    let bounds = cloud.bounds();
    let vp = cloud.viewpoint;
    if args.json {
        print_json(&json!({
            "file": args.file.display().to_string(),
            "points": cloud.len(),
            "finite_points": finite,
            "width": cloud.width,
            "height": cloud.height,
            "organized": cloud.is_organized(),
            "fields": facts.fields,
            "encoding": facts.encoding,
            "bounds": bounds.map(|(lo, hi)| json!({"min": lo, "max": hi})),
            "viewpoint": {"origin": vp.origin, "orientation_wxyz": vp.orientation},
        }));
    } else {
        eprintln!("{}", args.file.display());
        eprintln!("  points:        {} ({} finite)", cloud.len(), finite);
        if cloud.is_organized() {
            eprintln!("  organized:     {} x {}", cloud.width, cloud.height);
        } else {
            eprintln!("  organized:     no ({} x {})", cloud.width, cloud.height);
        }
        eprintln!("  fields:        {}", facts.fields.join(" "));
        eprintln!("  encoding:      {}", facts.encoding);
        match bounds {
            Some((lo, hi)) => {
                eprintln!("  bounds min:    {:?} m", lo);
                eprintln!("  bounds max:    {:?} m", hi);
            }
            None => eprintln!("  bounds:        (no finite points)"),
        }
        eprintln!(
            "  viewpoint:     origin {:?}, orientation (w x y z) {:?}",
            vp.origin, vp.orientation
        );
    }
    Ok(())
}

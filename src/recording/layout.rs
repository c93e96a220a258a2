//! Where a folder keeps its frames: the three layouts a recording is read from.

use super::RecordingError;
use std::path::{Path, PathBuf};

/// How a folder lays out its frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// `depth_NNNN.png` + `color_NNNN.png` + one `intrinsics.json` (what `scene generate`
    /// writes); frame numbers are the `NNNN`.
    Softsense,
    /// `STEM_depth.tiff` + `STEM_rgb.tiff` + `STEM.xml` per frame (PCL's image grabber;
    /// PNG also accepted, or one shared `intrinsics.json`/`.xml`); frames numbered in name
    /// order from 0.
    PclGrabber,
    /// `depth/` and `color/` (or `image/`) sub-folders of images paired in name order, with
    /// `intrinsics.json` or `camera_intrinsic.json` (Open3D's RGB-D datasets); frames
    /// numbered in name order from 0.
    Open3d,
}

/// The files of one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameFiles {
    /// The frame number (see [`Layout`]).
    pub number: usize,
    /// Depth image (16-bit PNG or TIFF).
    pub depth: PathBuf,
    /// Colour image, if there is one.
    pub color: Option<PathBuf>,
    /// Camera file (Open3D JSON or PCL XML).
    pub camera: PathBuf,
}

/// The frames of `dir` in whichever layout it has, in frame order.
pub fn list_frames(dir: &Path) -> Result<(Layout, Vec<FrameFiles>), RecordingError> {
    list_frames_with(dir, None)
}

/// As [`list_frames`], with `camera` (if given) in place of the folder's shared camera
/// file: a recording read in place whose folder has none, or a wrong one.
pub fn list_frames_with(
    dir: &Path,
    camera: Option<&Path>,
) -> Result<(Layout, Vec<FrameFiles>), RecordingError> {
    let names = file_names(dir)?;
    // `names` is sorted: a frame's partner files are found by binary search.
    let has = |n: &str| names.binary_search_by(|m| m.as_str().cmp(n)).is_ok();
    let shared = ["intrinsics.json", "intrinsics.xml", "camera_intrinsic.json"]
        .into_iter()
        .find(|n| has(n))
        .map(|n| dir.join(n));
    let shared = camera.map(Path::to_path_buf).or(shared);
    let flat = list_flat(dir, &names, shared.as_deref())?;
    if let Some(first) = flat.first() {
        return Ok((first.0, flat.into_iter().map(|(_, f)| f).collect()));
    }
    let depth_dir = dir.join("depth");
    if depth_dir.is_dir() {
        let color_dir = ["color", "image", "rgb"]
            .into_iter()
            .map(|d| dir.join(d))
            .find(|d| d.is_dir());
        return Ok((Layout::Open3d, list_open3d(&depth_dir, color_dir, shared)?));
    }
    Err(RecordingError::NoFrames {
        path: dir.to_path_buf(),
    })
}

/// Why `dir` cannot be a recording folder, if it cannot: a file (named by what its
/// extension says it is) or nothing there.
pub(super) fn not_a_folder(dir: &Path) -> Option<RecordingError> {
    if dir.is_dir() {
        return None;
    }
    let ext = dir
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let problem = match (dir.exists(), ext.as_deref()) {
        (false, _) => "no such folder: a recording is a folder of depth and colour \
                       frames (docs/recording-format.md)"
            .to_string(),
        (true, Some("toml")) => format!(
            "is a TOML file, not a recording folder: if it is a scene, render it first \
             (softsense scene generate {} OUT), then give OUT",
            dir.display()
        ),
        (true, Some("bag" | "mcap" | "db3")) => format!(
            "is a bag, not a recording folder: import it first (softsense import {} OUT), \
             then give OUT",
            dir.display()
        ),
        (true, _) => "is a file, not a recording folder: give the folder that holds the \
                      depth and colour frames (docs/recording-format.md)"
            .to_string(),
    };
    Some(RecordingError::NotAFolder {
        path: dir.to_path_buf(),
        problem,
    })
}

/// Sorted names of the files (not folders) in `dir`.
fn file_names(dir: &Path) -> Result<Vec<String>, RecordingError> {
    if let Some(e) = not_a_folder(dir) {
        return Err(e);
    }
    let entries = std::fs::read_dir(dir).map_err(|source| crate::io::IoError::Os {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .collect();
    names.sort();
    Ok(names)
}

/// The length of `name` without its image extension, if it is an image.
fn image_stem_len(name: &str) -> Option<usize> {
    let l = name.to_ascii_lowercase();
    [".png", ".tiff", ".tif", ".jpg", ".jpeg"]
        .into_iter()
        .find(|e| l.ends_with(e))
        .map(|e| name.len() - e.len())
}

/// The softsense and PCL grabber layouts: every frame's files side by side in `dir`.
fn list_flat(
    dir: &Path,
    names: &[String],
    shared: Option<&Path>,
) -> Result<Vec<(Layout, FrameFiles)>, RecordingError> {
    let softsense = list_softsense(dir, names, shared)?;
    let grabber = list_grabber(dir, names, shared)?;
    match (softsense.is_empty(), grabber.is_empty()) {
        (false, false) => Err(RecordingError::MixedLayouts {
            path: dir.to_path_buf(),
        }),
        (false, true) => Ok(softsense
            .into_iter()
            .map(|f| (Layout::Softsense, f))
            .collect()),
        _ => Ok(grabber
            .into_iter()
            .map(|f| (Layout::PclGrabber, f))
            .collect()),
    }
}

/// The softsense layout: `depth_NNNN` and `color_NNNN` images by frame number. A frame with
/// only one of the two keeps the missing one's expected path (reading it then fails, naming
/// it), except that a folder without any colour image is read without colour. Two files
/// of the same kind and number (`depth_0004.png`, `depth_00004.png`) are refused.
fn list_softsense(
    dir: &Path,
    names: &[String],
    shared: Option<&Path>,
) -> Result<Vec<FrameFiles>, RecordingError> {
    // number -> (depth name, colour name)
    let mut frames: std::collections::BTreeMap<usize, [Option<&str>; 2]> = Default::default();
    for name in names {
        let Some(stem_len) = image_stem_len(name) else {
            continue;
        };
        let stem = &name[..stem_len];
        let (kind, id) = match (stem.strip_prefix("depth_"), stem.strip_prefix("color_")) {
            (Some(id), _) => (0, id),
            (None, Some(id)) => (1, id),
            (None, None) => continue,
        };
        let Ok(number) = id.parse::<usize>() else {
            continue;
        };
        let slot = &mut frames.entry(number).or_default()[kind];
        if let Some(first) = slot {
            return Err(RecordingError::DuplicateFrame {
                number,
                first: dir.join(first),
                second: dir.join(name),
            });
        }
        *slot = Some(name);
    }
    let any_color = frames.values().any(|[_, c]| c.is_some());
    frames
        .into_iter()
        .map(|(number, [depth, color])| {
            let depth =
                dir.join(depth.map_or_else(|| format!("depth_{number:04}.png"), String::from));
            let camera = shared
                .map(Path::to_path_buf)
                .ok_or_else(|| RecordingError::NoCamera {
                    depth: depth.clone(),
                })?;
            let color = match color {
                Some(c) => Some(dir.join(c)),
                None => any_color.then(|| dir.join(format!("color_{number:04}.png"))),
            };
            Ok(FrameFiles {
                number,
                depth,
                color,
                camera,
            })
        })
        .collect()
}

/// The PCL grabber layout: `STEM_depth.*` with `STEM_rgb.*` (or `STEM_color.*`) and
/// `STEM.xml`, numbered in name order.
fn list_grabber(
    dir: &Path,
    names: &[String],
    shared: Option<&Path>,
) -> Result<Vec<FrameFiles>, RecordingError> {
    // `names` is sorted: a frame's partner files are found by binary search.
    let has = |n: &str| names.binary_search_by(|m| m.as_str().cmp(n)).is_ok();
    let mut out = Vec::new();
    for name in names {
        let Some(stem_len) = image_stem_len(name) else {
            continue;
        };
        let (stem, ext) = name.split_at(stem_len);
        let Some(base) = stem.strip_suffix("_depth") else {
            continue;
        };
        let color = [ext, ".png", ".tiff", ".jpg"]
            .iter()
            .flat_map(|e| [format!("{base}_rgb{e}"), format!("{base}_color{e}")])
            .find(|c| has(c))
            .map(|c| dir.join(c));
        let own_camera = format!("{base}.xml");
        let camera = Some(own_camera)
            .filter(|c| has(c))
            .map(|c| dir.join(c))
            .or_else(|| shared.map(Path::to_path_buf))
            .ok_or_else(|| RecordingError::NoCamera {
                depth: dir.join(name),
            })?;
        out.push(FrameFiles {
            number: out.len(),
            depth: dir.join(name),
            color,
            camera,
        });
    }
    Ok(out)
}

/// Open3D's layout: `depth/` and a colour folder, paired in name order.
fn list_open3d(
    depth_dir: &Path,
    color_dir: Option<PathBuf>,
    shared: Option<PathBuf>,
) -> Result<Vec<FrameFiles>, RecordingError> {
    let images = |d: &Path| -> Result<Vec<PathBuf>, RecordingError> {
        Ok(file_names(d)?
            .into_iter()
            .filter(|n| image_stem_len(n).is_some())
            .map(|n| d.join(n))
            .collect())
    };
    let depths = images(depth_dir)?;
    let colors = match &color_dir {
        Some(d) => images(d)?,
        None => Vec::new(),
    };
    if let Some(d) = color_dir.filter(|_| colors.len() != depths.len()) {
        return Err(RecordingError::Unpaired {
            depth: depths.len(),
            color: colors.len(),
            path: d,
        });
    }
    let Some(first) = depths.first() else {
        return Err(RecordingError::NoFrames {
            path: depth_dir.to_path_buf(),
        });
    };
    let camera = shared.ok_or_else(|| RecordingError::NoCamera {
        depth: first.clone(),
    })?;
    Ok(depths
        .into_iter()
        .enumerate()
        .map(|(number, depth)| FrameFiles {
            number,
            depth,
            color: colors.get(number).cloned(),
            camera: camera.clone(),
        })
        .collect())
}

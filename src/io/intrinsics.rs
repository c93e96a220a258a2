//! Pinhole camera intrinsics and depth-conversion settings, read from Open3D's
//! `PinholeCameraIntrinsic` JSON or PCL's image-grabber XML.
//!
//! - [`PinholeIntrinsics`]: image size, focal lengths and principal point, in pixels.
//! - [`DepthParams`]: how raw 16-bit depth becomes metres (`depth_scale` units per metre,
//!   `depth_trunc` metres) and whose arithmetic to reproduce ([`Arithmetic`]).
//! - [`CameraModel`]: the two together; [`read_camera_model`] picks the reader by extension
//!   (`.json` → [`parse_open3d_json`], `.xml` → [`parse_pcl_xml`]).
//! - [`read_camera_file`]: the model and the [`Lens`] in front of it (JSON only: Brown-Conrady
//!   distortion keys, or a per-pixel ray table named by `rays`; see [`parse_lens_keys`]).
//!
//! ```
//! use softsense::io::intrinsics::parse_open3d_json;
//! let json = r#"{"width": 640, "height": 480,
//!                "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]}"#;
//! let camera = parse_open3d_json(json)?;
//! assert_eq!(camera.intrinsics.cx, 319.5);
//! assert_eq!(camera.params.depth_scale, 1000.0);
//! # Ok::<(), softsense::io::rgbd::RgbdError>(())
//! ```

use super::rgbd_error::RgbdError;
use super::IoError;
pub use crate::camera::PinholeIntrinsics;
use crate::camera::{Distortion, DistortionModel, Lens, RayTable};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The largest image side we accept from an intrinsics file (guards later allocations).
pub const MAX_IMAGE_SIDE: u32 = 1 << 15;

// The check speaks the readers' error type, so it lives here rather than in `camera`.
impl PinholeIntrinsics {
    /// Checks focal lengths (finite, > 0), principal point (finite) and size (at most
    /// [`MAX_IMAGE_SIDE`]); the error names the first bad field.
    pub fn validate(&self) -> Result<(), RgbdError> {
        for (field, f) in [("fx", self.fx), ("fy", self.fy)] {
            if !(f.is_finite() && f > 0.0) {
                return Err(bad(field, format!("must be a finite number > 0, got {f}")));
            }
        }
        for (field, c) in [("cx", self.cx), ("cy", self.cy)] {
            if !c.is_finite() {
                return Err(bad(field, format!("must be finite, got {c}")));
            }
        }
        for (field, s) in [("width", self.width), ("height", self.height)] {
            if s > MAX_IMAGE_SIDE {
                return Err(bad(field, format!("{s} exceeds {MAX_IMAGE_SIDE}")));
            }
        }
        if (self.width == 0) != (self.height == 0) {
            return Err(bad(
                if self.width == 0 { "width" } else { "height" },
                "is 0 while the other side is not".into(),
            ));
        }
        Ok(())
    }

    /// [`validate`](Self::validate), then refuses values no real camera has, which
    /// would otherwise pass silently (fx = 1e308 makes every x -0.0): focal lengths
    /// outside [`FOCAL_RANGE`] times the larger image side (at least 64 for the upper
    /// bound), and a principal point more than one image size outside the image. With
    /// no size (PCL's XML) the bounds use [`MAX_IMAGE_SIDE`]. Used on intrinsics read
    /// from files.
    pub fn check_plausible(&self) -> Result<(), RgbdError> {
        self.validate()?;
        let (w, h) = if self.width == 0 {
            (MAX_IMAGE_SIDE, MAX_IMAGE_SIDE)
        } else {
            (self.width, self.height)
        };
        let side = f64::from(w.max(h));
        // Small crops (a 4x3 test image) keep a full camera's focal length, so the upper
        // bound is taken from at least a 64-pixel side.
        let (lo, hi) = (FOCAL_RANGE.0 * side, FOCAL_RANGE.1 * side.max(64.0));
        for (field, f) in [("fx", self.fx), ("fy", self.fy)] {
            // A known size bounds from below too; an unknown one only from above.
            if f > hi || (self.width > 0 && f < lo) {
                return Err(bad(
                    field,
                    format!(
                        "{f:.6e} pixels is implausible for a {w}x{h} image (expected {lo} to {hi})"
                    ),
                ));
            }
        }
        for (field, c, s) in [("cx", self.cx, w), ("cy", self.cy, h)] {
            let s = f64::from(s);
            if !(-s..=2.0 * s).contains(&c) {
                return Err(bad(
                    field,
                    format!(
                        "{c:.6e} lies far outside a {w}x{h} image (expected {} to {})",
                        -s,
                        2.0 * s
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Plausible focal lengths, as multiples of the larger image side (a 640-pixel image:
/// 32 to 64,000 pixels, fields of view from about 170 degrees down to 0.6).
pub const FOCAL_RANGE: (f64, f64) = (0.05, 100.0);

/// Whose floating-point arithmetic the back-projection reproduces. Both give the same
/// geometry; they differ in the last bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Arithmetic {
    /// PCL's grabbers, all in `f32`: `z = raw·f32(1/scale)`, `x = (u − cx)·z·f32(1/fx)`.
    /// Reproduces the organized PCD PCL writes for the same frames bit for bit.
    #[default]
    Pcl,
    /// Open3D's `create_from_rgbd_image`: `z = f32(raw)/f32(scale)` in `f32`, then
    /// `x = (u − cx)·z/fx` in `f64`, rounded to `f32` for storage.
    Open3d,
}

/// How raw depth values become metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DepthParams {
    /// Raw depth units per metre (1000 for millimetres, 5000 for TUM); must be > 0.
    pub depth_scale: f64,
    /// Depths at or beyond this many metres become invalid (NaN); `f64::INFINITY` keeps all.
    pub depth_trunc: f64,
    /// Whose floating-point order to reproduce.
    pub arithmetic: Arithmetic,
}

impl Default for DepthParams {
    /// Millimetres, no truncation (PCL's behaviour; Open3D's default truncation is 3 m),
    /// PCL arithmetic.
    fn default() -> Self {
        DepthParams {
            depth_scale: 1000.0,
            depth_trunc: f64::INFINITY,
            arithmetic: Arithmetic::Pcl,
        }
    }
}

impl DepthParams {
    /// Checks `depth_scale` (finite, > 0) and `depth_trunc` (> 0, may be infinite).
    pub fn validate(&self) -> Result<(), RgbdError> {
        if !(self.depth_scale.is_finite() && self.depth_scale > 0.0) {
            return Err(bad(
                "depth_scale",
                format!("must be a finite number > 0, got {}", self.depth_scale),
            ));
        }
        if self.depth_trunc.is_nan() || self.depth_trunc <= 0.0 {
            return Err(bad(
                "depth_trunc",
                format!("must be > 0 (or infinite), got {}", self.depth_trunc),
            ));
        }
        Ok(())
    }
}

/// Intrinsics plus depth conversion: everything needed to turn a depth image into points.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraModel {
    /// The pinhole camera.
    pub intrinsics: PinholeIntrinsics,
    /// Depth units and truncation.
    pub params: DepthParams,
}

fn bad(field: &str, problem: String) -> RgbdError {
    RgbdError::BadIntrinsics {
        field: field.to_string(),
        problem,
    }
}

/// Reads a camera model from `.json` (Open3D) or `.xml` (PCL grabber) by extension.
/// Refuses a file that gives a lens other than the pinhole (distortion, a ray table),
/// which a caller of this pinhole-only reader would silently drop: use
/// [`read_camera_file`].
pub fn read_camera_model(path: impl AsRef<Path>) -> Result<CameraModel, IoError> {
    let path = path.as_ref();
    let (model, lens) = read_camera_file(path)?;
    if lens != Lens::Pinhole {
        return Err(IoError::Rgbd {
            path: path.to_path_buf(),
            source: bad(
                "distortion_model/rays",
                "gives a lens this reader cannot apply (a pinhole-only caller)".into(),
            ),
        });
    }
    Ok(model)
}

/// Reads a camera file: [`read_camera_model`]'s model and the lens in front of it (JSON:
/// [`parse_lens_keys`]; XML: the pinhole). A ray table is read from its `.npy`, relative
/// to the camera file's folder, and must be the intrinsics' height x width x 2.
pub fn read_camera_file(path: impl AsRef<Path>) -> Result<(CameraModel, Lens), IoError> {
    let path = path.as_ref();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let wrap = |source| IoError::Rgbd {
        path: path.to_path_buf(),
        source,
    };
    let parse: fn(&str) -> Result<CameraModel, RgbdError> = match ext.as_deref() {
        Some("json") => parse_open3d_json,
        Some("xml") => parse_pcl_xml,
        _ => return Err(wrap(RgbdError::UnknownIntrinsicsFormat)),
    };
    let bytes = super::read_bytes(path)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        wrap(RgbdError::IntrinsicsSyntax {
            message: format!("not UTF-8 text: {e}"),
        })
    })?;
    let model = parse(text).map_err(wrap)?;
    if ext.as_deref() != Some("json") {
        return Ok((model, Lens::Pinhole));
    }
    let lens = match parse_lens_keys(text).map_err(wrap)? {
        LensKeys::Pinhole => Lens::Pinhole,
        LensKeys::Distorted(d) => Lens::Distorted(d),
        LensKeys::Rays(name) => {
            let file = path.parent().unwrap_or(Path::new(".")).join(name);
            Lens::Rays(std::sync::Arc::new(read_ray_table(
                &file,
                &model.intrinsics,
            )?))
        }
    };
    Ok((model, lens))
}

/// What an intrinsics JSON says about its lens.
#[derive(Debug, Clone, PartialEq)]
pub enum LensKeys {
    /// No lens keys, model `none`, or every coefficient 0.
    Pinhole,
    /// Brown-Conrady distortion.
    Distorted(Distortion),
    /// A ray table, as the file names it (relative to the intrinsics file's folder).
    Rays(String),
}

/// The optional lens keys of an intrinsics JSON:
///
/// - `distortion_model`: `brown_conrady` (also `plumb_bob`, OpenCV's name), or
///   `inverse_brown_conrady` (RealSense's colour streams), or `none`; default
///   `brown_conrady` when coefficients are given.
/// - `distortion_coeffs`: `[k1, k2, p1, p2, k3]` as RealSense's `coeffs` and OpenCV's `D`
///   (4 numbers: k3 = 0). All 0 is the pinhole.
/// - `rays`: a `.npy` file of `float32` height x width x 2, the normalised ray `(x/z, y/z)`
///   of every pixel (NaN where none); it replaces the pinhole's rays, the intrinsics still
///   give the image size (and a pinhole for pinhole-only consumers).
///
/// A file may give distortion or rays, not both.
pub fn parse_lens_keys(text: &str) -> Result<LensKeys, RgbdError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| RgbdError::IntrinsicsSyntax {
            message: e.to_string(),
        })?;
    let get = |k: &str| value.get(k).filter(|v| !v.is_null());
    let model = match get("distortion_model") {
        None => None,
        Some(v) => Some(
            v.as_str()
                .ok_or_else(|| bad("distortion_model", format!("must be a string, got {v}")))?,
        ),
    };
    let coeffs = match get("distortion_coeffs") {
        None => None,
        Some(v) => Some(coefficients(v)?),
    };
    let distortion = match (model, coeffs) {
        (None, None) => None,
        (Some(m), None) => match DistortionModel::parse(m)? {
            None => None,
            Some(_) => return Err(bad("distortion_coeffs", "is missing".into())),
        },
        (m, Some(c)) => match DistortionModel::parse(m.unwrap_or("brown_conrady"))? {
            None if c.iter().any(|&k| k != 0.0) => {
                return Err(bad(
                    "distortion_coeffs",
                    "are not all 0 but the model is none".into(),
                ))
            }
            None => None,
            // All zeros is the pinhole: its bit-identical path, not Newton's.
            Some(_) if c.iter().all(|&k| k == 0.0) => None,
            Some(model) => Some(Distortion::new(model, c)?),
        },
    };
    let rays = match get("rays") {
        None => None,
        Some(v) => Some(
            v.as_str()
                .filter(|s| !s.is_empty())
                .ok_or_else(|| bad("rays", format!("must be a file name, got {v}")))?
                .to_string(),
        ),
    };
    match (distortion, rays) {
        (Some(_), Some(_)) => Err(bad(
            "rays",
            "and a distortion are both given (a ray table already holds the distortion)".into(),
        )),
        (Some(d), None) => Ok(LensKeys::Distorted(d)),
        (None, Some(r)) => Ok(LensKeys::Rays(r)),
        (None, None) => Ok(LensKeys::Pinhole),
    }
}

/// `[k1, k2, p1, p2, k3]` from 4 or 5 finite numbers.
fn coefficients(v: &serde_json::Value) -> Result<[f64; 5], RgbdError> {
    let field = "distortion_coeffs";
    let a = v
        .as_array()
        .filter(|a| a.len() == 4 || a.len() == 5)
        .ok_or_else(|| {
            bad(
                field,
                format!("must be 4 or 5 numbers (k1, k2, p1, p2, k3), got {v}"),
            )
        })?;
    let mut c = [0.0; 5];
    for (i, x) in a.iter().enumerate() {
        c[i] = x.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            bad(
                &format!("{field}[{i}]"),
                format!("not a finite number: {x}"),
            )
        })?;
    }
    Ok(c)
}

/// Reads a ray table `.npy` of `intrinsics.height x intrinsics.width x 2`; errors name it.
pub fn read_ray_table(path: &Path, intrinsics: &PinholeIntrinsics) -> Result<RayTable, IoError> {
    let array = super::npy::read_npy_f32(path)?;
    let at = |source| IoError::Rgbd {
        path: path.to_path_buf(),
        source,
    };
    let (w, h) = (intrinsics.width, intrinsics.height);
    let [rows, cols, 2] = array.shape[..] else {
        return Err(at(bad(
            "rays",
            format!(
                "must be an array of height x width x 2, has shape {:?}",
                array.shape
            ),
        )));
    };
    if (cols as u64, rows as u64) != (u64::from(w), u64::from(h)) {
        let side = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        return Err(at(RgbdError::SizeMismatch {
            what: "ray table vs intrinsics",
            expected: (w, h),
            found: (side(cols), side(rows)),
        }));
    }
    let rays = array.data.chunks_exact(2).map(|r| [r[0], r[1]]).collect();
    RayTable::new(w, h, rays).map_err(|e| at(e.into()))
}

/// Parses Open3D's `PinholeCameraIntrinsic` JSON: `{"width", "height",
/// "intrinsic_matrix": [9 numbers, column-major]}`, plus an optional `"depth_scale"` (raw
/// depth units per metre, as in Open3D's RGB-D video metadata; default 1000). The other
/// depth settings are the defaults.
///
/// The matrix must be `[fx, 0, 0, s, fy, 0, cx, cy, 1]` with skew `s = 0` (we have no
/// skew term, so a non-zero one is an error rather than silently ignored as in Open3D).
pub fn parse_open3d_json(text: &str) -> Result<CameraModel, RgbdError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| RgbdError::IntrinsicsSyntax {
            message: e.to_string(),
        })?;
    let obj = value
        .as_object()
        .ok_or_else(|| bad("(root)", "expected a JSON object".into()))?;
    let side = |name: &str| -> Result<u32, RgbdError> {
        let v = obj
            .get(name)
            .ok_or_else(|| bad(name, "is missing".into()))?;
        let n = v
            .as_u64()
            .ok_or_else(|| bad(name, format!("must be a positive integer, got {v}")))?;
        if n == 0 || n > u64::from(MAX_IMAGE_SIDE) {
            return Err(bad(
                name,
                format!("must be in 1..={MAX_IMAGE_SIDE}, got {n}"),
            ));
        }
        Ok(n as u32)
    };
    let width = side("width")?;
    let height = side("height")?;
    let m = obj
        .get("intrinsic_matrix")
        .ok_or_else(|| bad("intrinsic_matrix", "is missing".into()))?
        .as_array()
        .ok_or_else(|| bad("intrinsic_matrix", "must be an array of 9 numbers".into()))?;
    if m.len() != 9 {
        return Err(bad(
            "intrinsic_matrix",
            format!("must have 9 numbers, has {}", m.len()),
        ));
    }
    let mut k = [0.0f64; 9];
    for (i, v) in m.iter().enumerate() {
        k[i] = v.as_f64().ok_or_else(|| {
            bad(
                &format!("intrinsic_matrix[{i}]"),
                format!("not a number: {v}"),
            )
        })?;
    }
    for (i, want) in [(1, 0.0), (2, 0.0), (3, 0.0), (5, 0.0), (8, 1.0)] {
        if k[i] != want {
            return Err(bad(
                &format!("intrinsic_matrix[{i}]"),
                format!(
                    "must be {want} for a pinhole camera without skew, got {}",
                    k[i]
                ),
            ));
        }
    }
    let intrinsics = PinholeIntrinsics {
        width,
        height,
        fx: k[0],
        fy: k[4],
        cx: k[6],
        cy: k[7],
    };
    intrinsics.check_plausible()?;
    // Open3D's RGB-D video metadata (a RealSense recording's `intrinsic.json`) adds the raw
    // depth units per metre; plain `PinholeCameraIntrinsic` files have none (millimetres).
    let mut params = DepthParams::default();
    if let Some(v) = obj.get("depth_scale") {
        params.depth_scale = v
            .as_f64()
            .filter(|s| s.is_finite() && *s > 0.0)
            .ok_or_else(|| {
                bad(
                    "depth_scale",
                    format!("must be a finite number > 0 (raw units per metre), got {v}"),
                )
            })?;
    }
    Ok(CameraModel { intrinsics, params })
}

/// Parses PCL's image-grabber XML (the `<depth>` section: `focal_length_x`,
/// `focal_length_y`, `principal_point_x`, `principal_point_y`, and optionally
/// `z_multiplication_factor`, metres per raw unit, default 0.001 as in PCL).
///
/// The XML carries no image size, so `width` and `height` are 0 (taken from the image).
/// A tiny parser: elements and text only (the files PCL writes have nothing else);
/// comments and the `<?xml ...?>` declaration are skipped.
pub fn parse_pcl_xml(text: &str) -> Result<CameraModel, RgbdError> {
    let depth = xml_element(text, "depth")?
        .ok_or_else(|| bad("depth", "the <depth> section is missing".into()))?;
    let number = |name: &str| -> Result<Option<f64>, RgbdError> {
        let Some(t) = xml_element(depth, name)? else {
            return Ok(None);
        };
        let t = t.trim();
        t.parse::<f64>()
            .map(Some)
            .map_err(|_| bad(name, format!("not a number: {t:?}")))
    };
    let need = |name: &str| -> Result<f64, RgbdError> {
        number(name)?.ok_or_else(|| bad(name, "is missing from <depth>".into()))
    };
    let intrinsics = PinholeIntrinsics {
        width: 0,
        height: 0,
        fx: need("focal_length_x")?,
        fy: need("focal_length_y")?,
        cx: need("principal_point_x")?,
        cy: need("principal_point_y")?,
    };
    intrinsics.check_plausible().map_err(|e| match e {
        // Name the XML element, not our struct field.
        RgbdError::BadIntrinsics { field, problem } => bad(
            match field.as_str() {
                "fx" => "focal_length_x",
                "fy" => "focal_length_y",
                "cx" => "principal_point_x",
                "cy" => "principal_point_y",
                other => other,
            },
            problem,
        ),
        other => other,
    })?;
    let factor = number("z_multiplication_factor")?.unwrap_or(0.001);
    if !(factor.is_finite() && factor > 0.0) {
        return Err(bad(
            "z_multiplication_factor",
            format!("must be a finite number > 0, got {factor}"),
        ));
    }
    let params = DepthParams {
        depth_scale: 1.0 / factor,
        ..DepthParams::default()
    };
    params.validate().map_err(|e| match e {
        RgbdError::BadIntrinsics { problem, .. } => bad("z_multiplication_factor", problem),
        other => other,
    })?;
    Ok(CameraModel { intrinsics, params })
}

/// The text between the first `<name>` and its matching `</name>` at any depth, after
/// removing comments; `None` if there is no such element. Errors on an unclosed element.
fn xml_element<'a>(text: &'a str, name: &str) -> Result<Option<&'a str>, RgbdError> {
    let open = format!("<{name}>");
    let close = format!("</{name}>");
    let mut from = 0;
    loop {
        let Some(rel) = text[from..].find(&open) else {
            return Ok(None);
        };
        let start = from + rel;
        // Skip matches inside comments.
        if let Some(c) = text[..start].rfind("<!--") {
            if !text[c..start].contains("-->") {
                from = start + open.len();
                continue;
            }
        }
        let body = start + open.len();
        let end = text[body..]
            .find(&close)
            .ok_or_else(|| RgbdError::IntrinsicsSyntax {
                message: format!("<{name}> is never closed"),
            })?;
        return Ok(Some(&text[body..body + end]));
    }
}

//! RGB-D images to organized point clouds.
//!
//! A depth image (16-bit, single channel, PNG or TIFF) and an optional colour image
//! (8-bit RGB or RGBA, PNG, TIFF or JPEG) of the same size become an organized cloud of
//! `width x height` points in the camera frame (x right, y down, z forward, metres):
//!
//! `z = raw / depth_scale`, `x = (u − cx)·z/fx`, `y = (v − cy)·z/fy`
//!
//! for column `u` and row `v` (0-based, no half-pixel offset). A raw depth of 0 (no
//! measurement), a raw 65535 (saturated: the encoding's maximum is no measurement), or a
//! depth at or beyond `depth_trunc` (else beyond [`DEFAULT_RANGE_M`]) gives a NaN point,
//! never (0,0,0); the organized shape is kept. A frame whose every pixel is saturated or
//! out of range is refused ([`RgbdError::NoUsableDepth`]) rather than read as empty.
//! Every pixel keeps its colour, valid or not, as PCL does.
//! The floating-point order follows [`Arithmetic`]: by default PCL's, which reproduces the
//! organized PCD PCL's grabber writes for the same frames bit for bit.
//!
//! For RGBA colour images the R, G and B channels are used and alpha is dropped. (Open3D
//! 0.20 takes channels 0, 1 and 3, so its blue becomes the alpha; we do not copy that.)
//!
//! Principal entry points: [`read_frame`] (files) and [`depth_to_cloud`] (pixels); through
//! a lens that is not the pinhole (distortion, a ray table: [`crate::camera::Lens`]),
//! [`read_frame_through`] and [`depth_to_cloud_through`].
//!
//! ```
//! use softsense::io::intrinsics::{DepthParams, PinholeIntrinsics};
//! use softsense::io::rgbd::depth_to_cloud;
//! let intrinsics = PinholeIntrinsics { width: 2, height: 1, fx: 500.0, fy: 500.0, cx: 0.0, cy: 0.0 };
//! let cloud = depth_to_cloud(&[0, 1000], None, &intrinsics, &DepthParams::default())?;
//! assert!(cloud.positions[0][2].is_nan()); // no depth: NaN, not (0,0,0)
//! assert_eq!(cloud.positions[1], [0.002, 0.0, 1.0]);
//! assert_eq!((cloud.width, cloud.height), (2, 1));
//! # Ok::<(), softsense::io::rgbd::RgbdError>(())
//! ```

use super::intrinsics::{Arithmetic, CameraModel, DepthParams, PinholeIntrinsics, MAX_IMAGE_SIDE};
use super::IoError;
use crate::camera::Lens;
use crate::cloud::PointCloud;
use image::{ColorType, DynamicImage, ImageDecoder, ImageReader};
use std::path::Path;

pub use super::rgbd_error::RgbdError;

/// The most decoded bytes per file byte we believe a PNG, TIFF or JPEG can hold (a flat
/// JPEG block of 192 bytes costs about 2 bits: under 1000:1).
const MAX_EXPANSION: u64 = 4096;

/// Memory a depth pixel costs from file to written cloud: the decoded 16-bit value, the
/// cloud's `f32` position and that position again as encoded for writing.
const DEPTH_BYTES_PER_PIXEL: u64 = 2 + 12 + 12;

/// Memory a colour pixel costs: decoded RGBA (the widest we accept), the RGB copy and
/// the cloud's colour.
const COLOR_BYTES_PER_PIXEL: u64 = 4 + 3 + 3;

/// A decoded 16-bit depth image, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthImage {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Raw depth values, `width * height`, row-major; 0 means no measurement.
    pub data: Vec<u16>,
}

/// A decoded 8-bit colour image, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct ColorImage {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// RGB pixels, `width * height`, row-major.
    pub data: Vec<[u8; 3]>,
}

fn describe(c: ColorType) -> String {
    let s = match c {
        ColorType::L8 => "8-bit grey",
        ColorType::La8 => "8-bit grey+alpha",
        ColorType::Rgb8 => "8-bit RGB",
        ColorType::Rgba8 => "8-bit RGBA",
        ColorType::L16 => "16-bit grey",
        ColorType::La16 => "16-bit grey+alpha",
        ColorType::Rgb16 => "16-bit RGB",
        ColorType::Rgba16 => "16-bit RGBA",
        ColorType::Rgb32F => "32-bit float RGB",
        ColorType::Rgba32F => "32-bit float RGBA",
        other => return format!("{other:?}"),
    };
    s.to_string()
}

/// Opens an image and checks its pixel type with `accept` before decoding any pixels,
/// so that a wrong type is reported (as `wrong(description)`) without allocating the image.
fn decode_checked(
    path: &Path,
    bytes_per_pixel: u64,
    accept: impl Fn(ColorType) -> bool,
    wrong: impl Fn(String) -> RgbdError,
) -> Result<DynamicImage, IoError> {
    let rgbd = |source| IoError::Rgbd {
        path: path.to_path_buf(),
        source,
    };
    let os = |source| IoError::Os {
        path: path.to_path_buf(),
        source,
    };
    let image_err = |e: image::ImageError| {
        rgbd(match e {
            // E.g. a 32-bit float grey TIFF: the decoder refuses its pixel type before we
            // can see it, reporting "Unknown(bits per pixel)".
            image::ImageError::Unsupported(u) => match u.kind() {
                image::error::UnsupportedErrorKind::Color(c) => {
                    wrong(format!("a pixel type the decoder cannot read ({c:?})"))
                }
                _ => RgbdError::Image {
                    message: u.to_string(),
                },
            },
            other => RgbdError::Image {
                message: other.to_string(),
            },
        })
    };
    let file = std::fs::File::open(path).map_err(os)?;
    let file_len = file.metadata().map_err(os)?.len();
    let mut reader = ImageReader::new(std::io::BufReader::new(file))
        .with_guessed_format()
        .map_err(os)?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    // The decoder's own guard, in case a format allocates more than its pixels.
    limits.max_alloc = Some(super::limits::max_bytes());
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(image_err)?;
    // Refused before decoding: a small file can declare gigabytes of pixels.
    let (width, height) = decoder.dimensions();
    super::limits::check(
        "pixels",
        u64::from(width) * u64::from(height),
        bytes_per_pixel,
    )
    .map_err(|source| IoError::TooLarge {
        path: path.to_path_buf(),
        source,
    })?;
    // No allocation beyond what the file can justify: no PNG/TIFF codec expands data by
    // more than MAX_EXPANSION (LZW's worst case is about 2730:1, deflate's 1032:1).
    let needed = decoder.total_bytes();
    if needed > file_len.saturating_mul(MAX_EXPANSION) + (1 << 20) {
        return Err(rgbd(RgbdError::ImplausibleSize {
            width,
            height,
            file_len,
        }));
    }
    let color_type = decoder.color_type();
    if !accept(color_type) {
        return Err(rgbd(wrong(describe(color_type))));
    }
    DynamicImage::from_decoder(decoder).map_err(image_err)
}

/// Reads a 16-bit single-channel depth image (PNG or TIFF).
pub fn read_depth_image(path: impl AsRef<Path>) -> Result<DepthImage, IoError> {
    let path = path.as_ref();
    let wrong = |found| RgbdError::UnsupportedDepthType { found };
    let img = decode_checked(path, DEPTH_BYTES_PER_PIXEL, |c| c == ColorType::L16, wrong)?;
    let (width, height) = (img.width(), img.height());
    match img {
        DynamicImage::ImageLuma16(buf) => Ok(DepthImage {
            width,
            height,
            data: buf.into_raw(),
        }),
        other => Err(IoError::Rgbd {
            path: path.to_path_buf(),
            source: wrong(describe(other.color())),
        }),
    }
}

/// Reads an 8-bit RGB or RGBA colour image (PNG, TIFF or JPEG); RGBA keeps R, G, B.
pub fn read_color_image(path: impl AsRef<Path>) -> Result<ColorImage, IoError> {
    let path = path.as_ref();
    let wrong = |found| RgbdError::UnsupportedColorType { found };
    let accept = |c| matches!(c, ColorType::Rgb8 | ColorType::Rgba8);
    let img = decode_checked(path, COLOR_BYTES_PER_PIXEL, accept, wrong)?;
    let (width, height) = (img.width(), img.height());
    let data = match img {
        DynamicImage::ImageRgb8(buf) => buf.pixels().map(|p| p.0).collect(),
        // R, G, B; not Open3D's channels 0, 1, 3 (alpha for blue).
        DynamicImage::ImageRgba8(buf) => buf.pixels().map(|p| [p[0], p[1], p[2]]).collect(),
        other => {
            return Err(IoError::Rgbd {
                path: path.to_path_buf(),
                source: wrong(describe(other.color())),
            })
        }
    };
    Ok(ColorImage {
        width,
        height,
        data,
    })
}

/// The sensor range when `depth_trunc` is infinite: no depth camera we read measures
/// past 20 m, and a raw value that far (20000 mm) is a fault, not a point.
pub const DEFAULT_RANGE_M: f64 = 20.0;

/// Back-projects a row-major depth image of `intrinsics.width x intrinsics.height` raw
/// values into an organized cloud, with colours if given (same size, row-major).
///
/// Errors if the intrinsics or params are invalid, the intrinsics have no size, or a
/// buffer's length is not `width * height`.
pub fn depth_to_cloud(
    depth: &[u16],
    color: Option<&[[u8; 3]]>,
    intrinsics: &PinholeIntrinsics,
    params: &DepthParams,
) -> Result<PointCloud, RgbdError> {
    depth_to_cloud_through(depth, color, intrinsics, params, &Lens::Pinhole)
}

/// [`depth_to_cloud`] through `lens`: the pinhole as there, else each pixel's ray from
/// [`Lens::ray`] in `f64`, `z = raw / depth_scale`, the point `(x/z·z, y/z·z, z)` rounded
/// to `f32` ([`Arithmetic`] only orders the pinhole's). A pixel without a ray (NaN in a
/// ray table) gives a NaN point. Errors also if a ray table is not the image's size.
pub fn depth_to_cloud_through(
    depth: &[u16],
    color: Option<&[[u8; 3]]>,
    intrinsics: &PinholeIntrinsics,
    params: &DepthParams,
    lens: &Lens,
) -> Result<PointCloud, RgbdError> {
    intrinsics.validate()?;
    params.validate()?;
    let (w, h) = (intrinsics.width, intrinsics.height);
    let n = w as usize * h as usize;
    let as_size = |len: usize| (u32::try_from(len).unwrap_or(u32::MAX), 1);
    if n == 0 || depth.len() != n {
        return Err(RgbdError::SizeMismatch {
            what: "depth buffer vs intrinsics width x height",
            expected: (w, h),
            found: as_size(depth.len()),
        });
    }
    if let Some(c) = color {
        if c.len() != n {
            return Err(RgbdError::SizeMismatch {
                what: "colour buffer vs intrinsics width x height",
                expected: (w, h),
                found: as_size(c.len()),
            });
        }
    }
    let nan = [f32::NAN; 3];
    let trunc = params.depth_trunc;
    // Without a truncation, depths past a depth camera's reach are noise, not points.
    let range = if trunc.is_finite() {
        trunc
    } else {
        DEFAULT_RANGE_M
    };
    let (mut saturated, mut beyond_range, mut zero) = (0usize, 0usize, 0usize);
    let mut dropped = |raw: u16, z: f64| {
        if raw == u16::MAX {
            saturated += 1;
        } else if z <= 0.0 {
            zero += 1;
        } else if z >= range {
            beyond_range += 1;
        } else {
            return false;
        }
        true
    };
    let mut positions = Vec::with_capacity(n);
    match (lens, params.arithmetic) {
        (Lens::Distorted(_) | Lens::Rays(_), _) => lens_positions(
            depth,
            intrinsics,
            params,
            lens,
            &mut dropped,
            &mut positions,
        )?,
        (Lens::Pinhole, Arithmetic::Pcl) => {
            // PCL (OpenNI grabber, image grabber): everything in f32, reciprocal focal
            // lengths, and the product taken as ((u - cx) * z) * (1/fx).
            let factor = (1.0 / params.depth_scale) as f32;
            let (kx, ky) = (1.0f32 / intrinsics.fx as f32, 1.0f32 / intrinsics.fy as f32);
            let (cx, cy) = (intrinsics.cx as f32, intrinsics.cy as f32);
            for (v, row) in depth.chunks_exact(w as usize).enumerate() {
                let dv = v as f32 - cy;
                for (u, &raw) in row.iter().enumerate() {
                    let z = f32::from(raw) * factor;
                    // z == 0: no measurement (raw 0), or a scale so large the product
                    // underflows; either way never a point at the origin.
                    positions.push(if dropped(raw, f64::from(z)) {
                        nan
                    } else {
                        [(u as f32 - cx) * z * kx, dv * z * ky, z]
                    });
                }
            }
        }
        (Lens::Pinhole, Arithmetic::Open3d) => {
            // Open3D: depth in f32 (raw / scale), back-projection in f64.
            let scale = params.depth_scale as f32;
            for (v, row) in depth.chunks_exact(w as usize).enumerate() {
                let dv = v as f64 - intrinsics.cy;
                for (u, &raw) in row.iter().enumerate() {
                    let z32 = f32::from(raw) / scale;
                    let z = f64::from(z32);
                    positions.push(if dropped(raw, z) {
                        nan
                    } else {
                        [
                            ((u as f64 - intrinsics.cx) * z / intrinsics.fx) as f32,
                            (dv * z / intrinsics.fy) as f32,
                            z32,
                        ]
                    });
                }
            }
        }
    }
    if saturated + beyond_range > 0 && saturated + beyond_range + zero == n {
        return Err(RgbdError::NoUsableDepth {
            saturated,
            beyond_range,
            range_m: range,
            pixels: n,
        });
    }
    Ok(PointCloud {
        positions,
        colors: color.map(<[[u8; 3]]>::to_vec),
        width: w,
        height: h,
        ..Default::default()
    })
}

/// The points of `depth` through a lens that is not the pinhole (see
/// [`depth_to_cloud_through`]); `dropped` says which raw values are no point.
fn lens_positions(
    depth: &[u16],
    intrinsics: &PinholeIntrinsics,
    params: &DepthParams,
    lens: &Lens,
    dropped: &mut impl FnMut(u16, f64) -> bool,
    positions: &mut Vec<[f32; 3]>,
) -> Result<(), RgbdError> {
    let (w, h) = (intrinsics.width, intrinsics.height);
    if let Lens::Rays(table) = lens {
        if (table.width(), table.height()) != (w, h) {
            return Err(RgbdError::SizeMismatch {
                what: "ray table vs intrinsics",
                expected: (w, h),
                found: (table.width(), table.height()),
            });
        }
    }
    for (v, row) in depth.chunks_exact(w as usize).enumerate() {
        for (u, &raw) in row.iter().enumerate() {
            let z = f64::from(raw) / params.depth_scale;
            let ray = match lens {
                // The stored ray itself, not an interpolation that could round it.
                Lens::Rays(t) => t.at(u as u32, v as u32).map(|r| r.map(f64::from)),
                _ => lens.ray(intrinsics, u as f64, v as f64),
            };
            let point = match ray.filter(|r| r[0].is_finite() && r[1].is_finite()) {
                _ if dropped(raw, z) => [f32::NAN; 3],
                Some([x, y]) => [(x * z) as f32, (y * z) as f32, z as f32],
                None => [f32::NAN; 3],
            };
            positions.push(point);
        }
    }
    Ok(())
}

/// Reads a depth image, an optional colour image and converts them with `camera`.
///
/// Sizes must agree: colour with depth, and both with the intrinsics unless the
/// intrinsics have no size (PCL's XML), in which case the depth image's size is used.
/// Errors name the file at fault.
pub fn read_frame(
    depth_path: impl AsRef<Path>,
    color_path: Option<&Path>,
    camera: &CameraModel,
) -> Result<PointCloud, IoError> {
    read_frame_through(depth_path, color_path, camera, &Lens::Pinhole)
}

/// [`read_frame`] through `lens` (from [`read_camera_file`](super::intrinsics::read_camera_file)).
pub fn read_frame_through(
    depth_path: impl AsRef<Path>,
    color_path: Option<&Path>,
    camera: &CameraModel,
    lens: &Lens,
) -> Result<PointCloud, IoError> {
    let depth_path = depth_path.as_ref();
    let at = |path: &Path, source| IoError::Rgbd {
        path: path.to_path_buf(),
        source,
    };
    let depth = read_depth_image(depth_path)?;
    let mut intrinsics = camera.intrinsics;
    if intrinsics.width == 0 && intrinsics.height == 0 {
        intrinsics.width = depth.width;
        intrinsics.height = depth.height;
    } else if (intrinsics.width, intrinsics.height) != (depth.width, depth.height) {
        return Err(at(
            depth_path,
            RgbdError::SizeMismatch {
                what: "depth image vs intrinsics",
                expected: (intrinsics.width, intrinsics.height),
                found: (depth.width, depth.height),
            },
        ));
    }
    let color = match color_path {
        Some(p) => {
            let c = read_color_image(p)?;
            if (c.width, c.height) != (depth.width, depth.height) {
                return Err(at(
                    p,
                    RgbdError::SizeMismatch {
                        what: "colour image vs depth image",
                        expected: (depth.width, depth.height),
                        found: (c.width, c.height),
                    },
                ));
            }
            Some(c.data)
        }
        None => None,
    };
    depth_to_cloud_through(
        &depth.data,
        color.as_deref(),
        &intrinsics,
        &camera.params,
        lens,
    )
    .map_err(|e| at(depth_path, e))
}

//! The error of RGB-D frames and of their intrinsics, below both [`super::rgbd`] and
//! [`super::intrinsics`] so that neither imports the other for it.

use thiserror::Error;

/// What is wrong with an RGB-D frame or its intrinsics.
#[derive(Debug, Error, PartialEq)]
pub enum RgbdError {
    /// An intrinsics or depth-conversion field is missing or has a bad value.
    #[error("bad intrinsics: `{field}` {problem}")]
    BadIntrinsics {
        /// The field (as named in the file, e.g. `focal_length_x`, `intrinsic_matrix[3]`).
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The intrinsics file is not well-formed JSON or XML.
    #[error("intrinsics file is malformed: {message}")]
    IntrinsicsSyntax {
        /// The parser's message.
        message: String,
    },
    /// The intrinsics file extension is neither `.json` nor `.xml`.
    #[error(
        "unknown intrinsics format (expected .json, Open3D's PinholeCameraIntrinsic, or .xml, PCL's grabber XML)"
    )]
    UnknownIntrinsicsFormat,
    /// The image could not be decoded (corrupt, truncated, unknown format).
    #[error("cannot decode image: {message}")]
    Image {
        /// The decoder's message.
        message: String,
    },
    /// The image declares more pixels than its file size can hold (hostile or corrupt
    /// header); refused before allocating.
    #[error("image declares {width}x{height} pixels, more than a {file_len}-byte file can hold")]
    ImplausibleSize {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// The file's size in bytes.
        file_len: u64,
    },
    /// The depth image is not 16-bit single-channel.
    #[error("depth image must be 16-bit single-channel (grey), found {found}")]
    UnsupportedDepthType {
        /// What the file holds, e.g. `8-bit grey` or `8-bit RGB`.
        found: String,
    },
    /// The colour image is not 8-bit RGB or RGBA.
    #[error("colour image must be 8-bit RGB or RGBA, found {found}")]
    UnsupportedColorType {
        /// What the file holds.
        found: String,
    },
    /// Two sizes that must agree do not (depth vs colour, image vs intrinsics).
    #[error("{what}: expected {expected:?} (width, height), found {found:?}")]
    SizeMismatch {
        /// Which two things disagree.
        what: &'static str,
        /// The size required.
        expected: (u32, u32),
        /// The size found.
        found: (u32, u32),
    },
    /// Every pixel of a depth image is saturated (the encoding's maximum, 65535) or
    /// beyond the sensor range, so the frame has no point at all.
    #[error(
        "no pixel gives a valid point: of {pixels}, {saturated} are saturated (65535), \
         {beyond_range} at or beyond {range_m} m and the rest 0 (no measurement)"
    )]
    NoUsableDepth {
        /// Pixels at 65535.
        saturated: usize,
        /// Pixels beyond the range.
        beyond_range: usize,
        /// The range in metres (`depth_trunc`, else the default sensor range).
        range_m: f64,
        /// Pixels in the image.
        pixels: usize,
    },
    /// The lens of an intrinsics file (distortion, ray table) cannot be built.
    #[error("bad lens: {0}")]
    Lens(#[from] crate::camera::LensError),
}

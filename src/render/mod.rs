//! Pictures a person can read: an RGB raster for `sense --render` and `explain` reports,
//! charts laid out by `plotters`, text rasterised by `ab_glyph`.
//!
//! - [`Canvas`]: an RGB8 image with anti-aliased lines, arrows, circles, discs, boxes and
//!   text (Hack through ab_glyph, [`text_size`], [`has_glyph`]), and the [`TextBox`] of
//!   every text drawn, so pictures are checked for overlapping labels; PNG in and out.
//! - [`ColorMap`]: a sequential (viridis-like) and a diverging (blue-white-red) map, with
//!   [`colorbar`] and [`format_value`] for labels.
//! - [`project`], [`Pose`]: the pinhole model and rigid camera poses, those of
//!   [`crate::camera::Camera`] and [`crate::camera::PinholeIntrinsics`].
//! - [`surface_map`]: a z-buffered, flat-shaded rendering of a triangle surface with a
//!   scalar per vertex or per triangle (e.g. residuals), with a colour bar and title.
//! - [`bar_chart`] and [`line_chart`]: charts laid out by plotters and drawn on a
//!   [`Canvas`] through its backend trait; [`legend`]: legend boxes.
//! - [`sense_overlay`]: the robot segment, feature points, contacts and force arrows over
//!   a colour frame, with an arrow length scale and labels placed by [`LabelPlacer`] so
//!   that none overlaps another; [`side_by_side`] puts before/after panels together.
//! - [`control`]: the pictures of a `control` run.
//! - [`discrepancy`]: the pictures of an `explain` report.
//! - [`markers::marker_picture`]: one frame of `softsense markers --render` (markers, their
//!   displacements, candidates and located forces, top and side views).
//! - [`model::model_picture`]: `softsense model check --picture` (a model's body from the
//!   top, front and side, with its fixed nodes, cables, cavities and points).
//! - [`scene3d`]: a sensed frame in 3-D as plain data (points, FE surface, features,
//!   forces with their uncertainty, cameras, status), and `rrd` (feature `rerun`) that
//!   writes it as a rerun recording (`softsense sense --rerun`).
//!
//! Pixel centres are at integer coordinates, as in the pinhole model. Drawing never panics:
//! shapes are clipped to the canvas, and NaN or infinite coordinates draw nothing.
//!
//! ```
//! use softsense::render::{bar_chart, Canvas, ColorMap, BLACK, WHITE};
//! let mut canvas = Canvas::new(120, 80, WHITE)?;
//! canvas.line([10.0, 10.0], [100.0, 60.0], BLACK, 2.0);
//! canvas.arrow([10.0, 70.0], [60.0, 70.0], ColorMap::Diverging.at(1.0), 2.0);
//! canvas.text(10, 20, "0.66 N", BLACK, 1);
//! assert_eq!(canvas.get(10, 10), Some(BLACK));
//! let chart = bar_chart("BIC", &["none", "young"], &[3.0, -1.5], Some(1), 300, 120)?;
//! assert_eq!((chart.width(), chart.height()), (300, 120));
//! # Ok::<(), softsense::render::RenderError>(())
//! ```

// `!(x > 0.0)` is the NaN-rejecting test, used on purpose throughout.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod canvas;
pub mod catheter;
mod chart;
mod colormap;
pub mod control;
pub mod discrepancy;
mod font;
pub mod markers;
pub mod model;
mod overlay;
mod plot;
mod project;
#[cfg(feature = "rerun")]
pub mod rrd;
pub mod scene3d;
mod sense_frame;
mod surface;

pub use canvas::{Canvas, Rgb, TextBox, BLACK, GREY, MAX_PIXELS, MAX_SIDE, WHITE};
pub use chart::{legend, legend_size, Swatch, BAR, BAR_HIGHLIGHT};
pub use colormap::{colorbar, finite_range, format_value, symmetric_range, ColorMap};
pub use font::{has_glyph, text_size, BASE_PX};
pub use overlay::{
    mask_from_indices, sense_overlay, side_by_side, ContactMark, FeatureMark, ForceArrow,
    LabelPlacer, OverlayParams, SenseOverlay, CONTACT, FEATURE_HIDDEN, FEATURE_VISIBLE, FORCE,
    MATCH_LINE, ROBOT_TINT,
};
pub use plot::{bar_chart, line_chart, Series};
pub use project::{camera_from_robot, project, project_with, Pose, NEAR_Z, RIGID_TOLERANCE};
pub use sense_frame::frame_picture;
pub use surface::{
    surface_map, SurfaceMapParams, SurfaceMesh, SurfaceValues, COLORBAR_PANEL, TITLE_BAND,
};

/// Errors of the render module.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A catheter run's path could not be rebuilt.
    #[error(transparent)]
    Catheter(#[from] crate::catheter::CatheterError),
    /// An output file could not be written (it names the file).
    #[error(transparent)]
    Write(#[from] crate::io::atomic::AtomicError),
    /// A canvas would exceed [`MAX_SIDE`] per side or [`MAX_PIXELS`] in all.
    #[error("a {width}x{height} picture is larger than allowed ({MAX_SIDE} per side, {MAX_PIXELS} pixels)")]
    TooLarge {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// An input slice has the wrong length.
    #[error("{what}: expected {expected} entries, got {got}")]
    Length {
        /// What the slice holds.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Given length.
        got: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} uses vertex {index}, but there are {vertices} vertices")]
    TriangleIndex {
        /// Triangle index.
        triangle: usize,
        /// The bad vertex index.
        index: usize,
        /// Number of vertices.
        vertices: usize,
    },
    /// A 4x4 matrix is not a rigid transform.
    #[error("not a rigid transform: {reason}")]
    NotRigid {
        /// What is wrong.
        reason: String,
    },
    /// plotters could not lay out or draw a chart.
    #[error("chart: {0}")]
    Plot(String),
    /// Reading or writing an image file failed.
    #[error("image {path}: {message}")]
    Image {
        /// The file.
        path: String,
        /// The underlying error.
        message: String,
    },
}

impl From<crate::math::pose::PoseError> for RenderError {
    fn from(e: crate::math::pose::PoseError) -> Self {
        match e {
            crate::math::pose::PoseError::NotRigid { reason } => RenderError::NotRigid { reason },
        }
    }
}

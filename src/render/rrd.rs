//! Rerun recordings (`.rrd`) of sensed frames: [`super::scene3d`]'s entities, each frame on
//! the `frame` timeline, for the rerun viewer (`rerun OUT.rrd`). Behind the `rerun`
//! feature.

use super::scene3d::{Entity, Level, Shape};
use rerun::components::FillMode;
use rerun::{archetypes as arch, RecordingStream, RecordingStreamBuilder, TimelineName};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The timeline every frame's entities are logged on.
pub const TIMELINE: &str = "frame";

/// Errors of writing or reading an `.rrd`.
#[derive(Debug, thiserror::Error)]
pub enum RrdError {
    /// The file could not be created, written or flushed.
    #[error("{path}: cannot write the rerun recording: {message}")]
    Write {
        /// The `.rrd` file.
        path: PathBuf,
        /// What rerun said.
        message: String,
    },
    /// The file could not be read back.
    #[error("{path}: not a readable rerun recording: {message}")]
    Read {
        /// The `.rrd` file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// An `.rrd` file being written.
pub struct RrdWriter {
    stream: RecordingStream,
    path: PathBuf,
}

impl RrdWriter {
    /// Creates `path` (replacing it) for a recording named `application` in the viewer.
    pub fn create(path: &Path, application: &'static str) -> Result<Self, RrdError> {
        let stream = RecordingStreamBuilder::new(application)
            .save(path)
            .map_err(|e| write_error(path, e))?;
        Ok(RrdWriter {
            stream,
            path: path.to_path_buf(),
        })
    }

    /// Logs `entities` at `frame` on [`TIMELINE`], or as static data (for every frame)
    /// when `frame` is None.
    pub fn log(&self, frame: Option<usize>, entities: &[Entity]) -> Result<(), RrdError> {
        if let Some(f) = frame {
            self.stream.set_time_sequence(TIMELINE, f as i64);
        }
        for e in entities {
            self.send(&e.path, &e.shape, frame.is_none())
                .map_err(|err| write_error(&self.path, err))?;
        }
        Ok(())
    }

    /// Writes everything out; the file is complete when this returns.
    pub fn finish(self) -> Result<(), RrdError> {
        self.stream
            .flush_blocking()
            .map_err(|e| write_error(&self.path, e))
    }

    fn send(&self, path: &str, shape: &Shape, is_static: bool) -> rerun::RecordingStreamResult<()> {
        macro_rules! put {
            ($a:expr) => {
                match is_static {
                    true => self.stream.log_static(path, &$a),
                    false => self.stream.log(path, &$a),
                }
            };
        }
        match shape {
            Shape::ZUp => put!(arch::ViewCoordinates::RIGHT_HAND_Z_UP()),
            Shape::Transform {
                translation,
                rotation_columns,
            } => put!(arch::Transform3D::from_translation_mat3x3(
                *translation,
                *rotation_columns
            )),
            Shape::Pinhole {
                focal,
                principal,
                resolution,
                plane_distance,
            } => put!(arch::Pinhole::from_focal_length_and_resolution(
                *focal,
                resolution.map(|r| r as f32)
            )
            .with_principal_point(*principal)
            .with_image_plane_distance(*plane_distance)),
            Shape::Image { width, height, rgb } => {
                put!(arch::Image::from_rgb24(rgb.clone(), [*width, *height]))
            }
            Shape::Points {
                positions,
                colors,
                radius,
                labels,
            } => {
                let mut a = arch::Points3D::new(positions.iter().copied())
                    .with_colors(colors.iter().copied())
                    .with_radii([*radius]);
                if !labels.is_empty() {
                    a = a.with_labels(labels.iter().map(String::as_str));
                }
                put!(a)
            }
            Shape::Lines {
                strips,
                color,
                radius,
            } => put!(arch::LineStrips3D::new(strips.iter().cloned())
                .with_colors([*color])
                .with_radii([*radius])),
            Shape::Mesh {
                vertices,
                normals,
                triangles,
                color,
            } => put!(arch::Mesh3D::new(vertices.iter().copied())
                .with_vertex_normals(normals.iter().copied())
                .with_triangle_indices(triangles.iter().copied())
                .with_albedo_factor(*color)),
            Shape::Arrows {
                origins,
                vectors,
                color,
                labels,
            } => put!(arch::Arrows3D::from_vectors(vectors.iter().copied())
                .with_origins(origins.iter().copied())
                .with_colors([*color])
                .with_labels(labels.iter().map(String::as_str))),
            Shape::Ellipsoids {
                centers,
                half_sizes,
                quaternions,
                color,
            } => put!(arch::Ellipsoids3D::from_centers_and_half_sizes(
                centers.iter().copied(),
                half_sizes.iter().copied()
            )
            .with_quaternions(quaternions.iter().map(|q| rerun::Quaternion::from_xyzw(*q)))
            .with_colors([*color])
            .with_fill_mode(FillMode::MajorWireframe)),
            Shape::Text { level, text } => {
                put!(arch::TextLog::new(text.as_str()).with_level(match level {
                    Level::Info => rerun::TextLogLevel::INFO,
                    Level::Warn => rerun::TextLogLevel::WARN,
                    Level::Error => rerun::TextLogLevel::ERROR,
                }))
            }
            Shape::Scalar { value } => put!(arch::Scalars::single(*value)),
            Shape::Clear => put!(arch::Clear::flat()),
        }
    }
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> RrdError {
    RrdError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Reads `path` back: the entity paths with data at each frame of [`TIMELINE`] (key
/// `Some(frame)`), and the static ones (key None). Rerun's own bookkeeping entities
/// (`/__properties`, ...) are left out; paths are given without the leading slash.
pub fn entities_per_frame(
    path: &Path,
) -> Result<BTreeMap<Option<i64>, BTreeSet<String>>, RrdError> {
    use rerun::external::re_log_types::LogMsg;
    use rerun::log::Chunk;
    let read_error = |e: &dyn std::fmt::Display| RrdError::Read {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let file = std::fs::File::open(path).map_err(|e| read_error(&e))?;
    let messages = re_log_encoding::DecoderApp::decode_eager(std::io::BufReader::new(file))
        .map_err(|e| read_error(&e))?;
    let timeline = TimelineName::from_static_str(TIMELINE);
    let mut out: BTreeMap<Option<i64>, BTreeSet<String>> = BTreeMap::new();
    for msg in messages {
        let LogMsg::ArrowMsg(_, arrow) = msg.map_err(|e| read_error(&e))? else {
            continue;
        };
        let chunk = Chunk::from_arrow_msg(&arrow).map_err(|e| read_error(&e))?;
        let entity = chunk.entity_path().to_string();
        let entity = entity.trim_start_matches('/');
        if entity.starts_with("__") {
            continue;
        }
        if chunk.is_static() {
            out.entry(None).or_default().insert(entity.to_string());
        } else if let Some(times) = chunk.timelines().get(&timeline) {
            for t in times.times_raw() {
                out.entry(Some(*t)).or_default().insert(entity.to_string());
            }
        }
    }
    Ok(out)
}

//! Reading and writing clouds and RGB-D frames.
//!
//! - [`pcd`]: PCL's PCD v0.7 (`ascii`, `binary`, `binary_compressed`).
//! - [`ply`]: PLY (ascii, binary little and big endian), Open3D's property names.
//! - [`xyz`]: plain `x y z` text, one point a line.
//! - [`rgbd`]: 16-bit depth + 8-bit colour images to an organized cloud, with intrinsics
//!   from Open3D's JSON or PCL's grabber XML ([`intrinsics`]).
//!
//! [`read_cloud`] and [`write_cloud`] choose the format by the file extension.

pub mod atomic;
pub mod intrinsics;
pub mod limits;
pub mod npy;
pub mod outputs;
pub mod pcd;
pub mod ply;
pub mod rgbd;
mod rgbd_error;
pub mod xyz;

use crate::cloud::PointCloud;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// An error that can name the file it came from: parsers report what is wrong without the
/// path, their callers add it once, and an error that names a file already (a read or
/// write failure, or one already wrapped) is passed through unchanged.
pub trait InFile: Sized {
    /// Whether the error names its file already.
    fn names_file(&self) -> bool;

    /// The error wrapped in a variant that names `path`.
    fn wrap_in_file(self, path: &Path) -> Self;

    /// The error naming `path`, unless it names a file already.
    fn in_file(self, path: &Path) -> Self {
        if self.names_file() {
            self
        } else {
            self.wrap_in_file(path)
        }
    }
}

/// Errors of reading and writing files. Every variant names the file.
#[derive(Debug, Error)]
pub enum IoError {
    /// The operating system refused to open, read or write the file.
    #[error("{path}: {source}")]
    Os {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a valid PCD file.
    #[error("{path}: {source}")]
    Pcd {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: pcd::PcdError,
    },
    /// The file is not a valid PLY file.
    #[error("{path}: {source}")]
    Ply {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: ply::PlyError,
    },
    /// The file is not a valid XYZ text file.
    #[error("{path}: {source}")]
    Xyz {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: xyz::XyzError,
    },
    /// A `.npy` array (a ray table) could not be read.
    #[error("{path}: {source}")]
    Npy {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: npy::NpyError,
    },
    /// An RGB-D image pair or its intrinsics could not be used.
    #[error("{path}: {source}")]
    Rgbd {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: rgbd::RgbdError,
    },
    /// The file declares more data than the memory budget allows ([`limits`]).
    #[error("{path}: {source}")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What it declares and the limit.
        #[source]
        source: limits::TooLarge,
    },
    /// A cloud to write whose attribute columns do not match its point count.
    #[error("{path}: not written: {source}")]
    Inconsistent {
        /// The file.
        path: PathBuf,
        /// What does not match.
        #[source]
        source: crate::cloud::CloudError,
    },
    /// The file extension names no format we read or write.
    #[error("{path}: unknown cloud format (expected .pcd, .ply or .xyz)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
}

/// Cloud file formats, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CloudFormat {
    /// PCL's PCD.
    Pcd,
    /// Stanford PLY.
    Ply,
    /// Plain text, `x y z` per line.
    Xyz,
}

impl CloudFormat {
    /// The format for a path's extension (case-insensitive), if known.
    pub fn from_path(path: &Path) -> Option<CloudFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "pcd" => Some(CloudFormat::Pcd),
            "ply" => Some(CloudFormat::Ply),
            "xyz" | "txt" => Some(CloudFormat::Xyz),
            _ => None,
        }
    }
}

/// How to encode a file we write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// Text.
    Ascii,
    /// Raw binary (PCD `binary`, PLY `binary_little_endian`).
    #[default]
    Binary,
    /// PCD `binary_compressed` (LZF); PLY has no such encoding and writes binary.
    BinaryCompressed,
}

/// Reads a cloud, choosing the format by extension.
pub fn read_cloud(path: impl AsRef<Path>) -> Result<PointCloud, IoError> {
    let path = path.as_ref();
    match CloudFormat::from_path(path) {
        Some(CloudFormat::Pcd) => pcd::read_pcd(path),
        Some(CloudFormat::Ply) => ply::read_ply(path),
        Some(CloudFormat::Xyz) => xyz::read_xyz(path),
        None => Err(IoError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// Writes a cloud, choosing the format by extension. The file is written to a temporary
/// name beside the target and renamed, so a reader never sees half a file.
pub fn write_cloud(
    path: impl AsRef<Path>,
    cloud: &PointCloud,
    encoding: Encoding,
) -> Result<(), IoError> {
    let path = path.as_ref();
    // The encoders assume every attribute column has one value per point (a cloud whose
    // width * height is off is written unorganized instead).
    if let Err(source @ crate::cloud::CloudError::LengthMismatch { .. }) = cloud.validate() {
        return Err(IoError::Inconsistent {
            path: path.to_path_buf(),
            source,
        });
    }
    let bytes = match CloudFormat::from_path(path) {
        Some(CloudFormat::Pcd) => pcd::to_pcd_bytes(cloud, encoding),
        Some(CloudFormat::Ply) => ply::to_ply_bytes(cloud, encoding),
        Some(CloudFormat::Xyz) => xyz::to_xyz_bytes(cloud),
        None => {
            return Err(IoError::UnknownFormat {
                path: path.to_path_buf(),
            })
        }
    };
    write_atomically(path, &bytes)
}

/// Writes `bytes` to `path` all or nothing ([`atomic::write`]).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    atomic::write(path, bytes).map_err(|e| match e {
        atomic::AtomicError::Os { path, source } => IoError::Os { path, source },
        other => IoError::Os {
            path: other.path().to_path_buf(),
            source: std::io::Error::other(other.to_string()),
        },
    })
}

/// Reads a whole file, mapping the error to [`IoError::Os`] with the path.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|source| IoError::Os {
        path: path.to_path_buf(),
        source,
    })
}

//! Plain-text `x y z` clouds. (Being implemented; see issue 2.)

use super::IoError;
use crate::cloud::PointCloud;
use std::path::Path;
use thiserror::Error;

/// What is wrong with an XYZ file.
#[derive(Debug, Error, PartialEq)]
pub enum XyzError {
    /// Placeholder until the reader lands.
    #[error("XYZ support is not built yet")]
    NotImplemented,
}

/// Reads an XYZ file.
pub fn read_xyz(path: &Path) -> Result<PointCloud, IoError> {
    let _ = super::read_bytes(path)?;
    Err(IoError::Xyz {
        path: path.to_path_buf(),
        source: XyzError::NotImplemented,
    })
}

/// Encodes a cloud as XYZ text.
pub fn to_xyz_bytes(_cloud: &PointCloud) -> Vec<u8> {
    unimplemented!("XYZ writer lands with issue 2")
}

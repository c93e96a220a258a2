//! PLY reader and writer. (Being implemented; see issue 2.)

use super::{Encoding, IoError};
use crate::cloud::PointCloud;
use std::path::Path;
use thiserror::Error;

/// What is wrong with a PLY file.
#[derive(Debug, Error, PartialEq)]
pub enum PlyError {
    /// Placeholder until the reader lands.
    #[error("PLY support is not built yet")]
    NotImplemented,
}

/// Reads a PLY file.
pub fn read_ply(path: &Path) -> Result<PointCloud, IoError> {
    let _ = super::read_bytes(path)?;
    Err(IoError::Ply {
        path: path.to_path_buf(),
        source: PlyError::NotImplemented,
    })
}

/// Encodes a cloud as PLY bytes.
pub fn to_ply_bytes(_cloud: &PointCloud, _encoding: Encoding) -> Vec<u8> {
    unimplemented!("PLY writer lands with issue 2")
}

//! PCL's PCD v0.7 reader and writer. (Being implemented; see issue 2.)

use super::{Encoding, IoError};
use crate::cloud::PointCloud;
use std::path::Path;
use thiserror::Error;

/// What is wrong with a PCD file.
#[derive(Debug, Error, PartialEq)]
pub enum PcdError {
    /// Placeholder until the reader lands.
    #[error("PCD support is not built yet")]
    NotImplemented,
}

/// Reads a PCD file.
pub fn read_pcd(path: &Path) -> Result<PointCloud, IoError> {
    let _ = super::read_bytes(path)?;
    Err(IoError::Pcd {
        path: path.to_path_buf(),
        source: PcdError::NotImplemented,
    })
}

/// Encodes a cloud as PCD bytes.
pub fn to_pcd_bytes(_cloud: &PointCloud, _encoding: Encoding) -> Vec<u8> {
    unimplemented!("PCD writer lands with issue 2")
}

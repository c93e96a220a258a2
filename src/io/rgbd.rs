//! RGB-D images to organized clouds. (Being implemented; see issue 2.)

use thiserror::Error;

/// What is wrong with an RGB-D frame or its intrinsics.
#[derive(Debug, Error, PartialEq)]
pub enum RgbdError {
    /// Placeholder until the converter lands.
    #[error("RGB-D support is not built yet")]
    NotImplemented,
}

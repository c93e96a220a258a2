//! The filter chain as a value (placeholder, filled in below).
use thiserror::Error;
/// Errors of the chain.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// Placeholder.
    #[error("bad configuration: {0}")]
    Config(String),
}
